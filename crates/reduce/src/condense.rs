//! Static condensation of the tangent stiffness onto the two input displacements (paper
//! Eq. 23–25) and the output stiffness with the inputs held.
//!
//! # Partition (Eq. 23)
//! The FE model already eliminates its fixed DOFs (rollers, clamps). Of its free DOFs, the two
//! input DOFs (the x DOFs of the PEA ports) are the prescribed set `s` and all others the free
//! set `f`. With `u_s = x_in` prescribed, linear equilibrium without load on `f` gives
//!
//! ```text
//! K_Tff u_f = −K_Tfs x_in,     q = L_o|_f u_f = α_abs x_in                      (Eq. 24)
//! ```
//!
//! (the paper writes Eq. 24 without the minus sign; it is absorbed in `α`). The grounded PEA
//! springs act on `s` only, so they enter `K_Tss` and drop out of `α`. `K_Tff` is factored
//! once (Cholesky, faer low-level API, [`flexstage_fem::Factor`]) by keeping the model's CSC
//! pattern and replacing the rows and columns of `s` by their diagonal; one block solve then
//! gives both unit inputs and both unit output forces.
//!
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

/// The ports of the reduction: the two prescribed input DOFs and the output node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ports {
    /// Full DOF index of input 1 and input 2 (x DOFs of the PEA ports).
    pub inputs: [usize; 2],
    /// Output node (`L_o`, Eq. 7).
    pub output: usize,
}

impl Ports {
    /// The ports of a two-input problem.
    pub fn from_problem(problem: &Problem) -> Result<Self> {
        match problem.inputs.as_slice() {
            [a, b] => Ok(Self {
                inputs: [a.dof, b.dof],
                output: problem.output,
            }),
            other => Err(ReduceError::Input(format!(
                "the reduced model needs exactly two inputs, the problem has {}",
                other.len()
            ))),
        }
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
    s: [usize; 2],
    o: [usize; 2],
    tangent: SparseMatrix,
    modified: SparseMatrix,
    factor: Factor,
    solve_ws: SolveWorkspace,
    assembly: AssemblyWorkspace,
    rhs: Vec<f64>,
}

impl Condenser {
    /// Buffers for `model` with these ports. The input DOFs and both output DOFs must be free.
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
        let s = [
            free(ports.inputs[0], "input 1")?,
            free(ports.inputs[1], "input 2")?,
        ];
        if s[0] == s[1] {
            return Err(ReduceError::Input("the two inputs are the same DOF".into()));
        }
        let o = [
            free(2 * ports.output, "output x")?,
            free(2 * ports.output + 1, "output y")?,
        ];
        if o.iter().any(|d| s.contains(d)) {
            return Err(ReduceError::Input(
                "the output node is an input node".into(),
            ));
        }
        let symbolic: Arc<SymbolicFactor> = SymbolicFactor::for_model(model)?;
        let mut factor = Factor::new(symbolic.clone());
        factor.allow_indefinite = true;
        Ok(Self {
            ports,
            s,
            o,
            tangent: model.new_matrix(),
            modified: model.new_matrix(),
            solve_ws: SolveWorkspace::with_columns(&symbolic, 4),
            factor,
            assembly: model.new_workspace(),
            rhs: vec![0.0; 4 * dofs.n_free()],
        })
    }

    /// The ports.
    pub fn ports(&self) -> Ports {
        self.ports
    }

    /// The tangent assembled by the last [`Condenser::condense`] (reduced, with springs).
    pub fn tangent(&self) -> &SparseMatrix {
        &self.tangent
    }

    /// Condensation of `K_T(u0)` (`u0 = None`: the undeformed state), Eq. 23–24.
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
        let s = self.s;
        // Columns K_{:,s} of the full reduced tangent.
        let pat = self.tangent.pattern().clone();
        let (cp, ri) = (pat.col_ptr(), pat.row_idx());
        let vals = self.tangent.values();
        let rhs = &mut self.rhs;
        rhs.fill(0.0);
        for c in 0..n {
            for k in cp[c]..cp[c + 1] {
                let r = ri[k];
                for (j, &sj) in s.iter().enumerate() {
                    if c == sj {
                        rhs[j * n + r] -= vals[k];
                    } else if r == sj && r != c {
                        rhs[j * n + c] -= vals[k];
                    }
                }
            }
        }
        // K_Tff with the s rows/columns replaced by their diagonal.
        let mv = self.modified.values_mut();
        mv.copy_from_slice(vals);
        let diag = [self.tangent.diag(s[0]), self.tangent.diag(s[1])];
        for c in 0..n {
            for k in cp[c]..cp[c + 1] {
                let r = ri[k];
                if r != c && (s.contains(&r) || s.contains(&c)) {
                    mv[k] = 0.0;
                }
            }
        }
        // Right-hand sides: unit inputs (u_s = e_j) and unit output forces (u_s = 0).
        for j in 0..2 {
            for (i, &si) in s.iter().enumerate() {
                rhs[j * n + si] = if i == j { diag[i] } else { 0.0 };
            }
        }
        for (j, &oj) in self.o.iter().enumerate() {
            let col = &mut rhs[(2 + j) * n..(3 + j) * n];
            col[oj] = 1.0;
        }
        let kind = self.factor.factorize(&self.modified)?;
        self.factor
            .solve_columns_in_place(&mut self.rhs, 4, &mut self.solve_ws)?;
        let rhs = &self.rhs;
        let o = self.o;
        let at = |col: usize, i: usize| rhs[col * n + o[i]];
        let alpha_abs = [[at(0, 0), at(1, 0)], [at(0, 1), at(1, 1)]];
        let compliance = [[at(2, 0), at(3, 0)], [at(2, 1), at(3, 1)]];
        let det = compliance[0][0] * compliance[1][1] - compliance[0][1] * compliance[1][0];
        let output_stiffness = [
            [compliance[1][1] / det, -compliance[0][1] / det],
            [-compliance[1][0] / det, compliance[0][0] / det],
        ];
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

    /// Full displacement field of unit input `j` (0 or 1) from the last condensation.
    pub fn unit_input_field(&self, model: &Model, j: usize) -> Vec<f64> {
        let n = model.dofs().n_free();
        let mut full = model.zero_vector();
        model
            .dofs()
            .scatter(&self.rhs[j * n..(j + 1) * n], &mut full);
        full
    }
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
