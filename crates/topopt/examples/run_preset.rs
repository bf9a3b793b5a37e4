//! Runs the design loop of a preset and prints the history:
//! `cargo run --release -p flexstage-topopt --example run_preset -- quick [max_iterations]`.

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = Preset::from_name(args.get(1).map(String::as_str).unwrap_or("quick"))
        .expect("preset: paper or quick");
    let mut s = Scenario::preset(preset);
    if let Some(n) = args.get(2) {
        s.optimization.max_iterations = n.parse().expect("max iterations");
    }
    let problem = Problem::from_scenario(&s, None).expect("problem");
    let params = OptimizerParams::from_scenario(&s);
    let mut opt = Optimizer::new(&problem, params).expect("optimizer");
    let t = std::time::Instant::now();
    let stop = opt
        .run(|_, r| {
            println!(
                "{:4} J={:.4e} g={:?} V={:.3} grey={:.3} ch={:.3e} kkt={:?} β={} newton={}/{} t={:.3}s",
                r.iteration, r.area, r.constraints.iter().map(|v| (v * 1e3).round() / 1e3).collect::<Vec<_>>(),
                r.volume, r.grey, r.change, r.kkt, r.beta, r.newton_total, r.newton_max, r.time
            );
            Ok(())
        })
        .expect("run");
    let h = opt.history();
    println!(
        "{stop:?} after {} iterations, {:.1} s; area growth {:.3}",
        h.len(),
        t.elapsed().as_secs_f64(),
        h.last().unwrap().area / h[0].area
    );
}
