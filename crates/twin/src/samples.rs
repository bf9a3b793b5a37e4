//! Designs and set-ups with known behaviour, for tests, examples and benches.

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::Problem;

use crate::error::Result;

/// A rhombus amplifier on the scenario's domain: solid bars of `width` \[m\] along the four
/// edges of the rhombus spanned by the two PEA ports (left and right mid-height), the output
/// (top centre) and the bottom centre, void elsewhere (ρ_min), the passive port patches
/// solid. Pushing the ports inwards lifts the top vertex: the classic bridge-type
/// displacement amplifier (amplification ≈ cot θ for pinned bars, θ the bars' angle to x),
/// crisp, with void regions that must carry no mass.
pub fn rhombus(problem: &Problem, width: f64) -> Vec<f64> {
    let mesh = problem.mesh();
    let (l, w) = (mesh.nl as f64 * mesh.dx(), mesh.nw as f64 * mesh.dy());
    let vertices = [[0.0, 0.5 * w], [0.5 * l, w], [l, 0.5 * w], [0.5 * l, 0.0]];
    let distance = |p: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let t = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
        ((p[0] - a[0] - t * dx).powi(2) + (p[1] - a[1] - t * dy).powi(2)).sqrt()
    };
    let mut rho: Vec<f64> = (0..mesh.n_elements())
        .map(|e| {
            let c = mesh.element_centroid(e);
            let near =
                (0..4).any(|k| distance(c, vertices[k], vertices[(k + 1) % 4]) <= 0.5 * width);
            if near { 1.0 } else { problem.rho_min }
        })
        .collect();
    mesh.apply_passive(&mut rho, problem.rho_min);
    rho
}

/// The quick preset with the rhombus design of 3 elements' bar width: the twin's test case.
pub fn quick_rhombus() -> Result<(Scenario, Vec<f64>)> {
    let s = Scenario::preset(Preset::Quick);
    let problem = flexstage_reduce::reduction_problem(&s, false)?;
    let dx = problem.mesh().dx();
    let rho = rhombus(&problem, 3.0 * dx);
    Ok((s, rho))
}
