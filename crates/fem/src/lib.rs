//! # flexstage-fem
//!
//! Geometrically nonlinear finite elements for the topology-optimized compliant positioning
//! stage of the paper (Actuators 2022, 11(7), 179; Section 2 and Appendix A).
//!
//! ## Formulation
//!
//! * **Mesh** ([`Mesh`]): structured `n_l × n_w` bilinear (Q4) plane elements of thickness `t`
//!   on an `l × w` rectangle; column-major node numbering, counter-clockwise connectivity,
//!   DOFs `2n` (x), `2n+1` (y).
//! * **Kinematics** ([`Kinematics`]): small strain, or total Lagrangian with the Green–Lagrange
//!   strain `E = ½(H + Hᵀ + HᵀH)`, `H = ∇u` (paper Eq. (A1)), 2×2 Gauss integration.
//! * **Material** ([`Material`]): St Venant–Kirchhoff, `S = E(ρ) D̂ E` with the plane-stress
//!   matrix `D̂` and the modified SIMP modulus `E(ρ) = E_min + ρ^p (E0 − E_min)`.
//! * **Additive hyperelasticity** ([`AdditiveYeoh`], optional): per element
//!   `Ψ̃ = (1 − ρ^p)[c1 (I1 − 3 − 2(J − 1)) + c2 (I1 − 3)²]` (paper Eq. (A2), with a
//!   stress-free-reference correction, see the type docs), `S̃ = 2∂Ψ̃/∂C` (Eq. (A4)), and the
//!   `c2` update of Eq. (A3) ([`AdditiveYeoh::update_c2`]).
//! * **Residual** (Eq. (A5)–(A6)): `R(u, ρ) = ∪_e ∫ Bᵀ(u)(S + S̃) dV + K_s u` with grounded
//!   springs (PEA model, Eq. (2)–(3)) and link springs on combinations of DOFs (a load acting
//!   relative to a moving frame) in `K_s`; equilibrium `R(u, ρ) = P` (Eq. (6), (A7)).
//!   The tangent `K_T = ∂R/∂u` is the exact consistent linearization (material + geometric
//!   stiffness), so the adjoint method gives exact gradients; `∂R/∂ρ_e` includes the additive
//!   term's `(1 − ρ^p)` factor (cf. the approximations of Eq. (14)–(16)).
//!
//! * **Stress recovery** ([`stress`]): the von Mises value of the solid stress `E0 D̂ E(u)` at
//!   the Gauss points, with its gradient, for stress-constrained design.
//!
//! ## Linear algebra and solvers
//!
//! The sparsity pattern of the reduced (free-DOF) tangent is computed once; assembly refills the
//! CSC values in place ([`Model::assemble`], element kernels in parallel with rayon). The sparse
//! Cholesky is faer's low-level API: one [`SymbolicFactor`] (in an `Arc`, shared by threads),
//! numeric [`Factor`]s with their own buffers (LLᵀ, with an LBLᵀ fallback for indefinite
//! tangents), per-thread [`SolveWorkspace`]s, and [`pcg`] to reuse one factor as the
//! preconditioner of other states/load cases. [`newton::solve`] is an incremental
//! Newton–Raphson solver with cutback, line search and typed errors.
//!
//! ## Dynamics
//!
//! [`eigen`] is the one modal solver of the project: shift-invert Lanczos for the lowest
//! eigenpairs of `K φ = λ M φ` on any operators (the design loop, the reduced model, the
//! body-fitted verification and the twin all call it).
//! [`mass`] assembles the consistent mass matrix in the tangent's own pattern, and
//! [`transient`] integrates `M ü + C u̇ + R(u) = P(t)` with Newmark's average-acceleration rule
//! or HHT-α, Newton iterations on the Total Lagrangian residual per step and Rayleigh damping:
//! the full-model reference of the digital twin (`flexstage-twin`).
//!
//! ## Example
//!
//! ```
//! use flexstage_fem::{newton, samples::Stage, Design, Kinematics, NewtonParams,
//!                     NewtonWorkspace, SymbolicFactor};
//!
//! let stage = Stage::paper(24, 12, Kinematics::TotalLagrangian).unwrap();
//! let model = &stage.model;
//! let rho = stage.uniform_density(0.5, 1e-6);
//! let design = Design::new(&rho);
//! let symbolic = SymbolicFactor::for_model(&model).unwrap(); // once per mesh
//! let mut ws = NewtonWorkspace::new(model, symbolic.clone());            // one per thread
//!
//! // PEA strokes +30 µm (left) and −30 µm (right).
//! let load = stage.pea_load(30e-6, -30e-6);
//! let mut u = model.zero_vector();
//! let report = newton::solve(model, &design, &load, &mut u, &NewtonParams::default(),
//!                            &mut ws, None).unwrap();
//! assert!(report.relative_residual < 1e-9);
//!
//! // Adjoint for the output y-displacement: K_T λ = L_o, with the factor at the solution.
//! ws.factorize_tangent().unwrap();
//! let mut l_o = model.zero_vector();
//! l_o[2 * stage.output + 1] = 1.0;
//! let mut lambda = model.zero_vector();
//! let mut tmp = vec![0.0; model.dofs().n_free()];
//! ws.factor.solve_full(model.dofs(), &l_o, &mut lambda, &mut tmp, &mut ws.solve_ws).unwrap();
//!
//! // d u_out / dρ_e = −λᵀ ∂R/∂ρ_e.
//! let mut g = vec![0.0; model.mesh().n_elements()];
//! model.contract_drho(&design, &u, &lambda, &mut g);
//! g.iter_mut().for_each(|x| *x = -*x);
//! ```

pub mod eigen;
pub mod element;
pub mod error;
pub mod mass;
pub mod material;
pub mod mesh;
pub mod model;
pub mod newton;
pub mod samples;
pub mod solver;
pub mod stress;
pub mod transient;

pub use eigen::{EigenError, EigenOperators, Eigenpairs, Lanczos, LanczosParams, SpringUpdate};
pub use element::{ElementCoefficients, ElementGeometry, ElementKernel};
pub use error::{IterationRecord, NewtonError, ParamError, SolverError};
pub use mass::{
    DofMass, MassInterpolation, consistent_mass, consistent_mass_forms, consistent_mass_into,
    rigid_body_load,
};
pub use material::{AdditiveYeoh, Kinematics, Material, YeohUpdate};
pub use mesh::{Edge, Mesh, Passive};
pub use model::{
    AssemblyWorkspace, BoundaryConditions, Component, Design, DofMap, LinkSpring, Model,
    SparseMatrix, SparsityPattern, Spring, pea_force,
};
pub use newton::{LinearStrategy, NewtonParams, NewtonReport, NewtonWorkspace};
pub use solver::{
    BlockPcgWorkspace, ColumnOutcome, Factor, FactorKind, PcgParams, PcgReport, PcgWorkspace,
    SolveWorkspace, SymbolicFactor, pcg, pcg_block, singular_pivot_threshold,
};
pub use stress::STRESS_POINTS;
pub use transient::{
    RayleighDamping, Transient, TransientError, TransientParams, TransientStats, newmark_frequency,
};
