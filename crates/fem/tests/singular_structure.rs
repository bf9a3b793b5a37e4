//! Reference: a stiffness matrix with an unrestrained rigid-body motion is singular (its null
//! space holds the rigid motions: Cook, Malkus, Plesha & Witt, *Concepts and Applications of
//! Finite Element Analysis*, 4th ed., §2.5 and §9.x); a pivot at round-off level,
//! `n·ε·max |a_ii|`, is a zero pivot (Golub & Van Loan, *Matrix Computations*, 4th ed., §3.3).
//! Goal: factorizing the stiffness of a floating structure (no support, no spring), or of one
//! held only along x, gives the typed [`SolverError::SingularStiffness`] that names the supports
//! and the output spring — never a factor that solves to garbage; Newton passes it on; the same
//! structures once supported factorize as LLᵀ (so the check does not fire on sound stiffness,
//! including a design with void material at E_min).

use flexstage_fem::*;

fn stiffness(bcs: BoundaryConditions, rho: f64) -> (Model, SparseMatrix) {
    let mesh = Mesh::new(0.12, 0.06, 0.01, 24, 12).unwrap();
    let n = mesh.n_elements();
    let model = Model::new(mesh, Material::paper(), Kinematics::TotalLagrangian, bcs).unwrap();
    let rho = vec![rho; n];
    let mut k = model.new_matrix();
    let mut ws = model.new_workspace();
    model.assemble(
        &Design::new(&rho),
        &model.zero_vector(),
        None,
        Some(&mut k),
        &mut ws,
    );
    (model, k)
}

fn factorize(model: &Model, k: &SparseMatrix) -> Result<FactorKind, SolverError> {
    let sym = SymbolicFactor::for_model(model).unwrap();
    let mut f = Factor::new(sym);
    f.factorize(k)
}

fn assert_singular(r: Result<FactorKind, SolverError>, what: &str) {
    match r {
        Err(e @ SolverError::SingularStiffness { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("[[supports]]"), "{what}: {msg}");
            assert!(msg.contains("output_spring"), "{what}: {msg}");
            assert!(msg.contains("floats"), "{what}: {msg}");
        }
        other => panic!("{what}: expected SingularStiffness, got {other:?}"),
    }
}

#[test]
fn cook_floating_structure_is_singular() {
    // Three rigid-body motions, nothing holds them.
    let (model, k) = stiffness(BoundaryConditions::new(), 0.5);
    assert_singular(factorize(&model, &k), "free");
    // Springs along x at two nodes on one horizontal line (the PEA springs of the stage with
    // no supports): y-translation and the rotation about that line stay free.
    let mesh = Mesh::new(0.12, 0.06, 0.01, 24, 12).unwrap();
    let left = mesh.nearest_node([0.0, 0.03]);
    let right = mesh.nearest_node([0.12, 0.03]);
    let mut bcs = BoundaryConditions::new();
    bcs.add_spring(2 * left, 2.5e8).add_spring(2 * right, 2.5e8);
    let (model, k) = stiffness(bcs, 1.0);
    assert_singular(factorize(&model, &k), "x springs only");
}

#[test]
fn cook_supported_structure_factorizes_including_void() {
    // The same springs plus y rollers at both ports: all rigid motions held.
    let mesh = Mesh::new(0.12, 0.06, 0.01, 24, 12).unwrap();
    let left = mesh.nearest_node([0.0, 0.03]);
    let right = mesh.nearest_node([0.12, 0.03]);
    let mut bcs = BoundaryConditions::new();
    bcs.add_spring(2 * left, 2.5e8)
        .add_spring(2 * right, 2.5e8)
        .fix_node(left, Component::Y)
        .fix_node(right, Component::Y);
    for rho in [1.0, 0.5, 0.0] {
        // rho = 0: all void at E_min (1e3 Pa against springs of 2.5e8 N/m).
        let (model, k) = stiffness(bcs.clone(), rho);
        assert_eq!(factorize(&model, &k).unwrap(), FactorKind::Llt, "rho {rho}");
    }
}

#[test]
fn cook_floating_structure_newton_reports_singular() {
    let (model, _) = stiffness(BoundaryConditions::new(), 0.5);
    let rho = vec![0.5; model.mesh().n_elements()];
    let mut load = model.zero_vector();
    load[1] = 1.0;
    let sym = SymbolicFactor::for_model(&model).unwrap();
    let mut ws = NewtonWorkspace::new(&model, sym);
    let mut u = model.zero_vector();
    let err = newton::solve(
        &model,
        &Design::new(&rho),
        &load,
        &mut u,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap_err();
    match &err {
        NewtonError::Linear {
            source: SolverError::SingularStiffness { .. },
            ..
        } => {}
        other => panic!("expected a singular linear failure, got {other}"),
    }
}
