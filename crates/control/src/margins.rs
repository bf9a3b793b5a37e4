//! Classical stability margins of a loop from its frequency response (python-control's
//! `margin` / `stability_margins`), for sampled loops with delay.
//!
//! Given the return ratio L(jω) of one loop (for a sampled loop, L(e^{jωT}) for
//! 0 < f < f_s/2), with the loop closed as `u = −L·u`:
//!
//! * **gain margin**: at every phase crossover (arg L = ±180°, i.e. Im L = 0 with Re L < 0),
//!   the factor 1/|L| by which the loop gain can change before the Nyquist curve passes
//!   through −1. Reported in dB as the crossing nearest to 0 dB, with its sign: +6 dB means
//!   the gain may double, a negative value means the loop is only stable because the gain is
//!   *above* a crossing (conditional stability) or the loop is unstable;
//! * **phase margin**: at every gain crossover (|L| = 1), PM = 180° + arg L wrapped to
//!   (−180°, 180°]; the smallest is reported;
//! * **delay margin**: the smallest PM_rad/ω_c over the gain crossovers: the extra pure delay
//!   that destabilizes the loop (python-control `stability_margins`, "dm").
//!
//! Crossings are found on a log-spaced grid and refined by bisection on the closure, so an
//! analytic L gives the margins to round-off; a measured L (sine injection) to the accuracy
//! of its evaluations.
//!
//! These are classical margins of one loop at a time (the other loop closed, as measured by
//! breaking one loop of a running MIMO system). They do not bound simultaneous perturbations
//! of both loops; disk margins would, but need the full 2 × 2 loop matrix, which sine
//! injection on a nonlinear controller does not give cheaply (DECISIONS.md, Control).

use nalgebra::Complex;

use crate::error::{Result, check};

/// Settings of the margin search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarginParams {
    /// Lowest frequency searched \[Hz\], > 0.
    pub f_min: f64,
    /// Highest frequency searched \[Hz\], > f_min (for a sampled loop, below f_s/2).
    pub f_max: f64,
    /// Log-spaced grid points, ≥ 8.
    pub points: usize,
    /// Bisection steps per crossing, 0–60 (each halves the log-frequency bracket).
    pub refine: usize,
}

impl Default for MarginParams {
    fn default() -> Self {
        MarginParams {
            f_min: 1.0,
            f_max: 4900.0,
            points: 200,
            refine: 40,
        }
    }
}

impl MarginParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check("margins.f_min", self.f_min, self.f_min > 0.0, "> 0 Hz")?;
        check(
            "margins.f_max",
            self.f_max,
            self.f_max > self.f_min,
            "> margins.f_min",
        )?;
        check(
            "margins.points",
            self.points as f64,
            self.points >= 8,
            "≥ 8",
        )?;
        check(
            "margins.refine",
            self.refine as f64,
            self.refine <= 60,
            "0–60",
        )
    }
}

/// Margins of one loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    /// Gain margin \[dB\] (module docs); +∞ without phase crossover in the band.
    pub gain_db: f64,
    /// Frequency of that phase crossover \[Hz\] (NaN without).
    pub phase_crossover: f64,
    /// Phase margin \[deg\]; +∞ without gain crossover in the band.
    pub phase_deg: f64,
    /// Frequency of that gain crossover \[Hz\] (NaN without).
    pub gain_crossover: f64,
    /// Delay margin \[s\]; +∞ without gain crossover.
    pub delay: f64,
}

impl Margins {
    /// True when the gain margin is at least `gm_db` and the phase margin at least `pm_deg`.
    pub fn meets(&self, gm_db: f64, pm_deg: f64) -> bool {
        self.gain_db >= gm_db && self.phase_deg >= pm_deg
    }
}

/// Margins of the loop with return ratio `l(f)` (f in Hz) over the band of `params`.
pub fn margin(mut l: impl FnMut(f64) -> Complex<f64>, params: &MarginParams) -> Result<Margins> {
    params.validate()?;
    let n = params.points;
    let (a, b) = (params.f_min.ln(), params.f_max.ln());
    let grid: Vec<f64> = (0..n)
        .map(|k| (a + (b - a) * k as f64 / (n - 1) as f64).exp())
        .collect();
    let vals: Vec<Complex<f64>> = grid.iter().map(|&f| l(f)).collect();
    let mut out = Margins {
        gain_db: f64::INFINITY,
        phase_crossover: f64::NAN,
        phase_deg: f64::INFINITY,
        gain_crossover: f64::NAN,
        delay: f64::INFINITY,
    };
    // Gain crossovers: |L| − 1 changes sign.
    let gain = |z: Complex<f64>| z.norm() - 1.0;
    // Phase crossovers: Im L changes sign where Re L < 0.
    let phase = |z: Complex<f64>| z.im;
    for k in 0..n - 1 {
        let (z0, z1) = (vals[k], vals[k + 1]);
        if gain(z0).signum() != gain(z1).signum() {
            let (f, z) = bisect(&mut l, grid[k], grid[k + 1], z0, gain, params.refine);
            let pm = wrap180(180.0 + z.arg().to_degrees());
            if pm < out.phase_deg {
                out.phase_deg = pm;
                out.gain_crossover = f;
            }
            let dm = pm.to_radians() / (std::f64::consts::TAU * f);
            out.delay = out.delay.min(if pm > 0.0 { dm } else { 0.0 });
        }
        if phase(z0).signum() != phase(z1).signum() && (z0.re < 0.0 || z1.re < 0.0) {
            let (f, z) = bisect(&mut l, grid[k], grid[k + 1], z0, phase, params.refine);
            if z.re < 0.0 {
                let gm = -20.0 * z.norm().log10();
                if gm.abs() < out.gain_db.abs() {
                    out.gain_db = gm;
                    out.phase_crossover = f;
                }
            }
        }
    }
    Ok(out)
}

/// Bisection in log-frequency for a sign change of `g(l(f))` between `f0` and `f1`.
fn bisect(
    l: &mut impl FnMut(f64) -> Complex<f64>,
    mut f0: f64,
    mut f1: f64,
    mut z0: Complex<f64>,
    g: impl Fn(Complex<f64>) -> f64,
    steps: usize,
) -> (f64, Complex<f64>) {
    let mut zm = z0;
    let mut fm = f0;
    for _ in 0..steps.max(1) {
        fm = (f0 * f1).sqrt();
        zm = l(fm);
        if g(zm).signum() == g(z0).signum() {
            f0 = fm;
            z0 = zm;
        } else {
            f1 = fm;
        }
    }
    (fm, zm)
}

/// Wraps an angle in degrees to (−180, 180].
fn wrap180(x: f64) -> f64 {
    let mut y = x % 360.0;
    if y > 180.0 {
        y -= 360.0;
    }
    if y <= -180.0 {
        y += 360.0;
    }
    y
}

/// The loop-at-a-time return ratio of loop `i` of a 2 × 2 loop matrix `l` (= P K at the
/// output, or K P at the input) with the other loop `j` closed:
/// `l_i = L_ii − L_ij L_ji / (1 + L_jj)` (Skogestad & Postlethwaite, Multivariable Feedback
/// Control, 2nd ed., Section 10.8, "one loop at a time").
pub fn loop_at_a_time(l: &[[Complex<f64>; 2]; 2], i: usize) -> Complex<f64> {
    let j = 1 - i;
    l[i][i] - l[i][j] * l[j][i] / (Complex::new(1.0, 0.0) + l[j][j])
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    /// Reference: closed form. L(s) = kp K (1 + 1/(T s)) e^{−sτ}/(T s + 1) with the PI zero
    /// on the plant pole (ki = kp/T) is L = (ω_c/s) e^{−sτ}, ω_c = kp K/T: the gain crossover
    /// is ω_c, PM = 90° − ω_c τ, the phase crossover ω_p = π/(2τ), GM = ω_p/ω_c, the delay
    /// margin (π/2 − ω_c τ)/ω_c. Goal: `margin` reproduces all five to 1e-9.
    #[test]
    fn closed_form_first_order_plant_with_delay_and_pi() {
        let (k, t, tau, kp) = (2.0, 1e-3, 1e-4, 0.5);
        let ki = kp / t;
        let l = |f: f64| {
            let s = Complex::new(0.0, TAU * f);
            let c = Complex::new(kp, 0.0) + ki / s;
            let p = k * (-s * tau).exp() / (s * t + 1.0);
            c * p
        };
        let m = margin(l, &MarginParams::default()).unwrap();
        let wc = kp * k / t;
        let wp = PI / (2.0 * tau);
        assert!((m.gain_crossover * TAU / wc - 1.0).abs() < 1e-9);
        assert!((m.phase_deg - (90.0 - (wc * tau).to_degrees())).abs() < 1e-7);
        assert!((m.phase_crossover * TAU / wp - 1.0).abs() < 1e-9);
        assert!((m.gain_db - 20.0 * (wp / wc).log10()).abs() < 1e-7);
        assert!((m.delay - (FRAC_PI_2 - wc * tau) / wc).abs() < 1e-12);
        assert!(m.meets(6.0, 40.0));
    }

    /// Reference: the same loop with ω_c τ past π/2 is unstable: negative phase margin, a
    /// gain margin below 0 dB and zero delay margin; and a loop that never crosses reports
    /// infinite margins.
    #[test]
    fn unstable_and_uncrossed_loops() {
        let tau = 1e-3;
        let wc = 2.0 / tau;
        let l = |f: f64| {
            let s = Complex::new(0.0, TAU * f);
            wc / s * (-s * tau).exp()
        };
        let m = margin(l, &MarginParams::default()).unwrap();
        assert!(m.phase_deg < 0.0 && m.gain_db < 0.0 && m.delay == 0.0);
        assert!(!m.meets(6.0, 40.0));
        let small = margin(|_| Complex::new(0.1, 0.0), &MarginParams::default()).unwrap();
        assert!(small.gain_db.is_infinite() && small.phase_deg.is_infinite());
    }

    /// Reference: for a diagonal loop matrix the loop-at-a-time ratio is the diagonal entry;
    /// for L = [[a, b], [c, d]] it is a − bc/(1+d) (hand expansion of the closed loop).
    #[test]
    fn loop_at_a_time_formula() {
        let z = |x: f64, y: f64| Complex::new(x, y);
        let diag = [[z(2.0, 1.0), z(0.0, 0.0)], [z(0.0, 0.0), z(3.0, -1.0)]];
        assert_eq!(loop_at_a_time(&diag, 0), z(2.0, 1.0));
        let full = [[z(1.0, 0.0), z(0.5, 0.0)], [z(0.2, 0.0), z(1.0, 0.0)]];
        assert!((loop_at_a_time(&full, 0) - z(0.95, 0.0)).norm() < 1e-15);
        assert!((loop_at_a_time(&full, 1) - z(0.95, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn bad_params_name_the_field() {
        let p = MarginParams {
            points: 2,
            ..MarginParams::default()
        };
        let e = margin(|_| Complex::new(1.0, 0.0), &p).unwrap_err();
        assert!(e.to_string().contains("margins.points"));
    }
}
