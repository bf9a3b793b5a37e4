//! Reference: constant-strain patch test (Irons & Razzaque 1972; MacNeal & Harder 1985, "A
//! proposed standard set of problems to test finite element accuracy").
//! Goal: a homogeneous deformation `u = (F − I) X` must be represented exactly by both
//! kinematics — interior residuals vanish, boundary nodal forces equal the consistent tractions of
//! the analytic stress, the stored energy equals Ψ·V — and solving with those tractions as dead
//! loads recovers the homogeneous field. TL is compared with the analytic St Venant–Kirchhoff
//! stress `S = D E(F)`, `E = ½(FᵀF − I)`.

use flexstage_fem::*;

fn model(kin: Kinematics, bcs: BoundaryConditions) -> Model {
    // Rectangular (non-square) elements on purpose.
    let mesh = Mesh::new(0.3, 0.2, 0.01, 5, 3).unwrap();
    Model::new(
        mesh,
        Material {
            e0: 2.0e11,
            e_min: 1.0,
            nu: 0.3,
            penalty: 3.0,
        },
        kin,
        bcs,
    )
    .unwrap()
}

/// Analytic first Piola–Kirchhoff stress for the homogeneous field `F`.
fn analytic_p(m: &Material, kin: Kinematics, f: [[f64; 2]; 2]) -> ([[f64; 2]; 2], f64) {
    let h = [[f[0][0] - 1.0, f[0][1]], [f[1][0], f[1][1] - 1.0]];
    let e = match kin {
        Kinematics::Linear => [h[0][0], h[1][1], h[0][1] + h[1][0]],
        Kinematics::TotalLagrangian => [
            0.5 * (f[0][0] * f[0][0] + f[1][0] * f[1][0] - 1.0),
            0.5 * (f[0][1] * f[0][1] + f[1][1] * f[1][1] - 1.0),
            f[0][0] * f[0][1] + f[1][0] * f[1][1],
        ],
    };
    let d = m.unit_plane_stress();
    let s: Vec<f64> = (0..3)
        .map(|i| m.e0 * (d[i][0] * e[0] + d[i][1] * e[1] + d[i][2] * e[2]))
        .collect();
    let sm = [[s[0], s[2]], [s[2], s[1]]];
    let psi = 0.5 * (s[0] * e[0] + s[1] * e[1] + s[2] * e[2]);
    let p = match kin {
        Kinematics::Linear => sm,
        Kinematics::TotalLagrangian => {
            let mut p = [[0.0; 2]; 2];
            for i in 0..2 {
                for j in 0..2 {
                    p[i][j] = f[i][0] * sm[0][j] + f[i][1] * sm[1][j];
                }
            }
            p
        }
    };
    (p, psi)
}

/// Consistent nodal forces of the boundary tractions `T = P N` (exact for constant P).
fn traction_loads(model: &Model, p: [[f64; 2]; 2]) -> Vec<f64> {
    let mesh = model.mesh();
    let t = mesh.thickness;
    let mut f = model.zero_vector();
    for (edge, n, h) in [
        (Edge::Right, [1.0, 0.0], mesh.dy()),
        (Edge::Left, [-1.0, 0.0], mesh.dy()),
        (Edge::Top, [0.0, 1.0], mesh.dx()),
        (Edge::Bottom, [0.0, -1.0], mesh.dx()),
    ] {
        let nodes = mesh.nodes_on_edge(edge);
        let last = nodes.len() - 1;
        for (k, &nd) in nodes.iter().enumerate() {
            let w = if k == 0 || k == last { 0.5 } else { 1.0 } * h * t;
            for i in 0..2 {
                f[2 * nd + i] += w * (p[i][0] * n[0] + p[i][1] * n[1]);
            }
        }
    }
    f
}

fn homogeneous_u(model: &Model, f: [[f64; 2]; 2]) -> Vec<f64> {
    let mut u = model.zero_vector();
    for n in 0..model.mesh().n_nodes() {
        let x = model.mesh().node_coords(n);
        u[2 * n] = (f[0][0] - 1.0) * x[0] + f[0][1] * x[1];
        u[2 * n + 1] = f[1][0] * x[0] + (f[1][1] - 1.0) * x[1];
    }
    u
}

fn check_residual(kin: Kinematics, f: [[f64; 2]; 2]) {
    let model = model(kin, BoundaryConditions::new());
    let rho = vec![1.0; model.mesh().n_elements()];
    let design = Design::new(&rho);
    let u = homogeneous_u(&model, f);
    let mut r = model.zero_vector();
    let mut ws = model.new_workspace();
    model.residual(&design, &u, &mut r, &mut ws);
    let (p, psi) = analytic_p(model.material(), kin, f);
    let expect = traction_loads(&model, p);
    let scale = expect.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    assert!(scale > 0.0);
    for (k, (a, b)) in r.iter().zip(&expect).enumerate() {
        assert!(
            (a - b).abs() <= 1e-10 * scale,
            "{kin:?} dof {k}: FE {a} vs analytic {b}"
        );
    }
    let vol = 0.3 * 0.2 * 0.01;
    let w = model.strain_energy(&design, &u);
    assert!(
        (w - psi * vol).abs() <= 1e-12 * psi.abs() * vol,
        "{kin:?} energy {w} vs {}",
        psi * vol
    );
}

#[test]
fn patch_residual_linear_all_constant_strain_states() {
    for f in [
        [[1.0 + 1e-3, 0.0], [0.0, 1.0]],
        [[1.0, 0.0], [0.0, 1.0 - 2e-3]],
        [[1.0, 1.5e-3], [0.5e-3, 1.0]],
    ] {
        check_residual(Kinematics::Linear, f);
    }
}

#[test]
fn patch_residual_total_lagrangian_svk() {
    for f in [
        [[1.02, 0.0], [0.0, 1.0]],
        [[1.0, 0.0], [0.0, 0.97]],
        [[1.01, 0.03], [-0.02, 0.99]],
    ] {
        check_residual(Kinematics::TotalLagrangian, f);
    }
}

#[test]
fn patch_solve_recovers_homogeneous_field() {
    for (kin, f) in [
        (Kinematics::Linear, [[1.0 + 1e-3, 4e-4], [0.0, 1.0 - 5e-4]]),
        (Kinematics::TotalLagrangian, [[1.03, 0.02], [0.0, 0.98]]),
    ] {
        let mut bcs = BoundaryConditions::new();
        // Statically determinate supports compatible with F (F21 = 0): node 0 fixed, the
        // bottom-right node fixed in y.
        let m0 = Mesh::new(0.3, 0.2, 0.01, 5, 3).unwrap();
        bcs.fix_node(0, Component::Both)
            .fix_node(m0.node(5, 0), Component::Y);
        let model = model(kin, bcs);
        let rho = vec![1.0; model.mesh().n_elements()];
        let design = Design::new(&rho);
        let (p, _) = analytic_p(model.material(), kin, f);
        let load = traction_loads(&model, p);
        let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
        let mut ws = NewtonWorkspace::new(&model, sym);
        let mut u = model.zero_vector();
        let params = NewtonParams {
            increments: 2,
            residual_tol: 1e-12,
            displacement_tol: 1e-10,
            ..Default::default()
        };
        newton::solve(&model, &design, &load, &mut u, &params, &mut ws, None).unwrap();
        let exact = homogeneous_u(&model, f);
        let umax = exact.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for (a, b) in u.iter().zip(&exact) {
            assert!((a - b).abs() <= 1e-9 * umax, "{kin:?}: {a} vs {b}");
        }
    }
}
