//! Verification of the body-fitted T6 model against known answers. Each test names its source
//! and states its goal. Run in release: `cargo test -p flexstage-verify --release`.

use flexstage_verify::fe::{Attachment, Cholesky, FeModel};
use flexstage_verify::geometry::Geometry;
use flexstage_verify::mesh::{Sizing, TriMesh, body_fitted};
use flexstage_verify::modal::lowest_frequencies;
use flexstage_verify::samples::{
    self, ALUMINIUM, howland_kt_gross, notch_hinge, paros_weisbord_compliance, paros_weisbord_thin,
    rectangle,
};
use flexstage_verify::t6::{PlaneStress, von_mises};

const THICKNESS: f64 = 0.01;

fn material() -> PlaneStress {
    PlaneStress {
        youngs_modulus: ALUMINIUM.0,
        poisson_ratio: ALUMINIUM.1,
        thickness: THICKNESS,
    }
}

fn sizing(h_max: f64, across: f64) -> Sizing {
    Sizing {
        elements_across: across,
        min_element: 5e-6,
        max_element: h_max,
        segment_angle: 15f64.to_radians(),
        gradation: 0.3,
        angle_limit_deg: 25.0,
        max_nodes: 2_000_000,
    }
}

fn mesh(loops: Vec<Vec<[f64; 2]>>, s: &Sizing) -> TriMesh {
    body_fitted(&Geometry::new(loops).unwrap(), s).unwrap()
}

/// Boundary nodes with `pred(x, y)`.
fn boundary_nodes(m: &TriMesh, pred: impl Fn([f64; 2]) -> bool) -> Vec<usize> {
    let mut v: Vec<usize> = m
        .boundary
        .iter()
        .flatten()
        .copied()
        .filter(|&n| pred(m.nodes[n]))
        .collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Solves with one force `f` on component `c` of each loaded attachment.
fn solve(model: &FeModel, loads: &[(usize, usize, f64)]) -> Vec<f64> {
    let springs = vec![[0.0; 2]; model.attachments.len()];
    let k = model.stiffness(&springs, &[]);
    let factor = Cholesky::new(&k).unwrap();
    let mut rhs = vec![0.0; model.n()];
    for &(a, c, f) in loads {
        model.port_load(a, c, f, &mut rhs);
    }
    factor.solve_in_place(&mut rhs, 1);
    model.expand(&rhs)
}

fn peak_von_mises(model: &FeModel, u: &[f64]) -> (f64, [f64; 2]) {
    let nodal = model.nodal_average(&model.element_stresses(u));
    let (i, s) = nodal
        .iter()
        .enumerate()
        .max_by(|a, b| von_mises(*a.1).total_cmp(&von_mises(*b.1)))
        .unwrap();
    (von_mises(*s), model.mesh.nodes[i])
}

#[test]
fn irons_patch_test_uniform_tension_on_an_unstructured_mesh() {
    // Reference: Irons' patch test (Irons & Razzaque 1972): a uniform traction σ0 on a plate
    // must give σxx = σ0, σyy = τxy = 0 in every element of any mesh (here a graded,
    // unstructured one around a small interior feature size). Goal: exact to 1e-9.
    let (w, h, sigma) = (20e-3, 10e-3, 5e6);
    let m = mesh(vec![rectangle(0.0, 0.0, w, h)], &sizing(1.5e-3, 4.0));
    let left = boundary_nodes(&m, |p| p[0].abs() < 1e-12);
    let mut fixed: Vec<(usize, usize)> = left.iter().map(|&n| (n, 0)).collect();
    let corner = *left.iter().find(|&&n| m.nodes[n][1].abs() < 1e-12).unwrap();
    fixed.push((corner, 1));
    let right = Attachment::on_boundary_where(&m, "right", [w, 0.5 * h], [false; 2], |p| {
        (p[0] - w).abs() < 1e-12
    })
    .unwrap();
    let model = FeModel::new(m, material(), vec![right], fixed).unwrap();
    let u = solve(&model, &[(0, 0, sigma * h * THICKNESS)]);
    for s in model.element_stresses(&u).iter().flatten() {
        assert!((s[0] - sigma).abs() < 1e-9 * sigma, "σxx {}", s[0]);
        assert!(
            s[1].abs() < 1e-9 * sigma && s[2].abs() < 1e-9 * sigma,
            "{s:?}"
        );
    }
}

#[test]
fn timoshenko_cantilever_tip_deflection() {
    // Reference: Timoshenko beam theory for a clamped–free beam with a tip shear load P:
    // δ = P L³ / (3 E I) + P L / (κ G A), κ = 10(1+ν)/(12+11ν) (Cowper 1966). Goal: the
    // body-fitted T6 model (root fully clamped, load as a uniform shear traction on the
    // free end) within 1 %, L/h = 10.
    let (l, h, p) = (100e-3, 10e-3, 100.0);
    let m = mesh(vec![rectangle(0.0, 0.0, l, h)], &sizing(2e-3, 4.0));
    let root = boundary_nodes(&m, |q| q[0].abs() < 1e-12);
    let fixed: Vec<(usize, usize)> = root.iter().flat_map(|&n| [(n, 0), (n, 1)]).collect();
    let tip = Attachment::on_boundary_where(&m, "tip", [l, 0.5 * h], [false; 2], |q| {
        (q[0] - l).abs() < 1e-12
    })
    .unwrap();
    let model = FeModel::new(m, material(), vec![tip], fixed).unwrap();
    let u = solve(&model, &[(0, 1, p)]);
    let delta = model.attachments[0].mean(&u, 1);
    let (e, nu) = (ALUMINIUM.0, ALUMINIUM.1);
    let i = THICKNESS * h.powi(3) / 12.0;
    let g = e / (2.0 * (1.0 + nu));
    let kappa = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
    let exact = p * l.powi(3) / (3.0 * e * i) + p * l / (kappa * g * h * THICKNESS);
    let err = (delta - exact) / exact;
    println!(
        "tip deflection {delta:e} vs Timoshenko {exact:e}: {:+.3} %",
        100.0 * err
    );
    assert!(err.abs() < 0.01, "{:+.3} %", 100.0 * err);
}

#[test]
fn kirsch_howland_plate_with_a_hole_stress_concentration() {
    // Reference: Kirsch (1898): σ_max = 3 σ at a circular hole in an infinite plate; for a
    // strip of width W with a central hole of diameter d = 0.2 W, Howland (1930) through
    // Heywood's fit (Peterson's Chart 4.1): K_t,gross = 3.15. Goal: the peak nodal von Mises
    // (pure tension at the hole's edge) within 2 % of K_t σ; the plate is 4 W long so the
    // end effects have decayed (Saint-Venant).
    let (w, len, d, sigma) = (50e-3, 200e-3, 10e-3, 1e6);
    let hole = samples::circle([0.5 * len, 0.5 * w], 0.5 * d, 400, false);
    let m = mesh(
        vec![rectangle(0.0, 0.0, len, w), hole],
        &sizing(2.5e-3, 4.0),
    );
    let left = boundary_nodes(&m, |p| p[0].abs() < 1e-12);
    let mut fixed: Vec<(usize, usize)> = left.iter().map(|&n| (n, 0)).collect();
    let mid = *left
        .iter()
        .min_by(|&&a, &&b| {
            (m.nodes[a][1] - 0.5 * w)
                .abs()
                .total_cmp(&(m.nodes[b][1] - 0.5 * w).abs())
        })
        .unwrap();
    fixed.push((mid, 1));
    let right = Attachment::on_boundary_where(&m, "right", [len, 0.5 * w], [false; 2], |p| {
        (p[0] - len).abs() < 1e-12
    })
    .unwrap();
    let model = FeModel::new(m, material(), vec![right], fixed).unwrap();
    let u = solve(&model, &[(0, 0, sigma * w * THICKNESS)]);
    let (peak, at) = peak_von_mises(&model, &u);
    let kt = howland_kt_gross(d, w);
    assert!((kt - 3.15).abs() < 0.01, "Howland/Heywood K_t {kt}");
    let err = (peak / sigma - kt) / kt;
    println!(
        "K_t FE {:.4} vs Howland {kt:.4} ({:+.2} %) at {at:?}",
        peak / sigma,
        100.0 * err
    );
    assert!(err.abs() < 0.02, "{:+.2} %", 100.0 * err);
    // At the top or bottom of the hole.
    assert!((at[0] - 0.5 * len).abs() < 0.1 * d, "{at:?}");
}

/// Rotation of the free block of a notch hinge under a pure moment `m_z`, and the peak von
/// Mises stress (left block clamped; the moment as opposite uniform tractions on the upper
/// and lower halves of the free end).
fn notch_hinge_response(r: f64, t: f64, across: f64) -> (f64, f64, f64) {
    let block = 2.0 * r;
    let m = mesh(
        vec![notch_hinge(r, t, block, 400)],
        &sizing(0.5 * r, across),
    );
    let x0 = -r - block;
    let x1 = r + block;
    let root = boundary_nodes(&m, |p| (p[0] - x0).abs() < 1e-12);
    let fixed: Vec<(usize, usize)> = root.iter().flat_map(|&n| [(n, 0), (n, 1)]).collect();
    let h2 = 0.5 * t + r;
    // Each half's port at its centroid: its force is the uniform traction on the half.
    let end = |name: &str, upper: bool| {
        let y = if upper { 0.5 * h2 } else { -0.5 * h2 };
        Attachment::on_boundary_where(&m, name, [x1, y], [false; 2], |p| {
            (p[0] - x1).abs() < 1e-12 && (p[1] > 0.0) == upper
        })
        .unwrap()
    };
    let (up, low) = (end("upper", true), end("lower", false));
    let model = FeModel::new(m, material(), vec![up, low], fixed).unwrap();
    // Forces ±F at the centroids y = ±h2/2 of the two halves: M = F · h2.
    let f = 1.0;
    let u = solve(&model, &[(0, 0, -f), (1, 0, f)]);
    let theta = (model.attachments[1].mean(&u, 0) - model.attachments[0].mean(&u, 0)) / h2;
    let (peak, _) = peak_von_mises(&model, &u);
    let moment = f * h2;
    (theta / moment, peak / moment, model.mesh.nodes.len() as f64)
}

#[test]
fn paros_weisbord_circular_notch_hinge_rotational_stiffness() {
    // Reference: Paros & Weisbord (1965): the rotational compliance of a circular-notch hinge
    // by beam theory, θ/M = ∫ 12 dx / (E b h(x)³) (evaluated here by quadrature); for
    // t ≪ R it tends to 9π√R / (2 E b t^{5/2}). Beam theory neglects the shear and the
    // two-dimensional stress state at the notch; finite-element studies (Yong, Lu & Handley
    // 2008, Precision Engineering 32:63–70) find the full equation within a few per cent of
    // FEA for t/R ≈ 0.1. Goal: the body-fitted compliance within 5 % of the full
    // Paros–Weisbord equation at t/R = 0.1, and the thin-hinge limit consistent with it.
    let (r, t) = (5e-3, 0.5e-3);
    let (c_fe, _, _) = notch_hinge_response(r, t, 4.0);
    let c_pw = paros_weisbord_compliance(ALUMINIUM.0, THICKNESS, r, t);
    let c_thin = paros_weisbord_thin(ALUMINIUM.0, THICKNESS, r, t);
    let err = (c_fe - c_pw) / c_pw;
    println!(
        "θ/M: FE {c_fe:.4e}, Paros–Weisbord {c_pw:.4e} ({:+.2} %), thin limit {c_thin:.4e}",
        100.0 * err
    );
    assert!(err.abs() < 0.05, "{:+.2} %", 100.0 * err);
    assert!((c_thin - c_pw).abs() < 0.1 * c_pw);
}

#[test]
fn notch_hinge_peak_stress_converges_as_the_size_function_is_refined() {
    // Reference: a converging discretization — the peak von Mises of a notch hinge under a
    // pure moment changes less with each halving of the element size at the neck, and is
    // close to the beam-theory bending stress 6M/(b t²) times a notch factor above 1.
    // Goal: successive changes shrink, the last below 1 %, and 1 < K_t < 1.3 at t/R = 0.1.
    let (r, t) = (5e-3, 0.5e-3);
    let peaks: Vec<f64> = [2.0, 4.0, 8.0]
        .iter()
        .map(|&n| notch_hinge_response(r, t, n).1)
        .collect();
    let d1 = (peaks[1] - peaks[0]).abs() / peaks[2];
    let d2 = (peaks[2] - peaks[1]).abs() / peaks[2];
    let nominal = 6.0 / (THICKNESS * t * t);
    println!(
        "peak σ/M: {peaks:?}; changes {d1:.4} then {d2:.4}; K_t {:.3}",
        peaks[2] / nominal
    );
    assert!(d2 < d1 && d2 < 0.01, "{d1} {d2}");
    let kt = peaks[2] / nominal;
    assert!(kt > 1.0 && kt < 1.3, "K_t {kt}");
}

#[test]
fn euler_bernoulli_cantilever_first_frequency() {
    // Reference: clamped–free Euler–Bernoulli beam, f1 = (β1 L)² / (2π L²) √(E I / (ρ A)),
    // β1 L = 1.8751; at L/h = 20 shear and rotary inertia lower it by about 0.3 %
    // (Timoshenko). Goal: the body-fitted first frequency with the consistent mass matrix
    // within 1 % of Euler–Bernoulli and not above it.
    let (l, h) = (200e-3, 10e-3);
    let m = mesh(vec![rectangle(0.0, 0.0, l, h)], &sizing(2e-3, 4.0));
    let root = boundary_nodes(&m, |q| q[0].abs() < 1e-12);
    let fixed: Vec<(usize, usize)> = root.iter().flat_map(|&n| [(n, 0), (n, 1)]).collect();
    let model = FeModel::new(m, material(), vec![], fixed).unwrap();
    let k = model.stiffness(&[], &[]);
    let factor = Cholesky::new(&k).unwrap();
    let mass = model.mass(ALUMINIUM.2, &[]);
    let f = lowest_frequencies(&k, &factor, &mass, 2).unwrap();
    let (e, rho) = (ALUMINIUM.0, ALUMINIUM.2);
    let i = THICKNESS * h.powi(3) / 12.0;
    let a = THICKNESS * h;
    let beta = 1.875_104_068_711_961;
    let exact = beta * beta / (2.0 * std::f64::consts::PI * l * l) * (e * i / (rho * a)).sqrt();
    let err = (f.hz[0] - exact) / exact;
    println!(
        "f1 {:.2} Hz vs Euler–Bernoulli {exact:.2} Hz ({:+.3} %)",
        f.hz[0],
        100.0 * err
    );
    assert!(err < 1e-4 && err > -0.01, "{:+.3} %", 100.0 * err);
    assert!(f.residuals.iter().all(|&r| r < 1e-6), "{:?}", f.residuals);
}

#[test]
fn a_port_moves_with_its_point_and_a_pinned_block_rotates_at_the_rigid_body_frequency() {
    // Reference: rigid-body kinematics and dynamics. A port's displacement is its point's in
    // the nodes' least-squares rigid motion (fe module docs): a rigid translation moves it by
    // the translation, a rigid rotation about its point not at all, even when its nodes lie to
    // one side of the point. A stiff square block (side L, mass M) pinned at the middle of its
    // left edge by a port holding both components, with a grounded y-spring k and a point mass
    // m on a port at its top-right corner (nodes on two edges), rotates about the pin with
    // ω² = k L² / (I_pin + m |p_B − p_A|²), I_pin = M L²/6 + M (L/2)². Goal: the coefficients
    // to 1e-12 and the first frequency within 1e-4 (the block's elastic modes are ~1000×
    // higher). The plain weighted mean of the nodes fails the rotation check (its nodes'
    // centroid is not the pin).
    let l = 10e-3;
    let m = mesh(vec![rectangle(0.0, 0.0, l, l)], &sizing(1e-3, 4.0));
    let pin_at = [0.0, 0.5 * l];
    let pin = Attachment::on_boundary_where(&m, "pin", pin_at, [true, true], |q| {
        q[0].abs() < 1e-12 && q[1] >= 0.5 * l && q[1] <= 0.8 * l
    })
    .unwrap();
    let corner_at = [l, l];
    let corner = Attachment::on_boundary_where(&m, "corner", corner_at, [false; 2], |q| {
        (q[0] - l).hypot(q[1] - l) < 0.3 * l
    })
    .unwrap();
    for att in [&pin, &corner] {
        let p = att.point;
        let u_of = |f: &dyn Fn([f64; 2]) -> [f64; 2]| {
            let mut u = vec![0.0; 2 * m.nodes.len()];
            for (n, x) in m.nodes.iter().enumerate() {
                let v = f(*x);
                u[2 * n] = v[0];
                u[2 * n + 1] = v[1];
            }
            u
        };
        let t = u_of(&|_| [2e-6, -3e-6]);
        assert!((att.mean(&t, 0) - 2e-6).abs() < 1e-18 && (att.mean(&t, 1) + 3e-6).abs() < 1e-18);
        let theta = 1e-3;
        let r = u_of(&|x| [-theta * (x[1] - p[1]), theta * (x[0] - p[0])]);
        let (rx, ry) = (att.mean(&r, 0), att.mean(&r, 1));
        assert!(
            rx.abs() < 1e-12 * theta * l && ry.abs() < 1e-12 * theta * l,
            "{rx} {ry}"
        );
    }
    let (k, point_mass) = (1e4, 1e-3);
    let model = FeModel::new(m, material(), vec![pin, corner], vec![]).unwrap();
    let stiffness = model.stiffness(&[[0.0; 2], [0.0, k]], &[]);
    let factor = Cholesky::new(&stiffness).unwrap();
    let mass = model.mass(ALUMINIUM.2, &[0.0, point_mass]);
    let f = lowest_frequencies(&stiffness, &factor, &mass, 2).unwrap();
    let block = ALUMINIUM.2 * l * l * THICKNESS;
    let arm2 = (corner_at[0] - pin_at[0]).powi(2) + (corner_at[1] - pin_at[1]).powi(2);
    let inertia = block * l * l / 6.0 + block * 0.25 * l * l + point_mass * arm2;
    let exact = (k * l * l / inertia).sqrt() / std::f64::consts::TAU;
    let err = f.hz[0] / exact - 1.0;
    println!(
        "pinned block: f1 {:.4} Hz vs rigid body {exact:.4} Hz ({err:+.2e}), f2 {:.0} Hz",
        f.hz[0], f.hz[1]
    );
    assert!(err.abs() < 1e-4, "{err:e}");
}
