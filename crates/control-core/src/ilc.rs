//! Iterative learning control for periodic references, reference-adjustment form (Bristow,
//! Tharayil & Alleyne, "A survey of iterative learning control", IEEE Control Systems
//! Magazine 26(3), 2006, Eq. (3) and Section "Design"; Longman, "Iterative learning control
//! and repetitive control for engineering practice", Int. J. Control 73(10), 2000, for the
//! phase-lead learning law and the zero-phase Q-filter).
//!
//! The loop (any feedback controller C around the plant P) sees the measurement shifted by a
//! learned correction c_j of period j: C regulates y − c_j to q_d, so y tracks q_d + c_j.
//! With T the closed-loop map q_d → y (the learning plant), the error e_j = q_d − y_j obeys
//! e_j = (1 − T) q_d − T c_j, and the update
//!
//! ```text
//! c_{j+1}[k] = Σ_{m=−M}^{M} q_m ( c_j[k+m] + γ e_j[k+m+λ] )     (indices mod N)
//! ```
//!
//! with Q(z) = Σ q_m z^m the zero-phase Bartlett (triangular) window of half-width M
//! (q_m = (M+1−|m|)/(M+1)², Q(e^{jω}) = Fejér kernel ∈ [0, 1], unity at DC) and L = γ z^λ a
//! gain with a phase lead of λ samples. The error converges monotonically in the ℓ² norm
//! over periods when (Bristow et al. 2006, Eq. (24)):
//!
//! ```text
//! |Q(e^{jω}) (1 − γ e^{jωλ} T(e^{jω}))| < 1   for all ω up to Nyquist
//! ```
//!
//! `flexstage-control`'s `learning` module designs γ, λ and M from a frequency response of T
//! and checks this condition; this module is the allocation-free kernel on caller-provided
//! buffers of one period N.
//!
//! Cost per sample: 2 (2M + 1) multiply-adds per axis, no allocation, no branch on data.

use crate::{CoreError, check};

/// Settings of the learning layer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IlcParams {
    /// Samples per period of the reference N, ≥ 2 (the buffers' length).
    pub period: usize,
    /// Learning gain γ in (0, 2) (monotone convergence needs |1 − γ T| < 1 where Q ≈ 1).
    pub gain: f64,
    /// Phase lead λ \[samples\], < N: the delay of the closed loop to undo.
    pub lead: usize,
    /// Half-width M of the Bartlett Q-filter \[samples\], 0 (no filter) ≤ M < N/2. The
    /// first zero of Q is at f_s/(M + 1).
    pub q_half_width: usize,
}

impl IlcParams {
    /// Checks the fields against their ranges.
    pub fn validate(&self) -> Result<(), CoreError> {
        check(
            "ilc.period",
            self.period as f64,
            self.period >= 2,
            "an integer ≥ 2 [samples]",
        )?;
        check(
            "ilc.gain",
            self.gain,
            self.gain > 0.0 && self.gain < 2.0,
            "a number in (0, 2)",
        )?;
        check(
            "ilc.lead",
            self.lead as f64,
            self.lead < self.period,
            "an integer < period [samples]",
        )?;
        check(
            "ilc.q_half_width",
            self.q_half_width as f64,
            2 * self.q_half_width < self.period,
            "an integer < period / 2 [samples]",
        )
    }

    /// The Bartlett weight q_m of the Q-filter (module docs), for |m| ≤ M.
    #[inline]
    pub fn q_weight(&self, m: isize) -> f64 {
        let w = (self.q_half_width + 1) as f64;
        (w - m.unsigned_abs() as f64) / (w * w)
    }
}

/// The four period buffers of the learning layer: the correction c_j applied in the last
/// period, the one being applied now (c_{j+1}, computed sample by sample), and the errors of
/// the last and the current period. `S` is any storage of a slice: `&mut [[f64; 2]]`, a
/// static array `[[f64; 2]; N]`, or a `Vec` where there is an allocator.
#[derive(Debug, Clone)]
pub struct IlcBuffers<S> {
    /// c_j \[m\].
    pub learned: S,
    /// c_{j+1} \[m\].
    pub applied: S,
    /// e_j \[m\].
    pub error: S,
    /// e_{j+1} \[m\].
    pub error_now: S,
}

/// The learning layer (module docs). Feed every sample with [`Ilc::step`]; sample k of the
/// run is sample k mod N of its period.
#[derive(Debug, Clone)]
pub struct Ilc<S> {
    params: IlcParams,
    buf: IlcBuffers<S>,
    k: usize,
    periods: usize,
    learning: bool,
}

impl<S: AsMut<[[f64; 2]]> + AsRef<[[f64; 2]]>> Ilc<S> {
    /// A learning layer on `buffers` (each of length `params.period`, zeroed here).
    pub fn new(params: IlcParams, buffers: IlcBuffers<S>) -> Result<Self, CoreError> {
        params.validate()?;
        for (field, b) in [
            ("ilc.learned", buffers.learned.as_ref()),
            ("ilc.applied", buffers.applied.as_ref()),
            ("ilc.error", buffers.error.as_ref()),
            ("ilc.error_now", buffers.error_now.as_ref()),
        ] {
            if b.len() != params.period {
                return Err(CoreError::Buffer {
                    field,
                    len: b.len(),
                    expected: params.period,
                });
            }
        }
        let mut buf = buffers;
        for b in [
            &mut buf.learned,
            &mut buf.applied,
            &mut buf.error,
            &mut buf.error_now,
        ] {
            b.as_mut().fill([0.0; 2]);
        }
        Ok(Ilc {
            params,
            buf,
            k: 0,
            periods: 0,
            learning: true,
        })
    }

    /// The settings.
    pub fn params(&self) -> &IlcParams {
        &self.params
    }

    /// The correction learned over the last complete period, c_j \[m\] (one entry per sample).
    pub fn learned(&self) -> &[[f64; 2]] {
        self.buf.learned.as_ref()
    }

    /// The errors of the last complete period, e_j = q_d − y \[m\].
    pub fn last_errors(&self) -> &[[f64; 2]] {
        self.buf.error.as_ref()
    }

    /// Completed periods.
    pub fn periods(&self) -> usize {
        self.periods
    }

    /// The index k (0 ≤ k < N) within its period of the sample about to be recorded.
    pub fn sample(&self) -> usize {
        self.k
    }

    /// Freezes (false) or resumes (true) learning: frozen, the last correction is replayed.
    pub fn set_learning(&mut self, on: bool) {
        self.learning = on;
    }

    /// One sample: records e = q_d − y and returns the correction c \[m\] to subtract from the
    /// measurement the feedback controller sees ([`Ilc::correction`] then [`Ilc::record`]).
    #[inline]
    pub fn step(&mut self, y: [f64; 2], reference: [f64; 2]) -> [f64; 2] {
        let c = self.correction();
        self.record(y, reference);
        c
    }

    /// The correction c_{j+1}\[k\] \[m\] of the current sample k (module docs); call once per
    /// sample, before [`Ilc::record`].
    #[inline]
    pub fn correction(&mut self) -> [f64; 2] {
        let n = self.params.period;
        let k = self.k;
        let learned = self.buf.learned.as_ref();
        let error = self.buf.error.as_ref();
        let c = if self.periods == 0 {
            [0.0; 2]
        } else if !self.learning {
            learned[k]
        } else {
            let m_half = self.params.q_half_width as isize;
            let (gain, lead) = (self.params.gain, self.params.lead);
            let mut c = [0.0; 2];
            for m in -m_half..=m_half {
                let w = self.params.q_weight(m);
                let i = (k as isize + m).rem_euclid(n as isize) as usize;
                let ie = (i + lead) % n;
                for a in 0..2 {
                    c[a] += w * (learned[i][a] + gain * error[ie][a]);
                }
            }
            c
        };
        self.buf.applied.as_mut()[k] = c;
        c
    }

    /// Stores a correction c_{j+1}\[k\] \[m\] computed outside this kernel (another
    /// learning law, from [`Ilc::learned`] and [`Ilc::last_errors`]) for the current sample
    /// k and returns what is applied: `c` while learning, the replayed c_j\[k\] when frozen,
    /// 0 in the first period (as [`Ilc::correction`]). Call once per sample instead of
    /// [`Ilc::correction`], before [`Ilc::record`].
    #[inline]
    pub fn set_correction(&mut self, c: [f64; 2]) -> [f64; 2] {
        let k = self.k;
        let c = if self.periods == 0 {
            [0.0; 2]
        } else if !self.learning {
            self.buf.learned.as_ref()[k]
        } else {
            c
        };
        self.buf.applied.as_mut()[k] = c;
        c
    }

    /// Records the measurement y \[m\] and the reference q_d \[m\] of the current sample and
    /// moves to the next (a new period after N samples).
    #[inline]
    pub fn record(&mut self, y: [f64; 2], reference: [f64; 2]) {
        let n = self.params.period;
        let error_now = &mut self.buf.error_now.as_mut()[self.k];
        for a in 0..2 {
            let e = reference[a] - y[a];
            error_now[a] = if e.is_finite() { e } else { 0.0 };
        }
        self.k += 1;
        if self.k == n {
            self.k = 0;
            self.periods += 1;
            core::mem::swap(&mut self.buf.learned, &mut self.buf.applied);
            core::mem::swap(&mut self.buf.error, &mut self.buf.error_now);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: the rules of [`Ilc::correction`] (nothing in the first period, the last
    /// period's correction replayed when frozen). Goal: a correction set from outside is
    /// applied while learning, replaced by 0 in the first period and by c_j when frozen,
    /// and becomes the learned table at the period's end.
    #[test]
    fn a_correction_set_from_outside_follows_the_kernels_rules() {
        let n = 4;
        let params = IlcParams {
            period: n,
            gain: 0.5,
            lead: 0,
            q_half_width: 0,
        };
        let buffers = IlcBuffers {
            learned: [[0.0; 2]; 4],
            applied: [[0.0; 2]; 4],
            error: [[0.0; 2]; 4],
            error_now: [[0.0; 2]; 4],
        };
        let mut ilc = Ilc::new(params, buffers).unwrap();
        for _ in 0..n {
            assert_eq!(ilc.set_correction([1.0, 2.0]), [0.0; 2]);
            ilc.record([0.0; 2], [0.0; 2]);
        }
        for k in 0..n {
            let c = [k as f64, -(k as f64)];
            assert_eq!(ilc.set_correction(c), c);
            ilc.record([0.0; 2], [0.0; 2]);
        }
        assert_eq!(ilc.learned()[3], [3.0, -3.0]);
        ilc.set_learning(false);
        assert_eq!(ilc.set_correction([9.0, 9.0]), [0.0, 0.0]);
        ilc.record([0.0; 2], [0.0; 2]);
        assert_eq!(ilc.set_correction([9.0, 9.0]), [1.0, -1.0]);
    }
}
