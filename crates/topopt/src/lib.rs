//! # flexstage-topopt
//!
//! Workspace topology optimization of the piezo-driven compliant stage (paper Section 2.2,
//! Eq. 4–5, Algorithm 1, Appendix A).
//!
//! * [`problem`]: the scenario → FE model mapping shared by `analyze`, `design` and `reduce`,
//!   the load cases (stroke-square walk) and the shoelace area (Eq. 4).
//! * [`filter`]: density filter and Heaviside projection.
//! * [`analysis`]: all load cases in parallel, exact adjoint gradients.

pub mod analysis;
pub mod check;
pub mod design_file;
pub mod error;
pub mod filter;
pub mod optimize;
pub mod problem;
pub mod samples;

pub use analysis::{AnalysisParams, Densities, Evaluation, Evaluator, Response, Timing};
pub use design_file::{DesignFile, density_csv, read_density_csv};
pub use error::{Result, TopoptError};
pub use filter::{DensityFilter, Projection};
pub use optimize::{
    AdditiveParams, IterationRecord, Optimizer, OptimizerParams, ProjectionSchedule, Scales,
    StopReason,
};
pub use problem::{EnergyLimit, Objective, Port, Problem, Tilt, perimeter_walk, shoelace};
