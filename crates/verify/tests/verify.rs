//! End-to-end verification of designs: the verdict, the comparison with the design mesh, the
//! typed errors.

use flexstage_scenario::{Preset, Scenario};
use flexstage_verify::{VerifyError, VerifyParams, samples, verify};

fn fast() -> VerifyParams {
    VerifyParams {
        compare_design_mesh: false,
        refine_check: false,
        ..VerifyParams::default()
    }
}

#[test]
fn the_verdict_follows_the_allowable_stress() {
    // Goal: the same design is "NOT safe" when its peak stress exceeds the allowable and safe
    // when it does not; the reason names the stress, its place and the allowable.
    let (s, rho, loops) = samples::bridge_design(Preset::Quick);
    let v = verify(&s, &rho, &loops, &fast()).unwrap();
    let peak = v.body_fitted.stress.von_mises;
    assert!(peak > 1e6 && peak < 1e9, "{peak}");
    let strict = VerifyParams {
        fatigue_strength: 0.5 * peak,
        safety_factor: 1.0,
        ..fast()
    };
    let v = verify(&s, &rho, &loops, &strict).unwrap();
    assert!(!v.verdict.safe && !v.verdict.stress_ok && v.verdict.manufacturable);
    assert!(v.verdict.reasons[0].contains("exceeds the allowable"));
    assert!(
        v.summary_lines()
            .last()
            .unwrap()
            .starts_with("verdict: NOT safe")
    );
    let lax = VerifyParams {
        fatigue_strength: 2.0 * peak,
        safety_factor: 1.0,
        ..fast()
    };
    let v = verify(&s, &rho, &loops, &lax).unwrap();
    assert!(v.verdict.safe, "{:?}", v.verdict);
    // The stress is symmetric: the design is, so the peak is at (+a, −a) or (−a, +a) and
    // its mirror image carries the same stress.
    assert!(v.body_fitted.stress.case[0] * v.body_fitted.stress.case[1] < 0.0);
    let vtu = v.to_vtu();
    assert_eq!(
        vtu.lines().filter(|l| *l == "22").count(),
        v.body_fitted.elements
    );
}

#[test]
fn body_fitted_and_design_mesh_agree_as_the_design_grid_is_refined() {
    // Reference: two independent models of the same (nearly binary) bridge design — the Q4
    // design mesh (staircase boundary, nonlinear kinematics, reduce's condensation and modal
    // analysis) and the body-fitted T6 model of its ρ = 0.5 outline. Goal: α within 3 % and the
    // first frequency within 10 % on a 0.5 mm design grid, both closer than on the 1 mm grid;
    // the design mesh's peak stress below the body-fitted one (the 1 mm … 0.5 mm grid cannot
    // resolve the junction fillets); linear and nonlinear Q4 peaks within 2 % (strains ~1e-3,
    // so linear elasticity is adequate); the body-fitted re-check on a mesh of half the size
    // within 5 % (the stress is converged).
    let mut out = Vec::new();
    for refine in [1, 2] {
        let mut s = Scenario::preset(Preset::Paper);
        s.mesh.nl *= refine;
        s.mesh.nw *= refine;
        let (s, rho, loops) = samples::bridge_on(s, 0.05);
        let p = VerifyParams {
            refine_check: refine == 2,
            ..VerifyParams::default()
        };
        let v = verify(&s, &rho, &loops, &p).unwrap();
        let d = v.design_mesh.clone().unwrap();
        let b = &v.body_fitted;
        let da =
            (b.transfer.alpha_scalar - d.transfer.alpha_scalar).abs() / d.transfer.alpha_scalar;
        let df = (b.frequencies[0] - d.first_frequency).abs() / d.first_frequency;
        println!(
            "grid /{refine}: α {:.4} vs {:.4} ({:.2} %), f1 {:.0} vs {:.0} Hz ({:.2} %), σ {:.1} vs {:.1} MPa",
            b.transfer.alpha_scalar,
            d.transfer.alpha_scalar,
            100.0 * da,
            b.frequencies[0],
            d.first_frequency,
            100.0 * df,
            b.stress.von_mises * 1e-6,
            d.stress.von_mises * 1e-6
        );
        assert!(d.stress.von_mises < b.stress.von_mises);
        assert!((d.stress.von_mises - d.stress_linear).abs() < 0.02 * d.stress.von_mises);
        assert!(
            (b.mass - d.mass).abs() < 0.01 * d.mass,
            "{} vs {}",
            b.mass,
            d.mass
        );
        if let Some(r) = b.stress_refined {
            let change = (r.von_mises - b.stress.von_mises).abs() / b.stress.von_mises;
            assert!(change < 0.05, "refined re-check moved the peak by {change}");
        }
        out.push((da, df));
    }
    assert!(out[1].0 < out[0].0 && out[1].1 < out[0].1, "{out:?}");
    assert!(out[1].0 < 0.03 && out[1].1 < 0.10, "{out:?}");
}

#[test]
fn an_output_block_held_by_nothing_but_its_springs_is_a_mechanism() {
    // Goal: a design whose output part is not joined to the inputs cannot be analysed; the
    // error says which part turns freely (the output springs hold only its translation).
    let (s, _, _) = samples::bridge_design(Preset::Quick);
    let (l, w) = (s.mesh.length, s.mesh.width);
    let loops = vec![
        samples::rectangle(0.0, 0.4 * w, 0.1 * l, 0.6 * w),
        samples::rectangle(0.9 * l, 0.4 * w, l, 0.6 * w),
        samples::rectangle(0.4 * l, 0.8 * w, 0.6 * l, w),
    ];
    let rho = vec![1.0; s.mesh.nl * s.mesh.nw];
    match verify(&s, &rho, &loops, &fast()) {
        Err(VerifyError::Mechanism { motion, .. }) => assert_eq!(motion, "rotation"),
        other => panic!("expected a mechanism error, got {other:?}"),
    }
}

#[test]
fn a_void_port_is_a_clear_error() {
    // Goal: an outline that misses the PEA2 port names the port and its place in mm.
    let (s, _, _) = samples::bridge_design(Preset::Quick);
    let (l, w) = (s.mesh.length, s.mesh.width);
    let loops = vec![samples::rectangle(0.0, 0.3 * w, 0.6 * l, w)];
    let rho = vec![1.0; s.mesh.nl * s.mesh.nw];
    let e = verify(&s, &rho, &loops, &fast()).unwrap_err().to_string();
    assert!(e.contains("PEA2") && e.contains("120.00"), "{e}");
}
