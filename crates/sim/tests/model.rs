//! Reference: Eq. (31)–(36) and Appendix C (A13–A14), Table 4, DECISIONS.md time scales.
//! Goal: B, D and the derived quantities are those of the paper's model, and the model has
//! the expected modes (stage ≈ 1.5–2.4 kHz, PEA ≈ 12 kHz) and static gain (Eq. 29).

use flexstage_control::linalg::spectral_abscissa;
use flexstage_control::model::{StageModel, to_dyn};
use flexstage_scenario::Scenario;

#[test]
fn b_and_d_follow_a14() {
    let p = Scenario::paper().stage.guess;
    let m = StageModel::new(&p).unwrap();
    let b = &m.b;
    let mm = p.mass;
    assert_eq!(b[(0, 4)], 1.0);
    assert_eq!(b[(3, 7)], 1.0);
    assert_eq!(b[(4, 0)], -2.0 * p.k_qo1 / mm);
    assert_eq!(b[(4, 2)], p.k_qo1 / mm);
    assert_eq!(b[(5, 3)], -p.alpha * p.k_qo2 / mm);
    assert_eq!(b[(5, 6)], p.alpha * p.c_qo2 / mm);
    assert_eq!(b[(7, 0)], p.k_qo1 / p.m_in2);
    assert_eq!(b[(6, 2)], -(p.k_in1 + p.k_pea1 + p.k_qo1) / p.m_in1);
    assert_eq!(b[(7, 7)], -(p.c_in2 + p.c_qo1) / p.m_in2);
    assert_eq!(b[(7, 4)], p.c_qo1 / p.m_in2);
    assert_eq!(m.d[(0, 0)], p.k_pea1 / p.m_in1);
    assert_eq!(m.d[(0, 1)], 0.0);
    assert_eq!(b[(4, 1)], 0.0, "no cross terms in the design model");
    let c = StageModel::with_coupling(&p, 1e5).unwrap();
    assert_eq!(c.b[(4, 1)], -1e5 / mm);
    assert_eq!(c.b[(5, 0)], -1e5 / mm);
}

#[test]
fn modes_damping_and_static_gain() {
    let s = Scenario::paper();
    for p in [&s.stage.guess, &s.stage.truth] {
        let m = StageModel::new(p).unwrap();
        let [f1, f2, f3] = m.natural_frequencies();
        assert!(
            (1.4e3..2.5e3).contains(&f1) && (1.4e3..2.5e3).contains(&f2),
            "{f1} {f2}"
        );
        assert!((11e3..13e3).contains(&f3), "{f3}");
        assert!(
            spectral_abscissa(&to_dyn(&m.b)).unwrap() < 0.0,
            "B is Hurwitz"
        );
        // Eq. (29) with θ = 0: q1 ≈ (x1 + x2)/2, q2 ≈ α (x1 − x2), times the PEA ratio κ.
        let g = m.dc_gain().unwrap();
        assert!((g[(0, 0)] - g[(0, 1)]).abs() < 1e-3 * g[(0, 0)], "{g}");
        assert!((g[(0, 0)] - 0.5).abs() < 0.02, "{g}");
        assert!((g[(1, 0)] / g[(0, 0)] - 2.0 * p.alpha).abs() < 0.05, "{g}");
    }
    assert!(
        StageModel::new(&flexstage_scenario::StageParams {
            mass: 0.0,
            ..s.stage.guess.clone()
        })
        .is_err()
    );
}

/// Reference: the statics of Eq. (31)–(35) (closed forms in `model::fit_to_response`) and
/// the eigenvalues of B. Goal: the lumped model fitted to a response reproduces its static
/// gain exactly and its two output modes within 1 % (the plates' mass effect), so a
/// controller built on it sees the identified plant, not the design guess.
#[test]
fn fit_to_response_reproduces_static_gain_and_output_modes() {
    use flexstage_control::model::{ResponseFit, fit_to_response};
    let guess = flexstage_scenario::Scenario::paper().stage.guess;
    let fit = ResponseFit {
        dc_gain: [[0.41, 0.41], [1.7, -1.7]],
        frequency: [Some(4500.0), Some(3220.0)],
        damping: [0.01, 0.02],
    };
    let p = fit_to_response(&guess, &fit).unwrap();
    let m = StageModel::new(&p).unwrap();
    let g = m.dc_gain().unwrap();
    for i in 0..2 {
        for j in 0..2 {
            let want = fit.dc_gain[i][j];
            assert!(
                (g[(i, j)] - want).abs() < 1e-9 * want.abs(),
                "G[{i}][{j}] = {}",
                g[(i, j)]
            );
        }
    }
    // The model's lowest two oscillation frequencies and their damping ratios.
    let mut modes: Vec<(f64, f64)> =
        m.b.complex_eigenvalues()
            .iter()
            .filter(|z| z.im > 0.0)
            .map(|z| (z.norm() / std::f64::consts::TAU, -z.re / z.norm()))
            .collect();
    modes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (f2, f1) = (modes[0], modes[1]);
    for ((f, z), (fw, zw)) in [(f1, (4500.0, 0.01)), (f2, (3220.0, 0.02))] {
        assert!((f / fw - 1.0).abs() < 0.01, "mode {f} Hz vs {fw} Hz");
        assert!((z / zw - 1.0).abs() < 0.05, "damping {z} vs {zw}");
    }
    // A mode no stiffness can reach is refused with its name.
    let bad = ResponseFit {
        frequency: [Some(1e6), Some(3220.0)],
        ..fit
    };
    let e = fit_to_response(&guess, &bad).unwrap_err().to_string();
    assert!(e.contains("fit.frequency[0]"), "{e}");
    // Without a q_o1 mode the design's K_qo1 is kept, the static gain still matches and
    // the q_o1 mode moves with the fitted mass: f₁ √(M_guess / M).
    let none = ResponseFit {
        frequency: [None, Some(3220.0)],
        ..fit
    };
    let p = fit_to_response(&guess, &none).unwrap();
    assert_eq!(p.k_qo1, guess.k_qo1);
    let g = StageModel::new(&p).unwrap().dc_gain().unwrap();
    assert!((g[(1, 0)] - 1.7).abs() < 1e-9 && (g[(0, 1)] - 0.41).abs() < 1e-9);
}

/// Reference: the statics of Eq. (30) with the coupling spring k_c (`StageModel::with_coupling`).
/// Goal: the coupling fitted to a static gain recovers the k_c that made it (both signs, on
/// the paper's guess), and a gain without cross terms (a mirror-symmetric stage) gives 0.
#[test]
fn fit_coupling_recovers_the_coupling_of_a_static_gain() {
    use flexstage_control::model::fit_coupling;
    let p = flexstage_scenario::Scenario::paper().stage.guess;
    let scale = (2.0 * p.k_qo1 * p.k_qo2).sqrt();
    for frac in [0.05, -0.1, 0.15] {
        let k_c = frac * scale;
        let g = StageModel::with_coupling(&p, k_c)
            .unwrap()
            .dc_gain()
            .unwrap();
        let got = fit_coupling(&p, [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]]).unwrap();
        assert!(
            (got - k_c).abs() < 1e-6 * scale,
            "k_c {k_c} fitted as {got} ({frac})"
        );
    }
    let g = StageModel::new(&p).unwrap().dc_gain().unwrap();
    let got = fit_coupling(&p, [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]]).unwrap();
    assert!(got.abs() < 1e-9 * scale, "{got}");
}
