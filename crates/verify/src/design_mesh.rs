//! The same quantities on the design's own Q4 mesh, for the side-by-side comparison: peak
//! element von Mises at the stroke corners (geometrically nonlinear and linear), the transfer
//! matrix by `flexstage-reduce`'s static condensation and the first frequency by its modal
//! analysis.

use flexstage_fem::{Design, Kinematics, NewtonParams, NewtonWorkspace, SymbolicFactor, newton};
use flexstage_reduce::{ModalParams, Ports, condense, modal_analysis};
use flexstage_scenario::Scenario;
use flexstage_topopt::Problem;
use serde::Serialize;

use crate::error::{Result, VerifyError};
use crate::verify::{StressPeak, Transfer};

/// The design mesh's values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignMeshValues {
    /// Elements of the design mesh.
    pub elements: usize,
    /// Element size \[m\] (the larger side).
    pub element_size: f64,
    /// Mass of the densities `Σ ρ_e ρ0 V_e` \[kg\].
    pub mass: f64,
    /// Peak element-average von Mises stress (SIMP modulus, what the optimizer sees) over the
    /// elements with ρ ≥ 0.5, geometrically nonlinear, at the worst stroke corner.
    pub stress: StressPeak,
    /// The same peak with linear kinematics \[Pa\].
    pub stress_linear: f64,
    /// Transfer matrix (undeformed state).
    pub transfer: Transfer,
    /// First natural frequency \[Hz\].
    pub first_frequency: f64,
}

fn corner_stress(problem: &Problem, rho: &[f64], corners: &[[f64; 2]]) -> Result<StressPeak> {
    let model = &problem.model;
    let design = Design::new(rho);
    let sym =
        SymbolicFactor::for_model(model).map_err(|e| VerifyError::DesignMesh(e.to_string()))?;
    let mut ws = NewtonWorkspace::new(model, sym);
    let mesh = model.mesh();
    let mut best = StressPeak {
        von_mises: 0.0,
        at: [0.0; 2],
        case: [0.0; 2],
    };
    let mut vm = vec![0.0; mesh.n_elements()];
    for &x in corners {
        let mut p = model.zero_vector();
        for (port, xi) in problem.inputs.iter().zip(x) {
            port.add_force(flexstage_fem::pea_force(port.stiffness, xi), &mut p);
        }
        let mut u = model.zero_vector();
        let np = NewtonParams {
            increments: 2,
            ..NewtonParams::default()
        };
        newton::solve(model, &design, &p, &mut u, &np, &mut ws, None).map_err(|e| {
            VerifyError::DesignMesh(format!(
                "nonlinear solve at x_nom = ({:.1}, {:.1}) µm: {e}",
                x[0] * 1e6,
                x[1] * 1e6
            ))
        })?;
        model.von_mises_stresses(&design, &u, &mut vm);
        for (e, &v) in vm.iter().enumerate() {
            if rho[e] >= 0.5 && v > best.von_mises {
                best = StressPeak {
                    von_mises: v,
                    at: mesh.element_centroid(e),
                    case: x,
                };
            }
        }
    }
    Ok(best)
}

/// Analyses the design `rho` on its Q4 mesh: `stress_problem` carries the design's boundary
/// conditions (output spring included), `reduction` those of the reduced model (output free).
pub fn analyse(
    scenario: &Scenario,
    stress_problem: &Problem,
    reduction: &Problem,
    rho: &[f64],
    corners: &[[f64; 2]],
    modes: usize,
    plate_masses: bool,
) -> Result<DesignMeshValues> {
    let err = |e: &dyn std::fmt::Display| VerifyError::DesignMesh(e.to_string());
    let stress = corner_stress(stress_problem, rho, corners)?;
    let linear = stress_problem
        .with_kinematics(Kinematics::Linear)
        .map_err(|e| err(&e))?;
    let stress_linear = corner_stress(&linear, rho, corners)?.von_mises;
    let ports = Ports::from_problem(reduction).map_err(|e| err(&e))?;
    let c = condense(&reduction.model, &Design::new(rho), ports, None).map_err(|e| err(&e))?;
    let masses = if plate_masses {
        flexstage_reduce::plate_masses(reduction, scenario)
    } else {
        Vec::new()
    };
    let modal = modal_analysis(
        &reduction.model,
        rho,
        scenario.material.density,
        &masses,
        &ModalParams {
            modes: modes.max(1),
            ..ModalParams::default()
        },
    )
    .map_err(|e| err(&e))?;
    let mesh = reduction.mesh();
    Ok(DesignMeshValues {
        elements: mesh.n_elements(),
        element_size: mesh.dx().max(mesh.dy()),
        mass: flexstage_reduce::design_mass(mesh, rho, scenario.material.density),
        stress,
        stress_linear,
        transfer: Transfer::from_alpha_abs(c.alpha_abs),
        first_frequency: modal.frequencies[0],
    })
}
