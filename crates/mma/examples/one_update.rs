//! One MMA update on the synthetic problem of `benches/update.rs`, for instruction counts:
//!
//! ```text
//! cargo build --release -p flexstage-mma --example one_update
//! valgrind --tool=callgrind --toggle-collect='*timed_update*' \
//!     target/release/examples/one_update 10000 serial [dual]
//! ```
//!
//! The optimizer is advanced three iterations first (as in the bench); only the fourth
//! update runs inside `timed_update`. Prints the Newton steps and the elapsed time.

use std::time::Instant;

use flexstage_mma::{Mma, MmaParams, Subsolver, UpdateReport};

const M: usize = 3;

fn eval(
    w: &[f64],
    a: &[f64],
    x: &[f64],
    df0dx: &mut [f64],
    f: &mut [f64],
    dfdx: &mut [f64],
) -> f64 {
    let n = x.len();
    let mut f0 = 0.0;
    for j in 0..n {
        f0 += w[j] / x[j] / n as f64;
        df0dx[j] = -w[j] / (x[j] * x[j]) / n as f64;
    }
    for i in 0..M {
        let row = &a[i * n..(i + 1) * n];
        f[i] = row.iter().zip(x).map(|(a, x)| a * x).sum::<f64>() / n as f64 - 0.4 - 0.1 * i as f64;
        for j in 0..n {
            dfdx[i * n + j] = row[j] / n as f64;
        }
    }
    f0
}

#[inline(never)]
fn timed_update(
    mma: &mut Mma,
    x: &mut [f64],
    f0: f64,
    df0dx: &[f64],
    f: &[f64],
    dfdx: &[f64],
) -> UpdateReport {
    mma.update(x, f0, df0dx, f, dfdx).unwrap()
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map_or(10_000, |s| s.parse().expect("n"));
    let w: Vec<f64> = (0..n)
        .map(|j| 1.0 + ((j * 7919) % 1000) as f64 / 1000.0)
        .collect();
    let a: Vec<f64> = (0..M * n)
        .map(|k| 1.0 + ((k * 104_729) % 997) as f64 / 997.0)
        .collect();
    // A second argument `serial` keeps rayon out (callgrind then counts every instruction),
    // `parallel` uses it whatever n.
    let parallel_threshold = match std::env::args().nth(2).as_deref() {
        Some("serial") => usize::MAX,
        Some("parallel") => 0,
        _ => MmaParams::default().parallel_threshold,
    };
    // A third argument `dual` selects the dual interior-point subproblem solver.
    let subsolver = match std::env::args().nth(3).as_deref() {
        Some("dual") => Subsolver::Dual,
        _ => Subsolver::PrimalDual,
    };
    let params = MmaParams {
        parallel_threshold,
        subsolver,
        ..MmaParams::default()
    };
    let mut mma = Mma::new(n, M, vec![1e-3; n], vec![1.0; n], params).unwrap();
    let mut x = vec![0.5; n];
    let (mut df0dx, mut f, mut dfdx) = (vec![0.0; n], vec![0.0; M], vec![0.0; M * n]);
    let mut f0 = eval(&w, &a, &x, &mut df0dx, &mut f, &mut dfdx);
    for _ in 0..3 {
        mma.update(&mut x, f0, &df0dx, &f, &dfdx).unwrap();
        f0 = eval(&w, &a, &x, &mut df0dx, &mut f, &mut dfdx);
    }
    let t = Instant::now();
    let rep = timed_update(&mut mma, &mut x, f0, &df0dx, &f, &dfdx);
    let dt = t.elapsed();
    let sum: f64 = x.iter().sum();
    println!(
        "n = {n}: {:?}, {} Newton steps, residual {:.3e}, {:.3} ms, sum(x) = {sum:.15e}, lambda = {:?}",
        rep.subsolver,
        rep.subproblem_iterations,
        rep.subproblem_residual,
        dt.as_secs_f64() * 1e3,
        mma.lambda()
    );
}
