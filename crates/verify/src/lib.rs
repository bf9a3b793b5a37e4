//! # flexstage-verify
//!
//! Verification of the manufactured geometry of a flexstage design (the paper, Actuators 2022,
//! 11(7), 179, Section 4.1: the stage is wire-cut from a plate), independent of the
//! optimizer's density pixels:
//!
//! 0. **Outline** ([`outline`]): the ρ = 0.5 iso-contour of the density field by marching
//!    squares, smoothed and refined, written as DXF, SVG and STL (what `flexstage export`
//!    stores); the verification below checks this outline, so it lives beside it.
//! 1. **Outline → parts.** The exported outline (the ρ = 0.5 contour, smoothed and refined,
//!    exactly the DXF's polylines) is grouped into connected solid parts ([`geometry`]); parts
//!    that no port or support holds are *islands*.
//! 2. **Local feature size** ([`feature`]): shrinking-ball medial discs on both sides of the
//!    boundary give the width of every ligament and gap.
//! 3. **Manufacturability** ([`manufacture`]): islands, ligaments thinner than the minimum
//!    hinge, gaps narrower than the kerf, pockets that need a start hole — each with its place
//!    in millimetres.
//! 4. **Body-fitted mesh** ([`mesh`]): boundary points spaced by the local feature size, a
//!    constrained Delaunay triangulation with Ruppert refinement (`spade`), quadratic T6
//!    triangles ([`t6`]).
//! 5. **Re-analysis** ([`fe`], [`modal`]): linear plane-stress statics with the design's
//!    boundary conditions (PEA springs and strokes on the inputs, rollers, the output port)
//!    through distributing couplings, at the four corners of the stroke square (the von Mises
//!    stress is a norm of the stress, which is linear in the strokes, so its maximum over the
//!    square lies at a corner); the transfer matrix `α` (Eq. 24–27) by static condensation
//!    onto the inputs; the lowest natural frequencies with a consistent mass matrix
//!    (ρ0 = 2710 kg/m³).
//! 6. **Comparison** ([`design_mesh`]): the same quantities on the Q4 design mesh.
//! 7. **Verdict**: safe when the peak von Mises is within the allowable (fatigue strength /
//!    safety factor, [`VerifyParams`]) and no manufacturability error remains.
//!
//! Linear elasticity: at the paper's stroke strains are about 1e-3; the design-mesh
//! comparison reports the peak stress with nonlinear and linear kinematics side by side, so
//! the assumption is checked on every design.
//!
//! ## Example
//! ```
//! use flexstage_verify::{samples, verify, VerifyParams};
//! let (scenario, rho, loops) = samples::bridge_design(flexstage_scenario::Preset::Quick);
//! let params = VerifyParams { compare_design_mesh: false, ..VerifyParams::default() };
//! let v = verify(&scenario, &rho, &loops, &params).unwrap();
//! assert!(v.body_fitted.stress.von_mises > 0.0);
//! println!("{}", v.summary_lines().join("\n"));
//! ```

pub mod design_mesh;
pub mod error;
pub mod fe;
pub mod feature;
pub mod geometry;
pub mod manufacture;
pub mod mesh;
pub mod modal;
pub mod outline;
pub mod params;
pub mod samples;
pub mod t6;
pub mod verify;
pub mod vtu;

pub use error::{Result, VerifyError};
pub use manufacture::{FilledPocket, Finding, FindingKind, Manufacturability, Severity};
pub use params::{
    AL6061_T6_FATIGUE_STRENGTH, AL6061_T6_YIELD_STRENGTH, DEFAULT_SAFETY_FACTOR, VerifyParams,
};
pub use verify::{BodyFitted, StressPeak, Transfer, Verdict, Verification, verify};
