//! The optimization problem of paper Eq. (5): the FE model with supports, PEA springs, passive
//! regions and ports, the load cases, the objective and the constraints.
//!
//! This is the **one place** where a [`Scenario`] becomes a finite-element model
//! ([`Problem::from_scenario`]); `flexstage analyze`, `flexstage design` and the reduced model
//! all build their model here. (topopt depends on `flexstage-scenario` directly, so a library
//! user gets the same mapping as the CLI.)
//!
//! # Scenario → model
//! * mesh, material (`E0`, `E_min`, ν) and SIMP penalty `p` → [`flexstage_fem::Model`];
//! * `supports` → fixed DOFs (selectors pick nodes);
//! * `regions` → passive solid / void elements (selectors pick element centroids);
//! * `actuators.pea1/pea2` → input ports: a grounded spring `K_pea` on the x DOF and the force
//!   `K_pea·x_nom` (Eq. 2–3), global signs;
//! * `output.at` → the output node `L_o` (Eq. 7); with `optimization.output_spring = k > 0`,
//!   the load it drives acts on the output's motion relative to the moving frame of Eq. (22): a
//!   grounded spring k on `u_oy` and a link spring k on `u_ox − ½(u_in1 + u_in2)`, so a rigid
//!   translation of the floating stage loads nothing (DECISIONS.md, "Output load");
//! * constraints: the strain energy Σ ≤ Σ0 (Eq. 5; Σ0 absolute, or derived from the allowable
//!   stress), the input strokes, the volume, the tilt (θ ≠ 0) and the fatigue stress
//!   ([`StressConstraint`]) at the four corners of the stroke square;
//! * `optimization.mirror_symmetry` → [`Problem::mirror_symmetry`], checked against the
//!   supports, springs, ports and passive regions.
//!
//! # General mechanism problems
//! A scenario with `[[ports]]` (inverter, gripper) builds the same [`Problem`] as the hand-made
//! [`crate::samples::inverter`]: one [`Port`] per scenario port (a grounded spring `k_in` on
//! the driven DOF, the load `k_in·x_nom`), one load case, the objective
//! [`Objective::Displacement`] along the unit `output.direction`, the output spring grounded
//! along it (a plain spring on an axis, a link spring on `d·u_out` otherwise), no stroke,
//! tilt or stress constraint, the energy bound only with `optimization.energy_constraint`.
//!
//! # Load cases (DECISIONS.md)
//! The `p_m` samples walk the perimeter of the stroke square `[−a, a]²` in `(x_nom1, x_nom2)`,
//! `p_m/4` per side, starting at the corner `(+a, +a)`:
//! `(+a,+a) → (+a,−a) → (−a,−a) → (−a,+a) → (+a,+a)`. Corner `(+a,−a)` (sample `p_m/4`) is the
//! compressive "maximum y_out" case of Table 2, `(+a,+a)` translates the stage along +x (the
//! moving frame, Eq. 22). With `x_out ≈ ½(x1+x2)`, `y_out ≈ α(x1−x2)` this walk traces a
//! counter-clockwise output polygon (positive shoelace area, Eq. 4) when `α > 0`, the regular
//! configuration; the reversed configuration maximizes the negated area, so its optimum has
//! `α < 0`.

use flexstage_fem::{
    BoundaryConditions, Component, DofMass, Kinematics, LinkSpring, MassInterpolation,
    Material as FemMaterial, Mesh, Model, Passive,
};
use flexstage_scenario::{
    Configuration, Edge as ScEdge, Fix, KinematicsKind, ObjectiveKind, RegionKind, Scenario,
    Selector,
};

use crate::design_space::{DesignSpace, mirror_element};
use crate::error::{Result, TopoptError};
use crate::modal::StageDynamics;
use crate::stress::StressConstraint;

/// An input port: a grounded spring on the port's displacement, loaded by `stiffness · x_nom`
/// (Eq. 2–3). A PEA port acts over the face its tip presses (DECISIONS.md, "The PEA port: a
/// face"): its displacement is the face's weighted mean `Σ w_i u_i` (`face`, the weights of a
/// uniform traction, `Σ w = 1`), its force the uniform traction `w_i F`; a port of one DOF has
/// `face = [(dof, 1)]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Port {
    /// Node id: the face's centre (the port's point).
    pub node: usize,
    /// Full DOF index of the port's point (the x DOF for the PEAs).
    pub dof: usize,
    /// Spring stiffness `K_pea` [N/m].
    pub stiffness: f64,
    /// The face: `(full DOF, weight)`, weights summing to 1.
    pub face: Vec<(usize, f64)>,
}

impl Port {
    /// A port on one DOF.
    pub fn point(node: usize, dof: usize, stiffness: f64) -> Self {
        Self {
            node,
            dof,
            stiffness,
            face: vec![(dof, 1.0)],
        }
    }

    /// The port's displacement `Σ w_i u_i` from a full vector.
    pub fn displacement(&self, u: &[f64]) -> f64 {
        self.face.iter().map(|&(d, w)| w * u[d]).sum()
    }

    /// Adds a force `f` on the port (the uniform traction `w_i f`) to the full vector `p`.
    pub fn add_force(&self, f: f64, p: &mut [f64]) {
        for &(d, w) in &self.face {
            p[d] += w * f;
        }
    }

    /// The face's terms scaled by `c` (a link spring's terms on the port's displacement).
    pub fn terms(&self, c: f64) -> Vec<(usize, f64)> {
        self.face.iter().map(|&(d, w)| (d, c * w)).collect()
    }
}

/// The face a PEA presses at input node `node` on a left or right domain edge: the edge's
/// nodes along the passive solid elements next to the node (the port patch,
/// `regions`), with the weights of a uniform traction on linear edges (`h/2` at each end of
/// an edge, normalized). A node off those edges, or without a solid patch beside it, is a
/// point port (`[(2·node, 1)]`).
pub fn pea_face(mesh: &Mesh, node: usize) -> Vec<(usize, f64)> {
    let (i, j0) = mesh.node_ij(node);
    let column = if i == 0 {
        0
    } else if i == mesh.nl {
        mesh.nl - 1
    } else {
        return vec![(2 * node, 1.0)];
    };
    let solid = |j: usize| mesh.passive[mesh.element(column, j)] == Passive::Solid;
    // Element rows j (between nodes j and j + 1) of the patch, contiguous through the node.
    let mut lo = j0;
    while lo > 0 && solid(lo - 1) {
        lo -= 1;
    }
    let mut hi = j0;
    while hi < mesh.nw && solid(hi) {
        hi += 1;
    }
    if hi - lo < 1 {
        return vec![(2 * node, 1.0)];
    }
    let mut w = vec![0.0; hi - lo + 1];
    for k in 0..hi - lo {
        w[k] += 0.5;
        w[k + 1] += 0.5;
    }
    let total = (hi - lo) as f64;
    (lo..=hi)
        .zip(w)
        .map(|(j, wj)| (2 * mesh.node(i, j), wj / total))
        .collect()
}

/// What is maximized.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Objective {
    /// Signed shoelace area `sign · J` of the output polygon (Eq. 4); `sign = +1` regular,
    /// `−1` reversed (Table 2).
    Workspace {
        /// +1 (regular) or −1 (reversed).
        sign: f64,
    },
    /// `d · u_out` for the single load case (displacement inverter).
    Displacement {
        /// Unit target direction `d`.
        direction: [f64; 2],
    },
}

/// Orientation requirement of the tilted output (Figure 4b): the differential output
/// `D = u_out(+a,−a) − u_out(−a,+a)` must lie within `tolerance` of the axis
/// `d = (sin θ, cos θ)`: `(D·n)² ≤ tan²(tolerance)·(D·d)²`, `n = (cos θ, −sin θ)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tilt {
    /// θ \[rad\].
    pub theta: f64,
    /// Tolerance angle \[rad\].
    pub tolerance: f64,
}

/// The stage's first natural frequency in the design (DECISIONS.md, "Design for bandwidth"),
/// through the aggregate of its lowest eigenvalues ([`crate::modal`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Resonance {
    /// Maximize the workspace with the first natural frequency at least `min_hz`.
    Bound {
        /// Lower bound \[Hz\].
        min_hz: f64,
    },
    /// Maximize the first natural frequency with the workspace at least `min_area` (the
    /// worst robust realization's, in the configuration's orientation).
    Maximize {
        /// Lower bound on the workspace area \[m²\].
        min_area: f64,
    },
}

/// A complete optimization problem.
#[derive(Debug, Clone)]
pub struct Problem {
    /// FE model used while optimizing (kinematics of `optimization.kinematics`).
    pub model: Model,
    /// Input ports (one or two).
    pub inputs: Vec<Port>,
    /// Output node.
    pub output: usize,
    /// Load cases: nominal strokes `x_nom` per input \[m\].
    pub cases: Vec<Vec<f64>>,
    /// Objective.
    pub objective: Objective,
    /// Strain-energy bound Σ0 \[J\] (None = no constraint).
    pub energy_limit: Option<f64>,
    /// Largest allowed |input displacement| \[m\] (None = no constraint).
    pub max_stroke: Option<f64>,
    /// Volume-fraction bound (None = no constraint).
    pub volume_fraction: Option<f64>,
    /// Lower volume-fraction bound of the blueprint (None = no constraint).
    pub min_volume_fraction: Option<f64>,
    /// Tilted-output requirement (workspace objective only).
    pub tilt: Option<Tilt>,
    /// Fatigue stress constraint (None = no constraint).
    pub stress: Option<StressConstraint>,
    /// One design variable per element and its mirror image about `x = l/2`.
    pub mirror_symmetry: bool,
    /// Lower density bound ρ_min.
    pub rho_min: f64,
    /// Initial uniform design density.
    pub initial_density: f64,
    /// The stage's masses and the springs by which it differs from `model` (the two-PEA
    /// stage; None for a general mechanism).
    pub dynamics: Option<StageDynamics>,
    /// The requirement on the stage's first natural frequency (None: not designed for).
    pub resonance: Option<Resonance>,
}

/// Nodes picked by a selector.
pub fn select_nodes(mesh: &Mesh, sel: &Selector) -> Vec<usize> {
    match sel {
        Selector::Nearest { point } => vec![mesh.nearest_node(*point)],
        Selector::Edge { edge } => mesh.nodes_on_edge(fem_edge(*edge)),
        Selector::Box { min, max } => mesh.nodes_in_box(*min, *max),
    }
}

/// Elements picked by a selector (by centroid; `Nearest` picks the element containing or
/// nearest to the point, `Edge` the elements along that edge).
pub fn select_elements(mesh: &Mesh, sel: &Selector) -> Vec<usize> {
    match sel {
        Selector::Nearest { point } => {
            let i = ((point[0] / mesh.dx()).floor() as isize).clamp(0, mesh.nl as isize - 1);
            let j = ((point[1] / mesh.dy()).floor() as isize).clamp(0, mesh.nw as isize - 1);
            vec![mesh.element(i as usize, j as usize)]
        }
        Selector::Edge { edge } => match edge {
            ScEdge::Left => (0..mesh.nw).map(|j| mesh.element(0, j)).collect(),
            ScEdge::Right => (0..mesh.nw).map(|j| mesh.element(mesh.nl - 1, j)).collect(),
            ScEdge::Bottom => (0..mesh.nl).map(|i| mesh.element(i, 0)).collect(),
            ScEdge::Top => (0..mesh.nl).map(|i| mesh.element(i, mesh.nw - 1)).collect(),
        },
        Selector::Box { min, max } => mesh.elements_in_box(*min, *max),
    }
}

fn fem_edge(e: ScEdge) -> flexstage_fem::Edge {
    match e {
        ScEdge::Left => flexstage_fem::Edge::Left,
        ScEdge::Right => flexstage_fem::Edge::Right,
        ScEdge::Bottom => flexstage_fem::Edge::Bottom,
        ScEdge::Top => flexstage_fem::Edge::Top,
    }
}

fn single_node(mesh: &Mesh, sel: &Selector, field: &str) -> Result<usize> {
    let nodes = select_nodes(mesh, sel);
    match nodes.as_slice() {
        [n] => Ok(*n),
        _ => Err(TopoptError::Problem(format!(
            "{field} must select exactly one node, it selects {}",
            nodes.len()
        ))),
    }
}

/// The `p_m` samples of the stroke-square perimeter (see the module docs for the walk).
pub fn perimeter_walk(samples: usize, a: f64) -> Vec<Vec<f64>> {
    let q = (samples / 4).max(1);
    let mut out = Vec::with_capacity(4 * q);
    for side in 0..4 {
        for t in 0..q {
            let s = -a + 2.0 * a * t as f64 / q as f64; // −a .. a
            let (x1, x2) = match side {
                0 => (a, -s),
                1 => (-s, -a),
                2 => (-a, s),
                _ => (s, a),
            };
            out.push(vec![x1, x2]);
        }
    }
    out
}

/// The corners `(+a,+a)`, `(+a,−a)`, `(−a,−a)`, `(−a,+a)` of a perimeter walk of `n` samples.
pub fn corner_cases(n: usize) -> [usize; 4] {
    let q = n / 4;
    [0, q, 2 * q, 3 * q]
}

/// The strain-energy bound derived from the allowable stress (DECISIONS.md, "Strain-energy
/// bound"): `Σ0 = (1 − ν) σ_a² V* / E0`. In plane stress the energy density is
/// `(σ1² + σ2² − 2ν σ1σ2)/(2E) ≤ (1 − ν) σ_vm²/E` (equality for equibiaxial stress), so a
/// material volume V* whose von Mises stress stays below σ_a stores at most Σ0.
pub fn stress_energy_bound(s: &Scenario) -> f64 {
    let m = &s.mesh;
    let volume = m.length * m.width * m.thickness * s.optimization.volume_fraction;
    let sa = s.limits.allowable_stress();
    (1.0 - s.material.poisson_ratio) * sa * sa * volume / s.material.youngs_modulus
}

/// The strain-energy bound Σ0 of a scenario, if `optimization.energy_constraint`:
/// `strain_energy_limit`, or [`stress_energy_bound`] when that is 0.
fn energy_limit(s: &Scenario) -> Option<f64> {
    let o = &s.optimization;
    o.energy_constraint.then(|| {
        if o.strain_energy_limit > 0.0 {
            o.strain_energy_limit
        } else {
            stress_energy_bound(s)
        }
    })
}

/// The stage's dynamic parts of a two-PEA scenario (`crate::modal`): the input plates of the
/// model guess (`stage.guess`: K_in and m_in on the input DOFs, Eq. 1–3), the payload on both
/// output DOFs, and the optimizer's output load taken off.
fn stage_dynamics(s: &Scenario, inputs: [&Port; 2], out: usize) -> StageDynamics {
    let g = &s.stage.guess;
    let mut springs = vec![
        LinkSpring {
            terms: inputs[0].terms(1.0),
            stiffness: g.k_in1,
        },
        LinkSpring {
            terms: inputs[1].terms(1.0),
            stiffness: g.k_in2,
        },
    ];
    let k = s.optimization.output_spring;
    if k > 0.0 {
        springs.push(LinkSpring {
            terms: vec![(2 * out + 1, 1.0)],
            stiffness: -k,
        });
        springs.push(LinkSpring {
            terms: output_link_terms(out, inputs),
            stiffness: -k,
        });
    }
    let payload = s.output.payload;
    // The plates move with their faces: each face DOF carries its weight's share.
    let mut point_masses: Vec<DofMass> = inputs
        .iter()
        .zip([g.m_in1, g.m_in2])
        .flat_map(|(p, m)| {
            p.face
                .iter()
                .map(move |&(dof, w)| DofMass { dof, mass: w * m })
        })
        .collect();
    point_masses.extend((0..2).map(|c| DofMass {
        dof: 2 * out + c,
        mass: payload,
    }));
    StageDynamics {
        density: s.material.density,
        interpolation: MassInterpolation::default(),
        point_masses,
        springs,
    }
}

/// The terms of the output load's link spring, `u_ox − ½(u_in1 + u_in2)` (the output relative
/// to the moving frame of Eq. 22, the inputs' displacements over their faces).
fn output_link_terms(out: usize, inputs: [&Port; 2]) -> Vec<(usize, f64)> {
    let mut terms = vec![(2 * out, 1.0)];
    terms.extend(inputs[0].terms(-0.5));
    terms.extend(inputs[1].terms(-0.5));
    terms
}

/// SIMP material of a scenario.
fn scenario_material(s: &Scenario) -> FemMaterial {
    FemMaterial {
        e0: s.material.youngs_modulus,
        e_min: s.material.min_modulus,
        nu: s.material.poisson_ratio,
        penalty: s.optimization.penalty,
    }
}

/// The fixed DOFs of a scenario's supports.
fn scenario_supports(s: &Scenario, mesh: &Mesh) -> Result<BoundaryConditions> {
    let mut bcs = BoundaryConditions::new();
    for (i, sup) in s.supports.iter().enumerate() {
        let nodes = select_nodes(mesh, &sup.at);
        if nodes.is_empty() {
            return Err(TopoptError::Problem(format!(
                "supports[{i}].at selects no node"
            )));
        }
        let c = match sup.fix {
            Fix::X => Component::X,
            Fix::Y => Component::Y,
            Fix::Xy => Component::Both,
        };
        bcs.fix_nodes(&nodes, c);
    }
    Ok(bcs)
}

/// Mesh with the scenario's passive regions (later regions override earlier ones).
pub fn scenario_mesh(s: &Scenario) -> Result<Mesh> {
    let m = &s.mesh;
    let mut mesh = Mesh::new(m.length, m.width, m.thickness, m.nl, m.nw)?;
    for r in &s.regions {
        let els = select_elements(&mesh, &r.at);
        let flag = match r.kind {
            RegionKind::Solid => Passive::Solid,
            RegionKind::Void => Passive::Void,
        };
        mesh.set_passive(&els, flag);
    }
    Ok(mesh)
}

/// FE kinematics of a scenario's optimization.
pub fn scenario_kinematics(s: &Scenario) -> Kinematics {
    match s.optimization.kinematics {
        KinematicsKind::Nonlinear => Kinematics::TotalLagrangian,
        KinematicsKind::Linear => Kinematics::Linear,
    }
}

impl Problem {
    /// Builds the problem of a scenario. `kinematics` overrides `optimization.kinematics`
    /// (e.g. the final nonlinear analysis of a linearly optimized design).
    pub fn from_scenario(s: &Scenario, kinematics: Option<Kinematics>) -> Result<Problem> {
        if !s.ports.is_empty() {
            return Self::mechanism_from_scenario(s, kinematics);
        }
        let mesh = scenario_mesh(s)?;
        let o = &s.optimization;
        let material = scenario_material(s);
        let a = &s.actuators;
        let n1 = single_node(&mesh, &a.pea1, "actuators.pea1")?;
        let n2 = single_node(&mesh, &a.pea2, "actuators.pea2")?;
        let out = single_node(&mesh, &s.output.at, "output.at")?;
        if n1 == n2 {
            return Err(TopoptError::Problem(
                "actuators.pea1 and actuators.pea2 select the same node".into(),
            ));
        }
        let mut bcs = scenario_supports(s, &mesh)?;
        let ports = [
            Port {
                face: pea_face(&mesh, n1),
                ..Port::point(n1, 2 * n1, a.stiffness)
            },
            Port {
                face: pea_face(&mesh, n2),
                ..Port::point(n2, 2 * n2, a.stiffness)
            },
        ];
        for p in &ports {
            if p.face.len() == 1 {
                bcs.add_spring(p.dof, p.stiffness);
            } else {
                bcs.add_link(&p.terms(1.0), p.stiffness);
            }
        }
        let theta = s.output.tilt_deg.to_radians();
        let sign = match a.configuration {
            Configuration::Regular => 1.0,
            Configuration::Reversed => -1.0,
        };
        let direction = s
            .output
            .unit_direction()
            .unwrap_or([sign * theta.sin(), sign * theta.cos()]);
        if o.output_spring > 0.0 {
            // The load the output drives, relative to the moving frame of Eq. (22): it forces
            // the mechanism to transmit force to the output instead of moving it through void
            // "hinges", while a rigid translation of the floating stage loads nothing.
            let k = o.output_spring;
            bcs.add_spring(2 * out + 1, k)
                .add_link(&output_link_terms(out, [&ports[0], &ports[1]]), k);
        }
        let (objective, cases) = match o.objective {
            ObjectiveKind::Workspace | ObjectiveKind::Resonance => (
                Objective::Workspace { sign },
                perimeter_walk(o.samples, a.stroke_amplitude),
            ),
            ObjectiveKind::Displacement => (
                Objective::Displacement { direction },
                vec![vec![a.stroke_amplitude, -a.stroke_amplitude]],
            ),
        };
        for &d in &bcs.fixed {
            if ports.iter().any(|p| p.face.iter().any(|t| t.0 == d)) {
                return Err(TopoptError::Problem(
                    "a support fixes the x DOF of a node of a PEA input's face".into(),
                ));
            }
        }
        let kin = kinematics.unwrap_or_else(|| scenario_kinematics(s));
        let model = Model::new(mesh, material, kin, bcs)?;
        let energy_limit = energy_limit(s);
        let corners = corner_cases(cases.len());
        let stress = (o.stress_constraint && matches!(objective, Objective::Workspace { .. }))
            .then(|| StressConstraint {
                allowable: s.limits.allowable_stress() / s.limits.mesh_stress_factor,
                cases: corners.to_vec(),
                relaxation: 0.5,
                exponent: 8.0,
            });
        let tilt =
            (matches!(objective, Objective::Workspace { .. }) && theta != 0.0).then_some(Tilt {
                theta,
                tolerance: o.tilt_tolerance_deg.to_radians(),
            });
        let p = Problem {
            model,
            dynamics: Some(stage_dynamics(s, [&ports[0], &ports[1]], out)),
            inputs: ports.to_vec(),
            output: out,
            cases,
            objective,
            energy_limit,
            max_stroke: Some(a.max_stroke),
            volume_fraction: (o.volume_fraction < 1.0).then_some(o.volume_fraction),
            min_volume_fraction: (o.min_volume_fraction > 0.0).then_some(o.min_volume_fraction),
            tilt,
            stress,
            mirror_symmetry: o.mirror_symmetry,
            rho_min: o.rho_min,
            initial_density: o.initial_density,
            resonance: match o.objective {
                ObjectiveKind::Resonance => Some(Resonance::Maximize {
                    min_area: o.min_workspace,
                }),
                _ if o.min_frequency > 0.0 => Some(Resonance::Bound {
                    min_hz: o.min_frequency,
                }),
                _ => None,
            },
        };
        p.validate()?;
        Ok(p)
    }

    /// The general mechanism problem of a scenario with `[[ports]]` (module docs, "General
    /// mechanism problems"): the ports' springs and loads, the output spring along the output
    /// direction, one load case, `d · u_out` maximized.
    fn mechanism_from_scenario(s: &Scenario, kinematics: Option<Kinematics>) -> Result<Problem> {
        let mesh = scenario_mesh(s)?;
        let o = &s.optimization;
        let out = single_node(&mesh, &s.output.at, "output.at")?;
        let mut bcs = scenario_supports(s, &mesh)?;
        let mut inputs = Vec::with_capacity(s.ports.len());
        for (i, p) in s.ports.iter().enumerate() {
            let node = single_node(&mesh, &p.at, &format!("ports[{i}].at"))?;
            let dof = 2 * node + p.component();
            bcs.add_spring(dof, p.spring);
            inputs.push(Port::point(node, dof, p.spring));
        }
        let direction = s
            .output
            .unit_direction()
            .ok_or_else(|| TopoptError::Problem("[[ports]] need output.direction".into()))?;
        if o.output_spring > 0.0 {
            // A grounded spring on d·u_out: a plain spring when d is along an axis.
            let [dx, dy] = direction;
            if dy == 0.0 {
                bcs.add_spring(2 * out, o.output_spring);
            } else if dx == 0.0 {
                bcs.add_spring(2 * out + 1, o.output_spring);
            } else {
                bcs.add_link(&[(2 * out, dx), (2 * out + 1, dy)], o.output_spring);
            }
        }
        let kin = kinematics.unwrap_or_else(|| scenario_kinematics(s));
        let model = Model::new(mesh, scenario_material(s), kin, bcs)?;
        let p = Problem {
            model,
            cases: vec![s.ports.iter().map(|p| p.nominal_stroke()).collect()],
            inputs,
            output: out,
            objective: Objective::Displacement { direction },
            energy_limit: energy_limit(s),
            max_stroke: None,
            volume_fraction: (o.volume_fraction < 1.0).then_some(o.volume_fraction),
            min_volume_fraction: None,
            tilt: None,
            stress: None,
            mirror_symmetry: o.mirror_symmetry,
            rho_min: o.rho_min,
            initial_density: o.initial_density,
            dynamics: None,
            resonance: None,
        };
        p.validate()?;
        Ok(p)
    }

    /// Is this a general mechanism problem (not the two-PEA workspace of Eq. 4–5)?
    pub fn is_mechanism(s: &Scenario) -> bool {
        !s.ports.is_empty()
    }

    /// Checks that the problem is mirror-symmetric about `x = l/2` (passive regions, supports,
    /// springs, ports, output on the centre line), as [`Problem::mirror_symmetry`] needs.
    pub fn check_mirror_symmetry(&self) -> Result<()> {
        let mesh = self.mesh();
        DesignSpace::new(mesh, true)?;
        let mirror_node = |n: usize| {
            let (i, j) = mesh.node_ij(n);
            mesh.node(mesh.nl - i, j)
        };
        // The mirror keeps a DOF's component: x ↦ −x of the mirror node, y ↦ y.
        let mirror_dof = |d: usize| 2 * mirror_node(d / 2) + d % 2;
        let asym = |what: &str| {
            TopoptError::Problem(format!(
                "mirror symmetry: the {what} is not symmetric about x = l/2; make it symmetric \
                 or set optimization.mirror_symmetry = false"
            ))
        };
        let bcs = self.model.bcs();
        let fixed: std::collections::BTreeSet<usize> = bcs.fixed.iter().copied().collect();
        if fixed.iter().any(|&d| !fixed.contains(&mirror_dof(d))) {
            return Err(asym("set of supports"));
        }
        let mut springs: Vec<(usize, u64)> = bcs
            .springs
            .iter()
            .map(|s| (s.dof, s.stiffness.to_bits()))
            .collect();
        let mut mirrored: Vec<(usize, u64)> =
            springs.iter().map(|&(d, k)| (mirror_dof(d), k)).collect();
        springs.sort_unstable();
        mirrored.sort_unstable();
        if springs != mirrored {
            return Err(asym("set of springs"));
        }
        let ports: Vec<usize> = self.inputs.iter().map(|p| p.node).collect();
        if ports.len() == 2 && mirror_node(ports[0]) != ports[1] {
            return Err(asym("pair of input ports"));
        }
        if mirror_node(self.output) != self.output {
            return Err(asym("output port (it must lie on the centre line)"));
        }
        debug_assert!(mesh.n_elements() == 0 || mirror_element(mesh, 0) < mesh.n_elements());
        Ok(())
    }

    /// Consistency checks.
    pub fn validate(&self) -> Result<()> {
        let nd = self.model.n_dofs();
        if self.inputs.is_empty() || self.inputs.len() > 2 {
            return Err(TopoptError::Problem(
                "one or two input ports are needed".into(),
            ));
        }
        for p in &self.inputs {
            if p.dof >= nd || self.model.dofs().is_fixed(p.dof) {
                return Err(TopoptError::Problem(format!(
                    "input DOF {} is fixed or out of range",
                    p.dof
                )));
            }
        }
        if self.cases.is_empty() || self.cases.iter().any(|c| c.len() != self.inputs.len()) {
            return Err(TopoptError::Problem(
                "every load case needs one stroke per input".into(),
            ));
        }
        if self.design_elements().is_empty() {
            return Err(TopoptError::Problem(
                "no design elements (all passive)".into(),
            ));
        }
        crate::error::check_range(
            "Problem::rho_min",
            self.rho_min,
            self.rho_min > 0.0 && self.rho_min <= 0.1,
            "(0, 0.1]",
        )?;
        if let Some(sc) = &self.stress {
            crate::error::check_range(
                "StressConstraint::allowable",
                sc.allowable,
                sc.allowable > 0.0 && sc.allowable.is_finite(),
                "(0, ∞) Pa",
            )?;
            crate::error::check_range(
                "StressConstraint::relaxation",
                sc.relaxation,
                sc.relaxation > 0.0 && sc.relaxation <= 1.0,
                "(0, 1]",
            )?;
            crate::error::check_range(
                "StressConstraint::exponent",
                sc.exponent,
                (2.0..=64.0).contains(&sc.exponent),
                "[2, 64]",
            )?;
            if sc.cases.iter().any(|&k| k >= self.cases.len()) {
                return Err(TopoptError::Problem(
                    "a stress case index exceeds the number of load cases".into(),
                ));
            }
        }
        if self.mirror_symmetry {
            self.check_mirror_symmetry()?;
        }
        Ok(())
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh {
        self.model.mesh()
    }

    /// Non-passive elements (the design variables, in this order).
    pub fn design_elements(&self) -> Vec<usize> {
        (0..self.mesh().n_elements())
            .filter(|&e| self.mesh().passive[e] == Passive::Design)
            .collect()
    }

    /// External load vector of case `k`: `K_pea·x_nom` on each input port (Eq. 2–3).
    pub fn load(&self, k: usize) -> Vec<f64> {
        let mut p = self.model.zero_vector();
        for (port, &x) in self.inputs.iter().zip(&self.cases[k]) {
            port.add_force(flexstage_fem::pea_force(port.stiffness, x), &mut p);
        }
        p
    }

    /// The workspace area of an output polygon (Eq. 4) in the configuration's orientation,
    /// `sign · J` \[m²\]: positive when the polygon runs the way Table 2 asks (counter-clockwise
    /// in the regular configuration, clockwise in the reversed one, whose compressive inputs
    /// drive the output along −y). 0 for the displacement objective.
    pub fn workspace_area(&self, outputs: &[[f64; 2]]) -> f64 {
        match self.objective {
            Objective::Workspace { sign } => sign * shoelace(outputs),
            Objective::Displacement { .. } => 0.0,
        }
    }

    /// Index of the compressive corner `(+a, −a)` and of the tensile corner `(−a, +a)` of the
    /// perimeter walk.
    pub fn differential_corners(&self) -> (usize, usize) {
        let q = self.cases.len() / 4;
        (q, 3 * q)
    }

    /// The case indices of the four corners of the perimeter walk (Table 2).
    pub fn corner_cases(&self) -> [usize; 4] {
        corner_cases(self.cases.len())
    }

    /// The same problem with other kinematics (e.g. the final nonlinear analysis).
    pub fn with_kinematics(&self, kin: Kinematics) -> Result<Problem> {
        let model = Model::new(
            self.mesh().clone(),
            *self.model.material(),
            kin,
            self.model.bcs().clone(),
        )?;
        Ok(Problem {
            model,
            ..self.clone()
        })
    }
}

/// Shoelace area of a closed polygon (Eq. 4), positive when counter-clockwise.
pub fn shoelace(points: &[[f64; 2]]) -> f64 {
    let n = points.len();
    0.5 * (0..n)
        .map(|j| {
            let (p, q) = (points[j], points[(j + 1) % n]);
            p[0] * q[1] - q[0] * p[1]
        })
        .sum::<f64>()
}

/// Gradient of [`shoelace`]: `∂J/∂x_j = ½(y_{j+1} − y_{j−1})`, `∂J/∂y_j = ½(x_{j−1} − x_{j+1})`.
pub fn shoelace_gradient(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let n = points.len();
    (0..n)
        .map(|j| {
            let (next, prev) = (points[(j + 1) % n], points[(j + n - 1) % n]);
            [0.5 * (next[1] - prev[1]), 0.5 * (prev[0] - next[0])]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walk_and_shoelace() {
        let w = perimeter_walk(8, 1.0);
        assert_eq!(w[0], vec![1.0, 1.0]);
        assert_eq!(w[2], vec![1.0, -1.0]);
        assert_eq!(w[4], vec![-1.0, -1.0]);
        assert_eq!(w[6], vec![-1.0, 1.0]);
        // x = ½(x1+x2), y = α(x1−x2) with α > 0 gives a counter-clockwise polygon.
        let pts: Vec<[f64; 2]> = w
            .iter()
            .map(|c| [0.5 * (c[0] + c[1]), 0.3 * (c[0] - c[1])])
            .collect();
        let a = shoelace(&pts);
        assert!((a - 1.2).abs() < 1e-12, "{a}"); // |det| · 4 = 0.3 · 4
        let g = shoelace_gradient(&pts);
        let h = 1e-6;
        for j in 0..pts.len() {
            for c in 0..2 {
                let mut p = pts.clone();
                p[j][c] += h;
                let mut m = pts.clone();
                m[j][c] -= h;
                let fd = (shoelace(&p) - shoelace(&m)) / (2.0 * h);
                assert!((fd - g[j][c]).abs() < 1e-9);
            }
        }
    }
}
