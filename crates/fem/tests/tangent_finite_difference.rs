//! Reference: consistent linearization check by central finite differences (e.g. Wriggers,
//! "Nonlinear Finite Element Methods", 2008, §5; the DECISIONS.md rule "check every gradient against
//! central finite differences").
//! Goal: the assembled tangent K_T = ∂R/∂u, the design derivative ∂R/∂ρ (incl. the additive
//! term's (1 − ρ^p) factor) and ∂W/∂ρ match central differences to a relative error < 1e-6,
//! for SVK, additive Yeoh alone and combined, at finite strain; and ∂W/∂u = R (hyperelasticity).

use flexstage_fem::*;

struct Case {
    name: &'static str,
    material: Material,
    yeoh: Option<AdditiveYeoh>,
}

fn cases(n: usize) -> Vec<Case> {
    let m = Material {
        e0: 1.0e3,
        e_min: 1e-3,
        nu: 0.3,
        penalty: 3.0,
    };
    vec![
        Case {
            name: "SVK",
            material: m,
            yeoh: None,
        },
        // Yeoh only: a void-like material (E_min tiny, E0 tiny), additive terms dominate.
        Case {
            name: "Yeoh",
            material: Material {
                e0: 1e-9,
                e_min: 0.0,
                ..m
            },
            yeoh: Some(AdditiveYeoh {
                c1: samples::random_vector(n, 50.0, 150.0, 3),
                c2: samples::random_vector(n, 100.0, 400.0, 4),
            }),
        },
        Case {
            name: "SVK+Yeoh",
            material: m,
            yeoh: Some(AdditiveYeoh {
                c1: samples::random_vector(n, 50.0, 150.0, 5),
                c2: samples::random_vector(n, 100.0, 400.0, 6),
            }),
        },
    ]
}

fn setup(material: Material) -> (Model, Vec<f64>, Vec<f64>) {
    let mesh = Mesh::new(1.0, 0.6, 0.1, 5, 3).unwrap();
    let mut bcs = BoundaryConditions::new();
    bcs.fix_edge(&mesh, Edge::Left, Component::Both)
        .add_spring(2 * mesh.node(5, 1), 300.0);
    let ne = mesh.n_elements();
    let model = Model::new(mesh, material, Kinematics::TotalLagrangian, bcs).unwrap();
    // Finite deformation: displacements up to ~0.05 on 0.2-sized elements (strains ~ 0.2).
    let mut u = samples::random_vector(model.n_dofs(), -0.04, 0.04, 11);
    for n in model.mesh().nodes_on_edge(Edge::Left) {
        u[2 * n] = 0.0;
        u[2 * n + 1] = 0.0;
    }
    let rho = samples::random_vector(ne, 0.1, 0.9, 12);
    (model, u, rho)
}

fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt();
    let den: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    num / den
}

#[test]
fn tangent_matches_central_differences() {
    let n = 15;
    for case in cases(n) {
        let (model, u, rho) = setup(case.material);
        let design = Design {
            rho: &rho,
            yeoh: case.yeoh.as_ref(),
        };
        let mut ws = model.new_workspace();
        let mut k = model.new_matrix();
        let mut r = model.zero_vector();
        model.assemble(&design, &u, Some(&mut r), Some(&mut k), &mut ws);
        let dofs = model.dofs();
        let h = 1e-6;
        let mut max_err = 0.0f64;
        for (j, &dj) in dofs.free_dofs().iter().enumerate() {
            let mut up = u.clone();
            let mut um = u.clone();
            up[dj] += h;
            um[dj] -= h;
            let (mut rp, mut rm) = (model.zero_vector(), model.zero_vector());
            model.residual(&design, &up, &mut rp, &mut ws);
            model.residual(&design, &um, &mut rm, &mut ws);
            let fd: Vec<f64> = dofs
                .free_dofs()
                .iter()
                .map(|&d| (rp[d] - rm[d]) / (2.0 * h))
                .collect();
            let an: Vec<f64> = (0..dofs.n_free()).map(|i| k.get(i, j)).collect();
            max_err = max_err.max(rel_err(&an, &fd));
        }
        assert!(
            max_err < 1e-6,
            "{}: tangent column rel. error {max_err:e}",
            case.name
        );
    }
}

#[test]
fn design_derivatives_match_central_differences() {
    let n = 15;
    for case in cases(n) {
        let (model, u, rho) = setup(case.material);
        let design = Design {
            rho: &rho,
            yeoh: case.yeoh.as_ref(),
        };
        let mut ws = model.new_workspace();
        // λᵀ ∂R/∂ρ for a random λ (fixed entries ignored by construction).
        let mut lambda = samples::random_vector(model.n_dofs(), -1.0, 1.0, 21);
        for &d in &model.bcs().fixed {
            lambda[d] = 0.0;
        }
        let mut an = vec![0.0; n];
        model.contract_drho(&design, &u, &lambda, &mut an);
        let mut dw = vec![0.0; n];
        model.energy_drho(&design, &u, &mut dw);
        let h = 1e-6;
        let mut fd = vec![0.0; n];
        let mut fdw = vec![0.0; n];
        for e in 0..n {
            let mut rp = rho.clone();
            let mut rm = rho.clone();
            rp[e] += h;
            rm[e] -= h;
            let dp = Design {
                rho: &rp,
                yeoh: case.yeoh.as_ref(),
            };
            let dm = Design {
                rho: &rm,
                yeoh: case.yeoh.as_ref(),
            };
            let (mut fp, mut fm) = (model.zero_vector(), model.zero_vector());
            model.residual(&dp, &u, &mut fp, &mut ws);
            model.residual(&dm, &u, &mut fm, &mut ws);
            fd[e] = lambda
                .iter()
                .zip(fp.iter().zip(&fm))
                .map(|(l, (a, b))| l * (a - b))
                .sum::<f64>()
                / (2.0 * h);
            fdw[e] = (model.strain_energy(&dp, &u) - model.strain_energy(&dm, &u)) / (2.0 * h);
        }
        let e1 = rel_err(&an, &fd);
        let e2 = rel_err(&dw, &fdw);
        assert!(e1 < 1e-6, "{}: λᵀ∂R/∂ρ rel. error {e1:e}", case.name);
        assert!(e2 < 1e-6, "{}: ∂W/∂ρ rel. error {e2:e}", case.name);
    }
}

#[test]
fn internal_force_is_energy_gradient() {
    for case in cases(15) {
        let (model, u, rho) = setup(case.material);
        let design = Design {
            rho: &rho,
            yeoh: case.yeoh.as_ref(),
        };
        let mut ws = model.new_workspace();
        let mut r = model.zero_vector();
        model.residual(&design, &u, &mut r, &mut ws);
        // Remove the spring force (not part of the strain energy).
        for s in &model.bcs().springs {
            r[s.dof] -= s.stiffness * u[s.dof];
        }
        let h = 1e-6;
        let fd: Vec<f64> = (0..model.n_dofs())
            .map(|d| {
                let mut up = u.clone();
                let mut um = u.clone();
                up[d] += h;
                um[d] -= h;
                (model.strain_energy(&design, &up) - model.strain_energy(&design, &um)) / (2.0 * h)
            })
            .collect();
        let e = rel_err(&r, &fd);
        assert!(e < 1e-6, "{}: ∂W/∂u vs R rel. error {e:e}", case.name);
    }
}
