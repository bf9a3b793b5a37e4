//! Reference: Eq. (31)–(36) and Appendix C (A13–A14), Table 4, DECISIONS.md time scales.
//! Goal: B, D and the derived quantities are those of the paper's model, and the model has
//! the expected modes (stage ≈ 1.5–2.4 kHz, PEA ≈ 12 kHz) and static gain (Eq. 29).

use flexstage_scenario::Scenario;
use flexstage_sim::linalg::spectral_abscissa;
use flexstage_sim::model::{StageModel, to_dyn};

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
