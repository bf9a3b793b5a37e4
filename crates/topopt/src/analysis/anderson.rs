//! Anderson acceleration (type II, Walker & Ni, "Anderson acceleration for fixed-point
//! iterations", SINUM 49 (2011) 1715–1735) of the lock-step equilibrium sweeps.

/// Depth of the Anderson acceleration of the lock-step sweeps.
const ANDERSON_DEPTH: usize = 5;

/// Anderson acceleration (type II, Walker & Ni 2011) of the fixed-point map
/// `g(x) = x + K⁻¹(P − R(x))` on the free DOFs: for a linear problem it is equivalent to GMRES,
/// so the few eigenvalues of `K⁻¹K_T` far from 1 (soft members under compression, additive
/// material) do not stall the sweeps as plain Richardson would.
pub(crate) struct Anderson {
    df: Vec<f64>,
    dg: Vec<f64>,
    f: Vec<f64>,
    g: Vec<f64>,
    pub(crate) x: Vec<f64>,
    len: usize,
    head: usize,
    started: bool,
}

impl Anderson {
    pub(crate) fn new(nf: usize) -> Self {
        Self {
            df: vec![0.0; ANDERSON_DEPTH * nf],
            dg: vec![0.0; ANDERSON_DEPTH * nf],
            f: vec![0.0; nf],
            g: vec![0.0; nf],
            x: vec![0.0; nf],
            len: 0,
            head: 0,
            started: false,
        }
    }

    pub(crate) fn reset(&mut self) {
        self.len = 0;
        self.head = 0;
        self.started = false;
    }

    /// Given the current iterate `x` (free DOFs, in `self.x`) and the preconditioned residual
    /// `f = K⁻¹(P − R(x))`, overwrite `self.x` with the next iterate.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn step(&mut self, f: &[f64]) {
        let nf = f.len();
        let m = ANDERSON_DEPTH;
        if self.started {
            let h = self.head;
            for i in 0..nf {
                let g = self.x[i] + f[i];
                self.df[h * nf + i] = f[i] - self.f[i];
                self.dg[h * nf + i] = g - self.g[i];
            }
            self.head = (h + 1) % m;
            self.len = (self.len + 1).min(m);
        }
        self.started = true;
        for i in 0..nf {
            self.f[i] = f[i];
            self.g[i] = self.x[i] + f[i];
        }
        let k = self.len;
        self.x.copy_from_slice(&self.g);
        if k == 0 {
            return;
        }
        // Least squares min ‖f − ΔF γ‖ by the (regularized) normal equations.
        let mut a = [[0.0f64; ANDERSON_DEPTH]; ANDERSON_DEPTH];
        let mut b = [0.0f64; ANDERSON_DEPTH];
        for p in 0..k {
            let dp = &self.df[p * nf..(p + 1) * nf];
            b[p] = dp.iter().zip(f).map(|(x, y)| x * y).sum();
            for q in p..k {
                let dq = &self.df[q * nf..(q + 1) * nf];
                let v: f64 = dp.iter().zip(dq).map(|(x, y)| x * y).sum();
                a[p][q] = v;
                a[q][p] = v;
            }
        }
        let tr: f64 = (0..k).map(|p| a[p][p]).sum();
        if !(tr > 0.0 && tr.is_finite()) {
            return;
        }
        for p in 0..k {
            a[p][p] += 1e-12 * tr;
        }
        // Gaussian elimination with partial pivoting.
        let mut gamma = b;
        for c in 0..k {
            let piv = (c..k)
                .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
                .unwrap_or(c);
            a.swap(c, piv);
            gamma.swap(c, piv);
            if a[c][c] == 0.0 {
                return;
            }
            for r in c + 1..k {
                let l = a[r][c] / a[c][c];
                for cc in c..k {
                    a[r][cc] -= l * a[c][cc];
                }
                gamma[r] -= l * gamma[c];
            }
        }
        for c in (0..k).rev() {
            let mut v = gamma[c];
            for cc in c + 1..k {
                v -= a[c][cc] * gamma[cc];
            }
            gamma[c] = v / a[c][c];
        }
        if gamma[..k].iter().any(|g| !g.is_finite()) {
            return;
        }
        for p in 0..k {
            let dg = &self.dg[p * nf..(p + 1) * nf];
            for (x, d) in self.x.iter_mut().zip(dg) {
                *x -= gamma[p] * d;
            }
        }
    }
}
