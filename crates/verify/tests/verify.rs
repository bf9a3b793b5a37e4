//! End-to-end verification of designs: the verdict, the comparison with the design mesh, the
//! typed errors.

use flexstage_scenario::{Preset, Scenario};
use flexstage_verify::{FindingKind, VerifyError, VerifyParams, samples, verify};

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

#[test]
fn a_pocket_too_small_for_the_start_hole_is_verified_filled_and_a_large_one_is_kept() {
    // Defect: two closed pockets in the bridge's output block, a Ø 0.6 mm one (no Ø 1 mm start
    // hole fits: the CAD/CAM step leaves it solid) and a Ø 3 mm one (cut through a start
    // hole). Goal: the small one is reported filled with its place, area (π r² of the
    // 200-gon within 0.1 %), inscribed diameter and added mass (area × thickness × density),
    // and is no manufacturability error; the large one stays a pocket (a note); and every
    // body-fitted value is exactly that of the outline drawn without the small pocket: the
    // part as it will be made is what is checked.
    let (s, rho, loops) = samples::bridge_design(Preset::Quick);
    let (small_at, large_at) = ([0.054, 0.053], [0.066, 0.053]);
    let mut with_both = loops.clone();
    with_both.push(samples::circle(small_at, 0.3e-3, 200, false));
    with_both.push(samples::circle(large_at, 1.5e-3, 200, false));
    let mut large_only = loops.clone();
    large_only.push(samples::circle(large_at, 1.5e-3, 200, false));
    let v = verify(&s, &rho, &with_both, &fast()).unwrap();
    let m = &v.manufacturing;
    assert_eq!(m.filled.len(), 1, "{:#?}", m.filled);
    let f = m.filled[0];
    assert_eq!(f.outline_loop, loops.len());
    assert!(
        f.inscribed < 1e-3 && (f.inscribed - 0.6e-3).abs() < 0.02e-3,
        "{f:?}"
    );
    assert!((f.at[0] - small_at[0]).hypot(f.at[1] - small_at[1]) < 0.05e-3);
    let area = std::f64::consts::PI * 0.3e-3_f64.powi(2);
    assert!((f.area - area).abs() < 1e-3 * area, "{} vs {area}", f.area);
    let mass = f.area * s.mesh.thickness * s.material.density;
    assert!((f.mass - mass).abs() < 1e-12 * mass);
    assert_eq!(m.pockets, 1, "the large pocket stays");
    assert!(m.findings.iter().any(|x| x.kind == FindingKind::Pocket));
    assert!(
        m.findings
            .iter()
            .all(|x| x.kind != FindingKind::PocketTooSmall)
    );
    assert!(v.verdict.manufacturable, "{:?}", v.verdict);
    let text = v.summary_lines().join("\n");
    assert!(text.contains("filled: 1 pocket(s)"), "{text}");
    let made = verify(&s, &rho, &large_only, &fast()).unwrap();
    assert!(made.manufacturing.filled.is_empty());
    let (a, b) = (&v.body_fitted, &made.body_fitted);
    assert_eq!(a.mass, b.mass);
    assert_eq!(a.stress.von_mises, b.stress.von_mises);
    assert_eq!(a.frequencies, b.frequencies);
    assert_eq!(a.elements, b.elements);
}
