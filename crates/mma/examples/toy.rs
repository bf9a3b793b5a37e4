//! Solves Svanberg's toy problem (2007 note) with MMA and prints every iteration.
//!
//! Run with `cargo run --release -p flexstage-mma --example toy`.

use flexstage_mma::{Mma, MmaParams, samples};

fn main() -> Result<(), flexstage_mma::MmaError> {
    let sample = samples::toy();
    let p = sample.problem.as_ref();
    let (n, m) = (p.n(), p.m());
    let mut mma = Mma::new(
        n,
        m,
        sample.xmin.clone(),
        sample.xmax.clone(),
        MmaParams::default(),
    )?;
    let mut x = sample.x0.clone();
    let (mut df0dx, mut f, mut dfdx) = (vec![0.0; n], vec![0.0; m], vec![0.0; m * n]);
    let mut f0 = p.evaluate(&x, &mut df0dx, &mut f, &mut dfdx);
    println!(
        "iter  {:>9} {:>9} {:>9}  {:>10}  {:>10} {:>10}  {:>9}  newton",
        "x1", "x2", "x3", "f0", "f1", "f2", "kkt"
    );
    println!(
        "{:>4}  {:9.5} {:9.5} {:9.5}  {:10.6}  {:10.2e} {:10.2e}",
        0, x[0], x[1], x[2], f0, f[0], f[1]
    );
    for _ in 0..50 {
        let rep = mma.update(&mut x, f0, &df0dx, &f, &dfdx)?;
        f0 = p.evaluate(&x, &mut df0dx, &mut f, &mut dfdx);
        let kkt = mma.kkt_residual(&x, &df0dx, &f, &dfdx)?;
        println!(
            "{:>4}  {:9.5} {:9.5} {:9.5}  {:10.6}  {:10.2e} {:10.2e}  {:9.2e}  {}",
            rep.iteration, x[0], x[1], x[2], f0, f[0], f[1], kkt.norm, rep.subproblem_iterations
        );
        if kkt.norm < 1e-6 {
            break;
        }
    }
    println!(
        "expected x* = {:?}, f* = {} (Svanberg 2007); lambda = {:?}",
        sample.x_star,
        sample.f_star,
        mma.lambda()
    );
    Ok(())
}
