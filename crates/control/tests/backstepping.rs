//! Reference: Appendix D (A16–A38) as corrected in `flexstage_control::backstepping`.
//! Goal: every hand-written derivative of the law — ṡ, Ż (the paper's ∂Z5/∂η, ∂Z6/∂η
//! terms) and ȧ (the Π12, Π22 terms of A31–A32) — equals the central finite difference of
//! the corresponding function along the nominal model flow, for the robust law inside its
//! boundary layer and for the non-robust law.

use flexstage_control::backstepping::{Law, LawParams, sigma, sigma_slope};
use flexstage_scenario::Scenario;
use flexstage_sim::model::StageModel;
use flexstage_sim::trajectory::{Reference, Shape};

fn law(robust: bool) -> Law {
    let s = Scenario::paper();
    let m = StageModel::new(&s.stage.guess).unwrap();
    let c = &s.controller;
    Law::new(
        &m,
        LawParams {
            error_gain: c.error_gain,
            eta_gain: c.eta_gain,
            feedback_gain: c.feedback_gain,
            robust,
            // A wide layer so that s stays inside it (the slope term is exercised).
            eta_bound: [0.3, 0.2],
            a_bound: c.a_bound,
            boundary_layer: [1.0, 1e-8],
        },
    )
    .unwrap()
}

fn check(robust: bool) {
    let law = law(robust);
    let r = Reference::new(Shape::Lissajous {
        ratio: 3.0,
        amplitude: [10e-6, 20e-6],
        frequency: 20.0,
    });
    let t = 0.0213;
    let eta = [3.1e-6, -7.0e-6, 2.0e-6, 4.5e-6, 1.2e-3, -0.8e-3];
    let xi_dot = [2e-4, -3e-4];
    let delta = [0.7, -0.4];
    let out = law.evaluate(&eta, &xi_dot, &delta, &r.sample(t));
    let eta_dot = law.eta_dot(&eta, &xi_dot, &delta);
    let at = |h: f64| {
        let e: Vec<f64> = (0..6).map(|i| eta[i] + h * eta_dot[i]).collect();
        let e: [f64; 6] = e.try_into().unwrap();
        law.virtual_control(&e, &xi_dot, &delta, &r.sample(t + h))
    };
    let h = 1e-7;
    let (sp, zp, ap) = at(h);
    let (sm, zm, am) = at(-h);
    for i in 0..2 {
        let fd = |p: f64, m: f64| (p - m) / (2.0 * h);
        let rel = |x: f64, y: f64| (x - y).abs() / y.abs().max(1e-30);
        let (s_fd, z_fd, a_fd) = (fd(sp[i], sm[i]), fd(zp[i], zm[i]), fd(ap[i], am[i]));
        assert!(
            rel(out.s_dot[i], s_fd) < 1e-6,
            "ṡ{i}: {} vs {s_fd}",
            out.s_dot[i]
        );
        assert!(
            rel(out.z_dot[i], z_fd) < 1e-6,
            "Ż{i}: {} vs {z_fd}",
            out.z_dot[i]
        );
        assert!(
            rel(out.a_dot[i], a_fd) < 1e-6,
            "ȧ{i} (Π{}2): {} vs {a_fd}",
            i + 1,
            out.a_dot[i]
        );
        assert!(out.s[i].abs() < 1.0, "inside the boundary layer");
    }
}

#[test]
fn derivatives_match_central_differences_robust() {
    check(true);
}

#[test]
fn derivatives_match_central_differences_non_robust() {
    check(false);
}

#[test]
fn v_is_a_dot_minus_k_eps_a_minus_robust_terms() {
    // A35/A37 as corrected: v = ȧ − k ε_a − ε_a − ρ_ε σ(ε_a/φ_a).
    let law = law(true);
    let p = *law.params();
    let r = Reference::new(Shape::Circle {
        radius: 10e-6,
        frequency: 5.0,
    })
    .sample(0.1);
    let eta = [1e-6, 2e-6, 5e-6, -1e-6, 0.0, 1e-4];
    let out = law.evaluate(&eta, &[0.0; 2], &[0.0; 2], &r);
    for i in 0..2 {
        let ea = eta[2 + i] - out.a[i];
        assert_eq!(out.eps_a[i], ea);
        let want = out.a_dot[i]
            - p.feedback_gain[i] * ea
            - ea
            - p.a_bound[i] * sigma(ea, p.boundary_layer[1]);
        assert!((out.v[i] - want).abs() <= 1e-12 * want.abs());
    }
    assert_eq!(sigma(2.0, 1.0), 1.0);
    assert_eq!(sigma(-0.5, 0.0), -1.0);
    assert_eq!(sigma_slope(0.5, 1.0), 1.0);
    assert_eq!(sigma_slope(2.0, 1.0), 0.0);
}
