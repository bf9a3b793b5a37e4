//! Cost of the stage's eigen-analysis on the paper mesh (Lanczos steps, time): a scratch probe.
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{ModalParams, Problem, stage_modes};
use std::time::Instant;

fn main() {
    let s = Scenario::preset(Preset::Paper);
    let problem = Problem::from_scenario(&s, None).unwrap();
    let ne = problem.mesh().n_elements();
    let rho: Vec<f64> = (0..ne).map(|e| 0.5 + 0.45 * ((e as f64 * 0.37).sin())).collect();
    for tol in [1e-10, 1e-8, 1e-6] {
        let p = ModalParams { tolerance: tol, ..ModalParams::default() };
        let t = Instant::now();
        let m = stage_modes(&problem, &rho, &p, true).unwrap();
        println!("tol {tol:e}: {} steps, {:.1} ms, f {:?}", m.steps, t.elapsed().as_secs_f64() * 1e3, m.frequencies);
    }
}
