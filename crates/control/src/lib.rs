//! # flexstage-control — the controllers and their design
//!
//! Section 3.2, Section 4 and Appendices C–D of the paper, with the defaults of DECISIONS.md.
//! The simulated world they run in (the rig, the plants, the lumped model of Eq. 36, the
//! trajectories and the experiment runner) is `flexstage-sim`; a controller meets it through
//! [`flexstage_sim::experiment::StageControl`].
//!
//! * [`observer`]: the K-filter of Eq. (37–42), B0 checked with the Lyapunov equation (39),
//!   discretized exactly for the sample time;
//! * [`estimator`]: the steady-state discrete Kalman gain of the same filters (sensor noise,
//!   documented process noise; DARE by structure-preserving doubling), the backstepping's
//!   default estimate in place of finite differences;
//! * [`backstepping`]: the robust backstepping law of Section 3.2.2 / Appendix D;
//! * [`registry`]: the one list of controllers ([`registry::CONTROLLERS`]): a controller is
//!   one module and one entry (name, label, default or on request, how it is designed for a
//!   stage; its design says how it steps);
//! * [`controller`]: the backstepping controller (robust or not), real time
//!   (`step(measurement) -> command`, no allocation, no I/O, deterministic), and its design
//!   from a stage's response fit with gains sized by its margins;
//! * [`actuator`]: inverse hysteresis compensation (inside the loop, Figure 7), amplifier
//!   range;
//! * [`fit`]: the controller's lumped model fitted to a measured response (static gain and
//!   output modes below Nyquist) and the coupling of Eq. (30) from its cross terms;
//! * [`feasibility`]: a reference is refused if it reaches the Nyquist frequency or needs more
//!   stroke, voltage or amplifier current than the rig has with the controller's feed-forward;
//! * [`experiment`]: one run of a controller on a plant ([`experiment::experiment_on`] takes any
//!   [`flexstage_sim::rig::StagePlant`]: the lumped model in the rig,
//!   [`experiment::Setup::lumped_plant`], or the twin of `flexstage-twin`);
//! * [`learning`]: iterative learning on top of any controller for periodic scans, designed
//!   from the loop's measured frequency response (monotone-convergence check);
//! * [`pi_notch`]: the industry baseline and the default controller: per-axis PI(D) with up
//!   to two notches, static feed-forward through a measured static gain, inverse-hysteresis
//!   compensation, tuned on the stage's sampled response;
//! * [`damping`]: positive position feedback on each axis's first mode (its filter placed on
//!   the measured loop's modal model, phase restored for the loop's delay) with the PI +
//!   notch tuned around the damped loop;
//! * [`pid`]: the PID + feed-forward baseline (the same law without notches), tuned or with
//!   the scenario's gains;
//! * [`margins`]: gain, phase and delay margins of a loop from its frequency response
//!   (python-control's `margin`), loop-at-a-time for the 2 × 2 loop;
//! * [`tuning`]: one documented tuning procedure (notches on the peaks of the sampled
//!   response, largest integral gain with ≥ 6 dB / 40°) applied with equal budget to every
//!   loop-shaping structure, on a sampled response ([`flexstage_sim::modal::LoopPlant`]);
//! * [`analysis`]: closed-loop poles of the sampled loop on the nominal linear model;
//! * [`target`]: a linear controller as a real-time target runs it (`step(reference,
//!   reading) -> command`, the law the PI + notch and PID step), its coefficients, and its
//!   self-contained C99 source and header;
//! * [`target_backstepping`]: the backstepping controller as a real-time target runs it (the
//!   law the simulated `robust` and `nonrobust` step, the reference's first three
//!   derivatives supplied from outside), its coefficients and its C99 source and header;
//! * [`samples`]: settings with known answers.
//!
//! ```
//! use flexstage_control::controller::ROBUST;
//! use flexstage_control::experiment::{Setup, experiment};
//! use flexstage_control::actuator::Compensation;
//! use flexstage_sim::trajectory::Reference;
//! let scenario = flexstage_scenario::Scenario::paper();
//! let setup = Setup::from_scenario(&scenario);
//! let (reference, _) = Reference::from_scenario(&scenario.trajectories[0]);
//! let rec = experiment(&setup, &ROBUST, Compensation::Inverse, reference, 0.05)?;
//! let m = rec.metrics(reference.half_range(0.05, 1e-4));
//! assert!(m.rms[0] < 1e-6 && m.peak_voltage <= 1000.0);
//! # Ok::<(), flexstage_control::ControlError>(())
//! ```
//!
//! # Units
//! SI throughout (m, s, N, kg, V), except the Bouc–Wen parameters, which stay in the µm/V/s
//! units of Table A1 as in flexstage-piezo.
//!
//! # Design decisions and corrections of the paper
//! Each is documented where it is implemented, with the equation number:
//!
//! * **Eq. (33)**: the second input plate's damper is C_qo1 (not C_qo2), as in Eq. (35)
//!   and (A14) ([`flexstage_sim::model`]).
//! * **Eq. (38)**: Table 4's scalar observer gains are read as injection vectors
//!   k_ei = g_i e_i ([`observer`]).
//! * **Eq. (40)–(41)**: Ωᵀ already carries D, so ẑ = ζ + Σ Ω_i (not ζ + Ωᵀb) ([`observer`]).
//! * **Observer disturbance state.** The K-filter is augmented with the model error Δ_η of
//!   Eq. (36)/(43) acting on the output accelerations (constant model, injection κ_d S⁻¹
//!   with S the static gain from Δ_η to q). The law uses the estimate Δ̂_η in Z and keeps the
//!   robust terms for the residual. Without it the loop has no integral action: the DC error
//!   under a disturbance Δ is Δ/(k_ε k_η), which needs k_ε k_η ≳ 1e9 s⁻² for nm accuracy
//!   (a 30 kHz bandwidth, impossible at 10 kHz sampling).
//! * **Discretization.** Forward Euler of the observer is unstable at 0.1 ms (pole −9 for
//!   g = 1e5). The observer is discretized exactly for sampled measurements
//!   (ε_{k+1} = F ε_k, F = Φ − L C matching e^{B0 T} in the injectable columns), the plant
//!   with the exact matrix exponential per substep ([`flexstage_sim::plant`]).
//! * **A16, A23**: the output damping (β55, β66) is part of Z.
//! * **A23, stiffness kept.** Z uses N at the *reference* (q_d, q̇_d) instead of the
//!   measured output, so the mechanism's own spring and damper act on the error rather than
//!   being cancelled. Cancelling them (as A23 does) makes the 10 kHz loop depend on an exact,
//!   delay-free cancellation of 2K_qo1/M ≈ 2·10⁸ s⁻² by terms of size k_ε k_η ≈ 10⁷ s⁻²; the
//!   sampled loop then has a slow, barely damped pole and 0.4 µm errors on the nominal model.
//!   With the stiffness kept, A27's first line becomes ṡ = −k_η s − Λ(ε, ε̇) with Λ the
//!   (passive) spring-damper of the mechanism: the CLF argument still holds.
//! * **A22, A25**: robust term −ρ_η sgn(s) (or boundary layer), not −max|Δ_η|.
//! * **A34–A35, A36–A37**: v_m = ȧ − k ε_a and v_s = −ε_a − ρ_ε σ(ε_a/φ_a): the paper's
//!   division by (ξ̂ + Π) = ε_a is an error (singular at ε_a = 0); A37 writes ζ̂ for ξ̂.
//! * **Eq. (44)**: with v̇ alone, ξ̇ − v is not restored; the input transformation is
//!   evaluated at the desired inner state ξ_d = ∫v, so the PEA's own stiffness is the
//!   step-3 feedback ([`controller`]). Step 2 uses ξ_d (and ξ̇_d = v) as the inner state
//!   ([`controller::Inner::Command`], default); the estimate ξ̂ as printed is an option.
//!
//! # Gains (retuned for the sampled loop)
//! Table 4's k_ε = (2e4, 1.5e4) and k = (1.2e4, 1.2e3) put the sampled closed loop's poles
//! outside the unit circle (largest |z| ≈ 2.6–2.7 on the nominal model with
//! `analysis::closed_loop_poles`): k_ε T = 2 is beyond what 10 kHz sampling with a
//! finite-difference velocity supports. The defaults k_ε = k_η = k = 3e3 s⁻¹ and κ_d = 3e4 s⁻¹
//! give a largest closed-loop |z| ≈ 0.86 with the K-filter (0.91 with the default Kalman
//! estimate) on the nominal model. The observer gains 1e5 of Table 4 are kept. The
//! PID baseline's integral gain 300 s⁻¹ is near its stability limit (the 1.5–2.3 kHz output
//! modes have ≈ 2 % damping; 1000 s⁻¹ is unstable).

//! # Which controller wins where (on the twin of the designed stage)
//! Measured with `flexstage-assess` on the quick design (docs/verification.md): the PI + notch + FF
//! ([`pi_notch::PI_NOTCH_FF`], the default), tuned by [`tuning`] on the twin's
//! sampled frequency response, meets 6 dB / 40° on both loops with one sample of delay
//! (6.0 dB, 69° / 9.5 dB, 58°), tracks the default Lissajous to 10.2/5.9 nm RMS (the sensor
//! noise floor is 7.8/10.4 nm) and passes 96 % of 100 perturbed twins. It wins because the
//! twin's modes above Nyquist fold into the sampled loop (8.99 kHz appears at 1.01 kHz on
//! q1) and the notches sit on those peaks, which lets the integral gain rise 3.7×. The PID +
//! FF without notch is limited by the same peaks to a 40 Hz crossover on q1 (18.5/8.4 nm);
//! with the scenario's gains its q1 gain margin is 4.3 dB.
//!
//! The backstepping controllers as the paper sets them up (design guess as the model,
//! K-filter, Table 4-derived gains) are unstable on the twin: the guess's output modes
//! (1570/2324 Hz) are not the twin's (q2 at 3220 Hz; q1 has no mode below Nyquist, its
//! static gain is three modes above it whose shares cancel), and those modes fold into the
//! sampled loop (8.99 kHz at 1.01 kHz on q1, 3.6× the static gain) where no lumped model
//! has them. [`controller::sized`] sets them up as a practitioner would from the sampled
//! response ([`controller::ControllerParams::for_response`]): the Kalman estimate
//! ([`controller::Estimator::Kalman`], the default), the model fitted to the static gain and
//! the modes below Nyquist ([`fit::fit_to_response`]), the folded peaks notched on the
//! measurement ([`controller::ControllerParams::measurement_notches`]) and the gains scaled
//! by the margins (the largest of [`controller::GAIN_SCALES`] keeping 6 dB / 40°, measured by
//! the stage's [`registry::MarginProbe`]: sine injection on the twin's linear loop in
//! `flexstage-assess`). On the quick design that is × 0.5: 7.6 dB / 61° (q1) and
//! 23.7 dB / 75° (q2) with one sample of delay, 3.8/12.4 nm RMS on the default Lissajous
//! (the PI + notch: 10.2/5.9 nm; Monte-Carlo pass 67 % against its 96 %). The notches delay
//! the measurement and (44*)'s mid-sample ξ_d makes the output half a sample early; the law
//! aims at the reference earlier by both ([`controller::notch_delay`], controller docs
//! "Reference timing"), without which the output led by 2.3 samples (48 nm).
//!
//! What each part buys, each with the Kalman estimate (default Lissajous, RMS q1/q2; twin |
//! lumped plant in the rig; `flexstage-assess`'s `diagnose` example): non-robust 3.8/12.4 |
//! 6.4/11.8 nm; robust with the scenario's ρ_η = 0.1 m/s² 3.8/12.1 | 6.2/11.9 nm; robust
//! with ρ_η = the twin's measured max|Δ̂_η| = 66/284 m/s² (A25) unstable (µm); the same with
//! the boundary layer widened to keep the margins 3.7/12.2 | 6.4/11.8 nm; without the
//! disturbance observer ([`controller::ControllerParams::disturbance_feedback`] off)
//! 668/1163 | 1628/1768 nm. The disturbance observer does the work; the robust terms at
//! their theoretical size either destabilize the loop or act as a little more linear gain.

// Loops over the two axes index several arrays at once, as the equations do.
#![allow(clippy::needless_range_loop)]

pub mod actuator;
pub mod analysis;
pub mod backstepping;
pub mod controller;
pub mod damping;
mod error;
pub mod estimator;
pub mod experiment;
pub mod feasibility;
pub mod feedforward;
pub mod fit;
pub mod learning;
pub mod margins;
pub mod observer;
pub mod pi_notch;
pub mod pid;
pub mod registry;
pub mod samples;
pub mod target;
pub mod target_backstepping;
mod target_backstepping_c;
mod target_c;
pub mod tuning;

pub use error::{ControlError, Result};
