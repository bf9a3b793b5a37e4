//! # flexstage-twin — the digital twin of the designed stage
//!
//! The simulated experiment of the paper (Actuators 2022, 11(7), 179, Section 4) proves little
//! when the plant is the controller's own 8-state model (Eq. 36, A13–A14). This crate builds a
//! structural-dynamics model of the **designed** mechanism from its finite-element model,
//! verifies it against the full nonlinear transient of that model, and runs it inside the loop
//! of a real rig (`flexstage_sim::rig`): the plant `track` and `run` simulate on.
//!
//! ## What the twin is
//!
//! 1. **The assembled stage** ([`structure`]): the scenario's FE model of the design (Q4, Total
//!    Lagrangian, SIMP stiffness `ρ^p E0`), consistent mass `m(ρ)·ρ0·V` with the void
//!    interpolation of `flexstage_fem::MassInterpolation` (void and faint grey carry no
//!    mass), void (ρ < 0.01) removed as air, and at each input port the **PEA set of Eq. 1–3**:
//!    the PEA spring K_pea (Table 1), the input plate's spring K_in and mass m_in (Table 4
//!    estimates, `stage.truth`), driven by the force K_pea·x_nom(t). The optimizer's output
//!    spring is a design device and is left out.
//! 2. **Craig–Bampton reduction** ([`craig_bampton`]): interface = the two PEA input DOFs and
//!    both output DOFs (the sensor point), static constraint modes plus fixed-interface modes
//!    until these reach twice the twin's reach (the larger of coverage × the first resonance,
//!    default 3×, and f_s + [`SCAN_REACH`] × it: the hold's images and folded modes of the
//!    sweep's fastest scan), at least `twin.min_modes` (default 40). Statics to the PEA
//!    forces are exact.
//! 3. **Damping** ([`modal`]): Rayleigh `C = a_M M + b_K K`, ζ = `twin.damping_ratio` (default
//!    1 %, aluminium flexures 0.5–2 %) at the first resonance and at coverage × it; the full
//!    reference uses the same C, so both are damped alike.
//! 4. **Geometric nonlinearity** ([`nonlinear`]) from nonlinear FE static solves over the
//!    stroke square: a cubic polynomial correction of the output in the input-plate
//!    displacements (the static distortion, ≈ 0.2–0.4 % of the stroke) and the first-order
//!    stiffening of every mode with the operating point (≈ ±0.2 % in frequency at the stroke
//!    corners), applied to the motion about the quasi-static state. Cross-coupling and tilt
//!    come out of the FE; nothing is hand-picked.
//! 5. **Real time** ([`stage`]): modal coordinates, each mode discretized exactly per substep
//!    with the input linear in time (first-order hold, Van Loan), structure-of-arrays update,
//!    no allocation per step; [`twin::Twin::plant`] wraps it in the scenario's rig (delay,
//!    amplifier bandwidth / slew / current limit, the plant's own Bouc–Wen PEAs with creep,
//!    floor vibration, sensor bandwidth, white + 1/f noise, quantization).
//!
//! ## What it neglects
//!
//! * Modes above the covered band: an input with content far above it (an ideal voltage
//!   jump) excites FE modes the twin does not have well converged (a 50 µs step, reported by
//!   [`reference::validate`] as "fast step": 0.76 / 0.45 % of range with the default 40
//!   fixed-interface modes on the quick design, 2.17 / 0.51 % with 24, where the modes at
//!   11–15 kHz had not converged; example `reach`). The default rig cannot move the PEAs that fast
//!   (0.1 A into 1.5 µF is 67 V/ms).
//! * Out-of-plane motion, contact, thermal drift, the PEAs' own mass and internal dynamics
//!   beyond the plate mass, the electrical dynamics of the PEA beyond `i = C dU/dt`,
//!   manufacturing tolerances (the twin is the design as drawn, grey densities included).
//! * Nonlinearity beyond first order in the modal stiffness and the quadratic/cubic static
//!   map: fine at strains ≈ 1e-3 (the verification below), not for strokes many times larger.
//!
//! ## Verification (tests/verification.rs, the quick preset's rhombus amplifier)
//!
//! * statics = FE statics to 1e-9; every claimed mode within 0.5 % of the FE modal analysis
//!   (measured ≤ 0.04 %);
//! * a step (C², 0.5 ms rise) and a 200 Hz sine at the PEA inputs over 20 ms: the output
//!   within 1 % of its range of the full nonlinear transient (Total Lagrangian, Newmark,
//!   Newton per step, `flexstage_fem::transient`): measured ≤ 0.1 %;
//! * the polynomial map reproduces nonlinear statics off its grid to ≤ 5 % of the
//!   nonlinear effect; the stiffening term predicts the FE tangent's modal shifts at an
//!   operating point within 10 %;
//! * undamped free vibration conserves energy to round-off (≤ 1e-11); the per-mode
//!   discretization equals the single-DOF closed forms; the Bode data equal a simulated
//!   steady-state sine; the step allocates nothing (`tests/allocation.rs`); in the rig, 20
//!   against 40 substeps per sample change the output by < 1e-4 of its range, and a plant is
//!   bit-for-bit deterministic for its seed (`tests/rig.rs`).
//!
//! ## Speed
//!
//! The twin runs inside the rig at the scenario's 20 substeps per 10 kHz sample; one simulated
//! second of the rhombus sample's twin in the full rig (46 modes on the quick and on the paper
//! mesh, with the default `twin.min_modes` of 40) takes 16.6 ms (quick) and 27.5 ms (paper),
//! medians of one run of `cargo bench -p flexstage-twin -- twin_plant_one_second` at load 2.3
//! on 2 cores (wall time, which depends strongly on the machine's load; docs/performance.md),
//! against the ≤ 50 ms target. With 16 modes (instruction counts, `benches/twin.rs`; not
//! re-counted at 46) the modes took ≈ 70 % of it ([`TwinStage`]: four modes per AVX2 register,
//! output sums fused into the update, one dispatched loop per sample through
//! `Mechanics::advance_sample`), the amplifier, Bouc–Wen and creep ≈ 20 %, the sensor filter
//! and noise the rest.
//!
//! On the designs of `flexstage design` (docs/performance.md) the same checks give, for the
//! quick preset, modes within 0.005 % and 0.07 % / 0.02 % of range (step / sine), and for the
//! paper preset the figures recorded in docs/verification.md.
//!
//! ## The existing controllers on the twin (the digital-twin requirements, reported as measured)
//!
//! `cargo run --release -p flexstage-assess --example track -- quick|paper DESIGN.json`, with the
//! controller's model the design's reduced lumped model (`flexstage reduce`, i.e. a perfect
//! identification of the lumped parameters) and the default 3:1 Lissajous (8/16 µm, 2 Hz):
//!
//! | plant | design | robust backstepping RMS q1/q2 | PID + feedforward RMS q1/q2 |
//! |---|---|---|---|
//! | lumped model, ideal loop (today's `track`) | quick | 28 / 24 nm | 18 / 54 nm |
//! | lumped model in the rig | quick | 0.66 / 8.3 µm (fails) | 24 / 52 nm |
//! | twin in the rig | quick | 0.13 / 15 µm (fails) | 15 / 84 nm |
//! | lumped model, ideal loop | paper | 9 / 23 nm | 14 / 64 nm |
//! | lumped model in the rig | paper | 3.5 / 0.19 µm (fails) | 21 / 57 nm |
//! | twin in the rig | paper | 5.0 / 18 µm (fails) | 108 / 56 nm |
//!
//! Both backstepping variants, which track to tens of nanometres on their own model, fail on
//! the twin: already in an ideal loop (no delay, ideal amplifier and sensor) they diverge
//! until the stroke limit, and in the full rig they settle into micrometre oscillations.
//! The lumped model of Eq. 36 misses what the FE shows: its static gain differs from the
//! design's by up to 17 % on q2 (quick) and it cannot represent the paper design's 12.8°
//! tilt (q1 = 0.90 x_nom1 + 0.10 x_nom2 in the twin, ≈ ½(x_nom1 + x_nom2) in the model); its
//! modes sit at 2.4–3.8 kHz where the FE has 2.7 and 5.7 kHz (quick). The PID with
//! inverse-hysteresis feedforward stays stable everywhere. Making the model-based controllers
//! work on the twin is the next issue's work; nothing here was retuned.
//!
//! ## Use
//!
//! ```no_run
//! use flexstage_sim::experiment::Command;
//! use flexstage_sim::rig::StagePlant;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let scenario = flexstage_scenario::Scenario::preset(flexstage_scenario::Preset::Quick);
//! let rho: Vec<f64> = vec![0.5; 48 * 24]; // a design's physical densities (DesignFile::rho)
//! let (twin, mut plant) = flexstage_twin::plant(&scenario, &rho)?;
//! // 10 ms of PEA1 at 600 V and PEA2 at the 500 V bias, through the rig's amplifiers.
//! let step = Command { voltage: [600.0, 500.0], ..Command::default() };
//! for _ in 0..100 {
//!     let _measured = plant.measure();
//!     plant.apply(&step);
//! }
//! println!("q = {:?} m, first resonance {:.0} Hz", plant.output(), twin.first_resonance());
//! # Ok(()) }
//! ```
//!
//! The controllers run on the twin through `flexstage_sim::experiment::run`
//! (`flexstage-control` builds them; `flexstage-assess` checks them on the twin).
//!
//! The report's data: the modes against the FE modal analysis ([`reference::mode_check`]),
//! the Bode data beside the lumped model ([`report::Bode`]: named columns and SVG figures via
//! `flexstage_figures::plot`) and the validity against the full transient
//! ([`reference::validate`], optional: it is expensive on fine meshes;
//! [`report::validity_lines`]). The pipeline's `twin` stage (`flexstage run`, `flexstage
//! track --write-twin`) stores them in the run folder.

// Loops over the two axes and the two inputs index several arrays at once, as the equations do.
#![allow(clippy::needless_range_loop)]

pub mod craig_bampton;
pub mod designed;
mod error;
pub mod modal;
pub mod nonlinear;
pub mod reference;
pub mod report;
pub mod samples;
pub mod stage;
pub mod structure;
pub mod twin;

pub use designed::DesignedStage;
pub use error::{Result, TwinError};
pub use reference::{Agreement, ModeCheck, ReferenceParams, ValidationParams, Validity, validate};
pub use stage::TwinStage;
pub use structure::StageFe;
pub use twin::{SCAN_REACH, Twin, TwinParams, plant};
