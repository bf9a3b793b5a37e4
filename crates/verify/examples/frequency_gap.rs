//! Where the body-fitted first frequency and the design's part: the design's stage
//! eigenproblem (`flexstage_topopt::stage_modes`) on the design mesh, on the same density
//! field thresholded at ½, on the design mesh refined `n × n` (the same piecewise-constant
//! field: the discretization of the design model; the bilinear field of the element centroids
//! that the outline contours, thresholded at ½ per sub-element: the outline's geometry in
//! pixels of `h/n`), the design mesh with point ports (each PEA on its node, the design model
//! before the PEA ports became faces), and the body-fitted T6 model of the exported outline
//! with the PEA ports over their faces (the design's port model) and with point ports (each
//! port on its nearest boundary node).
//!
//! ```text
//! cargo run --release -p flexstage-verify --example frequency_gap -- paper design.json [PAYLOAD_KG]
//! ```
//!
//! `REFINE=2,3` (the default) names the refinements, `REFINE=` skips them; `NO_PLATES=1`
//! takes the input plates' masses off both models.

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{ModalParams, Problem, stage_modes};
use flexstage_verify::outline::Outline;
use flexstage_verify::{VerifyParams, verify};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// The stage's lowest frequencies of `rho` on the scenario `s`.
fn stage(s: &Scenario, rho: &[f64]) -> Res<Vec<f64>> {
    let problem = Problem::from_scenario(s, None)?;
    Ok(stage_modes(&problem, rho, &ModalParams::default(), false)?.frequencies)
}

/// The element-centroid field of `rho` (fem order, `nl × nw`) sampled bilinearly at `(x, y)`
/// in element units (centroid of element `(i, j)` at `(i + ½, j + ½)`), void outside, as the
/// outline's marching squares sees it.
fn bilinear(rho: &[f64], nl: usize, nw: usize, x: f64, y: f64) -> f64 {
    let at = |i: isize, j: isize| {
        if i < 0 || j < 0 || i >= nl as isize || j >= nw as isize {
            0.0
        } else {
            rho[i as usize * nw + j as usize]
        }
    };
    let (u, v) = (x - 0.5, y - 0.5);
    let (i, j) = (u.floor() as isize, v.floor() as isize);
    let (a, b) = (u - i as f64, v - j as f64);
    (1.0 - a) * (1.0 - b) * at(i, j)
        + a * (1.0 - b) * at(i + 1, j)
        + (1.0 - a) * b * at(i, j + 1)
        + a * b * at(i + 1, j + 1)
}

/// The scenario on a mesh refined `n × n`, same regions (boxes in metres), and the two
/// refined fields: the same piecewise-constant one and the thresholded bilinear one.
fn refined(s: &Scenario, rho: &[f64], n: usize) -> (Scenario, Vec<f64>, Vec<f64>) {
    let (nl, nw) = (s.mesh.nl, s.mesh.nw);
    let mut r = s.clone();
    r.mesh.nl *= n;
    r.mesh.nw *= n;
    let void = s.optimization.rho_min;
    let mut same = Vec::with_capacity(rho.len() * n * n);
    let mut smooth = Vec::with_capacity(rho.len() * n * n);
    for i in 0..nl * n {
        for j in 0..nw * n {
            same.push(rho[(i / n) * nw + j / n]);
            let (x, y) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            smooth.push(if bilinear(rho, nl, nw, x, y) >= 0.5 {
                1.0
            } else {
                void
            });
        }
    }
    (r, same, smooth)
}

/// The design's stage eigenproblem with point ports, the design model before the PEA ports
/// became faces: the PEA spring, the input plate's spring and mass on the port's node's x DOF.
fn point_ports(s: &Scenario, rho: &[f64]) -> Res<f64> {
    use flexstage_fem::{DofMass, LinkSpring, Model};
    let mut problem = Problem::from_scenario(s, None)?;
    let ports = problem.inputs.clone();
    let mut bcs = problem.model.bcs().clone();
    let m_in = [s.stage.guess.m_in1, s.stage.guess.m_in2];
    for p in &ports {
        bcs.links.retain(|l| l.terms != p.terms(1.0));
        bcs.add_spring(p.dof, p.stiffness);
        for l in &mut bcs.links {
            let before = l.terms.len();
            l.terms.retain(|t| !p.face.iter().any(|f| f.0 == t.0));
            if l.terms.len() < before {
                l.terms.push((p.dof, -0.5));
            }
        }
    }
    let m = &problem.model;
    problem.model = Model::new(m.mesh().clone(), *m.material(), m.kinematics(), bcs)?;
    let dynamics = problem.dynamics.as_mut().ok_or("no stage dynamics")?;
    let faces: Vec<usize> = ports
        .iter()
        .flat_map(|p| p.face.iter().map(|t| t.0))
        .collect();
    dynamics.point_masses.retain(|pm| !faces.contains(&pm.dof));
    for (p, m) in ports.iter().zip(m_in) {
        dynamics.point_masses.push(DofMass {
            dof: p.dof,
            mass: m,
        });
        for sp in &mut dynamics.springs {
            if sp.terms == p.terms(1.0) {
                *sp = LinkSpring {
                    terms: vec![(p.dof, 1.0)],
                    stiffness: sp.stiffness,
                };
            } else {
                let before = sp.terms.len();
                sp.terms.retain(|t| !p.face.iter().any(|f| f.0 == t.0));
                if sp.terms.len() < before {
                    sp.terms.push((p.dof, -0.5));
                }
            }
        }
    }
    Ok(stage_modes(&problem, rho, &ModalParams::default(), false)?.frequencies[0])
}

fn mass(s: &Scenario, rho: &[f64]) -> f64 {
    let v = s.mesh.length * s.mesh.width * s.mesh.thickness / rho.len() as f64;
    rho.iter().sum::<f64>() * v * s.material.density
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: frequency_gap quick|paper DESIGN.json [PAYLOAD_KG]";
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or(usage)?;
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(args.get(2).ok_or(usage)?)?)?;
    let rho: Vec<f64> = serde_json::from_value(json["rho"].clone())?;
    let mut s = Scenario::preset(preset);
    if let Some(p) = args.get(3) {
        s.output.payload = p.parse()?;
    }
    let plates = std::env::var("NO_PLATES").is_err();
    if !plates {
        s.stage.guess.m_in1 = 1e-12;
        s.stage.guess.m_in2 = 1e-12;
    }
    let f0 = stage(&s, &rho)?;
    let pct = |f: f64| 100.0 * (f / f0[0] - 1.0);
    println!(
        "design mesh {}x{}: f {:.1?} Hz, mass {:.2} g",
        s.mesh.nl,
        s.mesh.nw,
        &f0[..3],
        1e3 * mass(&s, &rho)
    );
    let crisp: Vec<f64> = rho
        .iter()
        .map(|&r| {
            if r >= 0.5 {
                1.0
            } else {
                s.optimization.rho_min
            }
        })
        .collect();
    let f = stage(&s, &crisp)?[0];
    println!(
        "thresholded at 1/2: f1 {f:.1} Hz ({:+.2} %), mass {:.2} g",
        pct(f),
        1e3 * mass(&s, &crisp)
    );
    let f = point_ports(&s, &rho)?;
    println!(
        "design mesh, point ports (the PEA at its node): f1 {f:.1} Hz ({:+.2} %)",
        pct(f)
    );
    let levels: Vec<usize> = std::env::var("REFINE")
        .unwrap_or_else(|_| "2,3".into())
        .split(',')
        .filter_map(|t| t.parse().ok())
        .collect();
    for n in levels {
        let (r, same, smooth) = refined(&s, &rho, n);
        let a = stage(&r, &same)?[0];
        let b = stage(&r, &smooth)?[0];
        println!(
            "refined {n}x{n}: same field f1 {a:.1} Hz ({:+.2} %); outline field f1 {b:.1} Hz \
             ({:+.2} %), mass {:.2} g",
            pct(a),
            pct(b),
            1e3 * mass(&r, &smooth)
        );
    }
    let (nl, nw) = (s.mesh.nl, s.mesh.nw);
    let (dx, dy) = s.mesh.element_size();
    let outline = Outline::from_fem_order(nl, nw, dx, dy, 0.5, 10, &rho)?.refined(0.05e-3);
    let h = dx.max(dy);
    // `None`: point ports (one boundary node per port). The PEA ports take their faces; the
    // radius applies to the output.
    let radii: [Option<f64>; 2] = [None, Some(1.5)];
    for radius in radii {
        let p = VerifyParams {
            port_radius: radius.map(|r| r * h),
            point_ports: radius.is_none(),
            refine_check: false,
            plate_masses: plates,
            ..VerifyParams::from_limits(&s.limits)
        };
        let v = verify(&s, &rho, &outline.loops, &p)?;
        let b = &v.body_fitted;
        let d = v
            .design_mesh
            .as_ref()
            .map_or(f64::NAN, |d| d.first_frequency);
        let ports = radius.map_or("point ports".into(), |r| format!("ports within {r} h"));
        println!(
            "body-fitted, {ports}: f {:.1?} Hz ({:+.2} %), mass {:.2} g, {} elements; \
             verify's design-mesh value {d:.1} Hz",
            &b.frequencies,
            pct(b.frequencies[0]),
            1e3 * b.mass,
            b.elements
        );
    }
    Ok(())
}
