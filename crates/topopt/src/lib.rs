//! # flexstage-topopt
//!
//! Workspace topology optimization of the piezo-driven compliant stage (paper Section 2.2,
//! Eq. 4–5, Algorithm 1, Appendix A), with the robust formulation, minimum sizes and a fatigue
//! stress constraint (DECISIONS.md).
//!
//! * [`problem`]: the scenario → FE model mapping shared by `analyze`, `design` and `reduce`,
//!   the load cases (stroke-square walk), the constraints and the shoelace area (Eq. 4).
//! * [`design_space`]: design variables ↔ elements, mirror symmetry by construction.
//! * [`filter`]: density filter and Heaviside projection; [`length_scale`]: minimum sizes in
//!   metres → filter radius and robust thresholds.
//! * [`realization`]: the density chain and the eroded / blueprint / dilated designs.
//! * [`analysis`]: all load cases in parallel, exact adjoint gradients of the named
//!   [`responses`] (objective, strain energy, strokes, tilt, [`stress`]).
//! * [`modal`]: the stage's natural frequencies (design, PEA sets, rollers, payload) with exact
//!   sensitivities and a smooth aggregate of the lowest few, reusing the design's
//!   factorization.
//! * [`optimize`]: Algorithm 1 with MMA (bound formulation of the worst case), checkpoints.
//! * [`summary`] and [`geometry`]: what a design delivers (α, θ, area, mass, stress, minimum
//!   sizes, one-node hinges); [`design_file`]: density CSV input and output.

pub mod analysis;
pub mod check;
pub mod design_file;
pub mod design_space;
pub mod error;
pub mod filter;
pub mod geometry;
pub mod length_scale;
pub mod modal;
pub mod optimize;
pub mod problem;
pub mod realization;
pub mod responses;
pub mod samples;
pub mod stress;
pub mod summary;

pub use analysis::{AnalysisParams, CaseResults, CaseState, Evaluator, Timing, Workspace};
pub use design_file::{density_csv, read_density_csv};
pub use design_space::DesignSpace;
pub use error::{Result, TopoptError};
pub use filter::{DensityFilter, Projection};
pub use length_scale::{LengthScale, LengthScaleParams};
pub use modal::{ModalParams, ModalWorkspace, StageDynamics, StageModes, stage_modes};
pub use optimize::{
    AdditiveParams, Constraint, IterationRecord, Optimizer, OptimizerParams, ProjectionSchedule,
    Scales, StopReason,
};
pub use problem::{Objective, Port, Problem, Resonance, Tilt, perimeter_walk, shoelace};
pub use realization::{
    Densities, DesignEvaluator, Evaluation, Realization, RealizationEvaluation, RobustThresholds,
};
pub use responses::{PerResponse, ResponseKind};
pub use stress::StressConstraint;
pub use summary::{DesignSummary, MechanismSummary};
