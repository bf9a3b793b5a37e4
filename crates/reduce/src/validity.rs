//! Validity map of the reduced static model: the tangent-space limitation of Section 3.2.1.
//!
//! Over the workspace samples (the `p_m` perimeter walk of the stroke square in
//! `(x_nom1, x_nom2)`, scaled by each factor `s` of [`ValidityParams::scales`]) the full
//! nonlinear FE (total Lagrangian, Newton, continuation over the scales) gives the input
//! displacements `x_in` and the output `q_FE`. Two reduced predictions are compared with it:
//!
//! * **kinematic** (the reduced model's claim, Eq. 24/29): `q_red = α_abs x_in` with the
//!   FE input displacements — only the transfer matrix is tested;
//! * **actuated**: the full linear FE under the same PEA loads, `q_lin = G x_nom` — the tangent
//!   model including the input compliance.
//!
//! The error of a sample is `|q_red − q_FE| / R_s`, with `R_s = max_k |q_FE,k|` the workspace
//! radius at that scale (a relative error of the workspace, robust near the corners where q
//! is small in one direction). The map reports every sample and, per scale, the largest and
//! RMS errors: the scale where the error passes a tolerance is where the tangent model breaks
//! down.

use flexstage_fem::{
    Design, Factor, Kinematics, NewtonParams, NewtonWorkspace, SolveWorkspace, SymbolicFactor,
    newton,
};
use flexstage_topopt::Problem;
use rayon::prelude::*;
use serde::Serialize;

use crate::condense::{Condensation, Ports};
use crate::error::{ReduceError, Result, check};

/// Parameters of the validity map.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidityParams {
    /// Stroke scale factors `s`, each in (0, 2], increasing. Default [0.1, 0.25, 0.5, 0.75, 1].
    pub scales: Vec<f64>,
    /// Newton parameters per scale step (continuation from the previous scale).
    pub newton: NewtonParams,
}

impl Default for ValidityParams {
    fn default() -> Self {
        Self {
            scales: vec![0.1, 0.25, 0.5, 0.75, 1.0],
            newton: NewtonParams {
                increments: 2,
                max_iterations: 40,
                residual_tol: 1e-10,
                ..NewtonParams::default()
            },
        }
    }
}

impl ValidityParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        if self.scales.is_empty() {
            return Err(ReduceError::Input(
                "ValidityParams::scales is empty; give at least one scale in (0, 2]".into(),
            ));
        }
        let mut last = 0.0;
        for &s in &self.scales {
            check(
                "ValidityParams::scales",
                s,
                s > last && s <= 2.0,
                "a number in (0, 2], strictly increasing",
            )?;
            last = s;
        }
        self.newton.validate()?;
        Ok(())
    }
}

/// One sample of the map.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValiditySample {
    /// Stroke scale.
    pub scale: f64,
    /// Nominal strokes \[m\].
    pub x_nom: [f64; 2],
    /// FE input displacements \[m\].
    pub x_in: [f64; 2],
    /// Nonlinear FE output \[m\].
    pub q_fe: [f64; 2],
    /// Kinematic reduced prediction `α_abs x_in` \[m\].
    pub q_reduced: [f64; 2],
    /// Linear FE under the same loads \[m\].
    pub q_linear: [f64; 2],
    /// `|q_reduced − q_fe| / R_s`.
    pub error: f64,
    /// `|q_linear − q_fe| / R_s`.
    pub error_linear: f64,
}

/// Summary of one scale.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScaleSummary {
    /// Stroke scale.
    pub scale: f64,
    /// Stroke amplitude `s·a` \[m\].
    pub amplitude: f64,
    /// Workspace radius `R_s` \[m\].
    pub radius: f64,
    /// Largest kinematic error.
    pub max_error: f64,
    /// RMS kinematic error.
    pub rms_error: f64,
    /// Largest actuated (linear FE) error.
    pub max_error_linear: f64,
}

/// The validity map.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidityMap {
    /// All samples, scale-major.
    pub samples: Vec<ValiditySample>,
    /// Per scale.
    pub scales: Vec<ScaleSummary>,
}

impl ValidityMap {
    /// Largest kinematic error at scales ≤ 1 (inputs within the stroke).
    pub fn max_error_within_stroke(&self) -> f64 {
        self.scales
            .iter()
            .filter(|s| s.scale <= 1.0 + 1e-12)
            .fold(0.0, |m, s| m.max(s.max_error))
    }
    /// Largest scale whose kinematic error is at most `tol` (0 if none).
    pub fn valid_scale(&self, tol: f64) -> f64 {
        let mut best = 0.0;
        for s in &self.scales {
            if s.max_error <= tol {
                best = s.scale;
            } else {
                break;
            }
        }
        best
    }
}

/// Builds the validity map of `problem` (its `cases` are the samples at scale 1; its model
/// should have total-Lagrangian kinematics) for densities `rho` and the condensation `cond`
/// at the undeformed state.
pub fn validity_map(
    problem: &Problem,
    rho: &[f64],
    cond: &Condensation,
    params: &ValidityParams,
) -> Result<ValidityMap> {
    params.validate()?;
    let model = &problem.model;
    if model.kinematics() != Kinematics::TotalLagrangian {
        return Err(ReduceError::Input(
            "the validity map compares with nonlinear FE: build the problem with \
             Kinematics::TotalLagrangian"
                .into(),
        ));
    }
    let ports = Ports::from_problem(problem)?;
    let design = Design::new(rho);
    design.validate(model.mesh().n_elements())?;
    let symbolic = SymbolicFactor::for_model(model)?;
    // Linear FE: q = G x_nom (stiffness at u = 0, springs included).
    let g = {
        let mut k = model.new_matrix();
        let mut aws = model.new_workspace();
        model.assemble(&design, &model.zero_vector(), None, Some(&mut k), &mut aws);
        let mut f = Factor::new(symbolic.clone());
        f.factorize(&k)?;
        let mut sws = SolveWorkspace::new(&symbolic);
        let mut g = [[0.0; 2]; 2];
        let mut tmp = vec![0.0; model.dofs().n_free()];
        for (j, port) in problem.inputs.iter().enumerate() {
            let mut p = model.zero_vector();
            port.add_force(flexstage_fem::pea_force(port.stiffness, 1.0), &mut p);
            let mut u = model.zero_vector();
            f.solve_full(model.dofs(), &p, &mut u, &mut tmp, &mut sws)?;
            g[0][j] = u[2 * ports.output];
            g[1][j] = u[2 * ports.output + 1];
        }
        g
    };
    let cases = &problem.cases;
    // Per sample: continuation over the scales.
    type Track = Vec<([f64; 2], [f64; 2])>;
    let per_case: Vec<Result<Track>> = cases
        .par_iter()
        .map_init(
            || NewtonWorkspace::new(model, symbolic.clone()),
            |ws, case| {
                let mut u = model.zero_vector();
                let mut out = Vec::with_capacity(params.scales.len());
                for &s in &params.scales {
                    let mut p = model.zero_vector();
                    for (port, &x) in problem.inputs.iter().zip(case) {
                        port.add_force(flexstage_fem::pea_force(port.stiffness, s * x), &mut p);
                    }
                    let start = u.clone();
                    let mut res =
                        newton::solve(model, &design, &p, &mut u, &params.newton, ws, None);
                    if res.is_err() {
                        // Retry from the previous scale with more increments.
                        u.copy_from_slice(&start);
                        let retry = NewtonParams {
                            increments: params.newton.increments * 8,
                            ..params.newton
                        };
                        res = newton::solve(model, &design, &p, &mut u, &retry, ws, None);
                    }
                    res.map_err(|source| ReduceError::Newton {
                        x1: s * case[0],
                        x2: s * case[1],
                        source,
                    })?;
                    out.push((
                        ports.input_displacements(&u),
                        [u[2 * ports.output], u[2 * ports.output + 1]],
                    ));
                }
                Ok(out)
            },
        )
        .collect();
    let per_case = per_case.into_iter().collect::<Result<Vec<_>>>()?;
    let mut samples = Vec::new();
    let mut scales = Vec::new();
    for (si, &s) in params.scales.iter().enumerate() {
        let radius = per_case
            .iter()
            .map(|r| r[si].1[0].hypot(r[si].1[1]))
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let (mut max_e, mut sum2, mut max_l) = (0.0f64, 0.0, 0.0f64);
        for (case, r) in cases.iter().zip(&per_case) {
            let (x_in, q_fe) = r[si];
            let x_nom = [s * case[0], s * case[1]];
            let q_reduced = cond.predict(x_in);
            let q_linear = [
                g[0][0] * x_nom[0] + g[0][1] * x_nom[1],
                g[1][0] * x_nom[0] + g[1][1] * x_nom[1],
            ];
            let error = (q_reduced[0] - q_fe[0]).hypot(q_reduced[1] - q_fe[1]) / radius;
            let error_linear = (q_linear[0] - q_fe[0]).hypot(q_linear[1] - q_fe[1]) / radius;
            max_e = max_e.max(error);
            max_l = max_l.max(error_linear);
            sum2 += error * error;
            samples.push(ValiditySample {
                scale: s,
                x_nom,
                x_in,
                q_fe,
                q_reduced,
                q_linear,
                error,
                error_linear,
            });
        }
        let amplitude = s * cases
            .iter()
            .flat_map(|c| c.iter().map(|x| x.abs()))
            .fold(0.0, f64::max);
        scales.push(ScaleSummary {
            scale: s,
            amplitude,
            radius,
            max_error: max_e,
            rms_error: (sum2 / cases.len() as f64).sqrt(),
            max_error_linear: max_l,
        });
    }
    Ok(ValidityMap { samples, scales })
}
