//! The names of option values, as the CLI reads them and the result files spell them. One
//! table per kind, so that a parser, its help text and its output cannot disagree.

use flexstage_control::actuator::Compensation;
use flexstage_identify::regression::Scheme;
use flexstage_piezo::WaveShape;
use flexstage_verify::outline::Unit;

/// Length units of exported drawings.
pub const UNITS: [(&str, Unit); 2] = [("mm", Unit::Millimetres), ("m", Unit::Metres)];

/// Hysteresis compensation of the tracking controllers (the ideal actuator of the control
/// crate's tests is not offered).
pub const COMPENSATIONS: [(&str, Compensation); 2] = [
    ("inverse", Compensation::Inverse),
    ("off", Compensation::Off),
];

/// PEA drive shapes.
pub const SHAPES: [(&str, WaveShape); 3] = [
    ("sine", WaveShape::Sine),
    ("triangle", WaveShape::Triangle),
    ("decaying", WaveShape::Decaying),
];

/// Stiffness regressor schemes of the stage identification.
pub const SCHEMES: [(&str, Scheme); 2] =
    [("numerov", Scheme::Numerov), ("central", Scheme::Central)];

/// The value named `name` in `table`.
pub fn parse<T: Copy>(table: &[(&str, T)], name: &str) -> Option<T> {
    table.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
}

/// The name of `value` in `table` (`"?"` if it has none).
pub fn name<T: PartialEq>(table: &[(&'static str, T)], value: T) -> &'static str {
    table
        .iter()
        .find(|(_, v)| *v == value)
        .map_or("?", |(n, _)| n)
}

/// The names of a table, in order.
pub fn names<T, const N: usize>(table: &[(&'static str, T); N]) -> [&'static str; N] {
    std::array::from_fn(|i| table[i].0)
}

/// The name of a compensation mode (`inverse`, `off`, `ideal`).
pub fn compensation(c: Compensation) -> &'static str {
    match c {
        Compensation::Ideal => "ideal",
        c => name(&COMPENSATIONS, c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for (n, v) in UNITS {
            assert_eq!(parse(&UNITS, n), Some(v));
            assert_eq!(name(&UNITS, v), n);
        }
        for (n, v) in SHAPES {
            assert_eq!(
                WaveShape::from_name(n),
                Some(v),
                "the piezo crate's own names"
            );
            assert_eq!(name(&SHAPES, v), n);
        }
        assert_eq!(parse(&SCHEMES, "central"), Some(Scheme::Central));
        assert_eq!(compensation(Compensation::Off), "off");
        assert_eq!(compensation(Compensation::Ideal), "ideal");
        assert_eq!(names(&COMPENSATIONS), ["inverse", "off"]);
        assert_eq!(parse(&UNITS, "km"), None);
    }
}
