//! # flexstage-identify — online identification of the stage parameters
//!
//! Section 4.2 of the paper (Eq. 54–56, Table 4): the stiffnesses and dampings of the
//! reduced stage model (Eq. 31, 34; A13–A14) are estimated online by recursive least
//! squares on the models discretized at the sample time T_s. The masses are weighed and α
//! comes from Eq. (27): both are known inputs (the guess's values are kept).
//!
//! * [`regression`]: the regressors and targets of Eq. (54)–(56), as derived from the
//!   continuous model by central differences, with the paper's typos fixed (listed there);
//!   θ ↦ physical parameters ([`regression::physical`]), θ in the paper's form.
//! * [`estimator`]: the online [`StageIdentifier`] (four RLS rows of flexstage-piezo, with
//!   forgetting), prefilter, decimation, conditioning checks; [`identify`] over a record.
//! * [`data`]: uniformly sampled records (t, x_nom or U, x_in1, x_in2, q1, q2) and CSV.
//! * [`excitation`]: a two-band multisine within the stroke (the low band, and a resonance
//!   band from the model's modes, [`resonance_plan`]), the simulated record on
//!   flexstage-control's lumped plant ([`simulate`]) or on any stage in a rig
//!   ([`simulate_rig`], e.g. the digital twin).
//! * [`frequency`]: the lumped parameters that best represent an exact frequency response
//!   (the reference on a structure richer than the lumped model), the model's natural
//!   frequencies.
//! * [`response`]: the frequency-response identification of what the controller's model
//!   takes from a structure (static gain, the output modes below Nyquist), for the digital
//!   twin, where no lumped parameter set is the truth.
//! * [`measured`]: the loop as a lab measures it, at the controller's sample time: what a
//!   rig logs ([`measured::LabLog`]), the 2 × 2 response command → reading with coherence
//!   and uncertainty from a periodic multisine or by H1 ([`measured::MeasuredResponse`]),
//!   its z-domain fit as a loop model ([`measured::ZFit`]) and the files of both.
//! * [`samples`]: the paper's scenario (guess = Table 4 guess, truth = Table 4 estimates).
//!
//! ```
//! use flexstage_identify::{IdentifyParams, identify, samples, simulate};
//! let sim = samples::paper_simulation(0.3, true, false);
//! let record = simulate(&sim)?;
//! let id = identify(&record, &samples::table4_guess(), &IdentifyParams::default())?;
//! let truth = samples::table4_truth();
//! assert!((id.params.k_qo1 / truth.k_qo1 - 1.0).abs() < 0.01);
//! # Ok::<(), flexstage_identify::IdentifyError>(())
//! ```
//!
//! # Identifiability (masses and α known)
//! * **K_qo1, K_qo2** (and the coupling k_c): identified by the output rows; the weighed M
//!   fixes their scale through the inertial term.
//! * **K_pea,i, K_in,i**: with x_nom known (logged, or from U through the PEA model), the
//!   plate row separates them, since K_pea multiplies x_nom − x_in and K_in multiplies x_in.
//!   Below the ≈ 12 kHz plate mode the plate row is a static force balance, which fixes the
//!   *ratios* K_pea : K_in : K_qo1 well and their common scale badly; the scale is taken from
//!   K_qo1 ("calculated algebraically from the estimated K_in and K_qo1", Section 4.2).
//!   x_nom must be logged at the same instants as x_in: K_pea(x_nom − x_in) is a small
//!   difference (≈ 1.5 % of x_in), so a timing skew of a fraction of a sample biases it.
//! * **The lumped K_in of Eq. (35)** (= K_qo1 + K_in + K_pea, the paper's θ₃) is reported in
//!   [`regression::paper_theta`].
//! * **Dampings**: C_qo1 and C_qo2 are identified at the output modes, which the resonance
//!   band excites (without it they are not observable: c_qo2 came out 44.6 % off); the
//!   discretization is corrected at each row's natural frequency
//!   ([`regression::stiffness_factor`], [`regression::damping_factor`]). C_in is practically
//!   not identifiable below the plate mode (its force is ≈ 2ζω/ω_in ≈ 10⁻³ of the stiffness
//!   force); it is reported, not scored. Negative values are replaced by the guess in the
//!   parameter set.
//!
//! # Resonance band (measured, tests/identify.rs)
//! Defaults: 8 s record, low band 5–150 Hz, resonance band 0.5× the lowest to 1.3× the
//! highest natural frequency below 0.9× Nyquist, lines every 10 Hz, 2 µm peak per PEA; plate
//! rows prefiltered at 150 Hz, output rows at 1.2× the band's top; Numerov regressors with the
//! correction at the modes. On the Table 4 stage (Bouc–Wen PEAs, cross terms 5 %, 7.5/10 nm
//! noise and quantization), seeds 1–4 (`two_band_excitation_meets_the_identification_targets_on_the_lumped_plant`):
//!
//! | | K_qo1 | K_qo2 | K_in1 | K_in2 | K_pea1 | K_pea2 | C_qo1 | C_qo2 | k_c |
//! |---|---|---|---|---|---|---|---|---|---|
//! | worst of 4 seeds | −0.024 % | −0.066 % | −2.55 % | −1.51 % | −0.15 % | +0.05 % | +0.08 % | +0.77 % | −1.08 % |
//!
//! Measured alternatives (seeds 1–3): 4 s / 300 Hz plate prefilter gave K_in up to −4.9 %;
//! a 4 µm band up to −5.9 % (it takes amplitude from the low band, where K_in is seen);
//! without the correction at the modes K_qo1 −1.21 % and C_qo1 +16 % (even noise-free).
//! On the twin of a design the lumped model does not hold ([`frequency::fit`]'s residual says
//! how far off it is); there the stage is identified by its response ([`response`]).
//!
//! # Excitation length, prefilter, decimation (low band alone; measured before the resonance band existed)
//! Default multisine 5–150 Hz, 27 µm peak per PEA, Numerov regressors, 300 Hz prefilter,
//! no decimation, λ_f = 1:
//!
//! | record | K_qo1 | K_qo2 | K_in1 | K_in2 | K_pea1 | K_pea2 |
//! |---|---|---|---|---|---|---|
//! | linear model, noise-free, 1 s | +0.004 % | +0.002 % | −0.68 % | −0.78 % | +0.004 % | +0.004 % |
//! | linear model, 7.5/10 nm noise + quantization, 4 s | −0.74 % | −0.28 % | −2.7 % | −2.6 % | −0.82 % | −0.74 % |
//! | full twin (Bouc–Wen, cross terms, noise), 4 s | −0.85 % | −0.34 % | −3.2 % | −3.1 % | −0.93 % | −0.88 % |
//!
//! Required length: 1 s (10 000 samples) noise-free for 1 %; 4 s (40 000 samples) with the
//! default sensors for 5 % (2 s gave K_in errors of 4–5 %, too close). K_in, the plate's own
//! small spring, is the limiting parameter: its force is below the plate's inertial and
//! damping forces above ≈ 100 Hz, so it needs a low excitation band (150 Hz; at 300 Hz the
//! noise-free error was −3 %). Central differences as printed (Scheme::Central) bias K_qo1
//! by −0.2 % at 300 Hz; Numerov's weighting removes it. Decimation did not help (the
//! central-difference error grows as d²) and is off by default; the prefilter roughly halves
//! the noisy K_in error (1000 → 300 Hz: −6 % → −3 % at 2 s, 300 Hz band).

// Small dense matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]
// NaN-safe checks read as "not (x > limit)".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod data;
mod error;
pub mod estimator;
pub mod excitation;
pub mod frequency;
pub mod measured;
pub mod regression;
pub mod response;
pub mod samples;

pub use data::StageRecord;
pub use error::{IdentifyError, Result};
pub use estimator::{Identification, IdentifyParams, PLAUSIBLE_FACTOR, StageIdentifier, identify};
pub use excitation::{
    Band, Excitation, Multisine, RESONANCE_AMPLITUDE, RigExperiment, SimulationParams,
    resonance_plan, simulate, simulate_rig,
};
