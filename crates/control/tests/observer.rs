//! Reference: Eq. (37)–(42) (K-filters, B0 Hurwitz via the Lyapunov equation (39), error
//! dynamics (42)) and DECISIONS.md (forward Euler with gain 1e5 at 0.1 ms is unstable).
//! Goal: the observer design is verified as the paper asks, and the exactly discretized
//! K-filter's error follows its error dynamics ε_{k+1} = F ε_k to 1e-9 on the noise-free
//! linear plant, with F inheriting e^{B0 T} in the injected columns.

use flexstage_control::observer::{KFilter, NX, ObserverDesign, ObserverParams, Vector10};
use flexstage_scenario::Scenario;
use flexstage_sim::linalg::spectral_radius;
use flexstage_sim::model::{StageModel, to_dyn};
use nalgebra::SMatrix;

fn design() -> (StageModel, ObserverDesign) {
    let s = Scenario::paper();
    let m = StageModel::new(&s.stage.guess).unwrap();
    let p = ObserverParams {
        gain: s.controller.observer_gain,
        sample_time: s.simulation.sample_time,
        disturbance_gain: s.controller.disturbance_gain,
    };
    let d = ObserverDesign::new(&m, &p).unwrap();
    (m, d)
}

#[test]
fn b0_is_hurwitz_by_the_lyapunov_equation() {
    let (_, d) = design();
    assert!(d.lyapunov(), "P = Pᵀ > 0 (Eq. 39)");
    let scale = d.p.amax() * d.b0.amax();
    assert!(
        d.lyapunov_residual() < 1e-9 * scale,
        "residual {}",
        d.lyapunov_residual()
    );
}

#[test]
fn forward_euler_is_unstable_and_the_exact_discretization_is_not() {
    let (_, d) = design();
    let t = Scenario::paper().simulation.sample_time;
    let euler = SMatrix::<f64, NX, NX>::identity() + d.b0 * t;
    assert!(spectral_radius(&to_dyn(&euler)).unwrap() > 5.0);
    let rho = spectral_radius(&to_dyn(&d.f)).unwrap();
    assert!(rho < 0.9, "ρ(F) = {rho}");
    // F equals e^{B0 T} in the columns that output injection reaches.
    assert!((d.f.columns(0, 2) - d.phi0.columns(0, 2)).amax() < 1e-15);
}

#[test]
fn estimation_error_follows_its_error_dynamics() {
    let (m, d) = design();
    let mut filter = KFilter::new(&d);
    // True plant: the exact ZOH discretization of Eq. (36) (no noise, Δ = 0).
    let mut z = Vector10::zeros();
    let z0 = [1e-6, -2e-6, 0.5e-6, 0.3e-6, 1e-3, -2e-3, 0.0, 4e-3];
    for (i, v) in z0.iter().enumerate() {
        z[i] = *v;
    }
    let mut eps_pred = z - filter.estimate();
    let scale = eps_pred.amax();
    let mut worst = 0.0f64;
    for k in 0..400 {
        let u = [
            5e-6 * (k as f64 * 0.01).sin(),
            3e-6 * (k as f64 * 0.023).cos(),
        ];
        let y = [z[0], z[1]];
        filter.step(y, u);
        z = d.phi * z + d.gamma * nalgebra::Vector2::new(u[0], u[1]);
        eps_pred = d.f * eps_pred;
        let eps = z - filter.estimate();
        worst = worst.max((eps - eps_pred).amax() / scale);
    }
    assert!(worst < 1e-9, "max deviation {worst:e}");
    assert!(
        (z - filter.estimate()).amax() < 1e-6 * scale,
        "the error has decayed"
    );
    assert_eq!(m.b.nrows(), 8);
}
