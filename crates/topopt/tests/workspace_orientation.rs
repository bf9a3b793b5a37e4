//! Reference: paper Section 2.2 ("the area of the viable output region is enlarged by a factor
//! of over two"), Table 2 (regular/reversed working conditions) and Figure 4b (tilted output).
//! Goal: the quick preset's workspace area grows ≥ 2× with a mostly 0/1 design; the reversed
//! configuration drives the compressive corner's output along −y (clockwise polygon); a tilt θ
//! orients the differential output along (sin θ, cos θ) within the tolerance.

use flexstage_scenario::{Configuration, Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem, shoelace};

fn run(s: &Scenario) -> (Vec<[f64; 2]>, f64, f64, f64) {
    let problem = Problem::from_scenario(s, None).unwrap();
    let mut opt = Optimizer::new(&problem, OptimizerParams::from_scenario(s)).unwrap();
    opt.run(|_, _| Ok(())).unwrap();
    let h = opt.history();
    let (_, ev) = opt.last().unwrap();
    (
        ev.blueprint().response.outputs.clone(),
        h[0].area,
        h.last().unwrap().area,
        h.last().unwrap().grey,
    )
}

#[test]
fn quick_preset_area_grows_at_least_twofold() {
    let mut s = Scenario::preset(Preset::Quick);
    s.optimization.max_iterations = 30;
    let (out, a0, a1, grey) = run(&s);
    println!("area {a0:e} -> {a1:e} ({:.1}x), grey {grey:.3}", a1 / a0);
    assert!(a1 >= 2.0 * a0, "growth {}", a1 / a0);
    assert!(
        shoelace(&out) > 0.0,
        "regular configuration gives a CCW polygon"
    );
    assert!(grey < 0.25, "grey fraction {grey}");
}

fn small(mut s: Scenario) -> Scenario {
    s.mesh.nl = 32;
    s.mesh.nw = 16;
    s.optimization.samples = 8;
    s.optimization.max_iterations = 25;
    s.regions.clear();
    s
}

#[test]
fn reversed_and_tilted_workspaces_are_oriented_as_specified() {
    let mut rev = small(Scenario::preset(Preset::Quick));
    rev.actuators.configuration = Configuration::Reversed;
    let (out, _, _, _) = run(&rev);
    let q = out.len() / 4;
    println!("reversed: compressive corner {:?}", out[q]);
    assert!(
        out[q][1] < 0.0,
        "reversed: y_out at (+a,-a) must be negative"
    );
    assert!(shoelace(&out) < 0.0);

    let mut tilt = small(Scenario::preset(Preset::Quick));
    tilt.output.tilt_deg = 20.0;
    tilt.optimization.mirror_symmetry = false;
    let tol = tilt.optimization.tilt_tolerance_deg;
    assert_eq!(tol, 1.0, "the documented default tolerance");
    let (out, _, _, _) = run(&tilt);
    let d = [out[q][0] - out[3 * q][0], out[q][1] - out[3 * q][1]];
    let angle = d[0].atan2(d[1]).to_degrees();
    println!(
        "tilted: differential output angle from +y {angle:.2}° (target 20°, tolerance {tol}°)"
    );
    assert!((angle - 20.0).abs() <= tol, "angle {angle}");
}
