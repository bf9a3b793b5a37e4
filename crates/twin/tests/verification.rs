//! Reference: the full model. The twin of the quick preset's rhombus amplifier
//! (`samples::quick_rhombus`, 48 × 24 mesh) is checked against
//! * the FE statics of the assembled stage (Craig–Bampton reproduces boundary-load statics
//!   exactly: Craig & Bampton 1968),
//! * the FE modal analysis (shift-invert Lanczos) of the same assembled stage: every mode the
//!   twin claims within 0.5 %,
//! * the full nonlinear transient (Total Lagrangian, Newmark average acceleration, Newton per
//!   step) under a step and a 200 Hz sine at the PEA inputs over 20 ms: the output within 1 %
//!   of its range on both axes,
//! * the nonlinear FE statics at points off the fit grid (the polynomial correction), and the
//!   modes of the FE tangent at an operating point (first-order eigenvalue perturbation: the
//!   twin's stiffening term),
//! * the closed-form energy of an undamped free vibration (conserved to 1e-6; the exact modal
//!   discretization conserves it to round-off),
//! * its own frequency response (the Bode data) against a simulated steady-state sine.
//!
//! Goal: the twin is the designed mechanism's dynamics within the tolerances, and each
//! of its parts (reduction, discretization, nonlinear map, response) is verified on its own.

// Loops over the two axes index several arrays at once.
#![allow(clippy::needless_range_loop)]

use std::sync::OnceLock;

use flexstage_fem::RayleighDamping;
use flexstage_sim::rig::Mechanics;
use flexstage_twin::modal::ModalStage;
use flexstage_twin::nonlinear::static_responses;
use flexstage_twin::reference::{mode_check, twin_response};
use flexstage_twin::{ReferenceParams, Twin, TwinStage, ValidationParams, samples, validate};

fn twin() -> &'static Twin {
    static TWIN: OnceLock<Twin> = OnceLock::new();
    TWIN.get_or_init(|| {
        let (s, rho) = samples::quick_rhombus().unwrap();
        Twin::from_scenario(&s, &rho).unwrap()
    })
}

#[test]
fn craig_bampton_reproduces_the_fe_statics_exactly() {
    let t = twin();
    let g = t.dc_gain();
    let nl = t.nonlinear.as_ref().unwrap();
    for s in &nl.samples {
        let x = s.x_nom;
        for i in 0..2 {
            let q = g[i][0] * x[0] + g[i][1] * x[1];
            let scale = s.q_linear[0].abs().max(s.q_linear[1].abs());
            assert!(
                (q - s.q_linear[i]).abs() < 1e-9 * scale,
                "x_nom {x:?}: twin {q:e}, FE {:e}",
                s.q_linear[i]
            );
        }
    }
}

#[test]
fn twin_modes_match_the_fe_modal_analysis_within_half_a_percent() {
    let t = twin();
    let checks = mode_check(t).unwrap();
    for m in &checks {
        println!(
            "mode {}: twin {:.2} Hz, FE {:.2} Hz, {:+.4} %, ζ = {:.4}",
            m.index,
            m.twin,
            m.fe,
            100.0 * m.relative,
            m.damping
        );
        assert!(m.relative.abs() < 0.005, "{m:?}");
    }
    // The twin claims every mode below its reach, the larger of coverage × f1 (3 × f1) and
    // f_s + 0.3 f1 (10 kHz + 0.3 f1: the hold's images and folded modes of the sweep's
    // fastest scan), and keeps at least `min_modes` (40) fixed-interface modes reaching
    // twice that band.
    let f1 = t.first_resonance();
    let reach = (3.0 * f1).max(1e4 + 0.3 * f1);
    assert!((t.covered_frequency() - reach).abs() < 1e-9 * reach);
    assert!(t.covered_frequency() >= 1e4 + 0.3 * f1);
    assert!(t.reduction.modes() >= t.params.min_modes && t.params.min_modes == 40);
    let top = *t.reduction.fixed_interface_frequencies.last().unwrap();
    assert!(top >= 2.0 * t.covered_frequency(), "{top} Hz");
    assert!(checks.last().unwrap().twin <= t.covered_frequency());
    // Rayleigh damping: ζ = 1 % at the first resonance.
    assert!((checks[0].damping - 0.01).abs() < 1e-9);
}

#[test]
fn twin_follows_the_full_nonlinear_transient_within_one_percent() {
    let t = twin();
    let p = ValidationParams {
        reference: ReferenceParams {
            dt: 4e-6,
            residual_tol: 1e-8,
            ..ReferenceParams::default()
        },
        ..ValidationParams::default()
    };
    let v = validate(t, &p).unwrap();
    for line in flexstage_twin::report::validity_lines(&v) {
        println!("{line}");
    }
    for c in &v.cases {
        let r = c.twin.relative();
        if c.name == "fast step" {
            // A 50 µs rise excites modes up to about 50 kHz, where this coarse reference
            // step (4 µs, for the test's time) has a period error of 13 %: the fast step is
            // checked at the default 0.5 µs in verification.md (1.7 / 0.3 %), not here.
            assert!(r[0] > 0.01 || r[1] > 0.01, "{r:?}");
            continue;
        }
        assert!(r[0] < 0.01 && r[1] < 0.01, "{}: {r:?}", c.name);
        // The nonlinear correction does not make the twin worse on the amplified axis.
        assert!(c.twin.max_error[1] <= c.linear_twin.max_error[1] * 1.05);
    }
}

#[test]
fn nonlinear_map_reproduces_nonlinear_statics_off_the_grid() {
    let t = twin();
    let nl = t.nonlinear.as_ref().unwrap();
    let a = t.params.fit_amplitude;
    let points = [
        [0.37 * a, -0.81 * a],
        [-0.66 * a, 0.29 * a],
        [0.93 * a, 0.55 * a],
    ];
    for s in static_responses(&t.fe, &points).unwrap() {
        let d = nl.correction(s.x_in);
        for i in 0..2 {
            let effect = s.q_nonlinear[i] - s.q_linear[i];
            let miss = s.q_linear[i] + d[i] - s.q_nonlinear[i];
            println!(
                "x_nom {:?} axis {}: nonlinear effect {effect:.3e} m, after correction {miss:.3e} m",
                s.x_nom,
                i + 1
            );
            assert!(
                miss.abs() <= 0.05 * effect.abs() + 1e-12,
                "{miss:e} vs {effect:e}"
            );
        }
    }
}

#[test]
fn stiffening_predicts_the_tangent_modes_at_an_operating_point() {
    use flexstage_fem::{NewtonParams, NewtonWorkspace, SymbolicFactor, newton};
    let t = twin();
    let fe = &t.fe;
    let model = &fe.model;
    let nl = t.nonlinear.as_ref().unwrap();
    let x = [20e-6, -15e-6];
    let mut ws = NewtonWorkspace::new(model, SymbolicFactor::for_model(model).unwrap());
    let mut u = model.zero_vector();
    newton::solve(
        model,
        &fe.design(),
        &fe.pea_load(x),
        &mut u,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap();
    // The reduced tangent at the deformed state and its modes.
    let mut cb = t.reduction.clone();
    cb.stiffness = t.reduction.project(model, &ws.tangent);
    let tangent = ModalStage::new(&cb, fe.k_pea, RayleighDamping::none()).unwrap();
    let x_in = [u[fe.interface[0]], u[fe.interface[1]]];
    for kk in 0..4 {
        let w0 = (std::f64::consts::TAU * t.modal.modes[kk].frequency).powi(2);
        let wt = (std::f64::consts::TAU * tangent.modes[kk].frequency).powi(2);
        let s = nl.stiffening[kk];
        let predicted = s[0] * x_in[0] + s[1] * x_in[1];
        println!(
            "mode {}: ω² shift at the operating point {:+.3e} (tangent) vs {:+.3e} (twin)",
            kk + 1,
            (wt - w0) / w0,
            predicted / w0
        );
        assert!((wt - w0 - predicted).abs() <= 0.1 * (wt - w0).abs() + 1e-7 * w0);
    }
}

#[test]
fn undamped_free_vibration_conserves_energy() {
    let t = twin();
    let undamped = ModalStage::new(&t.reduction, t.fe.k_pea, RayleighDamping::none()).unwrap();
    let mut stage = TwinStage::new(&undamped, None, 5e-6);
    // Every mode displaced and moving.
    let state: Vec<[f64; 2]> = (0..stage.order())
        .map(|k| [1e-6 / (k + 1) as f64, 1e-3 * (k as f64).cos()])
        .collect();
    stage.set_modal_state(&state);
    let e0 = stage.energy();
    let mut drift = 0.0f64;
    for _ in 0..20_000 {
        stage.advance([[0.0; 2]; 2], [[0.0; 2]; 2]);
        drift = drift.max((stage.energy() / e0 - 1.0).abs());
    }
    println!("energy drift over 0.1 s: {drift:.2e}");
    assert!(drift < 1e-6, "{drift:e}");
    assert!(
        drift < 1e-11,
        "the exact discretization should be at round-off: {drift:e}"
    );
}

#[test]
fn frequency_response_matches_a_simulated_steady_state_sine() {
    let t = twin();
    let f = 1500.0;
    let a = 1e-6;
    // Differential input; after 30 ms the 1 %-damped transient has decayed.
    let input = move |time: f64| {
        let s = (std::f64::consts::TAU * f * time).sin();
        [a * s, -a * s]
    };
    let dt = 1e-6;
    let r = twin_response(t, &input, 0.04, dt, false);
    let n = r.t.len();
    let tail = &r.q[1][n - (0.01 / dt) as usize..];
    let amp_sim = 0.5
        * (tail.iter().copied().fold(f64::MIN, f64::max)
            - tail.iter().copied().fold(f64::MAX, f64::min));
    let g = t.modal.frequency_response(f);
    let (re, im) = (g[1][0].0 - g[1][1].0, g[1][0].1 - g[1][1].1);
    let amp = a * re.hypot(im);
    println!("|q2/x| at {f} Hz: response {amp:.6e}, simulated {amp_sim:.6e}");
    assert!((amp_sim / amp - 1.0).abs() < 2e-3);
}

#[test]
fn lumped_response_at_low_frequency_is_its_static_gain() {
    let s = flexstage_scenario::Scenario::paper();
    let m = flexstage_sim::model::StageModel::new(&s.stage.truth).unwrap();
    let g = m.dc_gain().unwrap();
    let r = flexstage_twin::report::lumped_response(&m, 1e-3).unwrap();
    for i in 0..2 {
        for j in 0..2 {
            assert!((r[i][j].0 - g[(i, j)]).abs() < 1e-9 * g[(i, j)].abs().max(1.0));
        }
    }
}
