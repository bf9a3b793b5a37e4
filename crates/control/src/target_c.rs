//! The C99 form of a [`TargetLaw`]: the templates `c/controller.h.in` and `c/controller.c.in`
//! (the law of [`crate::target::TargetController`] written out in C, operation by operation
//! in the Rust order) with the law's coefficients compiled in as `static const` constants.
//! Every number is written in Rust's shortest round-trip form, which a C compiler reads back
//! to the same `double` (C99 §6.4.4.2 with correctly rounded conversion, as GCC and Clang do).

use std::fmt::Write;

use flexstage_control_core::Biquad;

use crate::actuator::{ActuatorParams, Compensation};
use crate::error::Result;
use crate::target::{CSource, TargetLaw};

const HEADER: &str = include_str!("../c/controller.h.in");
const SOURCE: &str = include_str!("../c/controller.c.in");

/// A C identifier usable as the prefix of the exported functions and types: 1–63 ASCII
/// letters, digits and `_`, not starting with a digit.
pub fn is_c_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && s.len() <= 63
}

/// The C prefix of a controller name: every character but ASCII letters, digits and `_`
/// becomes `_` (`pi-notch-ff` → `pi_notch_ff`, `pi-notch-ff+learning-circle` →
/// `pi_notch_ff_learning_circle`).
pub fn c_prefix(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// A `double` literal that reads back to exactly `v` (finite).
pub(crate) fn lit(v: f64) -> String {
    format!("{v:e}")
}

pub(crate) fn list(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|&x| lit(x)).collect();
    format!("{{{}}}", items.join(", "))
}

/// The first constants of every exported controller, linear or backstepping: the
/// compensation modes the actuator functions switch on, the micrometre and the sample time
/// `sample_time` [s].
pub(crate) fn prelude_lines(sample_time: f64) -> Vec<String> {
    vec![
        "#define COMPENSATION_INVERSE 0".to_string(),
        "#define COMPENSATION_OFF 1".to_string(),
        "#define COMPENSATION_IDEAL 2".to_string(),
        "/* One micrometre in metres (the Bouc-Wen model works in um, V, s). */".to_string(),
        "static const double MICROMETRE = 1e-6;".to_string(),
        "/* Sample time T [s]. */".to_string(),
        format!("static const double SAMPLE_TIME = {};", lit(sample_time)),
    ]
}

fn coefficients(law: &TargetLaw) -> String {
    let mut s = String::new();
    let gains: Vec<String> = law
        .gains
        .iter()
        .map(|g| list(&[g.kp, g.ki, g.kd]))
        .collect();
    let section_b: Vec<String> = law
        .sections
        .iter()
        .map(|ax| {
            format!(
                "{{{}, {}}}",
                list(&ax[0].numerator()),
                list(&ax[1].numerator())
            )
        })
        .collect();
    let section_a: Vec<String> = law
        .sections
        .iter()
        .map(|ax| {
            format!(
                "{{{}, {}}}",
                list(&ax[0].denominator()),
                list(&ax[1].denominator())
            )
        })
        .collect();
    let g = law.inverse_gain;
    let mut lines = prelude_lines(law.sample_time);
    lines.extend([
        "/* Per axis: k_p [-], k_i [1/s], k_d [s] on e = q_d - y [m]. */".to_string(),
        format!(
            "static const double GAINS[2][3] = {{{}}};",
            gains.join(", ")
        ),
        "/* Per axis, two sections in series: numerators [b0, b1, b2], denominators [a1, a2]. */"
            .to_string(),
        format!(
            "static const double SECTION_B[2][2][3] = {{{}}};",
            section_b.join(", ")
        ),
        format!(
            "static const double SECTION_A[2][2][2] = {{{}}};",
            section_a.join(", ")
        ),
        "/* G_dc^-1, row-major: x_nom = G_dc^-1 (q_d + N(c)) [m]. */".to_string(),
        format!(
            "static const double INVERSE_GAIN[2][2] = {{{}, {}}};",
            list(&g[0]),
            list(&g[1])
        ),
    ]);
    lines.extend(actuator_lines(&law.actuator));
    lines.extend([
        "/* Largest change of a voltage per sample [V] (the amplifier's current and slew); 0: no \
         rate limit. */"
            .to_string(),
        format!(
            "static const double MAX_VOLTAGE_STEP = {};",
            lit(law.actuator.max_voltage_step)
        ),
    ]);
    for l in lines {
        let _ = writeln!(s, "{l}");
    }
    extensions(law, &mut s);
    s
}

/// The C constants of the actuator stage `a` (stroke, amplifier range, bias, compensation
/// mode, the compensator's Bouc–Wen parameters, preload and settings), the names the
/// actuator functions of `c/controller.c.in` read.
pub(crate) fn actuator_lines(a: &ActuatorParams) -> Vec<String> {
    let pre = crate::target::preload_of(a);
    let comp = a.compensator();
    let mode = match a.compensation {
        Compensation::Inverse => "COMPENSATION_INVERSE",
        Compensation::Off => "COMPENSATION_OFF",
        Compensation::Ideal => "COMPENSATION_IDEAL",
    };
    let bw: Vec<String> = a
        .hysteresis
        .iter()
        .map(|p| list(&[p.d_p, p.a_bw, p.b_bw, p.gamma_bw, p.delta_bw]))
        .collect();
    vec![
        "/* Largest |x_nom| [m]. */".to_string(),
        format!("static const double STROKE = {};", lit(a.stroke)),
        "/* Amplifier range [V] and preload bias voltage U_b [V]. */".to_string(),
        format!(
            "static const double VOLTAGE_RANGE[2] = {};",
            list(&a.voltage_range)
        ),
        format!(
            "static const double BIAS_VOLTAGE = {};",
            lit(a.bias_voltage)
        ),
        "/* Per PEA, Eq. (18): d_p [um/V], A_bw [um/V], B_bw [1/V], Gamma_bw [1/V], \
         delta_bw [um/(V s)]. */"
            .to_string(),
        format!(
            "static const double BOUC_WEN[2][5] = {{{}}};",
            bw.join(", ")
        ),
        "/* Per PEA at the bias: voltage [V], h [um], x_bias [um]; virgin mean slope [um/V]. */"
            .to_string(),
        format!(
            "static const double PRELOAD_VOLTAGE[2] = {};",
            list(&pre.map(|p| p.voltage))
        ),
        format!(
            "static const double PRELOAD_H[2] = {};",
            list(&pre.map(|p| p.h))
        ),
        format!(
            "static const double PRELOAD_X_BIAS[2] = {};",
            list(&pre.map(|p| p.x_bias))
        ),
        format!(
            "static const double SLOPE[2] = {};",
            list(&pre.map(|p| p.slope))
        ),
        "/* Inverse compensator: accepted |d_p U - h - x| [um], most model evaluations. */"
            .to_string(),
        format!(
            "static const double COMPENSATOR_TOLERANCE = {};",
            lit(comp.tolerance)
        ),
        format!(
            "static const int COMPENSATOR_MAX_ITERATIONS = {};",
            comp.max_iterations
        ),
        format!("static const int COMPENSATION = {mode};"),
    ]
}

/// The coefficients of the FIR feed-forward, the PPF filters and the learned table (a
/// single zero entry where the law has none, unused then).
fn extensions(law: &TargetLaw, s: &mut String) {
    let zero_tap = [[[0.0; 2]; 2]];
    let taps = law.feedforward.as_ref().map_or(&zero_tap[..], |f| f.taps());
    let _ = writeln!(
        s,
        "/* FIR feed-forward: F_n for n = -p, ..., L - p - 1, each row-major 2 x 2 [m/m]. */"
    );
    let _ = writeln!(s, "static const double FIR_TAPS[{}][2][2] = {{", taps.len());
    for t in taps {
        let _ = writeln!(s, "    {{{}, {}}},", list(&t[0]), list(&t[1]));
    }
    let _ = writeln!(s, "}};");
    let reading = law.feedforward.as_ref().and_then(|f| f.reading());
    let _ = writeln!(
        s,
        "/* Reading correction of the feedback's reference: C_n as F_n (a single zero entry \
         where there is none, unused then). */"
    );
    let _ = writeln!(
        s,
        "static const int READING = {};",
        u8::from(reading.is_some())
    );
    let reading = reading.unwrap_or(&zero_tap[..]);
    let _ = writeln!(s, "static const int READING_LENGTH = {};", reading.len());
    let _ = writeln!(
        s,
        "static const double READING_TAPS[{}][2][2] = {{",
        reading.len()
    );
    for t in reading {
        let _ = writeln!(s, "    {{{}, {}}},", list(&t[0]), list(&t[1]));
    }
    let _ = writeln!(s, "}};");
    let zero = Biquad::new([0.0; 3], [0.0; 2]);
    let damping = law.damping.unwrap_or([zero; 2]);
    let _ = writeln!(
        s,
        "/* PPF damping filters D_i on the readings: numerators [b0, b1, b2], denominators \
         [a1, a2]. */"
    );
    let _ = writeln!(
        s,
        "static const int DAMPING = {};",
        u8::from(law.damping.is_some())
    );
    let _ = writeln!(
        s,
        "static const double DAMPING_B[2][3] = {{{}, {}}};",
        list(&damping[0].numerator()),
        list(&damping[1].numerator())
    );
    let _ = writeln!(
        s,
        "static const double DAMPING_A[2][2] = {{{}, {}}};",
        list(&damping[0].denominator()),
        list(&damping[1].denominator())
    );
    learned_lines(law.learned.as_deref(), s);
}

/// The learned table `table` (a single zero entry where there is none, unused then) as the
/// C constants `LEARNING_ROWS` and `LEARNED`.
pub(crate) fn learned_lines(table: Option<&[[f64; 2]]>, s: &mut String) {
    let zero_row = [[0.0; 2]];
    let table = table.unwrap_or(&zero_row[..]);
    let _ = writeln!(
        s,
        "/* Learned correction c[k] [m] per sample k of the period, subtracted from the reading. */"
    );
    let _ = writeln!(
        s,
        "static const unsigned long LEARNING_ROWS = {};",
        table.len()
    );
    let _ = writeln!(s, "static const double LEARNED[{}][2] = {{", table.len());
    for c in table {
        let _ = writeln!(s, "    {},", list(c));
    }
    let _ = writeln!(s, "}};");
}

/// Refuses a prefix that is no C identifier and a header name that is no plain file name.
pub(crate) fn check_names(prefix: &str, header_file: &str) -> Result<()> {
    if !is_c_identifier(prefix) {
        return Err(flexstage_numerics::RangeError::new(
            "controller.c_prefix",
            prefix.to_string(),
            "a C identifier of 1–63 letters, digits and _, not starting with a digit",
        )
        .into());
    }
    let plain = header_file.ends_with(".h")
        && header_file.len() <= 100
        && header_file
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.' | '+'));
    if !plain {
        return Err(flexstage_numerics::RangeError::new(
            "controller.c_header",
            header_file.to_string(),
            "a file name of letters, digits, -, _, + and . ending in .h",
        )
        .into());
    }
    Ok(())
}

/// The header and source of `law` with functions and types prefixed `prefix`, the source
/// including the header as `header_file` ([`TargetLaw::c_source`]); the law is checked first
/// ([`TargetLaw::controller`]).
pub fn c_source(law: &TargetLaw, prefix: &str, header_file: &str) -> Result<CSource> {
    check_names(prefix, header_file)?;
    law.controller()?;
    let ff = law.feedforward.as_ref();
    let fill = |t: &str| {
        t.replace("COEFFICIENTS", &coefficients(law))
            .replace("SAMPLE_TIME_LITERAL", &lit(law.sample_time))
            .replace(
                "PREVIEW_LITERAL",
                &ff.map_or(0, |f| f.preview()).to_string(),
            )
            .replace("LAG_LITERAL", &lit(ff.map_or(0.0, |f| f.lag())))
            .replace(
                "FIR_LENGTH_LITERAL",
                &ff.map_or(1, |f| f.taps().len()).to_string(),
            )
            .replace("FIR_FLAG", if ff.is_some() { "1" } else { "0" })
            .replace(
                "READING_FLAG",
                if ff.is_some_and(|f| f.reading().is_some()) {
                    "1"
                } else {
                    "0"
                },
            )
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
