//! The assembled stage as a finite-element model: the designed mechanism plus the PEA sets of
//! Eq. (1)–(3) at its input ports. Both the twin and the full transient reference are built on
//! it, so that they differ only by the reduction.
//!
//! * **Structure**: the scenario's FE problem for the final analysis (Total Lagrangian, no
//!   additive material, `flexstage_reduce::reduction_problem`) with the design's densities. The
//!   optimizer's output spring (`optimization.output_spring`) is a design device, not a part of
//!   the stage, and is left out: the output point is free, as on the rig.
//! * **Void is air**: elements below [`StageFe::void_threshold`] (default 0.01) are removed
//!   (zero stiffness and mass), so are islands and fragments that hang on the structure by a
//!   single node (kept: the elements joined to a port through shared edges), and nodes left
//!   without any element are fixed. The optimizer's
//!   E_min = 1 kPa keeps its equations regular, but in a *dynamic* Total Lagrangian model
//!   massless void nodes with 1e-8 of the solid's stiffness are ill-posed (they drift by
//!   hundreds of µm and Newton stalls on them), and they are no part of the machined stage.
//!   Kept elements follow SIMP, `E = ρ^p E0` (E_min = 0): for a crisp design the statics and
//!   modes differ from `flexstage reduce`'s by about E_min/E0 = 1e-8.
//! * **Mass**: consistent Q4 element masses `m_e = m(ρ_e)·ρ0·V_e` with Du & Olhoff's (2007)
//!   interpolation `flexstage_fem::MassInterpolation` (`m = ρ` above ρ_c = 0.1, a C¹ polynomial
//!   `c₁ρ⁶ + c₂ρ⁷` below), the one the design's eigenproblem uses: void and faint grey material
//!   carry no mass, so they cannot resonate. The payload (`output.payload`) is a point mass on
//!   the output node.
//! * **PEA sets** (Eq. 1–3): at each input DOF a grounded spring K_pea (the PEA, Table 1) and a
//!   grounded spring K_in (the input plate's flexure, Table 4 estimate), a point mass m_in (the
//!   output blocking plate, Table 4) and the force K_pea·x_nom(t). The input ports stay on their
//!   rollers (u_y = 0).

use flexstage_fem::{
    BoundaryConditions, Design, DofMass, Kinematics, Model, SparseMatrix, consistent_mass,
    rigid_body_load,
};
use flexstage_reduce::MassInterpolation;
use flexstage_scenario::Scenario;
use flexstage_topopt::Problem;

use crate::error::{Result, TwinError, check};

/// The interface DOFs of the twin, in this order: PEA1 input (x), PEA2 input (x), output x,
/// output y.
pub const INTERFACE: usize = 4;

/// The assembled stage's FE model (module docs).
#[derive(Debug, Clone)]
pub struct StageFe {
    /// Total Lagrangian model with the PEA and input-plate springs.
    pub model: Model,
    /// Physical element densities.
    pub rho: Vec<f64>,
    /// Element masses \[kg\] (interpolated).
    pub element_mass: Vec<f64>,
    /// The input plates as point masses on the input DOFs.
    pub point_masses: Vec<DofMass>,
    /// Full DOF indices of the interface: [in1 x, in2 x, out x, out y].
    pub interface: [usize; INTERFACE],
    /// Output node.
    pub output_node: usize,
    /// PEA stiffnesses K_pea [N/m].
    pub k_pea: [f64; 2],
    /// The PEA ports' faces `(full DOF, weight)` (`flexstage_topopt::Port::face`): the PEA
    /// force is their uniform traction, an input's displacement their weighted mean.
    pub faces: [Vec<(usize, f64)>; 2],
    /// Input-plate stiffnesses K_in [N/m].
    pub k_in: [f64; 2],
    /// Input-plate masses m_in \[kg\].
    pub m_in: [f64; 2],
    /// Payload on the output node \[kg\] (`output.payload`).
    pub payload: f64,
    /// Material density ρ0 [kg/m³].
    pub density: f64,
    /// The void mass interpolation.
    pub interpolation: MassInterpolation,
    /// Elements with a density below this are removed (void is air).
    pub void_threshold: f64,
    /// Nodes without any remaining element (fixed).
    pub orphan_nodes: usize,
}

/// Default density below which an element is void and removed.
pub const VOID_THRESHOLD: f64 = 0.01;

/// `rho` with every element removed (set to 0) that is not joined to an element at one of
/// the `ports` through a chain of kept elements sharing edges: an island, or a fragment hanging
/// on a single node, is a mechanism once void is air (a singular stiffness), and no part of a
/// wire-cut stage.
fn edge_connected(mesh: &flexstage_fem::Mesh, mut rho: Vec<f64>, ports: &[usize]) -> Vec<f64> {
    let (nl, nw) = (mesh.nl, mesh.nw);
    let mut seen = vec![false; rho.len()];
    let mut stack: Vec<usize> = (0..rho.len())
        .filter(|&e| rho[e] > 0.0 && mesh.element_nodes(e).iter().any(|n| ports.contains(n)))
        .collect();
    for &e in &stack {
        seen[e] = true;
    }
    while let Some(e) = stack.pop() {
        let (i, j) = (e / nw, e % nw);
        let neighbours = [
            (i > 0).then(|| mesh.element(i - 1, j)),
            (i + 1 < nl).then(|| mesh.element(i + 1, j)),
            (j > 0).then(|| mesh.element(i, j - 1)),
            (j + 1 < nw).then(|| mesh.element(i, j + 1)),
        ];
        for f in neighbours.into_iter().flatten() {
            if !seen[f] && rho[f] > 0.0 {
                seen[f] = true;
                stack.push(f);
            }
        }
    }
    for (r, keep) in rho.iter_mut().zip(&seen) {
        if !keep {
            *r = 0.0;
        }
    }
    rho
}

impl StageFe {
    /// The stage of `problem` (two inputs with their PEA springs, rollers, output node) with
    /// densities `rho`, material density `density`, the plates `m_in` and `k_in` and the
    /// payload on the output; elements below [`VOID_THRESHOLD`] are removed.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        problem: &Problem,
        rho: &[f64],
        density: f64,
        interpolation: MassInterpolation,
        m_in: [f64; 2],
        k_in: [f64; 2],
        payload: f64,
    ) -> Result<StageFe> {
        let base = &problem.model;
        let n = base.mesh().n_elements();
        if rho.len() != n {
            return Err(TwinError::Design {
                got: rho.len(),
                expected: n,
            });
        }
        Design::new(rho).validate(n)?;
        check("material.density", density, density > 0.0, "> 0 kg/m³")?;
        interpolation.validate()?;
        let [a, b] = match problem.inputs.as_slice() {
            [a, b] => [a, b],
            other => {
                return Err(TwinError::Reduced(format!(
                    "the twin needs exactly two PEA inputs, the problem has {}",
                    other.len()
                )));
            }
        };
        check("output.payload", payload, payload >= 0.0, "≥ 0 kg")?;
        for i in 0..2 {
            check(&format!("m_in{}", i + 1), m_in[i], m_in[i] > 0.0, "> 0 kg")?;
            check(
                &format!("k_in{}", i + 1),
                k_in[i],
                k_in[i] >= 0.0,
                "≥ 0 N/m",
            )?;
        }
        let mesh = base.mesh();
        let rho: Vec<f64> = rho
            .iter()
            .map(|&r| if r < VOID_THRESHOLD { 0.0 } else { r })
            .collect();
        let rho = edge_connected(mesh, rho, &[a.node, b.node, problem.output]);
        let mut attached = vec![0usize; mesh.n_nodes()];
        for (e, &r) in rho.iter().enumerate() {
            if r > 0.0 {
                for n in mesh.element_nodes(e) {
                    attached[n] += 1;
                }
            }
        }
        let out = problem.output;
        for (what, node) in [
            ("PEA1 port", a.node),
            ("PEA2 port", b.node),
            ("output", out),
        ] {
            if attached[node] == 0 {
                return Err(TwinError::Reduced(format!(
                    "the {what} (node {node}) lies in void: the design does not connect it"
                )));
            }
        }
        let mut bcs: BoundaryConditions = base.bcs().clone();
        let orphans: Vec<usize> = (0..mesh.n_nodes()).filter(|&n| attached[n] == 0).collect();
        bcs.fix_nodes(&orphans, flexstage_fem::Component::Both);
        // The input plates' springs on the ports' displacements (their faces).
        for (p, k) in [(a, k_in[0]), (b, k_in[1])] {
            if p.face.len() == 1 {
                bcs.add_spring(p.dof, k);
            } else {
                bcs.add_link(&p.terms(1.0), k);
            }
        }
        let material = flexstage_fem::Material {
            e_min: 0.0,
            ..*base.material()
        };
        let model = Model::new(mesh.clone(), material, Kinematics::TotalLagrangian, bcs)?;
        let v = mesh.dx() * mesh.dy() * mesh.thickness;
        let element_mass = rho
            .iter()
            .map(|&r| interpolation.relative_mass(r) * density * v)
            .collect();
        // The plates move with their faces: each face DOF carries its weight's share.
        let mut point_masses: Vec<DofMass> = [(a, m_in[0]), (b, m_in[1])]
            .into_iter()
            .flat_map(|(p, m)| {
                p.face
                    .iter()
                    .map(move |&(dof, w)| DofMass { dof, mass: w * m })
            })
            .collect();
        if payload > 0.0 {
            point_masses.extend((0..2).map(|c| DofMass {
                dof: 2 * out + c,
                mass: payload,
            }));
        }
        Ok(StageFe {
            point_masses,
            interface: [a.dof, b.dof, 2 * out, 2 * out + 1],
            output_node: out,
            k_pea: [a.stiffness, b.stiffness],
            faces: [a.face.clone(), b.face.clone()],
            k_in,
            m_in,
            payload,
            density,
            interpolation,
            void_threshold: VOID_THRESHOLD,
            orphan_nodes: orphans.len(),
            rho,
            element_mass,
            model,
        })
    }

    /// The stage of a scenario and a design: the final-analysis problem without the output
    /// spring, `stage.truth`'s input plates (Table 4 estimates), the payload and the default
    /// void mass interpolation.
    pub fn from_scenario(scenario: &Scenario, rho: &[f64]) -> Result<StageFe> {
        let problem = flexstage_reduce::reduction_problem(scenario, false)?;
        let t = &scenario.stage.truth;
        StageFe::new(
            &problem,
            rho,
            scenario.material.density,
            MassInterpolation::default(),
            [t.m_in1, t.m_in2],
            [t.k_in1, t.k_in2],
            scenario.output.payload,
        )
    }

    /// The densities as a design.
    pub fn design(&self) -> Design<'_> {
        Design::new(&self.rho)
    }

    /// The consistent mass matrix in the model's pattern (plates included).
    pub fn mass_matrix(&self) -> Result<SparseMatrix> {
        Ok(consistent_mass(
            &self.model,
            &self.element_mass,
            &self.point_masses,
        )?)
    }

    /// The tangent stiffness at u = 0 (springs included).
    pub fn stiffness(&self) -> SparseMatrix {
        let mut k = self.model.new_matrix();
        let mut ws = self.model.new_workspace();
        let zero = self.model.zero_vector();
        self.model
            .assemble(&self.design(), &zero, None, Some(&mut k), &mut ws);
        k
    }

    /// `M r` for a rigid base translation along `direction` (0 = x, 1 = y), full vector.
    pub fn rigid_body_load(&self, direction: usize) -> Result<Vec<f64>> {
        Ok(rigid_body_load(
            &self.model,
            &self.element_mass,
            &self.point_masses,
            direction,
        )?)
    }

    /// The PEA load `K_pea,i · x_nom,i` on the inputs (Eq. 2–3; the uniform traction on each
    /// face), full vector, into `out`.
    pub fn pea_load_into(&self, x_nom: [f64; 2], out: &mut [f64]) {
        out.fill(0.0);
        for i in 0..2 {
            for &(d, w) in &self.faces[i] {
                out[d] += w * self.k_pea[i] * x_nom[i];
            }
        }
    }

    /// The input displacements `x_in` (the faces' weighted means) of a full vector.
    pub fn input_displacements(&self, u: &[f64]) -> [f64; 2] {
        std::array::from_fn(|i| self.faces[i].iter().map(|&(d, w)| w * u[d]).sum())
    }

    /// The PEA load as a new full vector.
    pub fn pea_load(&self, x_nom: [f64; 2]) -> Vec<f64> {
        let mut p = self.model.zero_vector();
        self.pea_load_into(x_nom, &mut p);
        p
    }

    /// The structure's mass (element masses + plates + payload) \[kg\].
    pub fn total_mass(&self) -> f64 {
        self.element_mass.iter().sum::<f64>() + self.m_in[0] + self.m_in[1] + self.payload
    }
}
