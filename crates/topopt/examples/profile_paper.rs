//! Per-iteration timing of a preset (default: paper) or of the 120×60 linear inverter:
//! `cargo run --release -p flexstage-topopt --example profile_paper --
//! [paper|quick|inverter] [iterations] [checkpoint]`. Prints the wall time of each design
//! iteration split into preconditioner, Newton solves and adjoints, with Newton/PCG counts
//! (per case with `PROFILE_CASES=1`).

use std::time::Instant;

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem, samples};

/// Process CPU time (user + system) [s] from /proc/self/stat (Linux; 0 elsewhere).
fn cpu_time() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map(|(_, r)| r.split_whitespace().collect())
        .unwrap_or_default();
    let tick = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (tick(11) + tick(12)) / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = match args.get(1).map(String::as_str) {
        Some("quick") => Preset::Quick,
        _ => Preset::Paper,
    };
    let iters: usize = args.get(2).and_then(|v| v.parse().ok()).unwrap_or(8);
    let s = Scenario::preset(preset);
    // "inverter": the linear 120×60 displacement inverter of the benchmark.
    let inverter = args.get(1).map(String::as_str) == Some("inverter");
    let problem = if inverter {
        samples::inverter(120, 60).unwrap()
    } else {
        Problem::from_scenario(&s, None).unwrap()
    };
    // Optional third argument: a checkpoint (design/checkpoint.bin of a run of this preset).
    let params = if inverter {
        samples::inverter_params(100_000)
    } else {
        OptimizerParams::from_scenario(&s)
    };
    let mut opt = match args.get(3) {
        Some(path) => {
            let bytes = std::fs::read(path).unwrap();
            Optimizer::resume(&problem, params, &bytes).unwrap()
        }
        None => Optimizer::new(&problem, params).unwrap(),
    };
    let mut total = 0.0;
    let mut total_cpu = 0.0;
    for k in 0..iters {
        let t = Instant::now();
        let c0 = cpu_time();
        let rec = opt.step().unwrap();
        let dt = t.elapsed().as_secs_f64();
        let cpu = cpu_time() - c0;
        total_cpu += cpu;
        if k > 0 {
            total += dt;
        }
        let tm = opt.evaluator.timing;
        let (_, ev) = opt.last().unwrap();
        let lin: usize = ev.response.linear_iterations.iter().sum();
        println!(
            "it {k:3}: {dt:.3} s, cpu {cpu:.2} s (precond {:.3}, solve {:.3}, adjoint {:.3}, rest {:.3}) newton {}/{} max, pcg {lin}, adjoint its {}, area {:.4e}",
            tm.precondition,
            tm.solve,
            tm.adjoint,
            dt - tm.precondition - tm.solve - tm.adjoint,
            rec.newton_total,
            rec.newton_max,
            tm.adjoint_iterations,
            rec.area
        );
        if std::env::var_os("PROFILE_CASES").is_some() {
            println!("  sweeps per case: {:?}", ev.response.newton_iterations);
            println!(
                "  adjoint its per case: {:?}",
                opt.evaluator
                    .cases
                    .iter()
                    .map(|c| c.adjoint_iterations())
                    .collect::<Vec<_>>()
            );
        }
    }
    let eps = opt.evaluator.max_element_strains();
    let (dens, _) = opt.last().unwrap();
    let mut hist = [0usize; 5];
    for (e, v) in eps.iter().enumerate() {
        let b = [1e-4, 1e-3, 1e-2, 1e-1].iter().filter(|t| *v > **t).count();
        if dens.physical[e] > 0.5 {
            continue;
        }
        hist[b] += 1;
    }
    let mx = eps.iter().cloned().fold(0.0, f64::max);
    println!(
        "void-ish element strains: <1e-4 {}, <1e-3 {}, <1e-2 {}, <1e-1 {}, more {}; max strain {mx:.3e}",
        hist[0], hist[1], hist[2], hist[3], hist[4]
    );
    if iters > 1 {
        println!(
            "mean over iterations 1..{iters}: {:.3} s wall; CPU {:.3} s per iteration (all iterations)",
            total / (iters - 1) as f64,
            total_cpu / iters as f64
        );
    }
}
