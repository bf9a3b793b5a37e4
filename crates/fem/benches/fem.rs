//! Benchmarks on the paper's stage problem (0.12 × 0.06 × 0.01 m, E = 73 GPa, ν = 0.33, PEA
//! springs K_pea = 2.5e8 N/m on roller input nodes, x_nom = ±30 µm; DECISIONS.md), TL kinematics,
//! random densities in [0.01, 1] with passive solid ports. Run: `cargo bench -p flexstage-fem`.

use std::sync::Arc;

use divan::Bencher;
use flexstage_fem::*;

fn main() {
    divan::main();
}

const SIZES: [(usize, usize); 2] = [(120, 60), (240, 120)];

struct Setup {
    stage: samples::Stage,
    rho: Vec<f64>,
    sym: Arc<SymbolicFactor>,
}

fn setup(nl: usize, nw: usize) -> Setup {
    let stage = samples::Stage::paper(nl, nw, Kinematics::TotalLagrangian).unwrap();
    let rho = stage.random_density(0.01, 1.0, 42, 1e-3);
    let sym = SymbolicFactor::for_model(&stage.model).unwrap();
    Setup { stage, rho, sym }
}

/// A representative deformed state (the converged solution for x_nom = (+30, −30) µm).
fn deformed(s: &Setup) -> Vec<f64> {
    let model = &s.stage.model;
    let mut ws = NewtonWorkspace::new(model, s.sym.clone());
    let mut u = model.zero_vector();
    let load = s.stage.pea_load(30e-6, -30e-6);
    newton::solve(
        model,
        &Design::new(&s.rho),
        &load,
        &mut u,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap();
    u
}

#[divan::bench(args = SIZES)]
fn assemble_tangent_residual(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let u = deformed(&s);
    let mut k = model.new_matrix();
    let mut r = model.zero_vector();
    let mut ws = model.new_workspace();
    let design = Design::new(&s.rho);
    b.bench_local(|| model.assemble(&design, &u, Some(&mut r), Some(&mut k), &mut ws));
}

/// The residual alone (what a lock-step sweep assembles), same state.
#[divan::bench(args = SIZES)]
fn assemble_residual(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let u = deformed(&s);
    let mut r = model.zero_vector();
    let mut ws = model.new_workspace();
    let design = Design::new(&s.rho);
    b.bench_local(|| model.residual(&design, &u, &mut r, &mut ws));
}

#[divan::bench(args = SIZES)]
fn assemble_tangent_residual_with_yeoh(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let u = deformed(&s);
    let yeoh = AdditiveYeoh::paper(model.mesh().n_elements(), 73e9, 1e-6, 3.0);
    let mut k = model.new_matrix();
    let mut r = model.zero_vector();
    let mut ws = model.new_workspace();
    let design = Design::with_yeoh(&s.rho, &yeoh);
    b.bench_local(|| model.assemble(&design, &u, Some(&mut r), Some(&mut k), &mut ws));
}

#[divan::bench(args = SIZES)]
fn symbolic_factorization(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    b.bench_local(|| SymbolicFactor::for_model(&s.stage.model).unwrap());
}

#[divan::bench(args = SIZES)]
fn numeric_factorization(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let u = deformed(&s);
    let mut k = model.new_matrix();
    model.assemble(
        &Design::new(&s.rho),
        &u,
        None,
        Some(&mut k),
        &mut model.new_workspace(),
    );
    let mut f = Factor::new(s.sym.clone());
    b.bench_local(|| f.factorize(&k).unwrap());
}

#[divan::bench(args = SIZES)]
fn solve(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let mut k = model.new_matrix();
    model.assemble(
        &Design::new(&s.rho),
        &model.zero_vector(),
        None,
        Some(&mut k),
        &mut model.new_workspace(),
    );
    let mut f = Factor::new(s.sym.clone());
    f.factorize(&k).unwrap();
    let mut sws = f.new_solve_workspace();
    let rhs = samples::random_vector(k.n(), -1.0, 1.0, 1);
    let mut x = rhs.clone();
    b.bench_local(|| {
        x.copy_from_slice(&rhs);
        f.solve_in_place(&mut x, &mut sws).unwrap();
    });
}

/// One Newton iteration's linear algebra: assembly + numeric factorization + solve.
#[divan::bench(args = SIZES)]
fn newton_iteration(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let u = deformed(&s);
    let design = Design::new(&s.rho);
    let mut k = model.new_matrix();
    let mut r = model.zero_vector();
    let mut ws = model.new_workspace();
    let mut f = Factor::new(s.sym.clone());
    let mut sws = f.new_solve_workspace();
    let mut x = vec![0.0; k.n()];
    b.bench_local(|| {
        model.assemble(&design, &u, Some(&mut r), Some(&mut k), &mut ws);
        f.factorize(&k).unwrap();
        model.dofs().gather(&r, &mut x);
        f.solve_in_place(&mut x, &mut sws).unwrap();
    });
}

/// Full Newton solve from zero with direct solves (x_nom = +30/−30 µm).
#[divan::bench(args = SIZES, sample_count = 20)]
fn newton_solve_direct(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let design = Design::new(&s.rho);
    let load = s.stage.pea_load(30e-6, -30e-6);
    let mut ws = NewtonWorkspace::new(model, s.sym.clone());
    let mut u = model.zero_vector();
    b.bench_local(|| {
        u.fill(0.0);
        newton::solve(
            model,
            &design,
            &load,
            &mut u,
            &NewtonParams::default(),
            &mut ws,
            None,
        )
        .unwrap()
    });
}

/// Full Newton solve from zero with PCG preconditioned by a shared factor of the undeformed
/// tangent (the topology-optimization setting: one factorization serves all load cases).
#[divan::bench(args = SIZES, sample_count = 20)]
fn newton_solve_pcg_shared_factor(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let design = Design::new(&s.rho);
    let load = s.stage.pea_load(30e-6, -30e-6);
    let mut k0 = model.new_matrix();
    model.assemble(
        &design,
        &model.zero_vector(),
        None,
        Some(&mut k0),
        &mut model.new_workspace(),
    );
    let mut f0 = Factor::new(s.sym.clone());
    f0.factorize(&k0).unwrap();
    let params = NewtonParams {
        linear: LinearStrategy::Pcg(PcgParams {
            rel_tol: 1e-10,
            max_iter: 100,
        }),
        ..Default::default()
    };
    let mut ws = NewtonWorkspace::new(model, s.sym.clone());
    let mut u = model.zero_vector();
    b.bench_local(|| {
        u.fill(0.0);
        newton::solve(model, &design, &load, &mut u, &params, &mut ws, Some(&f0)).unwrap()
    });
}

/// [`Model::assemble_serial`] (one case per thread, fused scatter), same state; compare with
/// `assemble_tangent_residual` under `RAYON_NUM_THREADS=1`.
#[divan::bench(args = SIZES)]
fn assemble_tangent_residual_serial(b: Bencher, (nl, nw): (usize, usize)) {
    let s = setup(nl, nw);
    let model = &s.stage.model;
    let u = deformed(&s);
    let mut k = model.new_matrix();
    let mut r = model.zero_vector();
    let mut ws = model.new_workspace();
    let design = Design::new(&s.rho);
    b.bench_local(|| model.assemble_serial(&design, &u, Some(&mut r), Some(&mut k), &mut ws));
}
