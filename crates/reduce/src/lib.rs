//! # flexstage-reduce
//!
//! The bridge from design to control (paper Section 3.2.1, Eq. 22–36, Appendix C): an
//! optimized density field becomes the small spring–mass model the controller is designed on.
//! The paper approximates the transfer matrix by hand from the maximum output (Eq. 26–28);
//! here it is computed from the FE model and checked.
//!
//! * [`condense`](mod@condense) — **transfer matrix** `α` by static condensation of the tangent stiffness
//!   onto the two input displacements (Eq. 23–25), at the undeformed state or an operating
//!   point; tilt θ (Eq. 26), scalar `α` (Eq. 27), `A(θ)` (Eq. 29); output stiffness with the
//!   inputs held. **Frame convention**: [`Condensation::alpha_abs`] maps `x_in` to the FE output
//!   displacement `q` (global frame, rigid translation included); [`Condensation::alpha`] is
//!   the paper's `α`, mapping `x_in` to `u_o = q − x` in the moving frame
//!   `x = [½(x_in1 + x_in2), 0]` (Eq. 22): `α = α_abs − [[½, ½], [0, 0]]`.
//! * [`mass`] — lumped mass `M = Σρ_e ρ0 V_e` (Table 3: ρ0 = 2710 kg/m³) and FE mass matrices
//!   with a void-safe mass interpolation.
//! * [`lumped`] — the parameter set of Eq. 31–35 / A13–A14 as
//!   [`flexstage_scenario::StageParams`] TOML (what `flexstage track --params` reads).
//! * [`modal`] — lowest natural frequencies and mode shapes (shift-invert Lanczos with the
//!   sparse Cholesky of `K`), for Assumption 2.
//! * [`validity`] — error of the reduced static model against the full nonlinear FE over the
//!   workspace samples and stroke scales: where the tangent model breaks down.
//! * [`reduction`] — all of it for one design ([`reduce`]).
//!
//! ## Example
//! ```
//! use flexstage_reduce::{condense, samples, Ports};
//! use flexstage_fem::Design;
//!
//! let (_scenario, problem) = samples::stage(flexstage_scenario::Preset::Quick).unwrap();
//! let rho = samples::default_design(&problem);
//! let c = condense(&problem.model, &Design::new(&rho), Ports::from_problem(&problem).unwrap(),
//!                  None).unwrap();
//! // x_in1 = x_in2 is a rigid translation: Eq. 26 in the moving frame.
//! assert!((c.alpha[1][0] + c.alpha[1][1]).abs() < 1e-9 * c.alpha[1][0].abs());
//! ```

pub mod condense;
pub mod error;
pub mod lumped;
pub mod mass;
pub mod modal;
pub mod reduction;
pub mod samples;
pub mod validity;

pub use condense::{Condensation, Condenser, Ports, condense};
pub use error::{ReduceError, Result};
pub use lumped::stage_params;
pub use mass::{MassInterpolation, MassLumping, MassMatrix, PointMass, design_mass};
pub use modal::{ModalParams, Modes, modal_analysis};
pub use reduction::{
    Assumption2, ReduceParams, Reduction, input_frequency, plate_masses, reduce, reduction_problem,
};
pub use validity::{ScaleSummary, ValidityMap, ValidityParams, ValiditySample, validity_map};
