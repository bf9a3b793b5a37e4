//! The C99 form of a [`BacksteppingLaw`]: the templates `c/backstepping.h.in` and
//! `c/backstepping.c.in` (the step of [`crate::target_backstepping::BacksteppingTarget`]
//! written out in C, operation by operation in the Rust order, with nalgebra's order of the
//! matrix–vector sums: column by column) with the law's coefficients compiled in as
//! `static const` constants, and the actuator stage's functions taken from the linear
//! controllers' template `c/controller.c.in`, so that both exports share one actuator stage.

use std::fmt::Write;

use crate::controller::{Inner, Velocity};
use crate::error::Result;
use crate::target::CSource;
use crate::target_backstepping::{BacksteppingLaw, rows};
use crate::target_c::{actuator_lines, learned_lines, list, lit, prelude_lines};

const HEADER: &str = include_str!("../c/backstepping.h.in");
const SOURCE: &str = include_str!("../c/backstepping.c.in");
const LINEAR_SOURCE: &str = include_str!("../c/controller.c.in");

/// The actuator stage's functions of the linear template (`clamp` to `section`, the
/// functions before the linear law's `init`); they read the actuator constants of
/// [`actuator_lines`] and the state's `pea_voltage`, `pea_h`.
pub(crate) fn actuator_stage() -> &'static str {
    let start = LINEAR_SOURCE
        .find("static double clamp(")
        .expect("c/controller.c.in defines clamp");
    let end = LINEAR_SOURCE
        .find("void PREFIX_init(")
        .expect("c/controller.c.in defines PREFIX_init");
    &LINEAR_SOURCE[start..end]
}

/// A matrix as a C initializer, row by row.
fn init<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> String {
    let r: Vec<String> = m.iter().map(|row| format!("    {}", list(row))).collect();
    format!("{{\n{}\n}}", r.join(",\n"))
}

/// The notch sections of `law` as a C initializer [axis][section][coefficient]: the
/// numerators (`numerator`) or the denominators.
fn sections(law: &BacksteppingLaw, numerator: bool) -> String {
    let c = |s: &flexstage_control_core::Biquad| {
        if numerator {
            list(&s.numerator())
        } else {
            list(&s.denominator())
        }
    };
    let axes: Vec<String> = law
        .notches
        .iter()
        .map(|ax| format!("{{{}, {}}}", c(&ax[0]), c(&ax[1])))
        .collect();
    format!("{{{}}}", axes.join(", "))
}

/// The C constants of the notches, the K-filter and the model.
fn model_lines(law: &BacksteppingLaw) -> Vec<String> {
    vec![
        "/* Per axis, the notches on the reading: numerators [b0, b1, b2], denominators \
         [a1, a2]; their low-frequency delay tau_i [s]. */"
            .to_string(),
        format!(
            "static const double NOTCH_B[2][2][3] = {};",
            sections(law, true)
        ),
        format!(
            "static const double NOTCH_A[2][2][2] = {};",
            sections(law, false)
        ),
        format!(
            "static const double NOTCH_DELAY[2] = {};",
            list(&law.notch_delay)
        ),
        "/* The K-filter (Eq. 37-42): F = Phi - L C, L, Gamma; the nominal sampled model Phi \
         of the prediction; state [z (8), d (2)]. */"
            .to_string(),
        format!(
            "static const double FILTER_F[10][10] = {};",
            init(&rows(&law.f))
        ),
        format!(
            "static const double FILTER_L[10][2] = {};",
            init(&rows(&law.l))
        ),
        format!(
            "static const double GAMMA[10][2] = {};",
            init(&rows(&law.gamma))
        ),
        format!(
            "static const double PHI[10][10] = {};",
            init(&rows(&law.phi))
        ),
        "/* B of the controller's model (Eq. 36), row-major; G^-1 (A24), D^-1 (Eq. 44). */"
            .to_string(),
        format!(
            "static const double MODEL_B[8][8] = {};",
            init(&rows(&law.b))
        ),
        format!(
            "static const double G_INV[2][2] = {};",
            init(&rows(&law.g_inv))
        ),
        format!(
            "static const double D_INV[2][2] = {};",
            init(&rows(&law.d_inv))
        ),
    ]
}

/// The C constants of the law's gains and switches.
fn law_lines(law: &BacksteppingLaw) -> Vec<String> {
    let p = &law.law;
    let flag = |on: bool| if on { "1" } else { "0" };
    let one = |on: bool| lit(if on { 1.0 } else { 0.0 });
    vec![
        "/* Per axis: k_eps [1/s], k_eta [1/s], k [1/s]; rho_eta [m/s^2], rho_eps [m/s]; \
         boundary layers phi_s [m/s], phi_a [m]; the robust terms on (1) or off (0). */"
            .to_string(),
        format!(
            "static const double LAW_GAINS[2][3] = {{{}, {}}};",
            list(&[p.error_gain[0], p.eta_gain[0], p.feedback_gain[0]]),
            list(&[p.error_gain[1], p.eta_gain[1], p.feedback_gain[1]])
        ),
        format!(
            "static const double LAW_BOUNDS[2][2] = {{{}, {}}};",
            list(&[p.eta_bound[0], p.a_bound[0]]),
            list(&[p.eta_bound[1], p.a_bound[1]])
        ),
        format!(
            "static const double BOUNDARY_LAYER[2] = {};",
            list(&p.boundary_layer)
        ),
        format!("static const double ROBUST = {};", one(p.robust)),
        "/* The law's inner state: the estimate (1) or the commanded xi_d (0); q dot by finite \
         difference without delay (1); the estimated model error cancelled (1.0) or not. */"
            .to_string(),
        format!(
            "static const int INNER_ESTIMATE = {};",
            flag(law.inner == Inner::Estimate)
        ),
        format!(
            "static const int VELOCITY_FINITE_DIFFERENCE = {};",
            flag(law.velocity == Velocity::FiniteDifference)
        ),
        format!(
            "static const double DISTURBANCE_FEEDBACK = {};",
            one(law.disturbance_feedback)
        ),
    ]
}

fn coefficients(law: &BacksteppingLaw) -> String {
    let mut s = String::new();
    let mut lines = prelude_lines(law.sample_time);
    lines.extend(model_lines(law));
    lines.extend(law_lines(law));
    lines.extend(actuator_lines(&law.actuator));
    for l in lines {
        let _ = writeln!(s, "{l}");
    }
    learned_lines(law.learned.as_deref(), &mut s);
    s
}

/// The header and source of `law` with functions and types prefixed `prefix`, the source
/// including the header as `header_file` ([`BacksteppingLaw::c_source`]); the law is checked
/// first ([`BacksteppingLaw::controller`]).
pub fn c_source(law: &BacksteppingLaw, prefix: &str, header_file: &str) -> Result<CSource> {
    crate::target_c::check_names(prefix, header_file)?;
    law.controller()?;
    let fill = |t: &str| {
        t.replace("COEFFICIENTS", &coefficients(law))
            .replace("ACTUATOR_STAGE", actuator_stage())
            .replace("SAMPLE_TIME_LITERAL", &lit(law.sample_time))
            .replace("DELAY_LITERAL", &law.delay.to_string())
            .replace("LEAD_LITERAL", &lit(law.lead()))
            .replace("NOTCH_DELAY_1_LITERAL", &lit(law.notch_delay[0]))
            .replace("NOTCH_DELAY_2_LITERAL", &lit(law.notch_delay[1]))
            .replace(
                "LEARNING_PERIOD_LITERAL",
                &law.learned.as_ref().map_or(0, Vec::len).to_string(),
            )
            .replace("HEADER_FILE", header_file)
            .replace("PREFIX", prefix)
    };
    Ok(CSource {
        header: fill(HEADER),
        source: fill(SOURCE),
    })
}
