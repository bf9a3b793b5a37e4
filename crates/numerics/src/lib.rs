//! # flexstage-numerics — the generic numerics of flexstage
//!
//! What the stage crates share and what is not specific to any of them:
//!
//! * [`validate`]: the one typed error of a bad setting, [`RangeError`] (it names the field,
//!   the value and the accepted range), the checks that build it ([`validate::check`],
//!   [`validate::positive`], [`validate::within`], [`validate::count`], ...), the
//!   [`validate::Interval`] of an accepted range, and [`DataError`] for inputs that do not fit
//!   together. The crates keep their own error enums and wrap these.
//! * [`records`]: numeric CSV records with header-checked columns and errors that give the
//!   line ([`records::NumericCsv`]).
//! * [`noise`]: seeded pseudo-random sequences — [`noise::GaussianNoise`] (feature `noise`)
//!   for sensor noise and excitation, [`noise::SplitMix64`] for deterministic start vectors.
//! * [`rls`] (feature `dense`): recursive least squares with forgetting in square-root form,
//!   its information form and the batch least squares they reproduce, generic over the
//!   number of parameters.
//! * [`dense`]: small dense linear algebra. The workspace's one library for it is nalgebra
//!   (feature `dense`, re-exported as [`dense::nalgebra`]); this module adds the equilibrated
//!   SPD solve of the 10 kHz loops (written out on arrays, measured faster there) and the
//!   symmetric eigen-decomposition the stage crates need.
//! * [`samples`]: problems with known answers.
//!
//! Both features (`noise`: ChaCha8; `dense`: nalgebra) are on by default; a crate that only
//! validates its parameters (the standalone `flexstage-mma`, the scenario) takes
//! `default-features = false` and pulls in nothing but `thiserror`.
//!
//! ```
//! use flexstage_numerics::rls::{Rls, RlsParams};
//! // y = 2 φ₁ − φ₂, noise-free: RLS from a vague prior recovers θ.
//! let mut rls = Rls::<2>::new(RlsParams::default(), [0.0; 2])?;
//! for k in 0..50 {
//!     let phi = [1.0, (k as f64 * 0.7).sin()];
//!     rls.update(&phi, 2.0 * phi[0] - phi[1]);
//! }
//! assert!((rls.theta()[0] - 2.0).abs() < 1e-5 && (rls.theta()[1] + 1.0).abs() < 1e-5);
//! # Ok::<(), flexstage_numerics::RangeError>(())
//! ```

#![warn(missing_docs)]

pub mod dense;
mod error;
pub mod noise;
pub mod records;
#[cfg(feature = "dense")]
pub mod rls;
pub mod samples;
pub mod validate;

pub use error::Error;
pub use validate::{DataError, RangeError, compact};
