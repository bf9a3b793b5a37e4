//! Reference: the average-acceleration Newmark rule (Newmark 1959) and HHT-α (Hilber, Hughes &
//! Taylor 1977) as analysed in Hughes, *The Finite Element Method* (1987), §9.3: for
//! `m ü + k u = 0` the average-acceleration amplification matrix is the Cayley transform of
//! the exact flow, so `u_n = u₀ cos(n θ)` exactly with `θ = 2 atan(ωΔt/2)` (period elongation,
//! no amplitude error) and `½ m v² + ½ k u²` is conserved to round-off for any linear undamped
//! system; HHT with α < 0 has the high-frequency spectral radius `(1 + α)/(1 − α)`.
//! Euler–Bernoulli clamped–free beam: `f₁ = (β₁L)²/(2πL²)·√(EI/(ρA))`, `β₁L = 1.8751`
//! (Blevins, *Formulas for Natural Frequency and Mode Shape*, 1979, Table 8-1).
//! Goal: the transient solver reproduces these known answers: the exact discrete solution of a
//! single DOF, energy conservation of a linear stage model to 1e-10 (and of the Total
//! Lagrangian model to 1e-6 at the working stroke), the cantilever's first period within 1 %
//! of Euler–Bernoulli with the predicted Newmark elongation between two steps, HHT's
//! dissipation, and the static limit of a slow load ramp on the nonlinear stage.
//! (The TL model's energy error is second order in Δt, not round-off: the trapezoidal rule
//! conserves energy exactly only for linear forces.)

use flexstage_fem::*;

/// One free DOF (node 2, x) of a single Q4 element, with a point mass: `m ü + k u = 0`.
fn single_dof() -> (Model, usize, f64) {
    let mesh = Mesh::new(0.01, 0.01, 0.01, 1, 1).unwrap();
    let mut bcs = BoundaryConditions::new();
    for n in 0..4 {
        bcs.fix_node(
            n,
            if n == 2 {
                Component::Y
            } else {
                Component::Both
            },
        );
    }
    let model = Model::new(mesh, Material::paper(), Kinematics::Linear, bcs).unwrap();
    let dof = 2 * 2;
    let rho = [1.0];
    let mut k = model.new_matrix();
    let mut ws = model.new_workspace();
    model.assemble(
        &Design::new(&rho),
        &model.zero_vector(),
        None,
        Some(&mut k),
        &mut ws,
    );
    let stiffness = k.get(0, 0);
    (model, dof, stiffness)
}

#[test]
fn single_dof_follows_the_exact_discrete_newmark_solution() {
    let m = 0.5;
    let (model, dof, k) = single_dof();
    let omega = (k / m).sqrt();
    let rho = [1.0];
    let mass = consistent_mass(&model, &[0.0], &[DofMass { dof, mass: m }]).unwrap();
    for steps_per_period in [8.0, 40.0] {
        let dt = std::f64::consts::TAU / omega / steps_per_period;
        let params = TransientParams {
            dt,
            ..TransientParams::default()
        };
        let mut tr = Transient::new(
            &model,
            Design::new(&rho),
            mass.clone(),
            RayleighDamping::none(),
            params,
        )
        .unwrap();
        let u0 = 1e-6;
        let mut u = model.zero_vector();
        u[dof] = u0;
        let zero = model.zero_vector();
        tr.set_state(0.0, &u, &zero, &zero).unwrap();
        let theta = newmark_frequency(omega, dt) * dt;
        let mut worst = 0.0f64;
        for n in 1..=200 {
            tr.step(&zero).unwrap();
            let exact = u0 * (n as f64 * theta).cos();
            worst = worst.max((tr.displacement()[dof] - exact).abs() / u0);
        }
        println!("{steps_per_period} steps/period: max |u - u0 cos(n theta)|/u0 = {worst:.2e}");
        assert!(worst < 1e-9, "{worst:e}");
        // The discrete frequency is below ω by ≈ (ωΔt)²/12.
        let w_bar = newmark_frequency(omega, dt);
        let rel = (omega - w_bar) / omega;
        let predicted = (omega * dt).powi(2) / 12.0;
        assert!(
            (rel - predicted).abs() < 0.1 * predicted,
            "{rel} vs {predicted}"
        );
    }
}

#[test]
fn hht_damps_the_highest_modes_at_the_predicted_rate() {
    let m = 0.5;
    let (model, dof, k) = single_dof();
    let omega = (k / m).sqrt();
    let rho = [1.0];
    let mass = consistent_mass(&model, &[0.0], &[DofMass { dof, mass: m }]).unwrap();
    let alpha = -0.1;
    let rho_inf = (1.0 + alpha) / (1.0 - alpha);
    let run = |dt: f64, steps: usize| -> Vec<f64> {
        let params = TransientParams {
            dt,
            hht_alpha: alpha,
            ..TransientParams::default()
        };
        let mut tr = Transient::new(
            &model,
            Design::new(&rho),
            mass.clone(),
            RayleighDamping::none(),
            params,
        )
        .unwrap();
        let mut u = model.zero_vector();
        u[dof] = 1e-6;
        let zero = model.zero_vector();
        tr.set_state(0.0, &u, &zero, &zero).unwrap();
        let mut e = vec![tr.energy()];
        for _ in 0..steps {
            tr.step(&zero).unwrap();
            e.push(tr.energy());
        }
        e
    };
    // ωΔt = 1000: the two principal roots coalesce at ρ∞, so the amplitude behaves as n·ρ∞ⁿ
    // (a Jordan block) and the energy as n²·ρ∞²ⁿ.
    let e = run(1000.0 / omega, 40);
    let ratio = (e[40] / e[20] / 4.0).powf(1.0 / 20.0);
    println!(
        "high frequency: energy ratio per step {ratio:.5}, rho_inf^2 = {:.5}",
        rho_inf * rho_inf
    );
    assert!((ratio - rho_inf * rho_inf).abs() < 0.005, "{ratio}");
    // ωΔt = 0.01: practically no dissipation over one period.
    let steps = (std::f64::consts::TAU / 0.01) as usize;
    let e = run(0.01 / omega, steps);
    let loss = 1.0 - e[steps] / e[0];
    println!("low frequency: energy loss over one period {loss:.2e}");
    assert!(loss > 0.0 && loss < 1e-4, "{loss:e}");
}

/// The paper's stage on a 48 × 24 mesh with random densities, the static solution under the
/// PEA load (+30, −30) µm, and element masses ρ_e·ρ0·V.
fn stage_release(kinematics: Kinematics) -> (samples::Stage, Vec<f64>, Vec<f64>, SparseMatrix) {
    let stage = samples::Stage::paper(48, 24, kinematics).unwrap();
    let rho = stage.random_density(0.05, 1.0, 3, 1e-3);
    let model = &stage.model;
    let sym = SymbolicFactor::for_model(model).unwrap();
    let mut ws = NewtonWorkspace::new(model, sym);
    let mut u = model.zero_vector();
    newton::solve(
        model,
        &Design::new(&rho),
        &stage.pea_load(30e-6, -30e-6),
        &mut u,
        &NewtonParams {
            residual_tol: 1e-12,
            ..NewtonParams::default()
        },
        &mut ws,
        None,
    )
    .unwrap();
    let v_e = model.mesh().dx() * model.mesh().dy() * model.mesh().thickness;
    let me: Vec<f64> = rho.iter().map(|r| r * 2710.0 * v_e).collect();
    let mass = consistent_mass(model, &me, &[]).unwrap();
    (stage, rho, u, mass)
}

fn free_vibration_energy_drift(kinematics: Kinematics, steps: usize, dt: f64) -> f64 {
    let (stage, rho, u0, mass) = stage_release(kinematics);
    let model = &stage.model;
    let params = TransientParams {
        dt,
        residual_tol: 1e-13,
        ..TransientParams::default()
    };
    let mut tr = Transient::new(
        model,
        Design::new(&rho),
        mass,
        RayleighDamping::none(),
        params,
    )
    .unwrap();
    let zero = model.zero_vector();
    tr.set_state(0.0, &u0, &zero, &zero).unwrap();
    let e0 = tr.energy();
    let mut drift = 0.0f64;
    for _ in 0..steps {
        tr.step(&zero).unwrap();
        drift = drift.max((tr.energy() - e0).abs() / e0);
    }
    println!(
        "{kinematics:?}: {steps} steps of {dt:e} s, max energy drift {drift:.2e}, {:?}",
        tr.stats()
    );
    drift
}

#[test]
fn linear_undamped_free_vibration_conserves_energy_to_round_off() {
    let drift = free_vibration_energy_drift(Kinematics::Linear, 300, 2e-6);
    assert!(drift < 1e-10, "{drift:e}");
}

/// Energy drift of the Total Lagrangian stage (uniform density 0.5, input plates of 42 g on
/// the PEA nodes as in Table 4) released from its static deflection under a uniform body
/// load that moves the output by ≈ 66 µm, over 1 ms.
fn total_lagrangian_drift(dt: f64) -> f64 {
    let stage = samples::Stage::paper(48, 24, Kinematics::TotalLagrangian).unwrap();
    let model = &stage.model;
    let rho = stage.uniform_density(0.5, 1e-3);
    let v_e = model.mesh().dx() * model.mesh().dy() * model.mesh().thickness;
    let me: Vec<f64> = rho.iter().map(|r| r * 2710.0 * v_e).collect();
    let plates = [
        DofMass {
            dof: 2 * stage.input_left,
            mass: 0.042,
        },
        DofMass {
            dof: 2 * stage.input_right,
            mass: 0.042,
        },
    ];
    let mass = consistent_mass(model, &me, &plates).unwrap();
    let mut load = rigid_body_load(model, &me, &plates, 1).unwrap();
    load.iter_mut().for_each(|x| *x *= 3e4);
    let sym = SymbolicFactor::for_model(model).unwrap();
    let mut ws = NewtonWorkspace::new(model, sym);
    let mut u0 = model.zero_vector();
    let np = NewtonParams {
        residual_tol: 1e-12,
        ..NewtonParams::default()
    };
    newton::solve(
        model,
        &Design::new(&rho),
        &load,
        &mut u0,
        &np,
        &mut ws,
        None,
    )
    .unwrap();
    let params = TransientParams {
        dt,
        residual_tol: 1e-12,
        ..TransientParams::default()
    };
    let mut tr = Transient::new(
        model,
        Design::new(&rho),
        mass,
        RayleighDamping::none(),
        params,
    )
    .unwrap();
    let zero = model.zero_vector();
    tr.set_state(0.0, &u0, &zero, &zero).unwrap();
    let e0 = tr.energy();
    let mut drift = 0.0f64;
    for _ in 0..(1e-3 / dt).round() as usize {
        tr.step(&zero).unwrap();
        drift = drift.max((tr.energy() - e0).abs() / e0);
    }
    println!(
        "Total Lagrangian, output {:.1} µm, dt {dt:e}: max energy drift {drift:.2e}, {:?}",
        u0[2 * stage.output + 1] * 1e6,
        tr.stats()
    );
    drift
}

#[test]
fn total_lagrangian_free_vibration_conserves_energy_to_1e_6() {
    // The trapezoidal rule does not conserve energy exactly for nonlinear forces; its error
    // is second order in Δt.
    let coarse = total_lagrangian_drift(4e-6);
    let fine = total_lagrangian_drift(2e-6);
    assert!(fine < 1e-6, "{fine:e}");
    let order = (coarse / fine).log2();
    println!("observed order {order:.2}");
    assert!(order > 1.7, "{order}");
}

/// Period of the tip's free vibration after releasing a static tip load, from the mean
/// spacing of its upward zero crossings (linear interpolation) over `periods` periods.
fn cantilever_period(dt_per_period: f64, periods: usize) -> (f64, f64) {
    let (l, h, t) = (0.2, 0.01, 0.005);
    let mat = Material {
        e0: 73e9,
        e_min: 1e3,
        nu: 0.33,
        penalty: 3.0,
    };
    let c = samples::Cantilever::new(mat, Kinematics::Linear, l, h, t, 160, 8).unwrap();
    let model = &c.model;
    let rho = vec![1.0; model.mesh().n_elements()];
    let me = vec![2710.0 * model.mesh().dx() * model.mesh().dy() * t; rho.len()];
    let mass = consistent_mass(model, &me, &[]).unwrap();
    let ei_rho_a = 73e9 * h * h / (12.0 * 2710.0);
    let f_eb = 1.875_104_068_711_961f64.powi(2) / (std::f64::consts::TAU * l * l) * ei_rho_a.sqrt();
    let dt = 1.0 / f_eb / dt_per_period;
    let params = TransientParams {
        dt,
        ..TransientParams::default()
    };
    // Static deflection under a tip load as the initial shape.
    let sym = SymbolicFactor::for_model(model).unwrap();
    let mut ws = NewtonWorkspace::new(model, sym);
    let mut u0 = model.zero_vector();
    newton::solve(
        model,
        &Design::new(&rho),
        &c.tip_load(0.0, -1.0),
        &mut u0,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap();
    let mut tr = Transient::new(
        model,
        Design::new(&rho),
        mass,
        RayleighDamping::none(),
        params,
    )
    .unwrap();
    let zero = model.zero_vector();
    tr.set_state(0.0, &u0, &zero, &zero).unwrap();
    let tip = 2 * c.tip_node + 1;
    let mut prev = tr.displacement()[tip];
    let mut crossings = Vec::new();
    let steps = (periods as f64 * dt_per_period * 1.02) as usize + 2;
    for _ in 0..steps {
        tr.step(&zero).unwrap();
        let now = tr.displacement()[tip];
        if prev < 0.0 && now >= 0.0 {
            let frac = -prev / (now - prev);
            crossings.push(tr.time() - dt + frac * dt);
        }
        prev = now;
    }
    let n = crossings.len() - 1;
    ((crossings[n] - crossings[0]) / n as f64, 1.0 / f_eb)
}

#[test]
fn cantilever_first_period_matches_euler_bernoulli() {
    let (t100, t_eb) = cantilever_period(100.0, 10);
    let (t50, _) = cantilever_period(50.0, 10);
    let err = t100 / t_eb - 1.0;
    println!(
        "period {t100:.6e} s, Euler-Bernoulli {t_eb:.6e} s: {:.3} %",
        100.0 * err
    );
    // 160 × 8 full-integration Q4 is slightly too stiff: the period is a little short.
    assert!(err.abs() < 0.01, "{err}");
    // Halving the steps per period lengthens the period by the Newmark elongation.
    let w = std::f64::consts::TAU / t100;
    let predicted =
        (w / newmark_frequency(w, t_eb / 50.0)) / (w / newmark_frequency(w, t_eb / 100.0));
    let measured = t50 / t100;
    println!("T(50)/T(100) = {measured:.6}, predicted {predicted:.6}");
    assert!(
        (measured - predicted).abs() < 2e-4,
        "{measured} vs {predicted}"
    );
}

#[test]
fn slow_load_ramp_reaches_the_nonlinear_static_solution() {
    let (stage, rho, u_static, mass) = stage_release(Kinematics::TotalLagrangian);
    let model = &stage.model;
    let damping = RayleighDamping::from_ratios([2000.0, 20000.0], [0.2, 0.2]).unwrap();
    let params = TransientParams {
        dt: 1e-5,
        ..TransientParams::default()
    };
    let mut tr = Transient::new(model, Design::new(&rho), mass, damping, params).unwrap();
    let full = stage.pea_load(30e-6, -30e-6);
    let mut p = model.zero_vector();
    let ramp = 300;
    for n in 1..=ramp + 300 {
        let s = (n as f64 / ramp as f64).min(1.0);
        let w = s * s * (3.0 - 2.0 * s);
        for (pi, fi) in p.iter_mut().zip(&full) {
            *pi = w * fi;
        }
        tr.step(&p).unwrap();
    }
    let out = 2 * stage.output + 1;
    let rel = (tr.displacement()[out] - u_static[out]).abs() / u_static[out].abs();
    println!(
        "output y: transient {:.6e}, static {:.6e}, rel {rel:.2e}; {:?}",
        tr.displacement()[out],
        u_static[out],
        tr.stats()
    );
    assert!(rel < 1e-4, "{rel}");
}
