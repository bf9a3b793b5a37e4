//! Lowest natural frequencies of the body-fitted model, `K φ = ω² M φ`, by shift-invert
//! Lanczos (σ = 0) in the `M` inner product with full reorthogonalization; the small
//! tridiagonal problem is solved by `flexstage_numerics::dense::symmetric_eigen`. This is the algorithm of
//! `flexstage-reduce`'s modal analysis, whose API is tied to the Q4 design model.

use flexstage_numerics::dense::symmetric_eigen;

use crate::error::{Result, VerifyError};
use crate::fe::{Cholesky, SymCsc};

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Natural frequencies \[Hz\] (lowest first) and the relative residual `‖Kφ − ω²Mφ‖/‖Kφ‖` of
/// each mode.
#[derive(Debug, Clone, PartialEq)]
pub struct Frequencies {
    /// `f = ω / 2π` \[Hz\].
    pub hz: Vec<f64>,
    /// Residuals.
    pub residuals: Vec<f64>,
}

/// The `modes` lowest frequencies of `(K, M)` with `K = factor` (positive definite).
pub fn lowest_frequencies(
    k: &SymCsc,
    factor: &Cholesky,
    m: &SymCsc,
    modes: usize,
) -> Result<Frequencies> {
    let n = k.n();
    let nev = modes.min(n);
    let max_steps = (20 * nev + 40).min(n);
    let tol = 1e-10;
    // Start vector in range(K⁻¹M): deterministic pseudo-random.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut w: Vec<f64> = (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let mut mw = vec![0.0; n];
    m.matvec(&w, &mut mw);
    w.copy_from_slice(&mw);
    factor.solve_in_place(&mut w, 1);
    m.matvec(&w, &mut mw);
    let b0 = dot(&w, &mw).sqrt();
    if b0.is_nan() || b0 <= 0.0 {
        return Err(VerifyError::Solver("the mass matrix is zero".into()));
    }
    let mut q: Vec<Vec<f64>> = vec![w.iter().map(|x| x / b0).collect()];
    let mut mq: Vec<Vec<f64>> = vec![mw.iter().map(|x| x / b0).collect()];
    let (mut alphas, mut betas) = (Vec::new(), Vec::new());
    let mut done: Option<(Vec<f64>, Vec<f64>, usize)> = None;
    let mut converged = 0;
    for j in 0..max_steps {
        w.copy_from_slice(&mq[j]);
        factor.solve_in_place(&mut w, 1);
        let a = dot(&mq[j], &w);
        alphas.push(a);
        for _ in 0..2 {
            for (qi, mqi) in q.iter().zip(&mq) {
                let c = dot(mqi, &w);
                w.iter_mut().zip(qi).for_each(|(wk, qk)| *wk -= c * qk);
            }
        }
        m.matvec(&w, &mut mw);
        let b = dot(&w, &mw).max(0.0).sqrt();
        let steps = j + 1;
        if steps >= nev && (steps % 5 == 0 || steps == max_steps || b <= 1e-14 * a.abs()) {
            let mut t = vec![0.0; steps * steps];
            for i in 0..steps {
                t[i * steps + i] = alphas[i];
                if i + 1 < steps {
                    t[i * steps + i + 1] = betas[i];
                    t[(i + 1) * steps + i] = betas[i];
                }
            }
            let (theta, s) = symmetric_eigen(&t, steps);
            let mut order: Vec<usize> = (0..steps).collect();
            order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
            converged = order[..nev]
                .iter()
                .filter(|&&i| (b * s[(steps - 1) * steps + i]).abs() <= tol * theta[i].abs())
                .count();
            if converged == nev || b <= 1e-14 * a.abs() || steps == max_steps {
                done = Some((theta, s, steps));
                break;
            }
        }
        betas.push(b);
        q.push(w.iter().map(|x| x / b).collect());
        mq.push(mw.iter().map(|x| x / b).collect());
    }
    let Some((theta, s, steps)) = done.filter(|_| converged == nev) else {
        return Err(VerifyError::Eigen {
            wanted: nev,
            converged,
            steps: alphas.len(),
        });
    };
    let mut order: Vec<usize> = (0..steps).collect();
    order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
    let mut out = Frequencies {
        hz: Vec::new(),
        residuals: Vec::new(),
    };
    let mut kphi = vec![0.0; n];
    for &i in &order[..nev] {
        let mut phi = vec![0.0; n];
        for (jj, qj) in q.iter().take(steps).enumerate() {
            let c = s[jj * steps + i];
            phi.iter_mut().zip(qj).for_each(|(p, v)| *p += c * v);
        }
        let om2 = 1.0 / theta[i];
        k.matvec(&phi, &mut kphi);
        m.matvec(&phi, &mut mw);
        let res = kphi
            .iter()
            .zip(&mw)
            .map(|(a, b)| (a - om2 * b).powi(2))
            .sum::<f64>()
            .sqrt()
            / dot(&kphi, &kphi).sqrt();
        out.hz.push(om2.sqrt() / (2.0 * std::f64::consts::PI));
        out.residuals.push(res);
    }
    Ok(out)
}
