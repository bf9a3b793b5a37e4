//! Test problems shared by the integration tests.

use flexstage_mma::{Mma, MmaParams, UpdateReport};

/// Five updates of a compliance-like problem with three linear constraints (as in the
/// benchmark); returns the iterates, multipliers and reports.
pub fn synthetic(n: usize, params: MmaParams) -> (Vec<f64>, Vec<f64>, Vec<UpdateReport>) {
    let m = 3;
    let mut mma = Mma::new(n, m, vec![1e-3; n], vec![1.0; n], params).unwrap();
    let w: Vec<f64> = (0..n).map(|j| 1.0 + (j % 17) as f64 / 17.0).collect();
    let mut x = vec![0.5; n];
    let (mut g, mut f, mut dfdx) = (vec![0.0; n], vec![0.0; m], vec![0.0; m * n]);
    let mut reports = Vec::new();
    for _ in 0..5 {
        let mut f0 = 0.0;
        for j in 0..n {
            f0 += w[j] / x[j] / n as f64;
            g[j] = -w[j] / (x[j] * x[j]) / n as f64;
        }
        for i in 0..m {
            let mut s = 0.0;
            for j in 0..n {
                let a = 1.0 + ((i + j) % 5) as f64 / 5.0;
                s += a * x[j];
                dfdx[i * n + j] = a / n as f64;
            }
            f[i] = s / n as f64 - 0.4 - 0.1 * i as f64;
        }
        reports.push(mma.update(&mut x, f0, &g, &f, &dfdx).unwrap());
    }
    (x, mma.lambda().to_vec(), reports)
}
