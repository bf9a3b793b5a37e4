//! The asymmetric Bouc–Wen model of a PEA, Eq. (18) with n = 1, and its exact integrator.
//!
//! ```text
//! x_nom(t) = d_p U(t) − h(t)
//! dh/dt    = A_bw U̇ − B_bw |U̇| h − Γ_bw U̇ |h| + δ_bw U sgn(U̇)          (18)
//! ```
//!
//! # Units
//! This crate works consistently in the paper's units of Table A1: x and h in µm, U in V,
//! t in s. So d_p and A_bw are in µm/V, B_bw and Γ_bw in 1/V and δ_bw in µm/(V·s). Multiply
//! displacements by [`MICROMETRE`] to get metres for the SI stage model.
//!
//! # The δ term and the sample time
//! The first three terms of (18) are proportional to U̇: over a step they depend only on the
//! voltage increment, not on how long it took (rate-independent). The asymmetry term
//! δ_bw·U·sgn(U̇) is not: over a step of duration Δt it contributes about δ_bw·U·Δt. A
//! discretization that drops Δt (adding δ_bw·U·sgn(ΔU) per sample) inflates it by 1/Δt =
//! 10⁴ at 0.1 ms and turns ~0.1 µm of asymmetry into ~1000 µm. Here Δt is always explicit.
//!
//! # Integration
//! Between two samples the voltage is taken as a straight line in time (the amplifier output
//! is continuous; this is the first-order hold of the drive). Along such a ramp, sgn(U̇) = s
//! is constant and, while h keeps its sign σ, (18) is *linear* in h. With ν = |U − U₀| as
//! the independent variable and c = Δt/|ΔU|:
//!
//! ```text
//! dh/dν = a + b ν − k h,    k = B_bw + s σ Γ_bw,   a = s A_bw + s δ_bw c U₀,   b = δ_bw c
//! h(ν)  = h₀ e^{−kν} + a (1 − e^{−kν})/k + b (kν − 1 + e^{−kν})/k²
//! ```
//!
//! [`advance`] evaluates this closed form, finds the exact zero crossing of h when it changes
//! sign inside the step, and continues from there. The result is exact for any step length
//! (up to rounding), so 0.1 ms steps, substeps, or one step per large voltage jump all agree;
//! a step with ΔU = 0 leaves h unchanged (sgn(0) = 0). With Δt = 0 (a voltage jump) the
//! δ term contributes nothing.

use serde::{Deserialize, Serialize};

use crate::error::{Result, check};

/// One micrometre in metres: the scale between this crate's µm and SI.
pub const MICROMETRE: f64 = 1e-6;

/// Parameters of Eq. (18) with n = 1, in µm, V and s (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoucWenParams {
    /// Piezoelectric coefficient d_p [µm/V], > 0.
    pub d_p: f64,
    /// A_bw [µm/V], finite (the initial slope of h against U).
    pub a_bw: f64,
    /// B_bw [1/V], ≥ 0.
    pub b_bw: f64,
    /// Γ_bw [1/V], finite with B_bw + Γ_bw > 0 (bounded hysteresis).
    pub gamma_bw: f64,
    /// Asymmetry factor δ_bw [µm/(V·s)], finite.
    pub delta_bw: f64,
}

impl BoucWenParams {
    /// PEA1 of Table A1.
    pub const PEA1: BoucWenParams = BoucWenParams {
        d_p: 6.2e-2,
        a_bw: 1.2e-2,
        b_bw: 1.9e-3,
        gamma_bw: 1.6e-3,
        delta_bw: 5.015e-4,
    };

    /// PEA2 of Table A1.
    pub const PEA2: BoucWenParams = BoucWenParams {
        d_p: 6.5e-2,
        a_bw: 2.5e-2,
        b_bw: 1.8e-3,
        gamma_bw: 5.3e-3,
        delta_bw: 1.973e-4,
    };

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<()> {
        check(
            "bouc_wen.d_p",
            self.d_p,
            self.d_p > 0.0,
            "a finite number > 0 [µm/V]",
        )?;
        check("bouc_wen.a_bw", self.a_bw, true, "a finite number [µm/V]")?;
        check(
            "bouc_wen.b_bw",
            self.b_bw,
            self.b_bw >= 0.0,
            "a finite number ≥ 0 [1/V]",
        )?;
        check(
            "bouc_wen.gamma_bw",
            self.gamma_bw,
            self.b_bw + self.gamma_bw > 0.0,
            "a finite number with b_bw + gamma_bw > 0 [1/V]",
        )?;
        check(
            "bouc_wen.delta_bw",
            self.delta_bw,
            true,
            "a finite number [µm/(V·s)]",
        )
    }

    /// The same parameters without the rate-dependent asymmetry (δ_bw = 0).
    pub fn without_asymmetry(self) -> Self {
        BoucWenParams {
            delta_bw: 0.0,
            ..self
        }
    }

    /// Bound of |h| for δ_bw = 0 when starting inside it: A_bw/(B_bw + Γ_bw) \[µm\].
    pub fn h_bound(&self) -> f64 {
        self.a_bw.abs() / (self.b_bw + self.gamma_bw)
    }

    /// The right-hand side of Eq. (18): dh/dt [µm/s] at voltage `u`, rate `u_dot` and state `h`.
    #[inline]
    pub fn h_dot(&self, u: f64, u_dot: f64, h: f64) -> f64 {
        self.a_bw * u_dot - self.b_bw * u_dot.abs() * h - self.gamma_bw * u_dot * h.abs()
            + self.delta_bw * u * sgn(u_dot)
    }

    /// The virgin loading curve from (U, h) = (0, 0) for δ_bw = 0, U ≥ 0:
    /// h(U) = A/(B+Γ)·(1 − e^{−(B+Γ)U}) \[µm\].
    pub fn virgin_h(&self, u: f64) -> f64 {
        let k = self.b_bw + self.gamma_bw;
        -self.a_bw * (-k * u).exp_m1() / k
    }
}

impl From<&flexstage_scenario::BoucWen> for BoucWenParams {
    fn from(b: &flexstage_scenario::BoucWen) -> Self {
        BoucWenParams {
            d_p: b.d_p,
            a_bw: b.a_bw,
            b_bw: b.b_bw,
            gamma_bw: b.gamma_bw,
            delta_bw: b.delta_bw,
        }
    }
}

impl From<&BoucWenParams> for flexstage_scenario::BoucWen {
    fn from(b: &BoucWenParams) -> Self {
        flexstage_scenario::BoucWen {
            d_p: b.d_p,
            a_bw: b.a_bw,
            b_bw: b.b_bw,
            gamma_bw: b.gamma_bw,
            delta_bw: b.delta_bw,
        }
    }
}

/// sgn of Eq. (17): 1, 0 or −1.
#[inline]
pub(crate) fn sgn(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// (1 − e^{−z})/z, continuous at z = 0, given em = e^{−z} − 1.
#[inline]
fn phi1(z: f64, em: f64) -> f64 {
    if z == 0.0 { 1.0 } else { -em / z }
}

/// (z − 1 + e^{−z})/z², continuous at z = 0, given em = e^{−z} − 1.
#[inline]
fn phi2(z: f64, em: f64) -> f64 {
    if z.abs() < 0.1 {
        // Taylor series; truncation error below z⁶/5040 ≈ 2e-10 relative at |z| = 0.1.
        1.0 / 2.0
            + z * (-1.0 / 6.0
                + z * (1.0 / 24.0 + z * (-1.0 / 120.0 + z * (1.0 / 720.0 - z / 5040.0))))
    } else {
        (z + em) / (z * z)
    }
}

/// h after a ramp of length ν inside one sign regime (closed form in the module docs).
#[inline]
fn h_at(h0: f64, a: f64, b: f64, k: f64, nu: f64) -> f64 {
    let z = k * nu;
    let em = (-z).exp_m1();
    h0 * (1.0 + em) + a * nu * phi1(z, em) + b * nu * nu * phi2(z, em)
}

/// Advances the hysteretic state h of Eq. (18) exactly over one step in which U moves
/// linearly in time from `u0` to `u1` during `dt` seconds (`dt` ≥ 0). Returns h at the end.
///
/// This is the integrator used by [`BoucWen`], the compensator and the identification.
#[inline]
pub fn advance(p: &BoucWenParams, u0: f64, h0: f64, u1: f64, dt: f64) -> f64 {
    let du = u1 - u0;
    if du == 0.0 {
        return h0;
    }
    let s = sgn(du);
    let c = dt / du.abs();
    let mut u_start = u0;
    let mut h = h0;
    let mut remaining = du.abs();
    // At most a few sign changes of h can happen along one monotone ramp.
    for _ in 0..4 {
        let a = s * p.a_bw + s * p.delta_bw * c * u_start;
        let b = p.delta_bw * c;
        // Sign regime: that of h, or of the initial slope a when h = 0.
        let sigma = if h > 0.0 {
            1.0
        } else if h < 0.0 {
            -1.0
        } else if a != 0.0 {
            sgn(a)
        } else if b != 0.0 {
            sgn(b)
        } else {
            return 0.0;
        };
        let k = p.b_bw + s * sigma * p.gamma_bw;
        let h_end = h_at(h, a, b, k, remaining);
        if sigma * h_end >= 0.0 {
            return h_end;
        }
        // h changes sign inside the step: locate ν* with h(ν*) = 0 (bracketed Newton).
        let (mut lo, mut hi) = (0.0, remaining);
        let mut nu = remaining * h / (h - h_end);
        for _ in 0..60 {
            let hv = h_at(h, a, b, k, nu);
            if sigma * hv > 0.0 {
                lo = nu;
            } else {
                hi = nu;
            }
            let slope = a + b * nu - k * hv;
            let mut next = if slope != 0.0 {
                nu - hv / slope
            } else {
                f64::NAN
            };
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - nu).abs() <= 1e-15 * remaining.max(1e-300) || hi - lo <= 1e-15 * remaining {
                nu = next;
                break;
            }
            nu = next;
        }
        u_start += s * nu;
        remaining -= nu;
        h = 0.0;
        if remaining <= 0.0 {
            return 0.0;
        }
    }
    h
}

/// A Bouc–Wen PEA with its state (U, h): the simulated actuator, Eq. (18).
#[derive(Debug, Clone)]
pub struct BoucWen {
    params: BoucWenParams,
    u: f64,
    h: f64,
}

impl BoucWen {
    /// A virgin actuator: U = 0, h = 0. The parameters must be valid ([`BoucWenParams::validate`]).
    pub fn new(params: BoucWenParams) -> Self {
        BoucWen::with_state(params, 0.0, 0.0)
    }

    /// An actuator at voltage `u` \[V\] with hysteretic state `h` \[µm\].
    pub fn with_state(params: BoucWenParams, u: f64, h: f64) -> Self {
        BoucWen { params, u, h }
    }

    /// The parameters.
    pub fn params(&self) -> &BoucWenParams {
        &self.params
    }

    /// Current voltage U \[V\].
    pub fn u(&self) -> f64 {
        self.u
    }

    /// Current hysteretic state h \[µm\].
    pub fn h(&self) -> f64 {
        self.h
    }

    /// Current displacement x_nom = d_p U − h \[µm\].
    pub fn x(&self) -> f64 {
        self.params.d_p * self.u - self.h
    }

    /// Sets the state (U \[V\], h \[µm\]).
    pub fn set_state(&mut self, u: f64, h: f64) {
        self.u = u;
        self.h = h;
    }

    /// Ramps the voltage linearly to `u` \[V\] over `dt` \[s\] and returns the new x_nom \[µm\].
    /// Exact for any `dt` (see the module docs); no allocation.
    #[inline]
    pub fn step(&mut self, u: f64, dt: f64) -> f64 {
        self.h = advance(&self.params, self.u, self.h, u, dt);
        self.u = u;
        self.x()
    }
}

/// Simulates x_nom \[µm\] for the voltage samples `u` \[V\] at times `t` \[s\] (linear between
/// samples), starting at (u\[0\], `h0`). `t` and `u` have equal length.
pub fn simulate(params: &BoucWenParams, t: &[f64], u: &[f64], h0: f64) -> Vec<f64> {
    assert_eq!(t.len(), u.len(), "one time per voltage sample");
    let Some(&u_first) = u.first() else {
        return Vec::new();
    };
    let mut pea = BoucWen::with_state(*params, u_first, h0);
    let mut x = Vec::with_capacity(u.len());
    x.push(pea.x());
    for k in 1..u.len() {
        x.push(pea.step(u[k], t[k] - t[k - 1]));
    }
    x
}
