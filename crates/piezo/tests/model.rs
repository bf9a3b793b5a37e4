// Reference: paper Eq. (18) with n = 1 (Section 3.1), DECISIONS.md "PEA hysteresis", Table A1.
// Goal: the exact integrator reproduces the analytic virgin loading curve
// h(U) = A/(B+Γ)(1 − e^{−(B+Γ)U}) for δ = 0, keeps |h| ≤ A/(B+Γ), is rate-independent for
// δ = 0 (and only then), agrees with substeps and with a fine RK4 reference at 0.1 ms, and
// carries the sample time in the δ term.

use flexstage_piezo::{BoucWen, BoucWenParams, GaussianNoise, advance, samples};
use proptest::prelude::*;

#[test]
fn virgin_loading_curve_is_analytic() {
    let (p, h_exact) = samples::virgin_ramp();
    let dt = 1e-4;
    let mut pea = BoucWen::new(p);
    for k in 1..=10_000 {
        let u = 0.1 * k as f64; // 0 → 1000 V in 1 s
        pea.step(u, dt);
        let e = h_exact(&p, u);
        assert!(
            (pea.h() - e).abs() <= 1e-10 * p.h_bound(),
            "U = {u}: h = {} vs {e}",
            pea.h()
        );
    }
    // One single 1000 V step is just as exact.
    let h = advance(&p, 0.0, 0.0, 1000.0, 1.0);
    assert!((h - h_exact(&p, 1000.0)).abs() < 1e-12 * p.h_bound());
    assert!(h < p.h_bound() && h > 0.9 * p.h_bound());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]
    #[test]
    fn h_stays_within_the_bound_without_asymmetry(seed in 0u64..1000, pea2 in any::<bool>()) {
        let p = if pea2 { BoucWenParams::PEA2 } else { BoucWenParams::PEA1 }.without_asymmetry();
        let mut pea = BoucWen::new(p);
        let mut noise = GaussianNoise::new(60.0, seed);
        let mut u = 500.0;
        for _ in 0..5000 {
            u = (u + noise.sample()).clamp(-1000.0, 1000.0);
            pea.step(u, 1e-4);
            prop_assert!(pea.h().abs() <= p.h_bound() * (1.0 + 1e-12), "h = {}", pea.h());
        }
    }
}

/// One period of a 0–1000 V sine at `f` Hz with 2000 samples, after 4 warm-up periods.
fn loop_at(p: BoucWenParams, f: f64) -> Vec<f64> {
    let n = 2000;
    let dt = 1.0 / f / n as f64;
    let mut pea = BoucWen::new(p);
    let mut x = Vec::new();
    for k in 0..5 * n {
        let u = 500.0 * (1.0 - (std::f64::consts::TAU * k as f64 / n as f64).cos());
        let xv = pea.step(u, dt);
        if k >= 4 * n {
            x.push(xv);
        }
    }
    x
}

#[test]
fn loop_is_rate_independent_only_without_asymmetry() {
    let p = BoucWenParams::PEA1;
    let slow = loop_at(p.without_asymmetry(), 1.0);
    let fast = loop_at(p.without_asymmetry(), 100.0);
    let diff = slow
        .iter()
        .zip(&fast)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-10, "δ = 0: loops differ by {diff} µm");
    // With δ (µm/(V·s)) the slow loop accumulates δ·∫U dt more: visibly different.
    let slow = loop_at(p, 1.0);
    let fast = loop_at(p, 100.0);
    let diff = slow
        .iter()
        .zip(&fast)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        diff > 0.01 && diff < 1.0,
        "δ ≠ 0: loops differ by {diff} µm"
    );
}

#[test]
fn delta_term_carries_the_sample_time() {
    // A 1 s ramp to 1000 V: the δ term adds about δ·∫U dt = δ·500 V·s, whatever the step.
    let p = BoucWenParams::PEA1;
    for dt in [1e-5, 1e-4, 1e-3] {
        let n = (1.0 / dt) as usize;
        let (mut with, mut without) = (BoucWen::new(p), BoucWen::new(p.without_asymmetry()));
        for k in 1..=n {
            let u = 1000.0 * k as f64 / n as f64;
            with.step(u, dt);
            without.step(u, dt);
        }
        let extra = with.h() - without.h();
        // Saturation damps the added state (factor e^{-(B+Γ)(1000-U)} < 1), so the increment
        // is between 5 % and 100 % of δ·500.
        let scale = p.delta_bw * 500.0;
        assert!(
            extra > 0.05 * scale && extra < scale,
            "dt = {dt}: extra h = {extra}"
        );
    }
}

/// Classic RK4 on Eq. (18) with U linear in time, `m` substeps per sample.
fn rk4_reference(p: &BoucWenParams, u: &[f64], dt: f64, m: usize) -> Vec<f64> {
    let mut h = 0.0;
    let mut out = vec![h];
    for k in 1..u.len() {
        let udot = (u[k] - u[k - 1]) / dt;
        let hs = dt / m as f64;
        for j in 0..m {
            let t0 = j as f64 * hs;
            let uu = |t: f64| u[k - 1] + udot * t;
            let f = |t: f64, h: f64| p.h_dot(uu(t), udot, h);
            let k1 = f(t0, h);
            let k2 = f(t0 + hs / 2.0, h + hs / 2.0 * k1);
            let k3 = f(t0 + hs / 2.0, h + hs / 2.0 * k2);
            let k4 = f(t0 + hs, h + hs * k3);
            h += hs / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        out.push(h);
    }
    out
}

#[test]
fn exact_step_matches_substeps_and_rk4_at_the_sample_time() {
    let p = BoucWenParams::PEA2;
    let dt = 1e-4;
    let u: Vec<f64> = (0..20_000)
        .map(|k| 500.0 * (1.0 - (std::f64::consts::TAU * 1.3 * k as f64 * dt).cos()))
        .collect();
    let mut one = BoucWen::new(p);
    let mut sub = BoucWen::new(p);
    let reference = rk4_reference(&p, &u, dt, 8);
    for k in 1..u.len() {
        one.step(u[k], dt);
        for j in 1..=20 {
            let uj = u[k - 1] + (u[k] - u[k - 1]) * j as f64 / 20.0;
            sub.step(uj, dt / 20.0);
        }
        assert!(
            (one.h() - sub.h()).abs() < 1e-11,
            "k = {k}: substeps differ"
        );
        assert!(
            (one.h() - reference[k]).abs() < 1e-8,
            "k = {k}: RK4 {} vs {}",
            reference[k],
            one.h()
        );
    }
}
