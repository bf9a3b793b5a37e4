//! The modal solver (`flexstage_fem::eigen`) against analytical eigenvalues: a fixed–free
//! spring–mass chain (closed form), the same chain with massless nodes (a singular `M`), and
//! a cantilever Euler–Bernoulli beam of Hermite elements (the roots of `1 + cos βL cosh βL = 0`).

use flexstage_fem::{EigenError, EigenOperators, Lanczos, LanczosParams, SolverError};

/// Dense symmetric `K` (with its Cholesky factor) and `M`, row-major.
struct Dense {
    n: usize,
    k: Vec<f64>,
    l: Vec<f64>,
    m: Vec<f64>,
}

impl Dense {
    fn new(n: usize, k: Vec<f64>, m: Vec<f64>) -> Self {
        let mut l = vec![0.0; n * n];
        for j in 0..n {
            let mut d = k[j * n + j];
            for p in 0..j {
                d -= l[j * n + p] * l[j * n + p];
            }
            assert!(d > 0.0, "K must be positive definite");
            l[j * n + j] = d.sqrt();
            for i in j + 1..n {
                let mut s = k[i * n + j];
                for p in 0..j {
                    s -= l[i * n + p] * l[j * n + p];
                }
                l[i * n + j] = s / l[j * n + j];
            }
        }
        Self { n, k, l, m }
    }

    fn matvec(a: &[f64], n: usize, x: &[f64], y: &mut [f64]) {
        for i in 0..n {
            y[i] = (0..n).map(|j| a[i * n + j] * x[j]).sum();
        }
    }
}

impl EigenOperators for Dense {
    fn n(&self) -> usize {
        self.n
    }
    fn solve(&mut self, x: &mut [f64]) -> Result<(), SolverError> {
        let (n, l) = (self.n, &self.l);
        for i in 0..n {
            let s: f64 = (0..i).map(|p| l[i * n + p] * x[p]).sum();
            x[i] = (x[i] - s) / l[i * n + i];
        }
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|p| l[p * n + i] * x[p]).sum();
            x[i] = (x[i] - s) / l[i * n + i];
        }
        Ok(())
    }
    fn mass(&self, x: &[f64], y: &mut [f64]) {
        Self::matvec(&self.m, self.n, x, y);
    }
    fn stiffness(&self, x: &[f64], y: &mut [f64]) {
        Self::matvec(&self.k, self.n, x, y);
    }
}

/// A chain of `n` springs `k` and masses `m`, fixed at one end: node i (0-based) is joined to
/// node i−1 (the ground for i = 0) and to node i+1.
fn chain(n: usize, k: f64, masses: &[f64]) -> Dense {
    let mut kk = vec![0.0; n * n];
    for i in 0..n {
        kk[i * n + i] = if i + 1 < n { 2.0 * k } else { k };
        if i + 1 < n {
            kk[i * n + i + 1] = -k;
            kk[(i + 1) * n + i] = -k;
        }
    }
    let mut mm = vec![0.0; n * n];
    for (i, &mi) in masses.iter().enumerate() {
        mm[i * n + i] = mi;
    }
    Dense::new(n, kk, mm)
}

/// Reference: a fixed–free chain of n equal springs k and masses m has
/// `λ_j = (4k/m) sin²((2j − 1)π / (2(2n + 1)))`, j = 1..n (e.g. Meirovitch, *Fundamentals of
/// Vibrations*, 2001, §8.4). Goal: the six lowest within 1e-12 relative, M-orthonormal modes.
#[test]
fn spring_mass_chain_matches_the_closed_form() {
    let (n, k, m) = (60, 3.0e5, 0.02);
    let mut op = chain(n, k, &vec![m; n]);
    let pairs = Lanczos::new()
        .solve(&mut op, &LanczosParams::default())
        .unwrap();
    assert_eq!(pairs.values.len(), 6);
    for (j, &l) in pairs.values.iter().enumerate() {
        let s = ((2 * j + 1) as f64 * std::f64::consts::PI / (2.0 * (2 * n + 1) as f64)).sin();
        let exact = 4.0 * k / m * s * s;
        assert!(
            (l - exact).abs() <= 1e-12 * exact,
            "λ{} = {l} vs {exact}",
            j + 1
        );
        assert!(pairs.residuals[j] < 1e-9, "residual {}", pairs.residuals[j]);
    }
    let mut mphi = vec![0.0; n];
    for (a, pa) in pairs.vectors.iter().enumerate() {
        op.mass(pa, &mut mphi);
        for (b, pb) in pairs.vectors.iter().enumerate() {
            let g: f64 = pb.iter().zip(&mphi).map(|(x, y)| x * y).sum();
            let want = if a == b { 1.0 } else { 0.0 };
            assert!((g - want).abs() < 1e-10, "φ{a}ᵀMφ{b} = {g}");
        }
    }
}

/// Reference: the same chain with every other mass zero is the chain of n/2 springs k/2 and
/// masses m (two springs in series through a massless node): the closed form above with k/2.
/// Goal: the singular `M` brings no spurious (infinite or zero) eigenvalue, within 1e-11.
#[test]
fn massless_nodes_give_the_condensed_chain() {
    let (n, k, m) = (40, 2.0e5, 0.05);
    let masses: Vec<f64> = (0..n).map(|i| if i % 2 == 1 { m } else { 0.0 }).collect();
    let mut op = chain(n, k, &masses);
    let params = LanczosParams {
        modes: 4,
        ..LanczosParams::default()
    };
    let pairs = Lanczos::new().solve(&mut op, &params).unwrap();
    let nc = n / 2;
    for (j, &l) in pairs.values.iter().enumerate() {
        let s = ((2 * j + 1) as f64 * std::f64::consts::PI / (2.0 * (2 * nc + 1) as f64)).sin();
        let exact = 4.0 * (0.5 * k) / m * s * s;
        assert!(
            (l - exact).abs() <= 1e-11 * exact,
            "λ{} = {l} vs {exact}",
            j + 1
        );
    }
}

/// Reference: a cantilever Euler–Bernoulli beam has `ω_j = (β_jL)² √(EI/(ρA L⁴))` with
/// `β_jL` = 1.875104069, 4.694091133, 7.854757438, 10.99554073 (roots of
/// `1 + cos βL cosh βL = 0`; Blevins, *Formulas for Natural Frequency and Mode Shape*, 1979,
/// Table 8-1). The beam is 80 cubic Hermite elements with consistent mass (Przemieniecki 1968),
/// whose eigenvalues converge as h⁴. Goal: the four lowest within 1e-6 relative.
#[test]
fn cantilever_beam_matches_euler_bernoulli() {
    let (ne, len, ei, rho_a) = (80, 0.12, 73e9 * 1e-2 * 1e-6 / 12.0, 2710.0 * 1e-2 * 1e-3);
    let h = len / ne as f64;
    let n = 2 * ne; // (w, θ) per node, the clamped node removed
    let ke = |i: usize, j: usize| {
        let c = ei / (h * h * h);
        let k = [
            [12.0, 6.0 * h, -12.0, 6.0 * h],
            [6.0 * h, 4.0 * h * h, -6.0 * h, 2.0 * h * h],
            [-12.0, -6.0 * h, 12.0, -6.0 * h],
            [6.0 * h, 2.0 * h * h, -6.0 * h, 4.0 * h * h],
        ];
        c * k[i][j]
    };
    let me = |i: usize, j: usize| {
        let c = rho_a * h / 420.0;
        let m = [
            [156.0, 22.0 * h, 54.0, -13.0 * h],
            [22.0 * h, 4.0 * h * h, 13.0 * h, -3.0 * h * h],
            [54.0, 13.0 * h, 156.0, -22.0 * h],
            [-13.0 * h, -3.0 * h * h, -22.0 * h, 4.0 * h * h],
        ];
        c * m[i][j]
    };
    let (mut k, mut m) = (vec![0.0; n * n], vec![0.0; n * n]);
    for e in 0..ne {
        // Element DOFs (w, θ) of nodes e and e+1; node 0 is clamped (DOF index −2, −1).
        let dofs: [isize; 4] = std::array::from_fn(|a| 2 * e as isize + a as isize - 2);
        for a in 0..4 {
            for b in 0..4 {
                let (da, db) = (dofs[a], dofs[b]);
                if da >= 0 && db >= 0 {
                    let (da, db) = (da as usize, db as usize);
                    k[da * n + db] += ke(a, b);
                    m[da * n + db] += me(a, b);
                }
            }
        }
    }
    let mut op = Dense::new(n, k, m);
    let params = LanczosParams {
        modes: 4,
        ..LanczosParams::default()
    };
    let pairs = Lanczos::new().solve(&mut op, &params).unwrap();
    let scale = (ei / (rho_a * len.powi(4))).sqrt();
    for (j, bl) in [1.875104069, 4.694091133, 7.854757438, 10.99554073]
        .into_iter()
        .enumerate()
    {
        let exact = bl * bl * scale;
        let omega = pairs.values[j].sqrt();
        assert!(
            (omega - exact).abs() <= 1e-6 * exact,
            "ω{} = {omega} vs {exact}",
            j + 1
        );
    }
}

/// A zero mass matrix is refused by name, and so is a parameter out of range.
#[test]
fn zero_mass_and_bad_parameters_are_refused() {
    let mut op = chain(5, 1.0, &[0.0; 5]);
    let err = Lanczos::new()
        .solve(&mut op, &LanczosParams::default())
        .unwrap_err();
    assert_eq!(err, EigenError::ZeroMass);
    let bad = LanczosParams {
        modes: 0,
        ..LanczosParams::default()
    };
    let msg = Lanczos::new().solve(&mut op, &bad).unwrap_err().to_string();
    assert!(msg.contains("LanczosParams::modes"), "{msg}");
}
