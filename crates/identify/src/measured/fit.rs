//! A z-domain rational model of a measured response ([`ZFit`]): the loop model a design
//! evaluates at any frequency.
//!
//! # Method
//! One common denominator for the four entries and the delay d (whole samples):
//! `H_ij(z) = z^{−d} B_ij(z⁻¹) / A(z⁻¹)`, `A = 1 + Σ_{m=1..n} a_m z^{−m}`,
//! `B_ij = Σ_{m=1..n} b_ij,m z^{−m}` (strictly proper: the zero-order hold acts one sample
//! later). Modes above Nyquist are poles in z like any other, at their folded frequency.
//! 1. **Linearized fit** (Levy) with Sanathanan–Koerner reweighting: minimize
//!    `Σ |B_ij z^{−d} − Ĥ_ij A|² / (σ_ij² |A_prev|²)` over a and b; each entry's numerator
//!    is eliminated by projecting onto the orthogonal complement of its columns (QR), so
//!    only the n denominator coefficients are solved jointly (`iterations` times).
//! 2. **Poles.** The roots of A (companion matrix); a root outside the unit circle is
//!    reflected to 1/z̄ (same frequency response magnitude shape, stable).
//! 3. **Numerators** with the poles fixed, by weighted linear least squares on the actual
//!    error `Σ |z^{−d} B_ij/A − Ĥ_ij|²/σ_ij²`.
//! 4. **Order and delay**: n = 1, 2, …, `max_order` and d = 0..=`max_delay`; the first
//!    order at which some delay gives χ²/dof ≤ 1 + 3√(2/dof) (the fit agrees with the lines
//!    within their standard deviations), else the smallest χ²/dof found. σ_ij is the
//!    line's standard deviation, at least `floor` × the largest |Ĥ| (a noise-free
//!    measurement is fitted to that relative accuracy).

use flexstage_sim::modal::LoopPlant;
use nalgebra::{DMatrix, DVector};

use crate::error::{IdentifyError, Result, check};
use crate::frequency::C64;
use crate::measured::MeasuredResponse;
use crate::response::ResponseFit;

/// Settings of the z-domain fit (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitParams {
    /// Highest denominator order tried, in 1..=60. Default 24.
    pub max_order: usize,
    /// Largest delay tried \[samples\], ≤ 4. Default 3.
    pub max_delay: usize,
    /// Sanathanan–Koerner iterations, ≥ 1. Default 8.
    pub iterations: usize,
    /// Least standard deviation relative to the largest |Ĥ|, in (0, 1). Default 1e-9.
    pub floor: f64,
}

impl Default for FitParams {
    fn default() -> Self {
        FitParams {
            max_order: 24,
            max_delay: 3,
            iterations: 8,
            floor: 1e-9,
        }
    }
}

impl FitParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "fit.max_order",
            self.max_order as f64,
            (1..=60).contains(&self.max_order),
            "an order in 1..=60",
        )?;
        check(
            "fit.max_delay",
            self.max_delay as f64,
            self.max_delay <= 4,
            "0..=4 samples",
        )?;
        check(
            "fit.iterations",
            self.iterations as f64,
            self.iterations >= 1,
            "≥ 1",
        )?;
        check(
            "fit.floor",
            self.floor,
            self.floor > 0.0 && self.floor < 1.0,
            "a relative level in (0, 1)",
        )
    }
}

/// The fitted loop model (module docs): a [`LoopPlant`] built only from a
/// [`MeasuredResponse`].
#[derive(Debug, Clone, PartialEq)]
pub struct ZFit {
    sample_time: f64,
    delay: usize,
    /// 1, a_1, …, a_n.
    a: Vec<f64>,
    /// b_ij,1..n per entry.
    b: [[Vec<f64>; 2]; 2],
    poles: Vec<C64>,
    chi2: f64,
    dof: usize,
}

/// The measured lines in the fit's form: z⁻¹ per line, Ĥ and 1/σ per entry.
struct Data {
    zi: Vec<C64>,
    h: Vec<[C64; 4]>,
    w: Vec<[f64; 4]>,
}

impl ZFit {
    /// Fits `response` (module docs).
    pub fn fit(response: &MeasuredResponse, p: &FitParams) -> Result<ZFit> {
        p.validate()?;
        let data = Data::of(response, p.floor);
        let rows = 8 * data.zi.len();
        let mut best: Option<ZFit> = None;
        for n in 1..=p.max_order {
            if 5 * n + 1 >= rows {
                break;
            }
            for d in 0..=p.max_delay {
                let Some(a) = denominator(&data, n, d, p.iterations) else {
                    continue;
                };
                let (a, poles) = stabilized(&a);
                let Some(fit) = numerators(&data, a, poles, d, response.sample_time()) else {
                    continue;
                };
                if best
                    .as_ref()
                    .is_none_or(|b| fit.reduced_chi2() < b.reduced_chi2())
                {
                    best = Some(fit);
                }
            }
            if let Some(b) = &best {
                let dof = b.dof as f64;
                if b.reduced_chi2() <= 1.0 + 3.0 * (2.0 / dof).sqrt() {
                    break;
                }
            }
        }
        best.ok_or_else(|| IdentifyError::Estimate {
            what: "z-domain fit of the measured response".into(),
            reason: format!(
                "no order up to {} gave a solvable fit on {} lines",
                p.max_order,
                data.zi.len()
            ),
        })
    }

    /// The delay \[samples\].
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The denominator order.
    pub fn order(&self) -> usize {
        self.a.len() - 1
    }

    /// The poles in z (inside the unit circle).
    pub fn poles(&self) -> &[C64] {
        &self.poles
    }

    /// χ²/dof of the fit on the lines it was fitted to (≈ 1: agrees within the
    /// standard deviations).
    pub fn reduced_chi2(&self) -> f64 {
        self.chi2 / self.dof.max(1) as f64
    }

    /// The largest |H_fit − Ĥ| / σ over the lines and entries of `response`, with σ as in
    /// the fit (`floor` relative to the largest |Ĥ|).
    pub fn worst_deviation(&self, response: &MeasuredResponse, floor: f64) -> f64 {
        let data = Data::of(response, floor);
        let mut worst = 0.0f64;
        for (l, line) in response.lines().iter().enumerate() {
            let h = self.response(line.f);
            for e in 0..4 {
                let d = (h[e / 2][e % 2] - data.h[l][e]).norm() * data.w[l][e];
                worst = worst.max(d);
            }
        }
        worst
    }

    /// The model as a filter in the time domain, at rest ([`ZFilter`]): a loop closed around
    /// it is the measured loop model in the time domain.
    pub fn filter(&self) -> ZFilter {
        let n = self.order();
        ZFilter {
            fit: self.clone(),
            y_past: [vec![0.0; n], vec![0.0; n]],
            u_past: [vec![0.0; n + self.delay], vec![0.0; n + self.delay]],
            y: [0.0; 2],
        }
    }

    /// What a response fit of the lumped model takes from this loop model
    /// ([`ResponseFit`]): the static gain H(1), and per output axis the lowest mode (a pole
    /// pair, at the frequency the sampled loop sees it, [`LoopPlant::modes`]) whose share of
    /// that axis's static gain is at least `share` (in (0, 1]). A pair's share of axis i is
    /// its partial fractions' value at z = 1, `2 Re(R_ij/(1 − p))` with the residue R_ij at
    /// the pole p of H_ij without its delay (z^{−d} is 1 at z = 1), combined over the PEAs as in [`ResponseFit::from_modes`] (+ for
    /// q_o1, − for q_o2); for the ZOH sampling of a mode this is exactly its out·in/ω².
    pub fn response_fit(&self, share: f64) -> ResponseFit {
        let g = self.static_gain();
        let n = self.order();
        let mut best: [Option<(f64, f64)>; 2] = [None; 2];
        for (k, &p) in self.poles.iter().enumerate() {
            if !(p.im > 0.0) {
                continue;
            }
            let den: C64 = self
                .poles
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .map(|(_, &q)| p - q)
                .product();
            // The delay is 1 at z = 1: the partial fractions of B(z⁻¹)/A(z⁻¹) =
            // zⁿB(z⁻¹)/Π(z − p_j), residue at p: pⁿ B(p⁻¹) / Π_{j≠k}(p − p_j).
            let dc = |e: usize| {
                let r = poly(&self.b[e / 2][e % 2], p.inv(), 1) * p.powi(n as i32) / den;
                2.0 * (r / (C64::new(1.0, 0.0) - p)).re
            };
            let s = p.ln() / self.sample_time;
            let (f, zeta) = (s.norm() / std::f64::consts::TAU, -s.re / s.norm());
            for i in 0..2 {
                let sign = if i == 0 { 1.0 } else { -1.0 };
                let part = dc(2 * i) + sign * dc(2 * i + 1);
                let total = g[i][0] + sign * g[i][1];
                if part / total >= share && best[i].is_none_or(|b| f < b.0) {
                    best[i] = Some((f, zeta));
                }
            }
        }
        ResponseFit {
            dc_gain: g,
            frequency: best.map(|b| b.map(|m| m.0)),
            damping: best.map(|b| b.map_or(0.0, |m| m.1)),
        }
    }

    /// The model at z⁻¹ = `zi`, entry e = 2i + j.
    fn eval(&self, zi: C64, e: usize) -> C64 {
        let a = poly(&self.a, zi, 0);
        poly(&self.b[e / 2][e % 2], zi, 1 + self.delay) / a
    }
}

/// A [`ZFit`] run sample by sample: `H_ij(z) = z^{−d} B_ij(z⁻¹)/A(z⁻¹)` as the difference
/// equation `y_i[k] = −Σ_{m=1..n} a_m y_i[k−m] + Σ_j Σ_{m=1..n} b_ij,m u_j[k−d−m]`, from rest.
/// [`ZFilter::output`] is y\[k\]; [`ZFilter::step`] takes u\[k\] and moves to k + 1. No
/// allocation after [`ZFit::filter`].
#[derive(Debug, Clone)]
pub struct ZFilter {
    fit: ZFit,
    /// y_i[k], y_i[k−1], … (n values per output, newest first).
    y_past: [Vec<f64>; 2],
    /// u_j[k], u_j[k−1], … (n + d values per input, newest first).
    u_past: [Vec<f64>; 2],
    y: [f64; 2],
}

impl ZFilter {
    /// The output y\[k\] (strictly proper: it does not depend on u\[k\]).
    pub fn output(&self) -> [f64; 2] {
        self.y
    }

    /// Takes the input u\[k\] and advances to k + 1; returns y\[k + 1\].
    pub fn step(&mut self, u: [f64; 2]) -> [f64; 2] {
        let d = self.fit.delay;
        for i in 0..2 {
            shift_in(&mut self.y_past[i], self.y[i]);
            shift_in(&mut self.u_past[i], u[i]);
        }
        let a = &self.fit.a[1..];
        for i in 0..2 {
            let mut y = -a
                .iter()
                .zip(&self.y_past[i])
                .map(|(a, y)| a * y)
                .sum::<f64>();
            for j in 0..2 {
                y += self.fit.b[i][j]
                    .iter()
                    .zip(&self.u_past[j][d..])
                    .map(|(b, u)| b * u)
                    .sum::<f64>();
            }
            self.y[i] = y;
        }
        self.y
    }
}

/// Puts `v` first in `past`, dropping the oldest value.
fn shift_in(past: &mut [f64], v: f64) {
    if let Some(last) = past.len().checked_sub(1) {
        past.copy_within(0..last, 1);
        past[0] = v;
    }
}

/// Σ_m c_m z^{−(m + shift)}.
fn poly(c: &[f64], zi: C64, shift: usize) -> C64 {
    let mut s = C64::new(0.0, 0.0);
    let mut p = zi.powi(shift as i32);
    for &v in c {
        s += p * v;
        p *= zi;
    }
    s
}

impl Data {
    fn of(r: &MeasuredResponse, floor: f64) -> Data {
        let t = r.sample_time();
        let top = r
            .lines()
            .iter()
            .flat_map(|l| l.h.iter().flatten())
            .map(|v| v.norm())
            .fold(0.0, f64::max);
        let least = (floor * top).max(f64::MIN_POSITIVE);
        let lines = r.lines();
        Data {
            zi: lines
                .iter()
                .map(|l| C64::from_polar(1.0, -std::f64::consts::TAU * l.f * t))
                .collect(),
            h: lines
                .iter()
                .map(|l| [l.h[0][0], l.h[0][1], l.h[1][0], l.h[1][1]])
                .collect(),
            w: lines
                .iter()
                .map(|l| {
                    [l.std[0][0], l.std[0][1], l.std[1][0], l.std[1][1]].map(|s| 1.0 / s.max(least))
                })
                .collect(),
        }
    }
}

/// Step 1: the denominator 1, a_1..a_n by Levy + Sanathanan–Koerner with the numerators
/// projected out.
fn denominator(data: &Data, n: usize, d: usize, iterations: usize) -> Option<Vec<f64>> {
    let lines = data.zi.len();
    let mut a = vec![1.0];
    a.extend(std::iter::repeat_n(0.0, n));
    for _ in 0..iterations {
        let mut stack_x = DMatrix::zeros(8 * lines, n);
        let mut stack_r = DVector::zeros(8 * lines);
        for e in 0..4 {
            let mut z = DMatrix::zeros(2 * lines, n);
            let mut x = DMatrix::zeros(2 * lines, n);
            let mut r = DVector::zeros(2 * lines);
            for l in 0..lines {
                let zi = data.zi[l];
                let w = data.w[l][e] / poly(&a, zi, 0).norm();
                let h = data.h[l][e];
                let mut p = zi.powi(d as i32 + 1);
                let mut q = zi;
                for m in 0..n {
                    // Σ b z^{−m−1−d} − Ĥ Σ a z^{−m−1} = Ĥ.
                    let (bz, ax) = (p * w, -h * q * w);
                    z[(2 * l, m)] = bz.re;
                    z[(2 * l + 1, m)] = bz.im;
                    x[(2 * l, m)] = ax.re;
                    x[(2 * l + 1, m)] = ax.im;
                    p *= zi;
                    q *= zi;
                }
                r[2 * l] = h.re * w;
                r[2 * l + 1] = h.im * w;
            }
            let q = z.qr().q();
            let px = &x - &q * (q.transpose() * &x);
            let pr = &r - &q * (q.transpose() * &r);
            stack_x.rows_mut(2 * lines * e, 2 * lines).copy_from(&px);
            stack_r.rows_mut(2 * lines * e, 2 * lines).copy_from(&pr);
        }
        let sol = stack_x.svd(true, true).solve(&stack_r, 1e-13).ok()?;
        if sol.iter().any(|v| !v.is_finite()) {
            return None;
        }
        a[1..].copy_from_slice(sol.as_slice());
    }
    Some(a)
}

/// Step 2: the poles of A, those outside the unit circle reflected, and A rebuilt from them.
fn stabilized(a: &[f64]) -> (Vec<f64>, Vec<C64>) {
    let n = a.len() - 1;
    // z^n + a_1 z^{n−1} + … + a_n: companion matrix.
    let mut c = DMatrix::zeros(n, n);
    for m in 0..n {
        c[(0, m)] = -a[m + 1];
        if m + 1 < n {
            c[(m + 1, m)] = 1.0;
        }
    }
    let poles: Vec<C64> = c
        .complex_eigenvalues()
        .iter()
        .map(|&p| if p.norm() > 1.0 { p.conj().inv() } else { p })
        .collect();
    // Π (1 − p z⁻¹): real coefficients up to rounding.
    let mut poly = vec![C64::new(1.0, 0.0)];
    for &p in &poles {
        poly.push(C64::new(0.0, 0.0));
        for m in (1..poly.len()).rev() {
            let prev = poly[m - 1];
            poly[m] -= p * prev;
        }
    }
    (poly.iter().map(|v| v.re).collect(), poles)
}

/// Step 3: the numerators for the fixed denominator `a`, and the fit's χ².
fn numerators(data: &Data, a: Vec<f64>, poles: Vec<C64>, d: usize, t: f64) -> Option<ZFit> {
    let lines = data.zi.len();
    let n = a.len() - 1;
    let mut b: [[Vec<f64>; 2]; 2] = Default::default();
    let mut chi2 = 0.0;
    for e in 0..4 {
        let mut z = DMatrix::zeros(2 * lines, n);
        let mut r = DVector::zeros(2 * lines);
        for l in 0..lines {
            let zi = data.zi[l];
            let w = data.w[l][e];
            let den = poly(&a, zi, 0);
            let mut p = zi.powi(d as i32 + 1) / den;
            for m in 0..n {
                z[(2 * l, m)] = p.re * w;
                z[(2 * l + 1, m)] = p.im * w;
                p *= zi;
            }
            r[2 * l] = data.h[l][e].re * w;
            r[2 * l + 1] = data.h[l][e].im * w;
        }
        let sol = z.clone().svd(true, true).solve(&r, 1e-14).ok()?;
        if sol.iter().any(|v| !v.is_finite()) {
            return None;
        }
        chi2 += (z * &sol - r).norm_squared();
        b[e / 2][e % 2] = sol.as_slice().to_vec();
    }
    Some(ZFit {
        sample_time: t,
        delay: d,
        a,
        b,
        poles,
        chi2,
        dof: (8 * lines).saturating_sub(5 * n),
    })
}

impl LoopPlant for ZFit {
    fn response(&self, f: f64) -> [[C64; 2]; 2] {
        let zi = C64::from_polar(1.0, -std::f64::consts::TAU * f * self.sample_time);
        [
            [self.eval(zi, 0), self.eval(zi, 1)],
            [self.eval(zi, 2), self.eval(zi, 3)],
        ]
    }

    fn static_gain(&self) -> [[f64; 2]; 2] {
        let one = C64::new(1.0, 0.0);
        [
            [self.eval(one, 0).re, self.eval(one, 1).re],
            [self.eval(one, 2).re, self.eval(one, 3).re],
        ]
    }

    /// The complex pole pairs as s = ln(z)/T (the folded frequency of a mode above
    /// Nyquist, as the sampled loop sees it), by frequency.
    fn modes(&self) -> Vec<(f64, f64)> {
        let mut m: Vec<(f64, f64)> = self
            .poles
            .iter()
            .filter(|p| p.im > 0.0)
            .map(|p| {
                let s = p.ln() / self.sample_time;
                (s.norm() / std::f64::consts::TAU, -s.re / s.norm())
            })
            .collect();
        m.sort_by(|a, b| a.0.total_cmp(&b.0));
        m
    }

    fn sample_time(&self) -> f64 {
        self.sample_time
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-made order-2 model with a resonance near 1 kHz at 10 kHz, cross terms and one
    /// sample of delay.
    fn model() -> ZFit {
        let (r, th) = (0.97f64, std::f64::consts::TAU * 0.1);
        let a = vec![1.0, -2.0 * r * th.cos(), r * r];
        let poles = vec![C64::from_polar(r, th), C64::from_polar(r, -th)];
        let b = [
            [vec![0.3, 0.1], vec![0.05, -0.02]],
            [vec![-0.04, 0.01], vec![0.2, 0.15]],
        ];
        ZFit {
            sample_time: 1e-4,
            delay: 1,
            a,
            b,
            poles,
            chi2: 0.0,
            dof: 1,
        }
    }

    /// Reference: by hand, H₁₁ = z⁻² (0.3 + 0.1 z⁻¹)/A with A = 1 + a₁z⁻¹ + a₂z⁻²: the
    /// impulse response is 0, 0, 0.3, 0.1 − 0.3 a₁, −a₁ y[3] − a₂ y[2], …; and a sine's
    /// steady state is `ZFit::response` at its frequency (the z-domain evaluation), within
    /// 1e-9. Goal: the filter is the fitted model in the time domain, delay and cross terms
    /// included.
    #[test]
    fn filter_is_the_fitted_model_in_the_time_domain() {
        let m = model();
        let (a1, a2) = (m.a[1], m.a[2]);
        let mut f = m.filter();
        let mut y = vec![f.output()[0]];
        y.push(f.step([1.0, 0.0])[0]);
        for _ in 0..4 {
            y.push(f.step([0.0, 0.0])[0]);
        }
        let y3 = 0.1 - 0.3 * a1;
        let expect = [0.0, 0.0, 0.3, y3, -a1 * y3 - a2 * 0.3];
        for (k, e) in expect.iter().enumerate() {
            assert!((y[k] - e).abs() < 1e-15, "y[{k}] = {} ≠ {e}", y[k]);
        }
        for (freq, input) in [(120.0, 0), (990.0, 1), (3300.0, 0)] {
            let mut f = m.filter();
            let w = std::f64::consts::TAU * freq * m.sample_time;
            let (settle, n) = (4000, 20000);
            let mut acc = [C64::new(0.0, 0.0); 2];
            let mut u_acc = C64::new(0.0, 0.0);
            for k in 0..settle + n {
                let u = (w * k as f64).sin();
                let y = f.output();
                if k >= settle {
                    let e = C64::from_polar(1.0, -w * k as f64);
                    acc[0] += y[0] * e;
                    acc[1] += y[1] * e;
                    u_acc += u * e;
                }
                let mut cmd = [0.0; 2];
                cmd[input] = u;
                f.step(cmd);
            }
            let h = m.response(freq);
            for out in 0..2 {
                let got = acc[out] / u_acc;
                let want = h[out][input];
                assert!(
                    (got - want).norm() < 1e-9 * want.norm().max(1.0),
                    "{freq} Hz, H{out}{input}: {got} vs {want}"
                );
            }
        }
    }
}
