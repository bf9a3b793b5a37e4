//! # flexstage-control-core — the embeddable controller core
//!
//! The control law of the simulated experiments, reduced to what runs on a target:
//! `step(measurement, reference) -> command`, with the setpoint supplied from outside at
//! every sample (no owned trajectory), `#![no_std]`, no allocation, no I/O, no floating-point
//! functions beyond `+ − × ÷` (so no `libm`).
//!
//! * [`pid`]: the PID + static feed-forward law, with optional notch sections on each axis
//!   (x_nom = G_dc⁻¹ (q_d + N(k_p e + k_i ∫e + k_d ė)), anti-windup by conditional
//!   integration): the one implementation of the law, which `flexstage-control`'s PI + notch
//!   and PID controllers run in the simulated experiments;
//! * [`ilc`]: the iterative learning layer for periodic references (reference adjustment:
//!   the controller sees y − c_j, so the output tracks q_d + c_j), with a zero-phase
//!   Bartlett Q-filter and a phase-lead learning gain, on caller-provided buffers;
//! * [`Controller`]: the two together.
//!
//! The hysteresis compensation and the amplifier model stay outside: the command is the
//! nominal actuator displacement x_nom \[m\] of Eq. (36) of Actuators 2022, 11(7), 179, which
//! the target's inverse-hysteresis stage turns into volts.
//!
//! # Checking no_std
//! The crate is `#![no_std]` and its only dependency (`thiserror` without default
//! features) is too, so `cargo build -p flexstage-control-core` fails if anything in it
//! reaches for `std`. A bare-metal target (`x86_64-unknown-none`, `thumbv7em-none-eabihf`)
//! is not installed on the build machine and cannot be fetched offline; with one,
//! `cargo build -p flexstage-control-core --target thumbv7em-none-eabihf` is the stronger
//! check.
#![no_std]
#![deny(missing_docs)]
// Loops over the two axes index several arrays at once, as the equations do.
#![allow(clippy::needless_range_loop)]

pub mod ilc;
pub mod pid;

pub use ilc::{Ilc, IlcBuffers, IlcParams};
pub use pid::{Biquad, PidGains, PidLaw};

/// Errors of the core: a setting outside its range.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum CoreError {
    /// A parameter is outside its accepted range.
    #[error("{field} = {value} is out of range: expected {expected}")]
    Range {
        /// The parameter.
        field: &'static str,
        /// Its value.
        value: f64,
        /// The accepted range.
        expected: &'static str,
    },
    /// A buffer has the wrong length.
    #[error("{field} has length {len}: expected {expected}")]
    Buffer {
        /// The buffer.
        field: &'static str,
        /// Its length.
        len: usize,
        /// The expected length.
        expected: usize,
    },
}

/// `Ok(())` when `ok`, else a [`CoreError::Range`].
pub(crate) fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    expected: &'static str,
) -> Result<(), CoreError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(CoreError::Range {
            field,
            value,
            expected,
        })
    }
}

/// PID + feed-forward with the learning layer: the learned correction c_j shifts the
/// measurement the PID sees (reference adjustment, [`ilc`]).
#[derive(Debug, Clone)]
pub struct Controller<S> {
    /// The feedback law.
    pub law: PidLaw,
    /// The learning layer (None: plain PID + feed-forward).
    pub learning: Option<Ilc<S>>,
}

impl<S: AsMut<[[f64; 2]]> + AsRef<[[f64; 2]]>> Controller<S> {
    /// One sample: measurement y \[m\] and reference q_d \[m\] in, command x_nom \[m\] out.
    #[inline]
    pub fn step(&mut self, y: [f64; 2], reference: [f64; 2]) -> [f64; 2] {
        let c = match &mut self.learning {
            Some(ilc) => ilc.step(y, reference),
            None => [0.0; 2],
        };
        self.law.step([y[0] - c[0], y[1] - c[1]], reference)
    }
}
