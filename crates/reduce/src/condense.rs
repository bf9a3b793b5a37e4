//! Static condensation of the tangent stiffness onto the two input displacements (paper
//! Eq. 23–25) and the output stiffness with the inputs held.
//!
//! # Partition (Eq. 23)
//! The FE model already eliminates its fixed DOFs (rollers, clamps). The inputs are the PEA
//! ports, each the weighted mean of its face's x DOFs (`flexstage_topopt::Port::face`; one DOF
//! for a point port). Prescribing `x_in` with no load elsewhere (Eq. 24) is the same as loading
//! the inputs with the forces that produce `x_in`: with the whole tangent `K_T` (springs
//! included) factored once, four solves give the input and output displacements under unit
//! input forces (uniform tractions on the faces) and unit output forces, the 2 × 2 blocks
//! `C_ii, C_oi, C_io, C_oo`, and
//!
//! ```text
//! α_abs = C_oi C_ii⁻¹,     C = C_oo − C_oi C_ii⁻¹ C_io   (output compliance, inputs held)  (Eq. 24)
//! ```
//!
//! Springs that act on the inputs' displacements only (the grounded PEA springs, over the
//! faces) change `C_ii` alone and drop out of both (Woodbury), as they drop out of the
//! partition `K_Tff u_f = −K_Tfs x_in` of a point input, which this equals. `K_T` is factored
//! by Cholesky (faer low-level API, [`flexstage_fem::Factor`]) with the LBLᵀ fallback at an
//! indefinite operating point.

//! # Frames (Eq. 22, 26)
//! The FE output displacement `q` is in the fixed global frame and contains the rigid
//! translation of the stage: [`Condensation::alpha_abs`] is `∂q/∂x_in`. The paper's `α`
//! (Eq. 24–26) maps `x_in` to the **deformation** `u_o = q − x`, `x = [½(x_in1 + x_in2), 0]ᵀ`
//! (the moving frame of Eq. 22), so [`Condensation::alpha`] `= α_abs − [[½, ½], [0, 0]]`.
//!
//! When the mechanism is held in x only through the inputs (the paper's setup: rollers in y at
//! the ports, PEA springs in x), `x_in1 = x_in2 = c` is an exact rigid translation of the
//! linearized model at any state, so `α11 + α12 = 0` and `α21 + α22 = 0` in the moving frame
//! for **every** design (Eq. 26, condition i) and, in the global frame, `α_abs11 + α_abs12 = 1`.
//! A left–right mirror-symmetric design additionally has `α11 = α12` (no tilt), hence
//! `α11 = α12 = 0` (`α_abs11 = α_abs12 = ½`).
//!
//! # Derived quantities (Eq. 26–29)
//! * tilt: at `x_in1 = −x_in2` the frame vanishes and `tan θ = u_o1/u_o2 =
//!   (α11 − α12)/(α21 − α22)` (Eq. 26, condition ii);
//! * scalar amplification `α = ½(α21 − α22)`, i.e. `q_2 = α (x_in1 − x_in2)`, the quantity Eq. 27
//!   estimates as `max q_o2 / max(x_in1 − x_in2)` and the one that appears in `A(θ)`
//!   (Eq. 28–29). (Eq. 27 writes `α := α22`; with Eq. 26, `α22 = −α21`, so the paper's own
//!   Eq. 28–29 use `α = α21 = −α22` — the convention kept here.)
//! * `A(θ) = [[½ + α tan θ, ½ − α tan θ], [α, −α]]` (Eq. 29); it equals `α_abs` exactly when
//!   Eq. 26 holds ([`Condensation::a_theta_residual`]).
//!
//! # Output stiffness (Eq. 30–32)
//! With the inputs held (`x_in = 0`), unit forces at the output DOFs give the output compliance
//! `C` (2×2) and its inverse, the condensed output stiffness `K_o = C⁻¹`. In the reduced model
//! (Eq. 30, 32, 33) the horizontal output is held by two springs `K_qo1` (one per input plate)
//! and the vertical one by `K_qo2`, so `K_qo1 = ½ / C11` and `K_qo2 = 1 / C22` (the stiffness
//! along each axis with the other output direction free). The cross terms of Eq. 30 are the
//! off-diagonal of `K_o`.

use std::sync::Arc;

use flexstage_fem::{
    AssemblyWorkspace, Design, Factor, FactorKind, Model, SolveWorkspace, SparseMatrix,
    SymbolicFactor,
};
use flexstage_topopt::Problem;
use serde::Serialize;

use crate::error::{ReduceError, Result};

/// The ports of the reduction: the two inputs (the PEA ports over their faces) and the output
/// node.
#[derive(Debug, Clone, PartialEq)]
pub struct Ports {
    /// Full DOF index of input 1 and input 2 (x DOFs of the PEA ports' points).
    pub inputs: [usize; 2],
    /// The inputs' faces: `(full DOF, weight)`, `Σ w = 1` (`flexstage_topopt::Port::face`);
    /// an input's displacement is its face's weighted mean.
    pub faces: [Vec<(usize, f64)>; 2],
    /// Output node (`L_o`, Eq. 7).
    pub output: usize,
}

impl Ports {
    /// The ports of a two-input problem.
    pub fn from_problem(problem: &Problem) -> Result<Self> {
        match problem.inputs.as_slice() {
            [a, b] => Ok(Self {
                inputs: [a.dof, b.dof],
                faces: [a.face.clone(), b.face.clone()],
                output: problem.output,
            }),
            other => Err(ReduceError::Input(format!(
                "the reduced model needs exactly two inputs, the problem has {}",
                other.len()
            ))),
        }
    }

    /// The two input displacements `x_in` (the faces' weighted means) of a full vector.
    pub fn input_displacements(&self, u: &[f64]) -> [f64; 2] {
        std::array::from_fn(|i| self.faces[i].iter().map(|&(d, w)| w * u[d]).sum())
    }
}

/// Result of the static condensation at one state.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Condensation {
    /// `∂q/∂x_in` in the global frame (q = FE output displacement), row i = output component.
    pub alpha_abs: [[f64; 2]; 2],
    /// The paper's `α` (Eq. 24–25): `∂u_o/∂x_in` in the moving frame, `u_o = q − x` (Eq. 22).
    pub alpha: [[f64; 2]; 2],
    /// Output compliance with the inputs held, `C = ∂q/∂F_o` [m/N].
    pub compliance: [[f64; 2]; 2],
    /// Condensed output stiffness `K_o = C⁻¹` [N/m].
    pub output_stiffness: [[f64; 2]; 2],
    /// Whether `K_Tff` was positive definite (LLᵀ) or needed the LBLᵀ fallback.
    pub positive_definite: bool,
}

impl Condensation {
    /// `tan θ = (α11 − α12)/(α21 − α22)` (Eq. 26).
    pub fn tan_theta(&self) -> f64 {
        let a = &self.alpha;
        (a[0][0] - a[0][1]) / (a[1][0] - a[1][1])
    }
    /// Tilt θ \[rad\] (Eq. 26).
    pub fn theta(&self) -> f64 {
        self.tan_theta().atan()
    }
    /// Scalar amplification `α = ½(α21 − α22)` (Eq. 27–29, see the module docs for the sign).
    pub fn alpha_scalar(&self) -> f64 {
        0.5 * (self.alpha[1][0] - self.alpha[1][1])
    }
    /// `A(θ)` of Eq. 29.
    pub fn a_theta(&self) -> [[f64; 2]; 2] {
        let (a, t) = (self.alpha_scalar(), self.tan_theta());
        [[0.5 + a * t, 0.5 - a * t], [a, -a]]
    }
    /// `max |A(θ) − α_abs|` relative to `max |α_abs|`: how far the design is from the two-
    /// parameter form of Eq. 26–29 (0 when the rigid translation is exact).
    pub fn a_theta_residual(&self) -> f64 {
        let a = self.a_theta();
        let scale = self
            .alpha_abs
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let r = a
            .iter()
            .flatten()
            .zip(self.alpha_abs.iter().flatten())
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        r / scale
    }
    /// Residuals of Eq. 26 in the moving frame, relative to `max |α|`:
    /// `(|α11 + α12|, |α21 + α22|)`.
    pub fn eq26_residuals(&self) -> [f64; 2] {
        let a = &self.alpha;
        let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        [
            (a[0][0] + a[0][1]).abs() / scale,
            (a[1][0] + a[1][1]).abs() / scale,
        ]
    }
    /// `K_qo1 = ½/C11`: each of the two horizontal springs of Eq. 30/33 [N/m].
    pub fn k_qo1(&self) -> f64 {
        0.5 / self.compliance[0][0]
    }
    /// `K_qo2 = 1/C22` [N/m].
    pub fn k_qo2(&self) -> f64 {
        1.0 / self.compliance[1][1]
    }
    /// Output displacement `q = α_abs x_in` predicted by the tangent model (global frame).
    pub fn predict(&self, x_in: [f64; 2]) -> [f64; 2] {
        let a = &self.alpha_abs;
        [
            a[0][0] * x_in[0] + a[0][1] * x_in[1],
            a[1][0] * x_in[0] + a[1][1] * x_in[1],
        ]
    }
}

/// Reusable buffers for condensations of one model (pattern, symbolic analysis, factor).
#[derive(Debug)]
pub struct Condenser {
    ports: Ports,
    /// The inputs' faces in reduced numbering.
    faces: [Vec<(usize, f64)>; 2],
    o: [usize; 2],
    tangent: SparseMatrix,
    factor: Factor,
    solve_ws: SolveWorkspace,
    assembly: AssemblyWorkspace,
    rhs: Vec<f64>,
    /// `C_ii⁻¹` of the last condensation (unit input displacements from unit input forces).
    inverse: [[f64; 2]; 2],
}

impl Condenser {
    /// Buffers for `model` with these ports. The inputs' face DOFs and both output DOFs must be
    /// free.
    pub fn new(model: &Model, ports: Ports) -> Result<Self> {
        let dofs = model.dofs();
        let nd = model.n_dofs();
        let free = |d: usize, what: &str| -> Result<usize> {
            if d >= nd {
                return Err(ReduceError::Input(format!(
                    "{what} DOF {d} is out of range"
                )));
            }
            dofs.reduced(d)
                .ok_or_else(|| ReduceError::Input(format!("{what} DOF {d} is fixed")))
        };
        let mut faces: [Vec<(usize, f64)>; 2] = [Vec::new(), Vec::new()];
        for (i, f) in ports.faces.iter().enumerate() {
            for &(d, w) in f {
                faces[i].push((free(d, &format!("input {}", i + 1))?, w));
            }
        }
        if ports.inputs[0] == ports.inputs[1] {
            return Err(ReduceError::Input("the two inputs are the same DOF".into()));
        }
        let o = [
            free(2 * ports.output, "output x")?,
            free(2 * ports.output + 1, "output y")?,
        ];
        if o.iter().any(|d| faces.iter().flatten().any(|t| t.0 == *d)) {
            return Err(ReduceError::Input(
                "the output node is an input node".into(),
            ));
        }
        let symbolic: Arc<SymbolicFactor> = SymbolicFactor::for_model(model)?;
        let mut factor = Factor::new(symbolic.clone());
        factor.allow_indefinite = true;
        Ok(Self {
            ports,
            faces,
            o,
            tangent: model.new_matrix(),
            solve_ws: SolveWorkspace::with_columns(&symbolic, 4),
            factor,
            assembly: model.new_workspace(),
            rhs: vec![0.0; 4 * dofs.n_free()],
            inverse: [[0.0; 2]; 2],
        })
    }

    /// The ports.
    pub fn ports(&self) -> &Ports {
        &self.ports
    }

    /// The tangent assembled by the last [`Condenser::condense`] (reduced, with springs).
    pub fn tangent(&self) -> &SparseMatrix {
        &self.tangent
    }

    /// Condensation of `K_T(u0)` (`u0 = None`: the undeformed state), Eq. 23–24, through
    /// four solves with the whole tangent (module docs, "Partition").
    pub fn condense(
        &mut self,
        model: &Model,
        design: &Design,
        u0: Option<&[f64]>,
    ) -> Result<Condensation> {
        design.validate(model.mesh().n_elements())?;
        let zero;
        let u0 = match u0 {
            Some(u) => {
                if u.len() != model.n_dofs() {
                    return Err(ReduceError::Input(format!(
                        "operating-point displacement has {} entries, the model {}",
                        u.len(),
                        model.n_dofs()
                    )));
                }
                u
            }
            None => {
                zero = model.zero_vector();
                &zero
            }
        };
        model.assemble(
            design,
            u0,
            None,
            Some(&mut self.tangent),
            &mut self.assembly,
        );
        let n = model.dofs().n_free();
        // Right-hand sides: unit forces on the inputs (uniform tractions on their faces) and on
        // the output DOFs.
        self.rhs.fill(0.0);
        for (j, face) in self.faces.iter().enumerate() {
            for &(r, w) in face {
                self.rhs[j * n + r] += w;
            }
        }
        for (j, &oj) in self.o.iter().enumerate() {
            self.rhs[(2 + j) * n + oj] = 1.0;
        }
        let kind = self.factor.factorize(&self.tangent)?;
        self.factor
            .solve_columns_in_place(&mut self.rhs, 4, &mut self.solve_ws)?;
        let rhs = &self.rhs;
        let input = |col: usize, i: usize| -> f64 {
            self.faces[i]
                .iter()
                .map(|&(r, w)| w * rhs[col * n + r])
                .sum()
        };
        let output = |col: usize, i: usize| rhs[col * n + self.o[i]];
        let block = |f: &dyn Fn(usize, usize) -> f64, c0: usize| -> [[f64; 2]; 2] {
            std::array::from_fn(|i| std::array::from_fn(|j| f(c0 + j, i)))
        };
        let (c_ii, c_io) = (block(&input, 0), block(&input, 2));
        let (c_oi, c_oo) = (block(&output, 0), block(&output, 2));
        let inverse = inverse2(c_ii);
        let alpha_abs = mul2(c_oi, inverse);
        let held = mul2(alpha_abs, c_io);
        let compliance: [[f64; 2]; 2] =
            std::array::from_fn(|i| std::array::from_fn(|j| c_oo[i][j] - held[i][j]));
        self.inverse = inverse;
        let output_stiffness = inverse2(compliance);
        let alpha = [
            [alpha_abs[0][0] - 0.5, alpha_abs[0][1] - 0.5],
            [alpha_abs[1][0], alpha_abs[1][1]],
        ];
        Ok(Condensation {
            alpha_abs,
            alpha,
            compliance,
            output_stiffness,
            positive_definite: kind == FactorKind::Llt,
        })
    }

    /// Full displacement field of unit input `j` (0 or 1: `x_in = e_j`, no output load) from
    /// the last condensation.
    pub fn unit_input_field(&self, model: &Model, j: usize) -> Vec<f64> {
        let n = model.dofs().n_free();
        let reduced: Vec<f64> = (0..n)
            .map(|r| self.rhs[r] * self.inverse[0][j] + self.rhs[n + r] * self.inverse[1][j])
            .collect();
        let mut full = model.zero_vector();
        model.dofs().scatter(&reduced, &mut full);
        full
    }
}

/// The inverse of a 2 × 2 matrix.
fn inverse2(a: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    [
        [a[1][1] / det, -a[0][1] / det],
        [-a[1][0] / det, a[0][0] / det],
    ]
}

/// The product of two 2 × 2 matrices.
fn mul2(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    std::array::from_fn(|i| std::array::from_fn(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j]))
}

/// One-shot condensation (see [`Condenser`]).
pub fn condense(
    model: &Model,
    design: &Design,
    ports: Ports,
    u0: Option<&[f64]>,
) -> Result<Condensation> {
    Condenser::new(model, ports)?.condense(model, design, u0)
}
