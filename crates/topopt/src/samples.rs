//! Problems with known answers, for tests and benchmarks.

use flexstage_fem::{BoundaryConditions, Component, Kinematics, Material, Mesh, Model};

use crate::analysis::AnalysisParams;
use crate::error::Result;
use crate::optimize::OptimizerParams;
use crate::problem::{Objective, Port, Problem};

/// Sigmund's displacement inverter ("On the design of compliant mechanisms using topology
/// optimization", Mech. Struct. Mach. 25, 1997; the 99-line mechanism code of Bendsøe & Sigmund,
/// *Topology Optimization*, 2003, §2.6): the upper half of the symmetric domain, `nl × nw` unit
/// elements, E = 1, ν = 0.3, p = 3, ρ_min = 1e-3, symmetry (u_y = 0) on the top edge, the two
/// lowest nodes of the left edge clamped, a unit input force along +x at the top-left corner with
/// an input spring 0.1, and an output spring 0.1 at the top-right corner, where the x
/// displacement is to be as negative as possible. Linear kinematics, volume fraction 0.3.
pub fn inverter(nl: usize, nw: usize) -> Result<Problem> {
    let mesh = Mesh::new(nl as f64, nw as f64, 1.0, nl, nw)?;
    let material = Material {
        e0: 1.0,
        e_min: 1e-9,
        nu: 0.3,
        penalty: 3.0,
    };
    let top_left = mesh.node(0, nw);
    let top_right = mesh.node(nl, nw);
    let mut bcs = BoundaryConditions::new();
    bcs.fix_edge(&mesh, flexstage_fem::Edge::Top, Component::Y);
    bcs.fix_node(mesh.node(0, 0), Component::Both)
        .fix_node(mesh.node(0, 1), Component::Both);
    bcs.add_spring(2 * top_left, 0.1)
        .add_spring(2 * top_right, 0.1);
    let model = Model::new(mesh, material, Kinematics::Linear, bcs)?;
    let p = Problem {
        model,
        inputs: vec![Port::point(top_left, 2 * top_left, 0.1)],
        output: top_right,
        // unit force = spring 0.1 × stroke 10
        cases: vec![vec![10.0]],
        objective: Objective::Displacement {
            direction: [-1.0, 0.0],
        },
        energy_limit: None,
        max_stroke: None,
        volume_fraction: Some(0.3),
        min_volume_fraction: None,
        tilt: None,
        stress: None,
        mirror_symmetry: false,
        rho_min: 1e-3,
        initial_density: 0.3,
        dynamics: None,
        resonance: None,
    };
    p.validate()?;
    Ok(p)
}

/// The 99-line code's settings for [`inverter`]: filter radius 1.2, no projection, linear
/// direct solves.
pub fn inverter_params(max_iterations: usize) -> OptimizerParams {
    OptimizerParams {
        filter_radius: 1.2,
        max_iterations,
        change_tolerance: 1e-3,
        kkt_tolerance: 1e-3,
        analysis: AnalysisParams::tight(),
        ..OptimizerParams::default()
    }
}
