//! Parameter validation: one typed error that names the field, the value found and the
//! accepted range, and the checks that build it.
//!
//! Every `Params::validate()` of the workspace reports a bad value through [`RangeError`]; the
//! crates wrap it in their own error enums (`#[error(transparent)] OutOfRange(#[from]
//! RangeError)`), so `?` converts and the message is the same everywhere:
//!
//! ```text
//! mesh.nl = 0 is out of range: expected an integer in [1, 4000]
//! ```
//!
//! Every check rejects NaN and ±∞ (a non-finite number is never a valid setting), so a
//! predicate such as `value > 0.0` need not repeat it.
//!
//! ```
//! use flexstage_numerics::validate::{Interval, RangeError, check, positive};
//! assert!(positive("stage.mass", 0.0139).is_ok());
//! let e: RangeError = positive("stage.mass", f64::NAN).unwrap_err();
//! assert_eq!(e.to_string(), "stage.mass = NaN is out of range: expected a finite number > 0");
//! assert!(Interval::open_closed(0.0, 1.0).check("rls.forgetting", 1.0).is_ok());
//! assert!(check("x", 3.0, 3.0 < 2.0, "a number < 2").is_err());
//! ```

use std::fmt;

/// A value outside its accepted range.
///
/// The fields are plain text so that any value (a number, a point, a name) and any accepted
/// set can be reported; [`RangeError::number`] formats a number as the checks do (`{:e}`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field} = {value} is out of range: expected {expected}")]
pub struct RangeError {
    /// The field, by its TOML path when it comes from the scenario (`material.youngs_modulus`)
    /// or by its Rust path otherwise (`ModalParams::modes`).
    pub field: String,
    /// The value found, formatted.
    pub value: String,
    /// The accepted range in words, e.g. "a finite number > 0" or "a number in (0, 1]".
    pub expected: String,
}

impl RangeError {
    /// A range error with an already formatted value.
    pub fn new(
        field: impl Into<String>,
        value: impl Into<String>,
        expected: impl Into<String>,
    ) -> Self {
        Self {
            field: field.into(),
            value: value.into(),
            expected: expected.into(),
        }
    }

    /// A range error for a number, formatted `{:e}` (exact, and readable at any magnitude).
    pub fn number(field: impl Into<String>, value: f64, expected: impl Into<String>) -> Self {
        Self::new(field, format!("{value:e}"), expected)
    }
}

/// A number as messages print it: exact (the shortest text that reads back to the same
/// `f64`) and short at any magnitude, `{}` for 0 and 1e-4 ≤ |x| < 1e6, `{:e}` otherwise
/// (`1e308`, not 309 digits).
///
/// ```
/// use flexstage_numerics::compact;
/// assert_eq!(compact(0.235), "0.235");
/// assert_eq!(compact(1e308), "1e308");
/// assert_eq!(compact(-2.5e-9), "-2.5e-9");
/// assert_eq!(compact(f64::NAN), "NaN");
/// ```
pub fn compact(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Input data that do not fit together: lengths that differ, too few samples, data that do
/// not determine the unknowns.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what}: {reason}")]
pub struct DataError {
    /// Which input, e.g. "pea data" or "least squares".
    pub what: String,
    /// What is wrong, with the numbers that show it.
    pub reason: String,
}

impl DataError {
    /// A data error.
    pub fn new(what: impl Into<String>, reason: impl Into<String>) -> Self {
        Self {
            what: what.into(),
            reason: reason.into(),
        }
    }
}

/// `Ok` when `value` is finite and `ok` holds, else a [`RangeError`] with `expected` as the
/// accepted range.
pub fn check(field: &str, value: f64, ok: bool, expected: &str) -> Result<(), RangeError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(RangeError::number(field, value, expected))
    }
}

/// `value` is finite and > 0.
pub fn positive(field: &str, value: f64) -> Result<(), RangeError> {
    check(field, value, value > 0.0, "a finite number > 0")
}

/// `value` is finite and ≥ 0.
pub fn non_negative(field: &str, value: f64) -> Result<(), RangeError> {
    check(field, value, value >= 0.0, "a finite number ≥ 0")
}

/// `lo ≤ value ≤ hi` (finite): [`Interval::closed`]`(lo, hi)`.
pub fn within(field: &str, value: f64, lo: f64, hi: f64) -> Result<(), RangeError> {
    Interval::closed(lo, hi).check(field, value)
}

/// An integer `min ≤ value ≤ max`.
pub fn count(field: &str, value: usize, min: usize, max: usize) -> Result<(), RangeError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(RangeError::new(
            field,
            value.to_string(),
            format!("an integer in [{min}, {max}]"),
        ))
    }
}

/// Defines the checks of this module in the calling crate, returning `Result<(), $error>`
/// for the crate's own error type (which must implement `From<RangeError>`), so that they
/// can end a `validate()` as well as be used with `?`:
///
/// ```
/// #[derive(Debug, thiserror::Error)]
/// enum MyError {
///     #[error(transparent)]
///     OutOfRange(#[from] flexstage_numerics::RangeError),
/// }
/// flexstage_numerics::range_checks!(MyError);
///
/// fn validate(mass: f64, modes: usize) -> Result<(), MyError> {
///     count("modes", modes, 1, 50)?;
///     positive("mass", mass)
/// }
/// assert!(validate(1.0, 6).is_ok() && validate(0.0, 6).is_err());
/// ```
#[macro_export]
macro_rules! range_checks {
    ($error:ty) => {
        /// `flexstage_numerics::validate::check` into this crate's error.
        #[allow(dead_code)]
        pub(crate) fn check(
            field: &str,
            value: f64,
            ok: bool,
            expected: &str,
        ) -> ::std::result::Result<(), $error> {
            Ok($crate::validate::check(field, value, ok, expected)?)
        }

        /// `flexstage_numerics::validate::positive` into this crate's error.
        #[allow(dead_code)]
        pub(crate) fn positive(field: &str, value: f64) -> ::std::result::Result<(), $error> {
            Ok($crate::validate::positive(field, value)?)
        }

        /// `flexstage_numerics::validate::non_negative` into this crate's error.
        #[allow(dead_code)]
        pub(crate) fn non_negative(field: &str, value: f64) -> ::std::result::Result<(), $error> {
            Ok($crate::validate::non_negative(field, value)?)
        }

        /// `flexstage_numerics::validate::within` into this crate's error.
        #[allow(dead_code)]
        pub(crate) fn within(
            field: &str,
            value: f64,
            lo: f64,
            hi: f64,
        ) -> ::std::result::Result<(), $error> {
            Ok($crate::validate::within(field, value, lo, hi)?)
        }

        /// `flexstage_numerics::validate::count` into this crate's error.
        #[allow(dead_code)]
        pub(crate) fn count(
            field: &str,
            value: usize,
            min: usize,
            max: usize,
        ) -> ::std::result::Result<(), $error> {
            Ok($crate::validate::count(field, value, min, max)?)
        }
    };
}

/// An interval of the real line whose ends are each open or closed, e.g. `(0, 1]`; the ends
/// may be infinite (`[0, ∞)`), the members never are.
///
/// ```
/// use flexstage_numerics::validate::Interval;
/// let forgetting = Interval::open_closed(0.0, 1.0);
/// assert!(forgetting.contains(1.0) && !forgetting.contains(0.0));
/// assert_eq!(forgetting.to_string(), "(0, 1]");
/// assert_eq!(Interval::at_least(1e-15).to_string(), "[1e-15, ∞)");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// Whether `lo` belongs to the interval.
    pub lo_closed: bool,
    /// Whether `hi` belongs to the interval.
    pub hi_closed: bool,
}

impl Interval {
    /// `[lo, hi]`.
    pub const fn closed(lo: f64, hi: f64) -> Self {
        Self::with_ends(lo, true, hi, true)
    }

    /// `(lo, hi)`.
    pub const fn open(lo: f64, hi: f64) -> Self {
        Self::with_ends(lo, false, hi, false)
    }

    /// `(lo, hi]`.
    pub const fn open_closed(lo: f64, hi: f64) -> Self {
        Self::with_ends(lo, false, hi, true)
    }

    /// `[lo, hi)`.
    pub const fn closed_open(lo: f64, hi: f64) -> Self {
        Self::with_ends(lo, true, hi, false)
    }

    /// `[lo, ∞)`.
    pub const fn at_least(lo: f64) -> Self {
        Self::closed_open(lo, f64::INFINITY)
    }

    /// `(lo, ∞)`.
    pub const fn greater_than(lo: f64) -> Self {
        Self::open(lo, f64::INFINITY)
    }

    const fn with_ends(lo: f64, lo_closed: bool, hi: f64, hi_closed: bool) -> Self {
        Self {
            lo,
            hi,
            lo_closed,
            hi_closed,
        }
    }

    /// Whether `value` is a finite member (NaN and ±∞ never are).
    #[inline]
    pub fn contains(&self, value: f64) -> bool {
        let above = if self.lo_closed {
            value >= self.lo
        } else {
            value > self.lo
        };
        let below = if self.hi_closed {
            value <= self.hi
        } else {
            value < self.hi
        };
        above && below && value.is_finite()
    }

    /// `Ok` when `value` is a member, else a [`RangeError`] "a number in (lo, hi]".
    pub fn check(&self, field: &str, value: f64) -> Result<(), RangeError> {
        check(
            field,
            value,
            self.contains(value),
            &format!("a number in {self}"),
        )
    }
}

impl fmt::Display for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}{}, {}{}",
            if self.lo_closed { '[' } else { '(' },
            Compact(self.lo),
            Compact(self.hi),
            if self.hi_closed { ']' } else { ')' },
        )
    }
}

/// A bound written briefly: `0.5`, `10`, `1e12`, `1e-15`, `∞`.
struct Compact(f64);

impl fmt::Display for Compact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        let a = v.abs();
        if v.is_infinite() {
            write!(f, "{}∞", if v < 0.0 { "-" } else { "" })
        } else if v == 0.0 || (1e-3..1e6).contains(&a) {
            write!(f, "{v}")
        } else {
            write!(f, "{v:e}")
        }
    }
}

#[cfg(test)]
mod tests {
    //! Reference: the contract in the module docs. Goal: every check rejects NaN and ±∞,
    //! accepts exactly its documented set, and names field, value and range in the message.

    use super::*;

    #[test]
    fn checks_reject_non_finite_values() {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(check("f", v, true, "any").is_err());
            assert!(positive("f", v).is_err());
            assert!(non_negative("f", v).is_err());
            assert!(within("f", v, f64::NEG_INFINITY, f64::INFINITY).is_err());
            assert!(!Interval::closed(f64::NEG_INFINITY, f64::INFINITY).contains(v));
        }
    }

    #[test]
    fn boundaries_follow_the_documented_sets() {
        assert!(positive("f", 0.0).is_err() && positive("f", f64::MIN_POSITIVE).is_ok());
        assert!(non_negative("f", 0.0).is_ok() && non_negative("f", -1e-300).is_err());
        assert!(within("f", 1.0, 0.0, 1.0).is_ok() && within("f", 1.0 + 1e-15, 0.0, 1.0).is_err());
        assert!(count("n", 4, 4, 8).is_ok() && count("n", 9, 4, 8).is_err());
        assert!(count("n", 3, 4, 8).is_err());
        let i = Interval::open_closed(0.0, 1.0);
        assert!(!i.contains(0.0) && i.contains(1e-300) && i.contains(1.0) && !i.contains(1.5));
        let j = Interval::closed_open(0.0, 1.0);
        assert!(j.contains(0.0) && !j.contains(1.0));
        assert!(Interval::open(0.0, 1.0).contains(0.5) && !Interval::open(0.0, 1.0).contains(1.0));
        assert!(
            Interval::greater_than(1.0).contains(1e300)
                && !Interval::greater_than(1.0).contains(1.0)
        );
    }

    #[test]
    fn messages_name_field_value_and_range() {
        let e = count("mesh.nl", 0, 1, 4000).unwrap_err();
        assert_eq!(
            e.to_string(),
            "mesh.nl = 0 is out of range: expected an integer in [1, 4000]"
        );
        let e = within("optimization.volume", 1.5, 0.0, 1.0).unwrap_err();
        assert_eq!(
            e,
            RangeError::new("optimization.volume", "1.5e0", "a number in [0, 1]")
        );
        let e = Interval::open(0.0, 0.5)
            .check("identify.sampling_tolerance", 0.5)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "identify.sampling_tolerance = 5e-1 is out of range: expected a number in (0, 0.5)"
        );
        assert_eq!(Interval::closed(1e-15, 1e-2).to_string(), "[1e-15, 0.01]");
        assert_eq!(Interval::open_closed(0.0, 1e12).to_string(), "(0, 1e12]");
        assert_eq!(Interval::closed(-f64::INFINITY, 0.0).to_string(), "[-∞, 0]");
        assert_eq!(
            DataError::new("least squares", "too few samples").to_string(),
            "least squares: too few samples"
        );
    }
}
