//! The verification of one design: outline → parts and islands → medial discs → body-fitted
//! T6 mesh → statics at the stroke corners, transfer matrix, frequencies → verdict.

use flexstage_fem::Kinematics;
use flexstage_scenario::Scenario;
use flexstage_topopt::Problem;
use serde::Serialize;

use crate::design_mesh::{self, DesignMeshValues};
use crate::error::{Result, VerifyError};
use crate::fe::{Attachment, Cholesky, FeModel, PortLink};
use crate::feature::{Boundary, medial_balls};
use crate::geometry::Geometry;
use crate::manufacture::{self, Limits, Manufacturability};
use crate::mesh::{self, Sizing, TriMesh};
use crate::modal::lowest_frequencies;
use crate::params::VerifyParams;
use crate::t6::{PlaneStress, von_mises};

/// The largest von Mises stress over the stroke corners and where it is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StressPeak {
    /// Von Mises stress \[Pa\] (body-fitted: nodal average over the elements at the node).
    pub von_mises: f64,
    /// Where \[m\].
    pub at: [f64; 2],
    /// The stroke corner `(x_nom1, x_nom2)` \[m\].
    pub case: [f64; 2],
}

/// The transfer matrix of the reduced model (paper Eq. 24–27).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Transfer {
    /// `∂q/∂x_in` in the fixed frame.
    pub alpha_abs: [[f64; 2]; 2],
    /// The paper's `α` in the moving frame of Eq. 22: `α_abs − [[½, ½], [0, 0]]`.
    pub alpha: [[f64; 2]; 2],
    /// Scalar `α = ½(α21 − α22)` (Eq. 27–29).
    pub alpha_scalar: f64,
    /// Tilt `θ = atan((α11 − α12)/(α21 − α22))` \[deg\] (Eq. 26), in (−90°, 90°]: the axis of
    /// the differential output from +y towards +x, the convention of the design summary and
    /// of the reduced model; the orientation along the axis is the sign of `alpha_scalar`
    /// (negative for a reversed design).
    pub theta_deg: f64,
}

impl Transfer {
    /// From `α_abs`.
    pub fn from_alpha_abs(alpha_abs: [[f64; 2]; 2]) -> Self {
        let a = alpha_abs;
        let alpha = [[a[0][0] - 0.5, a[0][1] - 0.5], a[1]];
        Self {
            alpha_abs,
            alpha,
            alpha_scalar: 0.5 * (alpha[1][0] - alpha[1][1]),
            theta_deg: axis_angle_deg(alpha[0][0] - alpha[0][1], alpha[1][0] - alpha[1][1]),
        }
    }
}

/// The angle of the axis through `(x, y)` from +y towards +x \[deg\], in (−90°, 90°] (the
/// direction's sign dropped: Eq. 26's `atan(x / y)`; `+0` for a zero angle).
pub fn axis_angle_deg(x: f64, y: f64) -> f64 {
    let theta = if y == 0.0 {
        90.0
    } else {
        (x / y).atan().to_degrees()
    };
    if theta == -90.0 { 90.0 } else { theta + 0.0 }
}

/// Body-fitted results.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodyFitted {
    /// Vertex and mid-side nodes.
    pub nodes: usize,
    /// T6 elements.
    pub elements: usize,
    /// Unknowns after supports and couplings.
    pub dofs: usize,
    /// Shortest and longest element edge \[m\].
    pub edge_range: [f64; 2],
    /// Meshed area \[m²\].
    pub area: f64,
    /// Mass `ρ0 · t · area` \[kg\].
    pub mass: f64,
    /// Peak von Mises at the stroke corners.
    pub stress: StressPeak,
    /// The same on a mesh with half the element size everywhere (`None` if not asked for):
    /// the re-check at a finer resolution. The verdict uses the larger of the two.
    pub stress_refined: Option<StressPeak>,
    /// T6 elements of the refined mesh (0 without it).
    pub refined_elements: usize,
    /// Transfer matrix.
    pub transfer: Transfer,
    /// Lowest natural frequencies \[Hz\].
    pub frequencies: Vec<f64>,
}

impl BodyFitted {
    /// The larger of the peak stresses on the mesh and on the refined mesh.
    pub fn peak(&self) -> StressPeak {
        match self.stress_refined {
            Some(r) if r.von_mises > self.stress.von_mises => r,
            _ => self.stress,
        }
    }
}

/// The verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// Stress within the allowable and no manufacturability error.
    pub safe: bool,
    /// `stress ≤ allowable`.
    pub stress_ok: bool,
    /// No manufacturability error.
    pub manufacturable: bool,
    /// Why not (empty when safe).
    pub reasons: Vec<String>,
}

/// Everything [`verify`] finds.
#[derive(Debug, Clone, Serialize)]
pub struct Verification {
    /// Allowable stress = fatigue strength / safety factor \[Pa\].
    pub allowable: f64,
    /// Yield strength \[Pa\] (for reference).
    pub yield_strength: f64,
    /// Diameter of the wire's start hole \[m\] the pockets were checked against.
    pub start_hole: f64,
    /// Body-fitted re-analysis.
    pub body_fitted: BodyFitted,
    /// The design mesh's values (if compared).
    pub design_mesh: Option<DesignMeshValues>,
    /// Manufacturability.
    pub manufacturing: Manufacturability,
    /// The verdict.
    pub verdict: Verdict,
    /// The body-fitted mesh (for the VTU file).
    #[serde(skip)]
    pub mesh: TriMesh,
    /// Nodal displacement at the worst corner \[m\].
    #[serde(skip)]
    pub displacement: Vec<[f64; 2]>,
    /// Nodal von Mises stress at the worst corner \[Pa\].
    #[serde(skip)]
    pub nodal_von_mises: Vec<f64>,
}

/// A port of the scenario on the design mesh.
#[derive(Debug, Clone, PartialEq)]
struct PortSpec {
    name: String,
    point: [f64; 2],
    fixed: [bool; 2],
    /// Springs `[k_x, k_y]` of the design problem (stress) and of the reduced model (α,
    /// modes: the optimizer's output spring removed, as `flexstage-reduce` does).
    spring_stress: [f64; 2],
    spring_reduced: [f64; 2],
    mass: f64,
    /// The face a PEA presses (the ends of its segment on the design mesh, `Port::face`), when
    /// the port has one: the coupling takes the outline's boundary along it.
    face: Option<[[f64; 2]; 2]>,
}

/// A support of the design mesh: its node's point [m] and the components it fixes.
type Support = ([f64; 2], [bool; 2]);

/// Ports and direct supports from the two problems' boundary conditions.
fn port_specs(
    s: &Scenario,
    stress: &Problem,
    reduced: &Problem,
    plate_masses: bool,
) -> (Vec<PortSpec>, Vec<Support>, Vec<PortLink>) {
    let mesh = stress.mesh();
    let springs = |p: &Problem, node: usize| {
        let mut k = [0.0; 2];
        for sp in &p.model.bcs().springs {
            if sp.dof / 2 == node {
                k[sp.dof % 2] += sp.stiffness;
            }
        }
        k
    };
    let fixed = |node: usize| {
        let f = &stress.model.bcs().fixed;
        [f.contains(&(2 * node)), f.contains(&(2 * node + 1))]
    };
    let mut specs = Vec::new();
    let mut named: Vec<(String, usize, f64)> = stress
        .inputs
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let m = [s.stage.guess.m_in1, s.stage.guess.m_in2][k.min(1)];
            (
                format!("PEA{}", k + 1),
                p.node,
                if plate_masses { m } else { 0.0 },
            )
        })
        .collect();
    // The payload (`output.payload`) rides on the output port.
    named.push(("output".into(), stress.output, s.output.payload));
    // The port a DOF belongs to: a PEA port's face, else its node's port.
    let face_port = |dof: usize| {
        stress
            .inputs
            .iter()
            .position(|p| p.face.iter().any(|t| t.0 == dof))
    };
    // A PEA's spring over its face is the port's spring (below), not a link.
    let is_face_link = |l: &flexstage_fem::LinkSpring| {
        stress
            .inputs
            .iter()
            .any(|p| p.face.len() > 1 && l.terms == p.terms(1.0))
    };
    for sp in &stress.model.bcs().springs {
        let node = sp.dof / 2;
        if !named.iter().any(|n| n.1 == node) {
            named.push((format!("spring at node {node}"), node, 0.0));
        }
    }
    for l in stress.model.bcs().links.iter().filter(|l| !is_face_link(l)) {
        for &(dof, _) in &l.terms {
            let node = dof / 2;
            if face_port(dof).is_none() && !named.iter().any(|n| n.1 == node) {
                named.push((format!("link spring at node {node}"), node, 0.0));
            }
        }
    }
    let links: Vec<PortLink> = stress
        .model
        .bcs()
        .links
        .iter()
        .filter(|l| !is_face_link(l))
        .map(|l| {
            // Terms on one port's component add up (a face's weights sum to its coefficient).
            let mut terms: Vec<(usize, usize, f64)> = Vec::new();
            for &(dof, c) in &l.terms {
                let port = face_port(dof).unwrap_or_else(|| {
                    named
                        .iter()
                        .position(|n| n.1 == dof / 2)
                        .expect("named above")
                });
                match terms.iter_mut().find(|t| t.0 == port && t.1 == dof % 2) {
                    Some(t) => t.2 += c,
                    None => terms.push((port, dof % 2, c)),
                }
            }
            PortLink {
                terms,
                stiffness: l.stiffness,
            }
        })
        .collect();
    for (k, (name, node, mass)) in named.into_iter().enumerate() {
        let input = stress.inputs.get(k);
        let mut spring_stress = springs(stress, node);
        let mut spring_reduced = springs(reduced, node);
        let mut face = None;
        if let Some(p) = input.filter(|p| p.face.len() > 1) {
            spring_stress[0] += p.stiffness;
            spring_reduced[0] += p.stiffness;
            let ends = |d: usize| mesh.node_coords(d / 2);
            face = Some([ends(p.face[0].0), ends(p.face[p.face.len() - 1].0)]);
        }
        specs.push(PortSpec {
            name,
            point: mesh.node_coords(node),
            fixed: fixed(node),
            spring_stress,
            spring_reduced,
            mass,
            face,
        });
    }
    let mut supports: Vec<Support> = Vec::new();
    let mut nodes: Vec<usize> = stress.model.bcs().fixed.iter().map(|d| d / 2).collect();
    nodes.sort_unstable();
    nodes.dedup();
    for node in nodes {
        let p = mesh.node_coords(node);
        if !specs.iter().any(|sp| sp.point == p) {
            supports.push((p, fixed(node)));
        }
    }
    (specs, supports, links)
}

/// The stroke corners `(±a, ±a)`.
fn stroke_corners(a: f64) -> [[f64; 2]; 4] {
    [[a, a], [a, -a], [-a, -a], [-a, a]]
}

/// The kept parts of the outline with their medial discs.
struct Prepared {
    kept: Geometry,
    boundary: Boundary,
    balls: crate::feature::Balls,
}

impl Prepared {
    /// The body-fitted mesh with `sizing`.
    fn mesh(&self, sizing: &Sizing) -> Result<TriMesh> {
        let h = mesh::size_field(&self.boundary, &self.balls, sizing);
        let loops: Vec<Vec<[f64; 2]>> = (0..self.kept.loops.len())
            .map(|k| mesh::resample_loop(&self.boundary, &h, k))
            .collect();
        mesh::triangulate(&loops, sizing)
    }
}

/// Keeps the parts that ports or supports hold, fills their pockets too small for the start
/// hole (the part as made: [`manufacture::small_pockets`]), finds the medial discs of what is
/// left and checks manufacturability. `areal_density` \[kg/m²\] (thickness × density) weighs
/// the filling.
fn prepare(
    geometry: &Geometry,
    anchors: &[[f64; 2]],
    port_radius: f64,
    sizing: &Sizing,
    p: &VerifyParams,
    areal_density: f64,
) -> Result<(Prepared, Manufacturability)> {
    let mut held = vec![false; geometry.parts.len()];
    for &a in anchors {
        for part in geometry.parts_near(a, port_radius) {
            held[part] = true;
        }
    }
    let islands: Vec<(f64, [f64; 2])> = geometry
        .parts
        .iter()
        .zip(&held)
        .filter(|(_, h)| !**h)
        .map(|(part, _)| (part.area, part.centroid))
        .collect();
    // The loops of the held parts, by their index in the outline as drawn.
    let mut kept_index: Vec<usize> = geometry
        .parts
        .iter()
        .zip(&held)
        .filter(|(_, h)| **h)
        .flat_map(|(part, _)| std::iter::once(part.outer).chain(part.holes.iter().copied()))
        .collect();
    if kept_index.is_empty() {
        return Err(VerifyError::Outline(
            "no part of the outline touches a port or support".into(),
        ));
    }
    let spacing = (0.1 * p.min_ligament.min(p.min_gap)).clamp(p.min_element, 0.1e-3);
    // Discs larger than every width that matters (the limits, the start hole, the element
    // size times the elements across) need not be measured: they are capped.
    let r_cap = 0.75
        * (p.min_ligament.max(p.min_gap).max(p.start_hole_diameter))
            .max(sizing.max_element * sizing.elements_across);
    let analyse = |index: &[usize]| -> Result<Prepared> {
        let kept = Geometry::new(index.iter().map(|&k| geometry.loops[k].clone()).collect())?;
        let boundary = Boundary::sample(&kept, spacing);
        let balls = medial_balls(&boundary, r_cap);
        Ok(Prepared {
            kept,
            boundary,
            balls,
        })
    };
    let mut prepared = analyse(&kept_index)?;
    let mut filled = manufacture::small_pockets(
        &prepared.kept,
        &prepared.boundary,
        &prepared.balls,
        p.start_hole_diameter,
    );
    if !filled.is_empty() {
        let gone: Vec<usize> = filled.iter().map(|f| kept_index[f.outline_loop]).collect();
        for f in &mut filled {
            f.outline_loop = kept_index[f.outline_loop];
            f.mass = f.area * areal_density;
        }
        kept_index.retain(|k| !gone.contains(k));
        prepared = analyse(&kept_index)?;
    }
    let limits = Limits {
        min_ligament: p.min_ligament,
        min_gap: p.min_gap,
        start_hole: p.start_hole_diameter,
    };
    let mut report = manufacture::check(
        &prepared.kept,
        &prepared.boundary,
        &prepared.balls,
        &islands,
        &limits,
    );
    report.filled = filled;
    Ok((prepared, report))
}

/// Checks that every connected part of the mesh is held against rigid motion by the
/// supports, rollers and springs (otherwise the stiffness is singular).
fn check_held(model: &FeModel, specs: &[PortSpec], links: &[PortLink]) -> Result<()> {
    let mesh = &model.mesh;
    let nn = mesh.nodes.len();
    let mut parent: Vec<usize> = (0..nn).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for el in &mesh.elements {
        for &n in &el[1..] {
            let (a, b) = (root(&mut parent, el[0]), root(&mut parent, n));
            parent[a] = b;
        }
    }
    let roots: Vec<usize> = (0..nn).map(|i| root(&mut parent, i)).collect();
    let mut groups: std::collections::BTreeMap<usize, [f64; 6]> = Default::default();
    // Constraint rows on the rigid modes (u_x, u_y, θ·scale) about the origin.
    let scale = 1.0 / (mesh.edge_range().1.max(1e-6) * 100.0);
    // One constraint row on (u_x, u_y, θ·scale) per held component; summed over the nodes of
    // a port (its mean displacement), per node for a direct support.
    let add_row =
        |root: usize, row: [f64; 3], g: &mut std::collections::BTreeMap<usize, [f64; 6]>| {
            let m = g.entry(root).or_insert([0.0; 6]);
            // Packed upper triangle of Σ row rowᵀ: (00, 01, 02, 11, 12, 22).
            let idx = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
            for (k, (i, j)) in idx.into_iter().enumerate() {
                m[k] += row[i] * row[j];
            }
        };
    let row = |node: usize, c: usize, w: f64| {
        let p = mesh.nodes[node];
        if c == 0 {
            [w, 0.0, -w * p[1] * scale]
        } else {
            [0.0, w, w * p[0] * scale]
        }
    };
    for &(node, c) in &model.fixed {
        add_row(roots[node], row(node, c, 1.0), &mut groups);
    }
    for (a, (att, spec)) in model.attachments.iter().zip(specs).enumerate() {
        for c in 0..2 {
            // A link spring holds a component elastically against the other ports it joins.
            let linked = links
                .iter()
                .any(|l| l.stiffness > 0.0 && l.terms.iter().any(|t| t.0 == a && t.1 == c));
            if spec.fixed[c]
                || spec.spring_reduced[c] > 0.0
                || spec.spring_stress[c] > 0.0
                || linked
            {
                let mut per_part: std::collections::BTreeMap<usize, [f64; 3]> = Default::default();
                for (d, a) in att.coefficients() {
                    let n = d / 2;
                    let r = per_part.entry(roots[n]).or_insert([0.0; 3]);
                    let v = row(n, d % 2, a[c]);
                    for k in 0..3 {
                        r[k] += v[k];
                    }
                }
                for (root, r) in per_part {
                    add_row(root, r, &mut groups);
                }
            }
        }
    }
    for (i, &r) in roots.iter().enumerate() {
        if r != i {
            continue;
        }
        let g = groups.get(&r).copied().unwrap_or([0.0; 6]);
        let [a, b, c, d, e, f] = g;
        let det2 = a * d - b * b;
        let det3 = a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c);
        let tol = 1e-12 * (a + d + f).max(1e-300);
        let held_t = a > tol && det2 > tol * tol;
        if !held_t || det3 <= tol * tol * tol {
            let p = mesh.nodes[i];
            return Err(VerifyError::Mechanism {
                x_mm: p[0] * 1e3,
                y_mm: p[1] * 1e3,
                motion: if held_t { "rotation" } else { "translation" },
            });
        }
    }
    Ok(())
}

/// Statics at the stroke corners: the peak nodal-average von Mises, and the worst corner's
/// displacement and nodal stress field.
fn corner_statics(
    model: &FeModel,
    specs: &[PortSpec],
    links: &[PortLink],
    inputs: &[(usize, f64)],
    corners: &[[f64; 2]],
) -> Result<(StressPeak, Vec<[f64; 2]>, Vec<f64>)> {
    let springs: Vec<[f64; 2]> = specs.iter().map(|s| s.spring_stress).collect();
    let k = model.stiffness(&springs, links);
    let factor = Cholesky::new(&k)?;
    let n = model.n();
    // Unit nominal strokes: the PEA force K_pea · 1 m on each input (Eq. 2–3).
    let mut rhs = vec![0.0; n * inputs.len()];
    for (col, &(a, k_pea)) in inputs.iter().enumerate() {
        model.port_load(a, 0, k_pea, &mut rhs[col * n..(col + 1) * n]);
    }
    factor.solve_in_place(&mut rhs, inputs.len());
    let units: Vec<Vec<f64>> = rhs.chunks(n).map(|x| model.expand(x)).collect();
    let elem: Vec<Vec<[[f64; 3]; 6]>> = units.iter().map(|u| model.element_stresses(u)).collect();
    let nodal: Vec<Vec<[f64; 3]>> = elem.iter().map(|e| model.nodal_average(e)).collect();
    let combine = |x: &[f64; 2], s: &[[f64; 3]]| -> [f64; 3] {
        std::array::from_fn(|c| (0..s.len()).map(|k| x[k] * s[k][c]).sum())
    };
    let mut best = (0.0, 0usize, [0.0; 2]);
    for x in corners {
        for node in 0..model.mesh.nodes.len() {
            let s: Vec<[f64; 3]> = nodal.iter().map(|f| f[node]).collect();
            let vm = von_mises(combine(x, &s));
            if vm > best.0 {
                best = (vm, node, *x);
            }
        }
    }
    let (vm, node, x) = best;
    let nn = model.mesh.nodes.len();
    let disp: Vec<[f64; 2]> = (0..nn)
        .map(|i| {
            std::array::from_fn(|c| {
                (0..units.len())
                    .map(|k| x[k] * units[k][2 * i + c])
                    .sum::<f64>()
            })
        })
        .collect();
    let field: Vec<f64> = (0..nn)
        .map(|i| {
            let s: Vec<[f64; 3]> = nodal.iter().map(|f| f[i]).collect();
            von_mises(combine(&x, &s))
        })
        .collect();
    let peak = StressPeak {
        von_mises: vm,
        at: model.mesh.nodes[node],
        case: x,
    };
    Ok((peak, disp, field))
}

/// Transfer matrix by unit forces on the inputs (output free, PEA springs kept; they act on the
/// inputs only, so they drop out of `α`, Eq. 24) and the lowest frequencies with a consistent
/// mass matrix.
fn transfer_and_modes(
    model: &FeModel,
    specs: &[PortSpec],
    inputs: [usize; 2],
    output: usize,
    density: f64,
    modes: usize,
) -> Result<(Transfer, Vec<f64>)> {
    let springs: Vec<[f64; 2]> = specs.iter().map(|s| s.spring_reduced).collect();
    let k = model.stiffness(&springs, &[]);
    let factor = Cholesky::new(&k)?;
    let n = model.n();
    let mut rhs = vec![0.0; 2 * n];
    for (col, &a) in inputs.iter().enumerate() {
        model.port_load(a, 0, 1.0, &mut rhs[col * n..(col + 1) * n]);
    }
    factor.solve_in_place(&mut rhs, 2);
    let u: Vec<Vec<f64>> = rhs.chunks(n).map(|x| model.expand(x)).collect();
    // C_ii = ∂x_in/∂F, C_oi = ∂q/∂F; α_abs = C_oi C_ii⁻¹.
    let g = |row: usize, col: usize| model.attachments[inputs[row]].mean(&u[col], 0);
    let q = |c: usize, col: usize| model.attachments[output].mean(&u[col], c);
    let (a, b, c, d) = (g(0, 0), g(0, 1), g(1, 0), g(1, 1));
    let det = a * d - b * c;
    let inv = [[d / det, -b / det], [-c / det, a / det]];
    let alpha_abs: [[f64; 2]; 2] =
        std::array::from_fn(|i| std::array::from_fn(|j| q(i, 0) * inv[0][j] + q(i, 1) * inv[1][j]));
    let masses: Vec<f64> = specs.iter().map(|s| s.mass).collect();
    let m = model.mass(density, &masses);
    let f = lowest_frequencies(&k, &factor, &m, modes)?;
    Ok((Transfer::from_alpha_abs(alpha_abs), f.hz))
}

/// Verifies a design: `loops` is the exported outline (closed loops in metres, solid on the
/// left), `rho` the design's physical densities in fem order (for the design-mesh comparison).
pub fn verify(
    scenario: &Scenario,
    rho: &[f64],
    loops: &[Vec<[f64; 2]>],
    p: &VerifyParams,
) -> Result<Verification> {
    p.validate()?;
    let prob = |keep_output_spring: bool| -> Result<Problem> {
        let r = if keep_output_spring {
            Problem::from_scenario(scenario, Some(Kinematics::TotalLagrangian))
        } else {
            flexstage_reduce::reduction_problem(scenario, false)
                .map_err(|e| flexstage_topopt::TopoptError::Problem(e.to_string()))
        };
        r.map_err(|e| VerifyError::DesignMesh(e.to_string()))
    };
    let (stress_problem, reduced) = (prob(true)?, prob(false)?);
    if stress_problem.inputs.len() != 2 {
        return Err(VerifyError::DesignMesh(
            "the verification needs two inputs (PEA1, PEA2)".into(),
        ));
    }
    let mesh = stress_problem.mesh();
    let h_design = mesh.dx().max(mesh.dy());
    let sizing = Sizing {
        elements_across: p.elements_across,
        min_element: p.min_element,
        max_element: p.max_element.unwrap_or(h_design).max(p.min_element),
        segment_angle: p.segment_angle_deg.to_radians(),
        gradation: p.gradation,
        angle_limit_deg: p.angle_limit_deg,
        max_nodes: p.max_nodes,
    };
    let port_radius = p.port_radius.unwrap_or(1.5 * h_design);
    let (specs, supports, links) = port_specs(scenario, &stress_problem, &reduced, p.plate_masses);
    let geometry = Geometry::new(loops.to_vec())?;
    let anchors: Vec<[f64; 2]> = specs
        .iter()
        .map(|s| s.point)
        .chain(supports.iter().map(|s| s.0))
        .collect();
    let areal_density = scenario.mesh.thickness * scenario.material.density;
    let (prepared, manufacturing) =
        prepare(&geometry, &anchors, port_radius, &sizing, p, areal_density)?;
    let model = build_model(
        scenario,
        prepared.mesh(&sizing)?,
        &specs,
        &supports,
        (port_radius, p.point_ports),
        h_design,
    )?;
    check_held(&model, &specs, &links)?;
    let corners = stroke_corners(scenario.actuators.stroke_amplitude);
    let inputs: Vec<(usize, f64)> = stress_problem
        .inputs
        .iter()
        .enumerate()
        .map(|(k, port)| (k, port.stiffness))
        .collect();
    let (stress, displacement, nodal_von_mises) =
        corner_statics(&model, &specs, &links, &inputs, &corners)?;
    let (stress_refined, refined_elements) = if p.refine_check {
        let fine = Sizing {
            elements_across: 2.0 * sizing.elements_across,
            min_element: 0.5 * sizing.min_element,
            max_element: 0.5 * sizing.max_element,
            ..sizing
        };
        let fine_model = build_model(
            scenario,
            prepared.mesh(&fine)?,
            &specs,
            &supports,
            (port_radius, p.point_ports),
            h_design,
        )?;
        let peak = corner_statics(&fine_model, &specs, &links, &inputs, &corners)?.0;
        (Some(peak), fine_model.mesh.elements.len())
    } else {
        (None, 0)
    };
    let output = specs
        .iter()
        .position(|s| s.name == "output")
        .expect("output port");
    let (transfer, frequencies) = transfer_and_modes(
        &model,
        &specs,
        [0, 1],
        output,
        scenario.material.density,
        p.modes,
    )?;
    let design_mesh = if p.compare_design_mesh {
        Some(design_mesh::analyse(
            scenario,
            &stress_problem,
            &reduced,
            rho,
            &corners,
            p.modes,
            p.plate_masses,
        )?)
    } else {
        None
    };
    let (edge_lo, edge_hi) = model.mesh.edge_range();
    let body_fitted = BodyFitted {
        nodes: model.mesh.nodes.len(),
        elements: model.mesh.elements.len(),
        dofs: model.n(),
        edge_range: [edge_lo, edge_hi],
        area: model.mesh.area(),
        mass: model.solid_mass(scenario.material.density),
        stress,
        stress_refined,
        refined_elements,
        transfer,
        frequencies,
    };
    let verdict = verdict(&body_fitted, &manufacturing, p);
    Ok(Verification {
        allowable: p.allowable_stress(),
        yield_strength: p.yield_strength,
        start_hole: p.start_hole_diameter,
        body_fitted,
        design_mesh,
        manufacturing,
        verdict,
        mesh: model.mesh,
        displacement,
        nodal_von_mises,
    })
}

/// The FE model with the scenario's ports and supports on the body-fitted boundary: each port
/// a distributing coupling within `port_radius`, or a point port (`VerifyParams::point_ports`).
fn build_model(
    scenario: &Scenario,
    tri: TriMesh,
    specs: &[PortSpec],
    supports: &[Support],
    (port_radius, point_ports): (f64, bool),
    h_design: f64,
) -> Result<FeModel> {
    let coupling = (!point_ports).then_some(port_radius);
    let mut attachments = Vec::with_capacity(specs.len());
    for s in specs {
        let a = match (coupling, s.face) {
            (None, _) => Attachment::at_nearest_boundary_node(&tri, &s.name, s.point, s.fixed),
            // The boundary along the face the PEA presses: beside the face's segment, within
            // half a design element of its line (the smoothed outline lies up to about 0.15
            // elements outside the domain's edge).
            (Some(_), Some(face)) => {
                Attachment::on_boundary_where(&tri, &s.name, s.point, s.fixed, |m| {
                    beside_segment(m, face, 0.5 * h_design)
                })
            }
            (Some(radius), None) => {
                Attachment::on_boundary(&tri, &s.name, s.point, radius, s.fixed)
            }
        };
        let a = a.ok_or_else(|| VerifyError::Port {
            what: s.name.clone(),
            x_mm: s.point[0] * 1e3,
            y_mm: s.point[1] * 1e3,
            radius_mm: port_radius * 1e3,
        })?;
        attachments.push(a);
    }
    // A support node of the design mesh holds the outline boundary within half an element.
    let mut fixed = Vec::new();
    for &(p, comps) in supports {
        for e in &tri.boundary {
            for &node in e {
                let q = tri.nodes[node];
                if (q[0] - p[0]).hypot(q[1] - p[1]) <= 0.5 * h_design * (1.0 + 1e-9) {
                    for c in (0..2).filter(|&c| comps[c]) {
                        fixed.push((node, c));
                    }
                }
            }
        }
    }
    fixed.sort_unstable();
    fixed.dedup();
    let material = PlaneStress {
        youngs_modulus: scenario.material.youngs_modulus,
        poisson_ratio: scenario.material.poisson_ratio,
        thickness: scenario.mesh.thickness,
    };
    FeModel::new(tri, material, attachments, fixed)
}

/// Whether `p` projects onto the segment `[a, b]` (between its ends) within `distance` of its
/// line.
fn beside_segment(p: [f64; 2], [a, b]: [[f64; 2]; 2], distance: f64) -> bool {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len = d[0].hypot(d[1]);
    if len == 0.0 {
        return (p[0] - a[0]).hypot(p[1] - a[1]) <= distance;
    }
    let r = [p[0] - a[0], p[1] - a[1]];
    let along = (r[0] * d[0] + r[1] * d[1]) / len;
    let normal = (r[0] * d[1] - r[1] * d[0]) / len;
    (-1e-9 * len..=len * (1.0 + 1e-9)).contains(&along) && normal.abs() <= distance
}

fn verdict(b: &BodyFitted, m: &Manufacturability, p: &VerifyParams) -> Verdict {
    let allowable = p.allowable_stress();
    let peak = b.peak();
    let stress_ok = peak.von_mises <= allowable;
    let mut reasons = Vec::new();
    if !stress_ok {
        reasons.push(format!(
            "peak von Mises {:.1} MPa at ({:.2}, {:.2}) mm exceeds the allowable {:.1} MPa \
             (fatigue strength {:.1} MPa / safety factor {})",
            peak.von_mises * 1e-6,
            peak.at[0] * 1e3,
            peak.at[1] * 1e3,
            allowable * 1e-6,
            p.fatigue_strength * 1e-6,
            p.safety_factor
        ));
    }
    let errors = m
        .findings
        .iter()
        .filter(|f| f.severity == crate::manufacture::Severity::Error)
        .count();
    if errors > 0 {
        reasons.push(format!("{errors} manufacturability error(s)"));
    }
    Verdict {
        safe: stress_ok && errors == 0,
        stress_ok,
        manufacturable: errors == 0,
        reasons,
    }
}

fn mm(p: [f64; 2]) -> String {
    format!("({:.2}, {:.2}) mm", p[0] * 1e3, p[1] * 1e3)
}

impl Verification {
    /// The verification as lines for a terminal: body-fitted values beside the design mesh's,
    /// the manufacturability findings and the verdict (the last line).
    pub fn summary_lines(&self) -> Vec<String> {
        let b = &self.body_fitted;
        let mut out = vec![format!(
            "body-fitted mesh: {} T6 elements, {} nodes, {} unknowns, edges {:.3}–{:.3} mm, \
             solid {:.1} g",
            b.elements,
            b.nodes,
            b.dofs,
            b.edge_range[0] * 1e3,
            b.edge_range[1] * 1e3,
            b.mass * 1e3
        )];
        let corner = |c: [f64; 2]| format!("x_nom = ({:+.0}, {:+.0}) µm", c[0] * 1e6, c[1] * 1e6);
        out.push(format!(
            "  max von Mises {:.1} MPa at {} ({}); allowable {:.1} MPa, yield {:.0} MPa",
            b.stress.von_mises * 1e-6,
            mm(b.stress.at),
            corner(b.stress.case),
            self.allowable * 1e-6,
            self.yield_strength * 1e-6
        ));
        if let Some(r) = &b.stress_refined {
            out.push(format!(
                "  re-check on a mesh of half the size ({} elements): {:.1} MPa at {} ({:+.1} %)",
                b.refined_elements,
                r.von_mises * 1e-6,
                mm(r.at),
                100.0 * (r.von_mises / b.stress.von_mises - 1.0)
            ));
        }
        out.push(format!(
            "  alpha {:.4}, theta {:+.2} deg, first frequency {:.0} Hz",
            b.transfer.alpha_scalar,
            b.transfer.theta_deg,
            b.frequencies.first().copied().unwrap_or(f64::NAN)
        ));
        if let Some(d) = &self.design_mesh {
            out.push(format!(
                "design mesh ({} Q4 elements of {:.2} mm, {:.1} g): max von Mises {:.1} MPa at {} \
                 ({:.1} MPa linear), alpha {:.4}, theta {:+.2} deg, first frequency {:.0} Hz",
                d.elements,
                d.element_size * 1e3,
                d.mass * 1e3,
                d.stress.von_mises * 1e-6,
                mm(d.stress.at),
                d.stress_linear * 1e-6,
                d.transfer.alpha_scalar,
                d.transfer.theta_deg,
                d.first_frequency
            ));
        }
        let m = &self.manufacturing;
        let width = |w: &Option<crate::manufacture::Width>| match w {
            Some(w) => format!("{:.3} mm at {}", w.width * 1e3, mm(w.at)),
            None => "none".into(),
        };
        out.push(format!(
            "manufacturing: thinnest ligament {}, narrowest gap {}, {} island(s), {} pocket(s)",
            width(&m.min_ligament),
            width(&m.min_gap),
            m.islands,
            m.pockets
        ));
        for f in &m.findings {
            let tag = match f.severity {
                crate::manufacture::Severity::Error => "error",
                crate::manufacture::Severity::Note => "note",
            };
            out.push(format!("  {tag}: {}", f.message));
        }
        if !m.filled.is_empty() {
            out.push(format!(
                "  filled: {} pocket(s) too small for a Ø {:.2} mm start hole, left solid (+{:.3} g); \
                 the stress, frequencies and mass above are of the part with them filled",
                m.filled.len(),
                self.start_hole * 1e3,
                m.filled.iter().map(|f| f.mass).sum::<f64>() * 1e3
            ));
            for f in &m.filled {
                out.push(format!(
                    "    {:.3} mm² at {} (largest inscribed Ø {:.3} mm), +{:.4} g",
                    f.area * 1e6,
                    mm(f.at),
                    f.inscribed * 1e3,
                    f.mass * 1e3
                ));
            }
        }
        out.push(if self.verdict.safe {
            "verdict: safe (stress within the allowable, no manufacturability error)".into()
        } else {
            format!("verdict: NOT safe: {}", self.verdict.reasons.join("; "))
        });
        out
    }

    /// The body-fitted mesh with the worst corner's displacement and nodal von Mises stress
    /// as a VTU document (ParaView).
    pub fn to_vtu(&self) -> String {
        crate::vtu::to_vtu(&self.mesh, &self.displacement, &self.nodal_von_mises)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `A(θ)` of Eq. 29 (the fixed frame) with amplification `a` and tilt `θ`.
    fn a_theta(a: f64, theta_deg: f64) -> [[f64; 2]; 2] {
        let t = theta_deg.to_radians().tan();
        [[0.5 + a * t, 0.5 - a * t], [a, -a]]
    }

    /// Goal: θ has one convention from design to export (Eq. 26, the axis in (−90°, 90°], the
    /// orientation in the sign of α): a reversed design (α < 0) is θ = 0°, not 180°; a tilted
    /// one keeps its tilt whichever way it is driven.
    #[test]
    fn theta_is_the_axis_and_alpha_carries_the_orientation() {
        for (a, theta) in [
            (1.2, 0.0),
            (-1.2, 0.0),
            (1.2, 20.0),
            (-1.2, 20.0),
            (0.8, -35.0),
        ] {
            let t = Transfer::from_alpha_abs(a_theta(a, theta));
            assert!((t.theta_deg - theta).abs() < 1e-12, "{a}, {theta}: {t:?}");
            assert!((t.alpha_scalar - a).abs() < 1e-12, "{a}, {theta}: {t:?}");
        }
        // A zero tilt prints as +0, and the ends of the range fold onto +90°.
        assert!(
            Transfer::from_alpha_abs(a_theta(-1.0, 0.0))
                .theta_deg
                .is_sign_positive()
        );
        assert_eq!(axis_angle_deg(1.0, 0.0), 90.0);
        assert_eq!(axis_angle_deg(-1.0, 0.0), 90.0);
    }
}
