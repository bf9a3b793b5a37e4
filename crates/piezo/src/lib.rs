//! # flexstage-piezo — hysteresis of the piezoelectric actuators (PEAs)
//!
//! Section 3.1 and Appendix B of the paper:
//!
//! * [`model`]: the asymmetric Bouc–Wen model, Eq. (18) with n = 1, with an exact
//!   voltage-driven integrator ([`advance`], [`BoucWen`]), steady-state loops and loop
//!   metrics ([`hysteresis`]);
//! * [`compensate`]: the inverse multiplicative compensation of Eq. (19)–(21), Figure 5;
//! * [`identify`](mod@identify): the parallel RLS of Algorithm A1 (A8, A12) on the summed regression, and a
//!   batch fit of the same model; it runs on the generic recursive least squares of
//!   `flexstage-numerics` (Eq. (A9)–(A11): [`Rls`], its information form [`WeightedMoments`],
//!   [`batch_least_squares`]), re-exported here;
//! * [`data`], [`synth`]: records (t, U, x) from CSV (read by `flexstage-numerics`'
//!   [`NumericCsv`]) or simulation with seeded [`GaussianNoise`];
//! * [`samples`]: problems with known answers.
//!
//! **Units.** x and h in µm, U in V, t in s: the units of Table A1 and of the scenario file
//! (so d_p, A_bw in µm/V, B_bw, Γ_bw in 1/V and δ_bw in µm/(V·s)). Multiply by
//! [`MICROMETRE`] for metres.
//!
//! ```
//! use flexstage_piezo::{BoucWen, BoucWenParams, CompensatorParams, InverseCompensator};
//! let dt = 1e-4; // 10 kHz
//! let mut pea = BoucWen::new(BoucWenParams::PEA1); // the actuator (simulated here)
//! let mut comp = InverseCompensator::new(BoucWenParams::PEA1, CompensatorParams::default())?;
//! for k in 0..2000 {
//!     let x_desired = 10.0 + 15.0 * (1.0 - (k as f64 * dt * 5.0 * std::f64::consts::TAU).cos());
//!     let u = comp.step(x_desired, dt).u; // Eq. (21)
//!     let x = pea.step(u, dt);
//!     assert!((x - x_desired).abs() < 1e-6);
//! }
//! # Ok::<(), flexstage_piezo::PiezoError>(())
//! ```

pub mod compensate;
pub mod data;
mod error;
pub mod hysteresis;
pub mod identify;
pub mod model;
pub mod samples;
pub mod synth;

pub use compensate::{
    Compensated, CompensatedLoop, CompensatorParams, InverseCompensator, compensated_loop,
};
pub use data::{NumericCsv, PeaData};
pub use error::{PiezoError, Result};
pub use hysteresis::{
    HysteresisLoop, LoopMetrics, LoopParams, WaveShape, Waveform, loop_metrics, steady_state_loop,
};
pub use identify::{
    BatchFit, HistoryPoint, Identification, IdentifyParams, ParallelRls, fit_batch, identify,
    rms_model_error,
};
pub use model::{BoucWen, BoucWenParams, MICROMETRE, advance, simulate};
// The generic numerics these modules run on, at their former paths.
pub use flexstage_numerics::dense::{SpdFactor, solve_spd};
pub use flexstage_numerics::rls::{Rls, RlsParams, WeightedMoments, batch_least_squares};
pub use synth::{GaussianNoise, synthesize};
