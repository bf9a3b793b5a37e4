//! Problems with known answers, used by the tests and benches.

use flexstage_fem::{Kinematics, Material, samples::Cantilever};
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::Problem;

use crate::error::Result;

/// First eigenvalue `β₁L` of the clamped–free Euler–Bernoulli beam (`cos βL cosh βL = −1`).
pub const BETA1_L: f64 = 1.875_104_068_711_961;

/// A clamped–free strip (left edge clamped) of aluminium (E = 73 GPa, ν = 0.33,
/// 2710 kg/m³): `length × height × thickness`, `nl × nw` Q4 elements.
pub fn cantilever_strip(
    length: f64,
    height: f64,
    thickness: f64,
    nl: usize,
    nw: usize,
) -> Result<Cantilever> {
    let mat = Material {
        e0: 73e9,
        e_min: 1e3,
        nu: 0.33,
        penalty: 3.0,
    };
    Ok(Cantilever::new(
        mat,
        Kinematics::Linear,
        length,
        height,
        thickness,
        nl,
        nw,
    )?)
}

/// Euler–Bernoulli frequency of mode `k` \[Hz\] of a clamped–free strip with `β_k L`:
/// `f = (β_k L)² / (2π L²) · √(E I / (ρ A))`, `I = t h³/12`, `A = t h`.
pub fn euler_bernoulli_frequency(
    beta_l: f64,
    e: f64,
    density: f64,
    length: f64,
    height: f64,
) -> f64 {
    let ei_over_rho_a = e * height * height / (12.0 * density);
    beta_l * beta_l / (2.0 * std::f64::consts::PI * length * length) * ei_over_rho_a.sqrt()
}

/// The default stage scenario (`preset`) and its reduction problem (total Lagrangian, the
/// optimizer's output spring removed, [`crate::reduction_problem`]).
pub fn stage(preset: Preset) -> Result<(Scenario, Problem)> {
    let s = Scenario::preset(preset);
    let p = crate::reduction_problem(&s, false)?;
    Ok((s, p))
}

/// The default design of `flexstage design` before optimization: uniform
/// `optimization.initial_density`, passive regions applied.
pub fn default_design(problem: &Problem) -> Vec<f64> {
    let mut rho = vec![problem.initial_density; problem.mesh().n_elements()];
    problem.mesh().apply_passive(&mut rho, problem.rho_min);
    rho
}

/// A left–right mirror-symmetric random design in `[lo, hi]` (`ρ(i, j) = ρ(n_l−1−i, j)`),
/// passive regions applied.
pub fn symmetric_random_design(problem: &Problem, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    let mesh = problem.mesh();
    let (nl, nw) = (mesh.nl, mesh.nw);
    let r = flexstage_fem::samples::random_vector(nl * nw, lo, hi, seed);
    let mut rho = vec![0.0; nl * nw];
    for i in 0..nl {
        for j in 0..nw {
            let src = i.min(nl - 1 - i);
            rho[i * nw + j] = r[src * nw + j];
        }
    }
    mesh.apply_passive(&mut rho, problem.rho_min);
    rho
}

/// A random (asymmetric) design in `[lo, hi]`, passive regions applied.
pub fn random_design(problem: &Problem, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    let mesh = problem.mesh();
    let mut rho = flexstage_fem::samples::random_vector(mesh.n_elements(), lo, hi, seed);
    mesh.apply_passive(&mut rho, problem.rho_min);
    rho
}
