//! Reference: plane-stress von Mises stress of homogeneous states (any strength-of-materials
//! text, e.g. Timoshenko & Goodier, "Theory of Elasticity", §1–§4): uniaxial stress σ gives
//! σ_vm = σ, pure shear τ gives σ_vm = √3 τ; and the stress-constraint rule of DECISIONS.md,
//! "check every gradient against central finite differences".
//! Goal: the Gauss-point solid stress of `flexstage_fem::stress` reproduces both homogeneous
//! states exactly (relative error < 1e-12, small strain; < 1e-12 for the PK2 stress of a
//! homogeneous total-Lagrangian stretch), and its displacement gradient matches central
//! differences to a relative error < 1e-7 for both kinematics at finite strain.

use flexstage_fem::*;

fn model(kin: Kinematics) -> Model {
    let mesh = Mesh::new(0.3, 0.2, 0.01, 3, 2).unwrap();
    let mat = Material {
        e0: 7.3e10,
        e_min: 1.0,
        nu: 0.33,
        penalty: 3.0,
    };
    Model::new(mesh, mat, kin, BoundaryConditions::new()).unwrap()
}

/// Nodal displacements of the homogeneous field `u = G X`.
fn homogeneous(m: &Model, g: [[f64; 2]; 2]) -> Vec<f64> {
    let mesh = m.mesh();
    let mut u = m.zero_vector();
    for n in 0..mesh.n_nodes() {
        let x = mesh.node_coords(n);
        u[2 * n] = g[0][0] * x[0] + g[0][1] * x[1];
        u[2 * n + 1] = g[1][0] * x[0] + g[1][1] * x[1];
    }
    u
}

#[test]
fn homogeneous_states_give_textbook_von_mises() {
    let m = model(Kinematics::Linear);
    let (e0, nu) = (m.material().e0, m.material().nu);
    let ne = m.mesh().n_elements();
    let mut vm2 = vec![[0.0; STRESS_POINTS]; ne];
    // Uniaxial stress σ along x: ε_x = σ/E, ε_y = −ν σ/E.
    let sigma = 50e6;
    let u = homogeneous(&m, [[sigma / e0, 0.0], [0.0, -nu * sigma / e0]]);
    m.solid_von_mises_squared(&u, &mut vm2);
    for p in vm2.iter().flatten() {
        assert!((p.sqrt() - sigma).abs() <= 1e-12 * sigma, "{}", p.sqrt());
    }
    // Pure shear τ: γ = τ/G, G = E/(2(1+ν)).
    let tau = 30e6;
    let gamma = tau * 2.0 * (1.0 + nu) / e0;
    let u = homogeneous(&m, [[0.0, 0.5 * gamma], [0.5 * gamma, 0.0]]);
    m.solid_von_mises_squared(&u, &mut vm2);
    let want = 3f64.sqrt() * tau;
    for p in vm2.iter().flatten() {
        assert!((p.sqrt() - want).abs() <= 1e-12 * want, "{}", p.sqrt());
    }
    // Total Lagrangian: a stretch λ along x with free contraction chosen so that S22 = 0:
    // E11 = ½(λ² − 1), E22 = −ν E11 → S11 = E0 E11.
    let mt = model(Kinematics::TotalLagrangian);
    let lam: f64 = 1.02;
    let e11 = 0.5 * (lam * lam - 1.0);
    let mu = (1.0 - 2.0 * nu * e11).sqrt();
    let u = homogeneous(&mt, [[lam - 1.0, 0.0], [0.0, mu - 1.0]]);
    mt.solid_von_mises_squared(&u, &mut vm2);
    let want = e0 * e11;
    for p in vm2.iter().flatten() {
        assert!(
            (p.sqrt() - want).abs() <= 1e-12 * want,
            "{} vs {want}",
            p.sqrt()
        );
    }
}

#[test]
fn stress_gradient_matches_central_differences() {
    for kin in [Kinematics::Linear, Kinematics::TotalLagrangian] {
        let m = model(kin);
        let kernel = m.kernel();
        let e0 = m.material().e0;
        // A finite, non-homogeneous element displacement (strains up to ~5 %).
        let u: [f64; 8] = std::array::from_fn(|k| 0.004 * ((k as f64 * 1.7).sin() + 0.3));
        let mut grad = [[0.0; 8]; STRESS_POINTS];
        let base = kernel.solid_von_mises_squared(e0, &u, Some(&mut grad));
        let scale = grad.iter().flatten().fold(0.0f64, |a, b| a.max(b.abs()));
        let h = 1e-7;
        let mut worst = 0.0f64;
        for p in 0..8 {
            let (mut up, mut um) = (u, u);
            up[p] += h;
            um[p] -= h;
            let (fp, fm) = (
                kernel.solid_von_mises_squared(e0, &up, None),
                kernel.solid_von_mises_squared(e0, &um, None),
            );
            for g in 0..STRESS_POINTS {
                let fd = (fp[g] - fm[g]) / (2.0 * h);
                worst = worst.max((fd - grad[g][p]).abs() / scale);
            }
        }
        println!(
            "{kin:?}: max relative error {worst:.2e}, σ_vm² up to {:.3e}",
            base[0]
        );
        assert!(worst < 1e-7, "{kin:?}: {worst:e}");
    }
}
