//! Reference: springs in series (statics): a force F on DOF 1, a link spring k between DOFs
//! 1 and 2 and a grounded spring k₂ on DOF 2 give u₂ = F/k₂ and u₁ = F/k₂ + F/k; and the
//! consistent tangent of a link spring on a linear combination g = Σ cᵢ uᵢ is k c cᵀ.
//! Goal: a model whose elements carry almost no stiffness reproduces the series-spring answer
//! to 1e-9 (relative), and with stiff elements the assembled tangent of a three-term link
//! (the output load relative to the moving frame, u_o − ½(u₁ + u₂)) matches central
//! differences of the residual to 1e-9.

use flexstage_fem::*;

#[test]
fn series_springs_through_a_link() {
    let mesh = Mesh::new(1.0, 1.0, 1.0, 1, 1).unwrap();
    let (d1, d2) = (2 * mesh.node(1, 1), 2 * mesh.node(1, 0));
    let mut bcs = BoundaryConditions::new();
    for d in 0..mesh.n_dofs() {
        if d != d1 && d != d2 {
            bcs.fixed.push(d);
        }
    }
    let (k, k2, f) = (3.0e6, 5.0e5, 120.0);
    bcs.add_link(&[(d1, 1.0), (d2, -1.0)], k).add_spring(d2, k2);
    let mat = Material {
        e0: 1e-6,
        e_min: 1e-9,
        nu: 0.3,
        penalty: 3.0,
    };
    let model = Model::new(mesh, mat, Kinematics::Linear, bcs).unwrap();
    let rho = vec![1.0];
    let design = Design::new(&rho);
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    let mut ws = NewtonWorkspace::new(&model, sym);
    let load = model.load_vector(&[(d1, f)]).unwrap();
    let mut u = model.zero_vector();
    newton::solve(
        &model,
        &design,
        &load,
        &mut u,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap();
    let (u1, u2) = (f / k2 + f / k, f / k2);
    println!(
        "u1 = {:e} (expected {u1:e}), u2 = {:e} (expected {u2:e})",
        u[d1], u[d2]
    );
    assert!((u[d1] - u1).abs() <= 1e-9 * u1);
    assert!((u[d2] - u2).abs() <= 1e-9 * u2);
}

#[test]
fn link_tangent_matches_central_differences() {
    let mesh = Mesh::new(0.4, 0.2, 0.01, 4, 2).unwrap();
    let (o, a, b) = (mesh.node(2, 2), mesh.node(0, 1), mesh.node(4, 1));
    let mut bcs = BoundaryConditions::new();
    bcs.fix_node(a, Component::Y).fix_node(b, Component::Y);
    bcs.add_spring(2 * a, 1e7).add_spring(2 * b, 1e7);
    bcs.add_link(&[(2 * o, 1.0), (2 * a, -0.5), (2 * b, -0.5)], 4e6)
        .add_link(&[(2 * o + 1, 1.0)], 4e6);
    let model = Model::new(mesh, Material::paper(), Kinematics::TotalLagrangian, bcs).unwrap();
    let rho: Vec<f64> = (0..model.mesh().n_elements())
        .map(|e| 0.3 + 0.05 * e as f64)
        .collect();
    let design = Design::new(&rho);
    let u: Vec<f64> = (0..model.n_dofs())
        .map(|d| {
            if model.dofs().is_fixed(d) {
                0.0
            } else {
                1e-4 * ((d as f64 * 0.9).sin())
            }
        })
        .collect();
    let mut ws = model.new_workspace();
    let mut kt = model.new_matrix();
    let mut r = model.zero_vector();
    model.assemble(&design, &u, Some(&mut r), Some(&mut kt), &mut ws);
    let free = model.dofs().free_dofs().to_vec();
    let h = 1e-9;
    let mut worst = 0.0f64;
    let scale = (0..kt.n()).map(|i| kt.diag(i).abs()).fold(0.0, f64::max);
    let (mut rp, mut rm) = (model.zero_vector(), model.zero_vector());
    for (j, &dj) in free.iter().enumerate() {
        let (mut up, mut um) = (u.clone(), u.clone());
        up[dj] += h;
        um[dj] -= h;
        model.residual(&design, &up, &mut rp, &mut ws);
        model.residual(&design, &um, &mut rm, &mut ws);
        for (i, &di) in free.iter().enumerate() {
            let fd = (rp[di] - rm[di]) / (2.0 * h);
            worst = worst.max((fd - kt.get(i, j)).abs() / scale);
        }
    }
    println!("max |K_T − FD| / max diag = {worst:.2e}");
    assert!(worst < 1e-9, "{worst:e}");
    // The link forces are part of R and of add_spring_forces.
    let mut f = model.zero_vector();
    model.add_spring_forces(&u, 1.0, &mut f);
    let g = u[2 * o] - 0.5 * (u[2 * a] + u[2 * b]);
    assert!((f[2 * o] - 4e6 * g).abs() <= 1e-9 * (4e6 * g).abs());
}
