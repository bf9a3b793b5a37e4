//! The lumped parameters that best represent a frequency response, and the modes that set
//! the excitation band.
//!
//! # Why
//! The time-domain estimator ([`crate::identify`]) fits the lumped 8-state model (Eq. 31, 34;
//! A13–A14) to a noisy record. When the stage is the lumped model itself, its parameters are
//! the answer. When it is a richer structure (the digital twin: the design's FE model with
//! higher modes, Rayleigh damping, the plates inside the structure), no lumped parameter set
//! is "the" truth; the honest reference is the lumped set that best reproduces the structure's
//! exact, noise-free frequency response in the identification band. [`fit`] computes it by
//! linear least squares on the same four equations the estimator uses, in the frequency
//! domain, with no noise, discretization, prefilter or rig in the way.
//!
//! # The equations (per frequency ω and per PEA input j, x_nom = e_j, complex amplitudes)
//! ```text
//! q_o1 row:   −ω²M q1 = 2(K_qo1 + jωC_qo1)·e1 − k_c q2,     e1 = (x_in1 + x_in2)/2 − q1
//! q_o2 row:   −ω²M q2 =  (K_qo2 + jωC_qo2)·e2 − k_c q1,     e2 = α(x_in1 − x_in2) − q2
//! plate i:    −ω²m_in,i x_i = K_pea,i(δ_ij − x_i) − K_in,i x_i − jωC_in,i x_i
//!                            + (K_qo1 + jωC_qo1)(q1 − x_i)
//! ```
//! M, m_in and α are the known (weighed / Eq. 27) values, as in the estimator. The output
//! rows are solved together (k_c shared), then the plate rows with K_qo1 and C_qo1 fixed (the
//! constrained fit of [`crate::regression::physical`]). Each complex equation is weighted by
//! 1/|left-hand side| (equal relative weight per frequency on a logarithmic grid). The relative
//! residual of each row ([`LumpedFit::residual`]) says how well the lumped model can represent
//! the response at all: 0 for the lumped model itself.

use flexstage_scenario::StageParams;
use flexstage_sim::model::StageModel;
use nalgebra::{Complex, DMatrix, DVector, SMatrix};

use crate::error::{IdentifyError, Result};

/// A complex amplitude.
pub type C64 = Complex<f64>;

/// The response of a stage at one frequency to unit x_nom of each PEA.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Response {
    /// Frequency \[Hz\], > 0.
    pub f: f64,
    /// `x_in[j][i]`: input plate i for x_nom = e_j \[m/m\].
    pub x_in: [[C64; 2]; 2],
    /// `q[j][i]`: output q_i for x_nom = e_j \[m/m\].
    pub q: [[C64; 2]; 2],
}

/// The exact frequency response of the lumped model `model` (Eq. 36 with the cross terms of
/// Eq. 30): (jωI − B) z = b x_nom, solved for x_nom = e₁, e₂.
pub fn lumped_response(model: &StageModel, f: f64) -> Result<Response> {
    let w = std::f64::consts::TAU * f;
    let b = model.b.map(|v| C64::new(v, 0.0));
    let a = SMatrix::<C64, 8, 8>::identity() * C64::new(0.0, w) - b;
    let bu = model.input_matrix().map(|v| C64::new(v, 0.0));
    let z = a.lu().solve(&bu).ok_or_else(|| IdentifyError::Estimate {
        what: "lumped frequency response".into(),
        reason: format!("jωI − B is singular at {f} Hz"),
    })?;
    let pick = |row: usize| {
        [
            [z[(row, 0)], z[(row + 1, 0)]],
            [z[(row, 1)], z[(row + 1, 1)]],
        ]
    };
    Ok(Response {
        f,
        q: pick(0),
        x_in: pick(2),
    })
}

/// The natural frequencies \[Hz\] of the lumped model (|λ|/2π of the eigenvalues of B, one per
/// complex pair, lowest first): two output modes (q_o1, q_o2) and two input-plate modes.
pub fn natural_frequencies(model: &StageModel) -> Vec<f64> {
    let mut f: Vec<f64> = model
        .b
        .complex_eigenvalues()
        .iter()
        .filter(|l| l.im >= 0.0)
        .map(|l| l.norm() / std::f64::consts::TAU)
        .collect();
    f.sort_by(f64::total_cmp);
    f
}

/// `n` frequencies from `f_lo` to `f_hi` \[Hz\], logarithmically spaced.
pub fn log_grid(f_lo: f64, f_hi: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    (0..n)
        .map(|k| f_lo * (f_hi / f_lo).powf(k as f64 / (n - 1) as f64))
        .collect()
}

/// The lumped parameter set that best represents a frequency response ([`fit`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LumpedFit {
    /// Stiffnesses and dampings fitted; masses and α those of the known set.
    pub params: StageParams,
    /// Cross-axis coupling k_c \[N/m\].
    pub coupling: f64,
    /// Static gains [β, α'] of the output rows ([`fit`]; [1, α] without `static_gains`).
    pub gains: [f64; 2],
    /// Relative weighted residual ‖Aθ − y‖/‖y‖ of the q_o1, q_o2, x_in1, x_in2 rows.
    pub residual: [f64; 4],
}

/// Weighted real least squares of complex equations `φ·θ = y` (module docs).
struct Equations {
    rows: Vec<f64>,
    rhs: Vec<f64>,
    cols: usize,
}

impl Equations {
    fn new(cols: usize) -> Equations {
        Equations {
            rows: Vec::new(),
            rhs: Vec::new(),
            cols,
        }
    }

    fn push(&mut self, phi: &[C64], y: C64) {
        let w = 1.0 / y.norm().max(f64::MIN_POSITIVE);
        self.rows.extend(phi.iter().map(|p| p.re * w));
        self.rhs.push(y.re * w);
        self.rows.extend(phi.iter().map(|p| p.im * w));
        self.rhs.push(y.im * w);
    }

    /// θ and the relative residual; columns are scaled to unit norm for the SVD.
    fn solve(&self, what: &str) -> Result<(Vec<f64>, f64)> {
        let n = self.rhs.len();
        let a = DMatrix::from_row_slice(n, self.cols, &self.rows);
        let y = DVector::from_column_slice(&self.rhs);
        let scale: Vec<f64> = (0..self.cols)
            .map(|c| a.column(c).norm().max(f64::MIN_POSITIVE))
            .collect();
        let mut s = a.clone();
        for (c, sc) in scale.iter().enumerate() {
            s.column_mut(c).scale_mut(1.0 / sc);
        }
        let x = s
            .svd(true, true)
            .solve(&y, 1e-12)
            .map_err(|e| IdentifyError::Estimate {
                what: what.into(),
                reason: e.to_string(),
            })?;
        let theta: Vec<f64> = x.iter().zip(&scale).map(|(v, sc)| v / sc).collect();
        let r = &a * DVector::from_column_slice(&theta) - &y;
        Ok((theta, r.norm() / y.norm().max(f64::MIN_POSITIVE)))
    }
}

/// The lumped parameters that best represent `points` (module docs), with the masses and α
/// of `known`; with `static_gains`, the output rows also fit their static gains (β, α'), as
/// the estimator does with [`crate::IdentifyParams::static_gains`], and α' replaces α. Needs
/// at least two frequencies.
pub fn fit(points: &[Response], known: &StageParams, static_gains: bool) -> Result<LumpedFit> {
    if points.len() < 2 {
        return Err(IdentifyError::Estimate {
            what: "frequency fit".into(),
            reason: format!("{} frequencies given; at least 2 are needed", points.len()),
        });
    }
    let j = C64::new(0.0, 1.0);
    let (m, alpha) = (known.mass, known.alpha);
    let mut out = Equations::new(if static_gains { 7 } else { 5 });
    for p in points {
        let w = std::f64::consts::TAU * p.f;
        for (x, q) in p.x_in.iter().zip(&p.q) {
            let e1 = 0.5 * (x[0] + x[1]) - q[0];
            let e2 = alpha * (x[0] - x[1]) - q[1];
            let z = C64::new(0.0, 0.0);
            let (s1, s2) = (0.5 * (x[0] + x[1]), x[0] - x[1]);
            let r1 = [2.0 * e1, 2.0 * j * w * e1, z, z, -q[1], s1, z];
            let r2 = [z, z, e2, j * w * e2, -q[0], z, s2];
            let n = out.cols;
            out.push(&r1[..n], -w * w * m * q[0]);
            out.push(&r2[..n], -w * w * m * q[1]);
        }
    }
    let (th, r_out) = out.solve("frequency fit of the output rows")?;
    let (k_qo1, c_qo1, k_qo2, c_qo2, k_c) = (th[0], th[1], th[2], th[3], th[4]);
    let gains = if static_gains {
        [1.0 + th[5] / (2.0 * k_qo1), alpha + th[6] / k_qo2]
    } else {
        [1.0, alpha]
    };
    let plate = |i: usize, m_in: f64| -> Result<([f64; 3], f64)> {
        let mut eq = Equations::new(3);
        for p in points {
            let w = std::f64::consts::TAU * p.f;
            for (jn, (x, q)) in p.x_in.iter().zip(&p.q).enumerate() {
                let u = if jn == i { 1.0 } else { 0.0 };
                let xi = x[i];
                let known_force = (k_qo1 + j * w * c_qo1) * (q[0] - xi);
                eq.push(
                    &[u - xi, -xi, -j * w * xi],
                    -w * w * m_in * xi - known_force,
                );
            }
        }
        let (t, r) = eq.solve("frequency fit of the plate rows")?;
        Ok(([t[0], t[1], t[2]], r))
    };
    let (p1, r1) = plate(0, known.m_in1)?;
    let (p2, r2) = plate(1, known.m_in2)?;
    Ok(LumpedFit {
        params: StageParams {
            k_qo1,
            k_qo2,
            c_qo1,
            c_qo2,
            k_pea1: p1[0],
            k_in1: p1[1],
            c_in1: p1[2],
            k_pea2: p2[0],
            k_in2: p2[1],
            c_in2: p2[2],
            alpha: gains[1],
            ..known.clone()
        },
        coupling: k_c,
        gains,
        residual: [r_out, r_out, r1, r2],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frequency_fit_recovers_the_lumped_model_with_coupling() {
        // Reference: the lumped model's own exact frequency response (Eq. 36 with the cross
        // terms of Eq. 30), Table 4 truth and k_c = 5 % of √(2K_qo1K_qo2).
        // Goal: the fit returns every stiffness, damping and k_c to 1e-8 relative, from a
        // guess that knows only the masses and α, with a residual at round-off; with the
        // static gains free it finds β = 1 and α of the model.
        let truth = crate::samples::table4_truth();
        let k_c = 0.05 * (2.0 * truth.k_qo1 * truth.k_qo2).sqrt();
        let model = StageModel::with_coupling(&truth, k_c).unwrap();
        let pts: Vec<Response> = log_grid(5.0, 4000.0, 60)
            .into_iter()
            .map(|f| lumped_response(&model, f).unwrap())
            .collect();
        let guess = crate::samples::table4_guess();
        let with_gains = fit(&pts, &guess, true).unwrap();
        let rel = |a: f64, b: f64| ((a - b) / b).abs();
        assert!(
            rel(with_gains.gains[0], 1.0) < 1e-8 && rel(with_gains.gains[1], truth.alpha) < 1e-8,
            "static gains of the lumped model: {:?}",
            with_gains.gains
        );
        let fit = fit(&pts, &guess, false).unwrap();
        let (e, t) = (&fit.params, &truth);
        for (name, a, b) in [
            ("k_qo1", e.k_qo1, t.k_qo1),
            ("k_qo2", e.k_qo2, t.k_qo2),
            ("k_pea1", e.k_pea1, t.k_pea1),
            ("k_pea2", e.k_pea2, t.k_pea2),
            ("k_in1", e.k_in1, t.k_in1),
            ("k_in2", e.k_in2, t.k_in2),
            ("c_qo1", e.c_qo1, t.c_qo1),
            ("c_qo2", e.c_qo2, t.c_qo2),
            ("c_in1", e.c_in1, t.c_in1),
            ("c_in2", e.c_in2, t.c_in2),
            ("k_c", fit.coupling, k_c),
        ] {
            assert!(rel(a, b) < 1e-8, "{name}: {a:e} vs {b:e}");
        }
        assert!(fit.residual.iter().all(|r| *r < 1e-9), "{:?}", fit.residual);
    }

    #[test]
    fn natural_frequencies_match_the_single_mode_closed_form() {
        // Reference: with the plates clamped by a very stiff PEA (K_pea × 1000 pins x_in to
        // x_nom within ≈ 1e-5), the q_o2 row is a single mode ω² = K_qo2/M and the q_o1 row
        // ω² = 2K_qo1/M. Goal: natural_frequencies finds both within 1e-4.
        let mut p = crate::samples::table4_truth();
        p.k_pea1 *= 1e3;
        p.k_pea2 *= 1e3;
        let f = natural_frequencies(&StageModel::new(&p).unwrap());
        let tau = std::f64::consts::TAU;
        let f1 = (2.0 * p.k_qo1 / p.mass).sqrt() / tau;
        let f2 = (p.k_qo2 / p.mass).sqrt() / tau;
        for want in [f1, f2] {
            let got = f
                .iter()
                .map(|g| (g - want).abs() / want)
                .fold(f64::MAX, f64::min);
            assert!(got < 1e-4, "{want} Hz not in {f:?}");
        }
    }
}
