//! The whole reduction of a design: condensation (optionally at an operating point), lumped
//! parameters, modal analysis with the Assumption-2 check, and the validity map.

use flexstage_fem::{Design, Kinematics, NewtonParams, NewtonWorkspace, SymbolicFactor, newton};
use flexstage_scenario::{Scenario, StageParams, Trajectory};
use flexstage_topopt::Problem;
use serde::Serialize;

use crate::condense::{Condensation, Condenser, Ports};
use crate::error::{ReduceError, Result, check, within};
use crate::lumped::stage_params;
use crate::mass::{PointMass, design_mass};
use crate::modal::{ModalParams, Modes, modal_analysis};
use crate::validity::{ValidityMap, ValidityParams, validity_map};

/// The FE problem of the reduction: the scenario's final-analysis model (total Lagrangian,
/// no additive material). The optimizer's artificial output load (`optimization.output_spring`,
/// grounded springs on the output DOFs that make the optimized mechanism transmit force) is
/// a design device, not part of the stage: unless `keep_output_spring`, it is removed, so that
/// the output is free in statics as in Eq. 24 and `x_in1 = x_in2` is a rigid translation.
pub fn reduction_problem(scenario: &Scenario, keep_output_spring: bool) -> Result<Problem> {
    let mut s = scenario.clone();
    if !keep_output_spring {
        s.optimization.output_spring = 0.0;
    }
    Ok(Problem::from_scenario(
        &s,
        Some(Kinematics::TotalLagrangian),
    )?)
}

/// Parameters of [`reduce`].
#[derive(Debug, Clone, PartialEq)]
pub struct ReduceParams {
    /// Operating point `x_nom` \[m\] at which the tangent is taken (`None`: undeformed state).
    /// Each |x_nom| ≤ 1 mm.
    pub operating_point: Option<[f64; 2]>,
    /// Modal analysis (`None`: skipped).
    pub modal: Option<ModalParams>,
    /// Put the input-plate masses `m_in` (scenario `stage.guess`) on the input nodes and the
    /// payload on the output node in the modal analysis (the assembled stage). Default true.
    pub plate_masses: bool,
    /// Assumption 2 holds when the first natural frequency is at least this multiple of the
    /// highest input frequency, in [1, 1e6]. Default 10.
    pub separation: f64,
    /// Validity map (`None`: skipped).
    pub validity: Option<ValidityParams>,
}

impl Default for ReduceParams {
    fn default() -> Self {
        Self {
            operating_point: None,
            modal: Some(ModalParams::default()),
            plate_masses: true,
            separation: 10.0,
            validity: Some(ValidityParams::default()),
        }
    }
}

impl ReduceParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        if let Some(op) = self.operating_point {
            for x in op {
                check(
                    "ReduceParams::operating_point",
                    x,
                    x.abs() <= 1e-3,
                    "a number in [-1e-3, 1e-3] [m] per input",
                )?;
            }
        }
        if let Some(m) = &self.modal {
            m.validate()?;
        }
        if let Some(v) = &self.validity {
            v.validate()?;
        }
        within("ReduceParams::separation", self.separation, 1.0, 1e6)
    }
}

/// The Assumption-2 check (design resonance ≫ input frequency).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Assumption2 {
    /// Lowest natural frequency \[Hz\].
    pub first_frequency: f64,
    /// Highest input frequency of the scenario's trajectories \[Hz\] (Lissajous: the faster
    /// axis, `ratio · f`).
    pub input_frequency: f64,
    /// `first_frequency / input_frequency`.
    pub ratio: f64,
    /// Required ratio.
    pub required: f64,
    /// Whether `ratio ≥ required`.
    pub holds: bool,
}

impl Assumption2 {
    /// A one-line statement of the check.
    pub fn statement(&self) -> String {
        format!(
            "Assumption 2 {}: first natural frequency {:.1} Hz is {:.0}x the highest input \
             frequency {:.2} Hz (required >= {:.0}x)",
            if self.holds { "holds" } else { "FAILS" },
            self.first_frequency,
            self.ratio,
            self.input_frequency,
            self.required
        )
    }
}

/// Highest input frequency of the trajectories \[Hz\] (0 without trajectories).
pub fn input_frequency(scenario: &Scenario) -> f64 {
    scenario
        .trajectories
        .iter()
        .map(|t| match t {
            Trajectory::Lissajous {
                ratio, frequency, ..
            } => ratio.max(1.0) * frequency,
            Trajectory::Circle { frequency, .. } => *frequency,
        })
        .fold(0.0, f64::max)
}

/// Everything [`reduce`] computes.
#[derive(Debug, Clone)]
pub struct Reduction {
    /// Condensation at the chosen state.
    pub condensation: Condensation,
    /// Operating point used (`None`: undeformed).
    pub operating_point: Option<[f64; 2]>,
    /// FE output displacement at the operating point \[m\] (zero when undeformed).
    pub operating_output: [f64; 2],
    /// Mass `M` of the design's material \[kg\] (the parameter set adds the payload).
    pub mass: f64,
    /// Volume fraction `Σρ/N`.
    pub volume_fraction: f64,
    /// The parameter set for the control stage.
    pub params: StageParams,
    /// Modes (if requested).
    pub modes: Option<Modes>,
    /// Assumption-2 check (if modes were computed and the scenario has trajectories).
    pub assumption2: Option<Assumption2>,
    /// Validity map (if requested).
    pub validity: Option<ValidityMap>,
}

/// Reduces the design `rho` (physical densities, fem order) of `problem` (built from
/// `scenario`; total-Lagrangian kinematics for the operating point and the validity map).
pub fn reduce(
    scenario: &Scenario,
    problem: &Problem,
    rho: &[f64],
    params: &ReduceParams,
) -> Result<Reduction> {
    params.validate()?;
    let model = &problem.model;
    let ports = Ports::from_problem(problem)?;
    let design = Design::new(rho);
    design.validate(model.mesh().n_elements())?;
    let mut condenser = Condenser::new(model, ports.clone())?;
    let (u0, operating_output) = match params.operating_point {
        None => (None, [0.0; 2]),
        Some(x) => {
            if model.kinematics() != Kinematics::TotalLagrangian {
                return Err(ReduceError::Input(
                    "an operating point needs Kinematics::TotalLagrangian".into(),
                ));
            }
            let sym = SymbolicFactor::for_model(model)?;
            let mut ws = NewtonWorkspace::new(model, sym);
            let mut p = model.zero_vector();
            for (port, xi) in problem.inputs.iter().zip(x) {
                port.add_force(flexstage_fem::pea_force(port.stiffness, xi), &mut p);
            }
            let mut u = model.zero_vector();
            let np = NewtonParams {
                increments: 8,
                ..NewtonParams::default()
            };
            newton::solve(model, &design, &p, &mut u, &np, &mut ws, None).map_err(|source| {
                ReduceError::Newton {
                    x1: x[0],
                    x2: x[1],
                    source,
                }
            })?;
            let q = [u[2 * ports.output], u[2 * ports.output + 1]];
            (Some(u), q)
        }
    };
    let condensation = condenser.condense(model, &design, u0.as_deref())?;
    let mass = design_mass(model.mesh(), rho, scenario.material.density);
    let volume_fraction = rho.iter().sum::<f64>() / rho.len() as f64;
    // The payload moves with the output: it adds to the moving mass M of Eq. 31–32.
    let stage = stage_params(
        scenario,
        condensation.k_qo1(),
        condensation.k_qo2(),
        mass + scenario.output.payload,
        condensation.alpha_scalar(),
    )?;
    let modes = match &params.modal {
        Some(mp) => {
            let pm = if params.plate_masses {
                plate_masses(problem, scenario)
            } else {
                Vec::new()
            };
            Some(modal_analysis(
                model,
                rho,
                scenario.material.density,
                &pm,
                mp,
            )?)
        }
        None => None,
    };
    let f_in = input_frequency(scenario);
    let assumption2 = modes.as_ref().filter(|_| f_in > 0.0).map(|m| {
        let f1 = m.frequencies[0];
        Assumption2 {
            first_frequency: f1,
            input_frequency: f_in,
            ratio: f1 / f_in,
            required: params.separation,
            holds: f1 / f_in >= params.separation,
        }
    });
    let validity = match &params.validity {
        Some(vp) => {
            let cond0 = if params.operating_point.is_some() {
                condenser.condense(model, &design, None)?
            } else {
                condensation.clone()
            };
            Some(validity_map(problem, rho, &cond0, vp)?)
        }
        None => None,
    };
    Ok(Reduction {
        condensation,
        operating_point: params.operating_point,
        operating_output,
        mass,
        volume_fraction,
        params: stage,
        modes,
        assumption2,
        validity,
    })
}

/// The stage's point masses: the PEA input plates on the inputs' faces (`m_in1`, `m_in2` of
/// the scenario's model guess, Eq. 1–3, each face node carrying its weight's share in x, as
/// the design's eigenproblem puts them) and the payload on the output node (`output.payload`,
/// when it is not zero), for the modal analysis of the design with its actuators.
pub fn plate_masses(problem: &Problem, scenario: &Scenario) -> Vec<PointMass> {
    let mut out: Vec<PointMass> = problem
        .inputs
        .iter()
        .zip([scenario.stage.guess.m_in1, scenario.stage.guess.m_in2])
        .flat_map(|(p, m)| {
            p.face.iter().map(move |&(dof, w)| PointMass {
                node: dof / 2,
                mass: w * m,
                axes: [dof % 2 == 0, dof % 2 == 1],
            })
        })
        .collect();
    if scenario.output.payload > 0.0 {
        out.push(PointMass {
            node: problem.output,
            mass: scenario.output.payload,
            axes: [true, true],
        });
    }
    out
}
