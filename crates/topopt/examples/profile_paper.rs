//! Per-iteration timing of a preset (default: paper): `cargo run --release -p flexstage-topopt
//! --example profile_paper -- [paper|quick] [iterations]`. Prints the wall time of each design
//! iteration split into preconditioner, Newton solves and adjoints, with Newton/PCG counts.

use std::time::Instant;

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = match args.get(1).map(String::as_str) {
        Some("quick") => Preset::Quick,
        _ => Preset::Paper,
    };
    let iters: usize = args.get(2).and_then(|v| v.parse().ok()).unwrap_or(8);
    let s = Scenario::preset(preset);
    let problem = Problem::from_scenario(&s, None).unwrap();
    let mut opt = Optimizer::new(&problem, OptimizerParams::from_scenario(&s)).unwrap();
    let mut total = 0.0;
    for k in 0..iters {
        let t = Instant::now();
        let rec = opt.step().unwrap();
        let dt = t.elapsed().as_secs_f64();
        if k > 0 {
            total += dt;
        }
        let tm = opt.evaluator.timing;
        let (_, ev) = opt.last().unwrap();
        let lin: usize = ev.response.linear_iterations.iter().sum();
        println!(
            "it {k:3}: {dt:.3} s (precond {:.3}, solve {:.3}, adjoint {:.3}, rest {:.3}) newton {}/{} max, pcg {lin}, adjoint its {}, area {:.4e}",
            tm.precondition,
            tm.solve,
            tm.adjoint,
            dt - tm.precondition - tm.solve - tm.adjoint,
            rec.newton_total,
            rec.newton_max,
            tm.adjoint_iterations,
            rec.area
        );
    }
    if iters > 1 {
        println!(
            "mean over iterations 1..{iters}: {:.3} s",
            total / (iters - 1) as f64
        );
    }
}
