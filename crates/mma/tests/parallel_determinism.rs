// Reference: the chunked reduction design in src/subsolv.rs (fixed chunks, ordered sums).
// Goal: the rayon code path (n >= parallel_threshold) gives bit-for-bit the same iterates,
// multipliers and subproblem iteration counts as the serial path, on a problem with m = 3.

use flexstage_mma::{Mma, MmaParams};

fn run(parallel_threshold: usize) -> (Vec<f64>, Vec<f64>, Vec<usize>) {
    let n = 20_000;
    let m = 3;
    let params = MmaParams {
        parallel_threshold,
        ..MmaParams::default()
    };
    let mut mma = Mma::new(n, m, vec![0.01; n], vec![1.0; n], params).unwrap();
    let mut x = vec![0.5; n];
    let w: Vec<f64> = (0..n).map(|j| 1.0 + (j % 17) as f64 / 17.0).collect();
    let mut its = Vec::new();
    let (mut g, mut f, mut dfdx) = (vec![0.0; n], vec![0.0; m], vec![0.0; m * n]);
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
        let rep = mma.update(&mut x, f0, &g, &f, &dfdx).unwrap();
        its.push(rep.subproblem_iterations);
    }
    (x, mma.lambda().to_vec(), its)
}

#[test]
fn parallel_and_serial_paths_agree_bitwise() {
    let serial = run(usize::MAX);
    let parallel = run(0);
    assert_eq!(serial.2, parallel.2, "subproblem iteration counts differ");
    assert_eq!(serial.1, parallel.1, "multipliers differ");
    assert!(serial.0 == parallel.0, "iterates differ");
    assert!(
        serial.1.iter().any(|&l| l > 1e-6),
        "no active constraint: {:?}",
        serial.1
    );
}
