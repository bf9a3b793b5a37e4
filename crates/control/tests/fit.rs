//! Reference: the statics of Eq. (31)–(35) and the cross terms of Eq. (30) (closed forms in
//! `flexstage_control::fit`). Goal: the lumped model fitted to a measured response has that
//! response's static gain and output modes, and the fitted coupling reproduces the measured
//! static cross terms.

use flexstage_sim::model::StageModel;

/// Reference: the statics of Eq. (31)–(35) (closed forms in `fit::fit_to_response`) and
/// the eigenvalues of B. Goal: the lumped model fitted to a response reproduces its static
/// gain exactly and its two output modes within 1 % (the plates' mass effect), so a
/// controller built on it sees the identified plant, not the design guess.
#[test]
fn fit_to_response_reproduces_static_gain_and_output_modes() {
    use flexstage_control::fit::fit_to_response;
    use flexstage_identify::response::ResponseFit;
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
    use flexstage_control::fit::fit_coupling;
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
