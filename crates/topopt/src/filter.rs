//! Density filter and smoothed Heaviside projection (DECISIONS.md "Filtering"; Bourdin 2001,
//! Wang, Lazarov & Sigmund 2011), with their adjoints for the chain rule.
//!
//! `ρ̃_e = Σ_j w_ej x_j / Σ_j w_ej`, `w_ej = max(0, r − dist(e, j))` (top88's conic weights,
//! radius `r` in element sizes), then `ρ̄ = (tanh βη + tanh β(ρ̃ − η)) / (tanh βη + tanh β(1 − η))`.

use flexstage_fem::Mesh;

/// The conic density filter on a structured mesh (element `e = i·n_w + j`).
#[derive(Debug, Clone)]
pub struct DensityFilter {
    /// Row pointers (CSR) into `cols`/`weights`.
    ptr: Vec<usize>,
    cols: Vec<u32>,
    weights: Vec<f64>,
    /// `Σ_j w_ej`.
    sums: Vec<f64>,
}

impl DensityFilter {
    /// Filter of radius `radius` element sizes (≤ 1 means no neighbours: the identity).
    pub fn new(mesh: &Mesh, radius: f64) -> Self {
        let (nl, nw) = (mesh.nl, mesh.nw);
        let h = (mesh.dx() * mesh.dy()).sqrt();
        let (sx, sy) = (mesh.dx() / h, mesh.dy() / h);
        let r = radius.max(1.0);
        let reach_i = (r / sx).ceil() as isize;
        let reach_j = (r / sy).ceil() as isize;
        let ne = nl * nw;
        let mut ptr = Vec::with_capacity(ne + 1);
        ptr.push(0);
        let (mut cols, mut weights, mut sums) = (Vec::new(), Vec::new(), Vec::with_capacity(ne));
        for i in 0..nl as isize {
            for j in 0..nw as isize {
                let mut s = 0.0;
                for k in (i - reach_i).max(0)..=(i + reach_i).min(nl as isize - 1) {
                    for l in (j - reach_j).max(0)..=(j + reach_j).min(nw as isize - 1) {
                        let d =
                            (((k - i) as f64 * sx).powi(2) + ((l - j) as f64 * sy).powi(2)).sqrt();
                        let w = if radius <= 1.0 {
                            if k == i && l == j { 1.0 } else { 0.0 }
                        } else {
                            (radius - d).max(0.0)
                        };
                        if w > 0.0 {
                            cols.push((k as usize * nw + l as usize) as u32);
                            weights.push(w);
                            s += w;
                        }
                    }
                }
                sums.push(s);
                ptr.push(cols.len());
            }
        }
        Self {
            ptr,
            cols,
            weights,
            sums,
        }
    }

    /// `out = H x / Hs`.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        for (e, o) in out.iter_mut().enumerate() {
            let (a, b) = (self.ptr[e], self.ptr[e + 1]);
            let s: f64 = (a..b)
                .map(|k| self.weights[k] * x[self.cols[k] as usize])
                .sum();
            *o = s / self.sums[e];
        }
    }

    /// Adjoint: `out = Hᵀ (g / Hs)` (the weights are symmetric).
    pub fn apply_adjoint(&self, g: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        #[allow(clippy::needless_range_loop)]
        for e in 0..self.sums.len() {
            let ge = g[e] / self.sums[e];
            for k in self.ptr[e]..self.ptr[e + 1] {
                out[self.cols[k] as usize] += self.weights[k] * ge;
            }
        }
    }
}

/// Smoothed Heaviside projection with sharpness β and threshold η.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Sharpness β ≥ 0 (0 = identity).
    pub beta: f64,
    /// Threshold η ∈ (0, 1).
    pub eta: f64,
}

impl Projection {
    /// The identity.
    pub fn off() -> Self {
        Self {
            beta: 0.0,
            eta: 0.5,
        }
    }
    /// `ρ̄(ρ̃)`.
    pub fn value(&self, x: f64) -> f64 {
        if self.beta == 0.0 {
            return x;
        }
        let (b, n) = (self.beta, self.eta);
        let den = (b * n).tanh() + (b * (1.0 - n)).tanh();
        ((b * n).tanh() + (b * (x - n)).tanh()) / den
    }
    /// `dρ̄/dρ̃`.
    pub fn derivative(&self, x: f64) -> f64 {
        if self.beta == 0.0 {
            return 1.0;
        }
        let (b, n) = (self.beta, self.eta);
        let den = (b * n).tanh() + (b * (1.0 - n)).tanh();
        let t = (b * (x - n)).tanh();
        b * (1.0 - t * t) / den
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_preserves_constants_and_adjoint_is_transpose() {
        let mesh = Mesh::new(6.0, 4.0, 1.0, 6, 4).unwrap();
        let f = DensityFilter::new(&mesh, 2.3);
        let mut out = vec![0.0; 24];
        f.apply(&[0.7; 24], &mut out);
        assert!(out.iter().all(|v| (v - 0.7).abs() < 1e-14));
        let x: Vec<f64> = (0..24).map(|k| (k as f64 * 0.37).sin()).collect();
        let y: Vec<f64> = (0..24).map(|k| (k as f64 * 0.91).cos()).collect();
        let (mut hx, mut hty) = (vec![0.0; 24], vec![0.0; 24]);
        f.apply(&x, &mut hx);
        f.apply_adjoint(&y, &mut hty);
        let a: f64 = hx.iter().zip(&y).map(|(p, q)| p * q).sum();
        let b: f64 = x.iter().zip(&hty).map(|(p, q)| p * q).sum();
        assert!((a - b).abs() < 1e-12);
        let p = Projection {
            beta: 8.0,
            eta: 0.5,
        };
        assert!(p.value(0.0).abs() < 1e-15 && (p.value(1.0) - 1.0).abs() < 1e-15);
        let h = 1e-6;
        let fd = (p.value(0.4 + h) - p.value(0.4 - h)) / (2.0 * h);
        assert!((fd - p.derivative(0.4)).abs() < 1e-7);
    }
}
