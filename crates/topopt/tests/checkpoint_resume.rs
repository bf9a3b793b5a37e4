//! Reference: the checkpoint-and-resume requirement: after a crash, resuming from the last
//! checkpoint reaches the same result. Goal: N iterations uninterrupted vs k iterations,
//! checkpoint bytes, a fresh optimizer resumed from them, then N − k more iterations give
//! the same designs and histories to 1e-12 (nonlinear, additive material and β continuation
//! on). Not bitwise: faer's SIMD kernels round differently depending on buffer alignment, so
//! two uninterrupted runs in one process already differ in the last bit.

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem};

#[test]
fn resumed_run_reproduces_the_uninterrupted_run() {
    let mut s = Scenario::preset(Preset::Quick);
    s.mesh.nl = 24;
    s.mesh.nw = 12;
    s.optimization.samples = 8;
    s.optimization.projection.interval = 3;
    s.regions.truncate(3);
    let problem = Problem::from_scenario(&s, None).unwrap();
    let params = OptimizerParams::from_scenario(&s);
    let (n, k) = (8, 5);
    let mut a = Optimizer::new(&problem, params.clone()).unwrap();
    for _ in 0..n {
        a.step().unwrap();
    }
    let mut b = Optimizer::new(&problem, params.clone()).unwrap();
    for _ in 0..k {
        b.step().unwrap();
    }
    let bytes = b.checkpoint();
    drop(b); // "kill -9"
    let mut c = Optimizer::resume(&problem, params, &bytes).unwrap();
    assert_eq!(c.iteration(), k);
    for _ in k..n {
        c.step().unwrap();
    }
    let dx = a
        .x()
        .iter()
        .zip(c.x())
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    println!("max |x_a − x_resumed| = {dx:e}");
    assert!(dx <= 1e-12, "designs differ after resume by {dx:e}");
    let (ha, hc) = (a.history(), c.history());
    assert_eq!(ha.len(), hc.len());
    for (ra, rc) in ha.iter().zip(hc) {
        let rel = (ra.area - rc.area).abs() / ra.area.abs();
        assert!(
            rel <= 1e-12,
            "iteration {}: areas differ by {rel:e}",
            ra.iteration
        );
        for (p, q) in ra.constraints.iter().zip(&rc.constraints) {
            assert!((p - q).abs() <= 1e-12, "iteration {}", ra.iteration);
        }
        assert_eq!(ra.beta, rc.beta);
    }
    assert!(
        ha.last().unwrap().beta > 1.0,
        "β continuation was exercised"
    );
    // A corrupted checkpoint is rejected with a typed error.
    assert!(
        Optimizer::resume(&problem, OptimizerParams::from_scenario(&s), &bytes[..100]).is_err()
    );
}
