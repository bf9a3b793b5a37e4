//! One MMA update for n = 10⁴, 10⁵, 10⁶ variables and m = 3 constraints, with each
//! subproblem solver.
//!
//! Run with `cargo bench -p flexstage-mma`. The optimizer is first advanced three
//! iterations on a synthetic problem (so the asymptote-update branch is used and the dual
//! solver is warm-started), then each sample times one `Mma::update` from that same state.

use flexstage_mma::{Mma, MmaParams, Subsolver};

fn main() {
    // Newton steps of the benchmarked update, so the time per step and variable can be read.
    for sub in [Subsolver::PrimalDual, Subsolver::Dual] {
        for n in SIZES {
            let s = setup(n, sub);
            let rep = s
                .mma
                .clone()
                .update(&mut s.x.clone(), s.f0, &s.df0dx, &s.f, &s.dfdx)
                .unwrap();
            println!(
                "{sub:?}, n = {n}: {} interior-point Newton steps per update",
                rep.subproblem_iterations
            );
        }
    }
    divan::main();
}

const SIZES: [usize; 3] = [10_000, 100_000, 1_000_000];

const M: usize = 3;

/// Synthetic smooth problem scaled like a topology optimization: objective
/// `(1/n) Σ wⱼ/xⱼ` (compliance-like) and three linear "volume fraction" constraints
/// `(1/n) Σ aᵢⱼ xⱼ ≤ Vᵢ`, with coefficients filled deterministically.
struct Synthetic {
    n: usize,
    w: Vec<f64>,
    a: Vec<f64>,
}

impl Synthetic {
    fn new(n: usize) -> Self {
        let w = (0..n)
            .map(|j| 1.0 + ((j * 7919) % 1000) as f64 / 1000.0)
            .collect();
        let a = (0..M * n)
            .map(|k| 1.0 + ((k * 104_729) % 997) as f64 / 997.0)
            .collect();
        Self { n, w, a }
    }

    fn eval(&self, x: &[f64], df0dx: &mut [f64], f: &mut [f64], dfdx: &mut [f64]) -> f64 {
        let n = self.n;
        let mut f0 = 0.0;
        for j in 0..n {
            f0 += self.w[j] / x[j] / n as f64;
            df0dx[j] = -self.w[j] / (x[j] * x[j]) / n as f64;
        }
        for i in 0..M {
            let row = &self.a[i * n..(i + 1) * n];
            f[i] = row.iter().zip(x).map(|(a, x)| a * x).sum::<f64>() / n as f64
                - 0.4
                - 0.1 * i as f64;
            for j in 0..n {
                dfdx[i * n + j] = row[j] / n as f64;
            }
        }
        f0
    }
}

struct Setup {
    mma: Mma,
    x: Vec<f64>,
    f0: f64,
    df0dx: Vec<f64>,
    f: Vec<f64>,
    dfdx: Vec<f64>,
}

fn setup(n: usize, subsolver: Subsolver) -> Setup {
    let p = Synthetic::new(n);
    let params = MmaParams {
        subsolver,
        ..MmaParams::default()
    };
    let mut mma = Mma::new(n, M, vec![1e-3; n], vec![1.0; n], params).unwrap();
    let mut x = vec![0.5; n];
    let (mut df0dx, mut f, mut dfdx) = (vec![0.0; n], vec![0.0; M], vec![0.0; M * n]);
    let mut f0 = p.eval(&x, &mut df0dx, &mut f, &mut dfdx);
    for _ in 0..3 {
        mma.update(&mut x, f0, &df0dx, &f, &dfdx).unwrap();
        f0 = p.eval(&x, &mut df0dx, &mut f, &mut dfdx);
    }
    Setup {
        mma,
        x,
        f0,
        df0dx,
        f,
        dfdx,
    }
}

/// `Subsolver::PrimalDual` (the default, Svanberg's `subsolv`).
#[divan::bench(args = SIZES, sample_count = 10, sample_size = 1)]
fn mma_update(bencher: divan::Bencher, n: usize) {
    bench(bencher, n, Subsolver::PrimalDual);
}

/// `Subsolver::Dual`.
#[divan::bench(args = SIZES, sample_count = 10, sample_size = 1)]
fn mma_update_dual(bencher: divan::Bencher, n: usize) {
    bench(bencher, n, Subsolver::Dual);
}

fn bench(bencher: divan::Bencher, n: usize, subsolver: Subsolver) {
    let s = setup(n, subsolver);
    bencher
        .counter(divan::counter::ItemsCount::new(n))
        .with_inputs(|| (s.mma.clone(), s.x.clone()))
        .bench_local_refs(|(mma, x)| {
            let rep = mma.update(x, s.f0, &s.df0dx, &s.f, &s.dfdx).unwrap();
            divan::black_box(rep)
        });
}
