//! Lane arithmetic and chunking shared by the O(n) passes of the subproblem solvers.
//!
//! A [`V`] holds [`LANES`] variables' values of one quantity; the loops over its lanes are
//! written so that the compiler turns them into SIMD instructions of the instruction set the
//! calling kernel was compiled for (`multiversion`). No fused multiply–add is used, so every
//! instruction set gives bitwise the same results.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Calls `$func::<M>(args)` with `M` the compile-time value of `m` for m ≤ 4, so that the
/// inner loops over the constraints are unrolled, and with `M = DYN` otherwise.
macro_rules! dispatch_m {
    ($m:expr, $func:ident, $($arg:expr),*) => {
        match $m {
            0 => $func::<0>($($arg),*),
            1 => $func::<1>($($arg),*),
            2 => $func::<2>($($arg),*),
            3 => $func::<3>($($arg),*),
            4 => $func::<4>($($arg),*),
            _ => $func::<DYN>($($arg),*),
        }
    };
}

/// Variables per SIMD block of the O(n) passes.
pub(crate) const LANES: usize = 8;
/// Variables per chunk of the O(n) passes (a multiple of [`LANES`]).
pub(crate) const CHUNK: usize = 1024;

/// Smallest number of chunks per rayon job: 1 lets rayon spread the chunks over its threads;
/// `usize::MAX` keeps the whole pass one job on the calling thread (the serial mode). The
/// chunks and their ordered reductions are the same either way, hence the same bits.
pub(crate) fn min_len(parallel: bool) -> usize {
    if parallel { 1 } else { usize::MAX }
}
/// Marker for "m not known at compile time".
pub(crate) const DYN: usize = usize::MAX;
/// Largest `m` with a compile-time kernel (see `dispatch_m`).
pub(crate) const MAX_STATIC_M: usize = 4;

/// Blocks of a chunk: `(offset, valid lanes)`, the last one possibly partial.
#[inline(always)]
pub(crate) fn chunk_len(n: usize, c: usize) -> (usize, usize) {
    let len = (n - c * CHUNK).min(CHUNK);
    (len / LANES, len % LANES)
}

/// One chunk's node fields.
#[derive(Clone, Copy)]
pub(crate) struct Nodes<'a>(pub(crate) &'a [f64]);

impl Nodes<'_> {
    #[inline(always)]
    pub(crate) fn get(self, f: usize, o: usize) -> V {
        V::load(&self.0[f * CHUNK..(f + 1) * CHUNK], o)
    }
}

/// `LANES` variables' values of one quantity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct V(pub(crate) [f64; LANES]);

impl V {
    #[inline(always)]
    pub(crate) fn splat(v: f64) -> Self {
        Self([v; LANES])
    }

    /// Lanes `o..o+LANES` of `s`.
    #[inline(always)]
    pub(crate) fn load(s: &[f64], o: usize) -> Self {
        let mut a = [0.0; LANES];
        a.copy_from_slice(&s[o..o + LANES]);
        Self(a)
    }

    /// Writes the first `valid` lanes to `s[o..]`.
    #[inline(always)]
    pub(crate) fn store<const MASK: bool>(self, s: &mut [f64], o: usize, valid: usize) {
        if MASK {
            s[o..o + valid].copy_from_slice(&self.0[..valid]);
        } else {
            s[o..o + LANES].copy_from_slice(&self.0);
        }
    }

    /// `self` in the first `valid` lanes and `fill` in the others (only when `MASK`).
    #[inline(always)]
    pub(crate) fn keep<const MASK: bool>(self, valid: usize, fill: f64) -> Self {
        if MASK {
            let mut r = self.0;
            for (l, v) in r.iter_mut().enumerate() {
                if l >= valid {
                    *v = fill;
                }
            }
            Self(r)
        } else {
            self
        }
    }

    /// Lanes `o..o+LANES` of `s`, or only `o..o+valid` and `fill` in the others when `MASK`
    /// (for slices without padding).
    #[inline(always)]
    pub(crate) fn load_part<const MASK: bool>(
        s: &[f64],
        o: usize,
        valid: usize,
        fill: f64,
    ) -> Self {
        if MASK {
            let mut a = [fill; LANES];
            a[..valid].copy_from_slice(&s[o..o + valid]);
            Self(a)
        } else {
            Self::load(s, o)
        }
    }

    /// Lane-wise square root.
    #[inline(always)]
    pub(crate) fn sqrt(self) -> Self {
        Self(self.0.map(f64::sqrt))
    }

    /// Lane-wise minimum (`self` where the lanes are equal or unordered).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn minv(self, o: Self) -> Self {
        let mut r = [0.0; LANES];
        for l in 0..LANES {
            r[l] = if o.0[l] < self.0[l] {
                o.0[l]
            } else {
                self.0[l]
            };
        }
        Self(r)
    }

    /// `self` in the lanes where `lo < x < hi`, `other` elsewhere.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn where_inside(self, x: Self, lo: Self, hi: Self, other: Self) -> Self {
        let mut r = [0.0; LANES];
        for l in 0..LANES {
            r[l] = if lo.0[l] < x.0[l] && x.0[l] < hi.0[l] {
                self.0[l]
            } else {
                other.0[l]
            };
        }
        Self(r)
    }

    /// Sum of the lanes, in lane order.
    #[inline(always)]
    pub(crate) fn hsum(self) -> f64 {
        self.0.iter().fold(0.0, |a, &b| a + b)
    }

    /// Maximum of the lanes and `init`.
    #[inline(always)]
    pub(crate) fn hmax(self, init: f64) -> f64 {
        self.0.iter().fold(init, |a, &b| a.max(b))
    }
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for V {
            type Output = V;
            #[inline(always)]
            #[allow(clippy::needless_range_loop)]
            fn $f(self, o: V) -> V {
                let mut r = [0.0; LANES];
                for l in 0..LANES {
                    r[l] = self.0[l] $op o.0[l];
                }
                V(r)
            }
        }
    };
}
lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl Neg for V {
    type Output = V;
    #[inline(always)]
    fn neg(self) -> V {
        V(self.0.map(|v| -v))
    }
}

/// The arithmetic shared by the scalar (`f64`) and lane (`V`) code.
pub(crate) trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn splat(v: f64) -> Self;
    /// `max`, equal to `f64::max` for numbers.
    fn maxv(self, o: Self) -> Self;
    fn absv(self) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn maxv(self, o: Self) -> Self {
        self.max(o)
    }
    #[inline(always)]
    fn absv(self) -> Self {
        self.abs()
    }
}

impl Real for V {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        V::splat(v)
    }
    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    fn maxv(self, o: Self) -> Self {
        let mut r = [0.0; LANES];
        for l in 0..LANES {
            r[l] = if o.0[l] > self.0[l] {
                o.0[l]
            } else {
                self.0[l]
            };
        }
        V(r)
    }
    #[inline(always)]
    fn absv(self) -> Self {
        V(self.0.map(f64::abs))
    }
}
