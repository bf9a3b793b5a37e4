//! Per-iteration timing of a preset (default: paper) or of the 120×60 linear inverter:
//! `cargo run --release -p flexstage-topopt --example profile_paper --
//! [paper|quick|fine|inverter] [iterations] [checkpoint]`. Prints the wall time of each design
//! iteration split, per realization, into preconditioner, equilibrium and adjoints, with
//! Newton/PCG counts (per case with `PROFILE_CASES=1`; `PROFILE_SAMPLES=n` overrides p_m).

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
    let name = args.get(1).map(String::as_str).unwrap_or("paper");
    let iters: usize = args.get(2).and_then(|v| v.parse().ok()).unwrap_or(8);
    let inverter = name == "inverter";
    let mut s = Scenario::preset(Preset::from_name(name).unwrap_or(Preset::Paper));
    // PROFILE_NO_ADDITIVE=1: without the additive material.
    if std::env::var_os("PROFILE_NO_ADDITIVE").is_some() {
        s.optimization.additive.enabled = false;
    }
    // PROFILE_SAMPLES=n: fewer load cases (e.g. for callgrind).
    if let Some(n) = std::env::var("PROFILE_SAMPLES")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        s.optimization.samples = n;
    }
    let problem = if inverter {
        samples::inverter(120, 60).unwrap()
    } else {
        Problem::from_scenario(&s, None).unwrap()
    };
    let params = if inverter {
        samples::inverter_params(100_000)
    } else {
        OptimizerParams::from_scenario(&s)
    };
    // Optional third argument: a checkpoint (design/checkpoint.bin of a run of this preset).
    let mut opt = match args.get(3) {
        Some(path) => {
            let bytes = std::fs::read(path).unwrap();
            Optimizer::resume(&problem, params, &bytes).unwrap()
        }
        None => Optimizer::new(&problem, params).unwrap(),
    };
    let (mut total, mut total_cpu) = (0.0, 0.0);
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
        let (_, ev) = opt.last().unwrap();
        let mut parts = Vec::new();
        let mut fe = 0.0;
        for (e, r) in opt.evaluator.evaluators.iter().zip(&ev.realizations) {
            let tm = e.timing;
            fe += tm.precondition + tm.solve + tm.adjoint;
            let lin: usize = r.response.linear_iterations.iter().sum();
            parts.push(format!(
                "{} {:.3}/{:.3}/{:.3} pcg {lin} adj {}",
                r.kind.name(),
                tm.precondition,
                tm.solve,
                tm.adjoint,
                tm.adjoint_iterations
            ));
            if std::env::var_os("PROFILE_CASES").is_some() {
                println!(
                    "  {} sweeps per case: {:?}",
                    r.kind.name(),
                    r.response.newton_iterations
                );
            }
        }
        println!(
            "it {k:3}: {dt:.3} s, cpu {cpu:.2} s, rest {:.3} s [{}] area {:.0} µm²",
            dt - fe,
            parts.join("; "),
            rec.area * 1e12
        );
    }
    if iters > 1 {
        println!(
            "mean over iterations 1..{iters}: {:.3} s wall; CPU {:.3} s per iteration (all iterations)",
            total / (iters - 1) as f64,
            total_cpu / iters as f64
        );
    }
}
