//! Craig–Bampton reduction of the assembled stage (Craig & Bampton, *AIAA J.* 6 (1968)
//! 1313–1319).
//!
//! The boundary set b is the interface of [`crate::structure`]: the x DOFs of the two PEA
//! ports and both output DOFs; everything else is the interior i. The basis is
//!
//! ```text
//! T = [ Ψ  X  Φ ],   Ψ = [ I ; −K_ii⁻¹ K_ib ]   (static constraint modes, one per interface DOF)
//!                    X = [ 0 ; K_ii⁻¹ f_i ]     (static corrections, one per PEA face)
//!                    Φ = [ 0 ; φ_k ]            (fixed-interface modes, K_ii φ = ω² M_ii φ)
//! ```
//!
//! with `K` the tangent at u = 0 without the springs (they act on the PEA faces and the
//! interface, and enter through the projection), `f_i` the uniform traction of a PEA port
//! over its face (DOFs off the interface besides the port's point) and `M` the consistent mass
//! of [`crate::StageFe`]. The reduced matrices are `M_r = Tᵀ M T`, `K_r = Tᵀ K T` (dense,
//! order 4 + faces + m); the rigid-base loads are `Tᵀ M r` for unit base accelerations in x
//! and y. The interface DOFs are the first four reduced coordinates themselves and the face
//! loads' static responses are in the span, so the reduced model's static response to the
//! PEA forces equals the FE's exactly; the fixed-interface modes add the dynamics up to the
//! frequency they cover. `K_ii` is factored once (Cholesky, faer through `flexstage_fem::Factor`); the
//! fixed-interface modes come from `flexstage_reduce::modal_analysis` (shift-invert Lanczos)
//! on the model with the interface clamped.

use flexstage_fem::{
    BoundaryConditions, Factor, Kinematics, Model, SolveWorkspace, SymbolicFactor,
};
use flexstage_reduce::{MassLumping, ModalParams, modal_analysis};
use nalgebra::{DMatrix, DVector};

use crate::error::{Result, TwinError};
use crate::structure::{INTERFACE, StageFe};

/// The Craig–Bampton reduced stage.
#[derive(Debug, Clone)]
pub struct CraigBampton {
    /// `M_r = Tᵀ M T` \[kg\] (order 4 + m).
    pub mass: DMatrix<f64>,
    /// `K_r = Tᵀ K T` [N/m].
    pub stiffness: DMatrix<f64>,
    /// `Tᵀ M r` for unit base accelerations in x and y \[kg\].
    pub floor: [DVector<f64>; 2],
    /// `Tᵀ a_i` for the two inputs, `a_i` the uniform traction of unit force on PEA port i's
    /// face: the reduced PEA force per newton, and the input displacement `a_iᵀ T q` as a
    /// function of the reduced coordinates (`e_i` for a port of one DOF).
    pub inputs: [DVector<f64>; 2],
    /// Static corrections in the basis (one per PEA port over a face, module docs).
    pub corrections: usize,
    /// The basis as full displacement vectors: 4 constraint modes, the static corrections,
    /// then m fixed-interface modes.
    pub basis: Vec<Vec<f64>>,
    /// Frequencies of the fixed-interface modes \[Hz\].
    pub fixed_interface_frequencies: Vec<f64>,
}

impl CraigBampton {
    /// `Tᵀ A T` for a symmetric matrix `a` in the model's pattern (e.g. a tangent at a
    /// deformed state), symmetrized against round-off.
    pub fn project(&self, model: &Model, a: &flexstage_fem::SparseMatrix) -> DMatrix<f64> {
        project(model, &self.basis, a)
    }

    /// Order of the reduced model.
    pub fn order(&self) -> usize {
        self.mass.nrows()
    }

    /// Number of fixed-interface modes.
    pub fn modes(&self) -> usize {
        self.order() - INTERFACE - self.corrections
    }
}

/// The model with the interface clamped (linear kinematics; the interior's stiffness is the
/// tangent at u = 0).
fn clamped_model(fe: &StageFe) -> Result<Model> {
    let base = &fe.model;
    let mut bcs = BoundaryConditions {
        fixed: base.bcs().fixed.clone(),
        springs: Vec::new(),
        links: Vec::new(),
    };
    bcs.fixed.extend_from_slice(&fe.interface);
    Ok(Model::new(
        base.mesh().clone(),
        *base.material(),
        Kinematics::Linear,
        bcs,
    )?)
}

/// `Tᵀ A T` for the basis `basis` (full vectors) and a symmetric matrix in the model's pattern.
fn project(model: &Model, basis: &[Vec<f64>], a: &flexstage_fem::SparseMatrix) -> DMatrix<f64> {
    let dofs = model.dofs();
    let n = dofs.n_free();
    let t: Vec<Vec<f64>> = basis
        .iter()
        .map(|v| {
            let mut red = vec![0.0; n];
            dofs.gather(v, &mut red);
            red
        })
        .collect();
    let r = t.len();
    let mut at = vec![0.0; n];
    let mut out = DMatrix::zeros(r, r);
    for j in 0..r {
        a.matvec(&t[j], &mut at);
        for i in 0..r {
            out[(i, j)] = t[i].iter().zip(&at).map(|(x, y)| x * y).sum::<f64>();
        }
    }
    0.5 * (&out + out.transpose())
}

/// Reduces `fe` with `modes` fixed-interface modes (1–50).
pub fn craig_bampton(fe: &StageFe, modes: usize) -> Result<CraigBampton> {
    if !(1..=50).contains(&modes) {
        return Err(TwinError::OutOfRange {
            field: "fixed-interface modes".into(),
            value: modes.to_string(),
            expected: "an integer in [1, 50]".into(),
        });
    }
    let model = &fe.model;
    let dofs = model.dofs();
    let k = fe.stiffness();
    let m = fe.mass_matrix()?;
    let clamped = clamped_model(fe)?;
    let cdofs = clamped.dofs();
    // Fixed-interface modes.
    let params = ModalParams {
        modes,
        lumping: MassLumping::Consistent,
        interpolation: fe.interpolation,
        ..ModalParams::default()
    };
    let fixed = modal_analysis(&clamped, &fe.rho, fe.density, &[], &params)?;
    // Constraint modes: K_ii ψ_i = −K_ib e_j.
    let mut kc = clamped.new_matrix();
    let mut ws = clamped.new_workspace();
    let zero = clamped.zero_vector();
    clamped.assemble(&fe.design(), &zero, None, Some(&mut kc), &mut ws);
    let sym = SymbolicFactor::for_model(&clamped)?;
    let mut factor = Factor::new(sym.clone());
    factor.allow_indefinite = false;
    factor.factorize(&kc)?;
    let mut sws = SolveWorkspace::new(&sym);
    let n = dofs.n_free();
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(INTERFACE + 2 + modes);
    let (mut e, mut col) = (vec![0.0; n], vec![0.0; n]);
    let mut full = model.zero_vector();
    let mut rhs = vec![0.0; cdofs.n_free()];
    for &b in &fe.interface {
        let rb = dofs
            .reduced(b)
            .ok_or_else(|| TwinError::Reduced(format!("interface DOF {b} is fixed")))?;
        e.fill(0.0);
        e[rb] = 1.0;
        k.matvec(&e, &mut col);
        dofs.scatter(&col, &mut full);
        cdofs.gather(&full, &mut rhs);
        rhs.iter_mut().for_each(|x| *x = -*x);
        factor.solve_in_place(&mut rhs, &mut sws)?;
        let mut psi = model.zero_vector();
        cdofs.scatter(&rhs, &mut psi);
        psi[b] = 1.0;
        basis.push(psi);
    }
    // Static corrections of the PEA faces: a face's uniform traction loads DOFs off the
    // interface, so its static response with the interface clamped, K_ii χ = f_i, joins the
    // basis (the twin then reproduces the FE statics exactly, as for a port of one DOF).
    let mut corrections = 0;
    for face in fe.faces.iter().filter(|f| f.len() > 1) {
        let mut load = model.zero_vector();
        for &(d, w) in face {
            load[d] += w;
        }
        cdofs.gather(&load, &mut rhs);
        factor.solve_in_place(&mut rhs, &mut sws)?;
        let mut chi = model.zero_vector();
        cdofs.scatter(&rhs, &mut chi);
        basis.push(chi);
        corrections += 1;
    }
    basis.extend(fixed.shapes.iter().cloned());
    let r = basis.len();
    let mass = project(model, &basis, &m);
    let stiffness = project(model, &basis, &k);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut floor = [DVector::zeros(r), DVector::zeros(r)];
    for (d, f) in floor.iter_mut().enumerate() {
        let mr = fe.rigid_body_load(d)?;
        for j in 0..r {
            f[j] = dot(&basis[j], &mr);
        }
    }
    let inputs = fe
        .faces
        .clone()
        .map(|face| DVector::from_fn(r, |j, _| face.iter().map(|&(d, w)| w * basis[j][d]).sum()));
    Ok(CraigBampton {
        mass,
        stiffness,
        floor,
        inputs,
        corrections,
        basis,
        fixed_interface_frequencies: fixed.frequencies,
    })
}
