//! The pieces of an eigenvalue sensitivity on the FE model, each against an independent
//! computation: the Woodbury spring update against a factorization of the updated model, the
//! stiffness and mass derivative forms against central differences of `aᵀK(ρ)a` and `aᵀM(ρ)a`,
//! and Du & Olhoff's mass interpolation (value and slope continuous at ρ_c, their published
//! coefficients).

use flexstage_fem::samples::{Stage, random_vector};
use flexstage_fem::{
    BoundaryConditions, Design, Factor, Kinematics, LinkSpring, MassInterpolation, Model,
    SolveWorkspace, SparseMatrix, SpringUpdate, SymbolicFactor, consistent_mass,
    consistent_mass_forms,
};

fn stiffness(model: &Model, rho: &[f64]) -> SparseMatrix {
    let mut k = model.new_matrix();
    let zero = model.zero_vector();
    let mut ws = model.new_workspace();
    model.assemble(&Design::new(rho), &zero, None, Some(&mut k), &mut ws);
    k
}

/// Reference: a direct factorization of the stage with a link spring taken off and two
/// grounded springs added. Goal: `K_s⁻¹b` through the original factor within 1e-10 relative,
/// and `K_s x` from the update equal to the assembled `K_s x` within 1e-12.
#[test]
fn spring_update_matches_the_factorization_of_the_updated_model() {
    let stage = Stage::paper(24, 12, Kinematics::TotalLagrangian).unwrap();
    let base = &stage.model;
    let out = stage.output;
    let (a, b) = (stage.input_left, stage.input_right);
    let link = LinkSpring {
        terms: vec![(2 * out, 1.0), (2 * a, -0.5), (2 * b, -0.5)],
        stiffness: 4e6,
    };
    let mut bcs: BoundaryConditions = base.bcs().clone();
    bcs.links.push(link.clone());
    bcs.add_spring(2 * out + 1, 4e6);
    let design_model = Model::new(
        base.mesh().clone(),
        *base.material(),
        Kinematics::TotalLagrangian,
        bcs,
    )
    .unwrap();
    let mut stage_bcs: BoundaryConditions = base.bcs().clone();
    stage_bcs.add_spring(2 * a, 1e5).add_spring(2 * b, 0.9e5);
    let stage_model = Model::new(
        base.mesh().clone(),
        *base.material(),
        Kinematics::TotalLagrangian,
        stage_bcs,
    )
    .unwrap();
    let rho = stage.random_density(0.2, 1.0, 3, 1e-6);
    let kd = stiffness(&design_model, &rho);
    let ks = stiffness(&stage_model, &rho);
    let sym = SymbolicFactor::for_model(&design_model).unwrap();
    let mut fd = Factor::new(sym.clone());
    fd.factorize(&kd).unwrap();
    let mut ws = SolveWorkspace::new(&sym);
    let mut update = SpringUpdate::new(
        design_model.dofs(),
        &[
            LinkSpring {
                stiffness: -4e6,
                ..link
            },
            LinkSpring {
                terms: vec![(2 * out + 1, 1.0)],
                stiffness: -4e6,
            },
            LinkSpring {
                terms: vec![(2 * a, 1.0)],
                stiffness: 1e5,
            },
            LinkSpring {
                terms: vec![(2 * b, 1.0)],
                stiffness: 0.9e5,
            },
        ],
    );
    assert_eq!(update.rank(), 4);
    update.refactor(&fd, &mut ws).unwrap();
    let n = design_model.dofs().n_free();
    assert_eq!(n, stage_model.dofs().n_free());
    let rhs = random_vector(n, -1.0, 1.0, 9);
    let mut x = rhs.clone();
    update.solve(&fd, &mut x, &mut ws).unwrap();
    let ssym = SymbolicFactor::for_model(&stage_model).unwrap();
    let mut fs = Factor::new(ssym.clone());
    fs.factorize(&ks).unwrap();
    let mut y = rhs.clone();
    fs.solve_in_place(&mut y, &mut SolveWorkspace::new(&ssym))
        .unwrap();
    let norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
    let err = x
        .iter()
        .zip(&y)
        .map(|(p, q)| (p - q).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(err <= 1e-10 * norm, "K_s⁻¹b off by {:e}", err / norm);
    // K_s x = K_d x + V C Vᵀ x.
    let (mut kx, mut ksx) = (vec![0.0; n], vec![0.0; n]);
    kd.matvec(&rhs, &mut kx);
    update.add_product(&rhs, &mut kx);
    ks.matvec(&rhs, &mut ksx);
    let norm = ksx.iter().map(|v| v * v).sum::<f64>().sqrt();
    let err = kx
        .iter()
        .zip(&ksx)
        .map(|(p, q)| (p - q).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(err <= 1e-12 * norm, "K_s x off by {:e}", err / norm);
}

/// Reference: central differences of `aᵀK₀(ρ)a` (assembled at u = 0, total Lagrangian) and of
/// `aᵀM(ρ)a` (consistent mass with Du & Olhoff's interpolation) in each of a few densities.
/// Goal: the forms within 1e-7 relative.
#[test]
fn derivative_forms_match_central_differences() {
    let stage = Stage::paper(12, 6, Kinematics::TotalLagrangian).unwrap();
    let model = &stage.model;
    let ne = model.mesh().n_elements();
    let rho = random_vector(ne, 0.02, 1.0, 5);
    let interp = MassInterpolation::default();
    let (density, volume) = (2710.0, model.mesh().dx() * model.mesh().dy() * 0.01);
    let mut a = random_vector(model.n_dofs(), -1e-3, 1e-3, 11);
    for (d, v) in a.iter_mut().enumerate() {
        if model.dofs().is_fixed(d) {
            *v = 0.0;
        }
    }
    let mut ar = vec![0.0; model.dofs().n_free()];
    model.dofs().gather(&a, &mut ar);
    let quad = |m: &SparseMatrix| {
        let mut y = vec![0.0; ar.len()];
        m.matvec(&ar, &mut y);
        ar.iter().zip(&y).map(|(p, q)| p * q).sum::<f64>()
    };
    let mass_of = |r: &[f64]| {
        let mut me = vec![0.0; ne];
        interp.element_masses(r, density, volume, &mut me);
        consistent_mass(model, &me, &[]).unwrap()
    };
    let mut kf = vec![0.0; ne];
    model.stiffness_drho_forms(&Design::new(&rho), &a, &mut kf);
    let mut mf = vec![0.0; ne];
    consistent_mass_forms(model, &a, &mut mf);
    for e in [0, 7, 23, 40, 71] {
        let h = 1e-6;
        let (mut p, mut m) = (rho.clone(), rho.clone());
        p[e] += h;
        m[e] -= h;
        let fd_k = (quad(&stiffness(model, &p)) - quad(&stiffness(model, &m))) / (2.0 * h);
        assert!(
            (fd_k - kf[e]).abs() <= 1e-7 * fd_k.abs(),
            "K, element {e}: {fd_k} vs {}",
            kf[e]
        );
        let fd_m = (quad(&mass_of(&p)) - quad(&mass_of(&m))) / (2.0 * h);
        let an = interp.derivative(rho[e]) * density * volume * mf[e];
        assert!(
            (fd_m - an).abs() <= 1e-7 * fd_m.abs(),
            "M, element {e}: {fd_m} vs {an}"
        );
    }
}

/// Reference: Du & Olhoff (2007) write the interpolation below ρ_c = 0.1 as
/// `c₁ρ⁶ + c₂ρ⁷` with `c₁ = 6·10⁵`, `c₂ = −5·10⁶`. Goal: the same values to 1e-12, value and
/// slope continuous at ρ_c, and the slope equal to central differences.
#[test]
fn mass_interpolation_is_du_olhoff_and_c1() {
    let m = MassInterpolation::default();
    for rho in [0.0f64, 1e-3, 0.02, 0.05, 0.09, 0.0999] {
        let want = 6e5 * rho.powi(6) - 5e6 * rho.powi(7);
        assert!((m.relative_mass(rho) - want).abs() <= 1e-12, "m({rho})");
        let h = 1e-7;
        let fd = (m.relative_mass(rho + h) - m.relative_mass((rho - h).max(0.0)))
            / (rho + h - (rho - h).max(0.0));
        assert!((fd - m.derivative(rho)).abs() <= 1e-5, "m'({rho}): {fd}");
    }
    let c = m.cutoff;
    assert!((m.relative_mass(c - 1e-12) - c).abs() < 1e-10);
    assert!((m.derivative(c - 1e-12) - 1.0).abs() < 1e-9);
    assert_eq!(m.derivative(0.5), 1.0);
    assert!(m.validate().is_ok());
    let bad = MassInterpolation { exponent: 0.5, ..m };
    assert!(bad.validate().unwrap_err().to_string().contains("exponent"));
}
