//! Problems with known answers or representative of the paper, used by tests and benches.

use crate::error::ParamError;
use crate::material::{Kinematics, Material};
use crate::mesh::{Edge, Mesh, Passive};
use crate::model::{BoundaryConditions, Component, Model, pea_force};

/// A cantilever clamped on its left edge (`x = 0`, both components) with a tip load shared
/// by the right-edge nodes.
#[derive(Debug, Clone)]
pub struct Cantilever {
    /// The model.
    pub model: Model,
    /// Length `L`, m.
    pub length: f64,
    /// Depth `h`, m.
    pub height: f64,
    /// Node at mid-depth of the free end (exists when `nw` is even; otherwise the nearest node).
    pub tip_node: usize,
    /// Right-edge nodes and their consistent share of a uniform edge load (sums to 1).
    pub tip_weights: Vec<(usize, f64)>,
}

impl Cantilever {
    /// `nl × nw` elements over `length × height × thickness`.
    pub fn new(
        material: Material,
        kinematics: Kinematics,
        length: f64,
        height: f64,
        thickness: f64,
        nl: usize,
        nw: usize,
    ) -> Result<Self, ParamError> {
        let mesh = Mesh::new(length, height, thickness, nl, nw)?;
        let mut bcs = BoundaryConditions::new();
        bcs.fix_edge(&mesh, Edge::Left, Component::Both);
        let tip_node = mesh.nearest_node([length, 0.5 * height]);
        let right = mesh.nodes_on_edge(Edge::Right);
        let tip_weights = right
            .iter()
            .enumerate()
            .map(|(j, &n)| {
                let w = if j == 0 || j == nw { 0.5 } else { 1.0 };
                (n, w / nw as f64)
            })
            .collect();
        let model = Model::new(mesh, material, kinematics, bcs)?;
        Ok(Self {
            model,
            length,
            height,
            tip_node,
            tip_weights,
        })
    }

    /// Full load vector of a total tip force `(fx, fy)` (dead load), spread uniformly over the
    /// free-end nodes.
    pub fn tip_load(&self, fx: f64, fy: f64) -> Vec<f64> {
        let mut p = self.model.zero_vector();
        for &(n, w) in &self.tip_weights {
            p[2 * n] += w * fx;
            p[2 * n + 1] += w * fy;
        }
        p
    }

    /// Second moment of area `t h³ / 12`.
    pub fn inertia(&self) -> f64 {
        self.model.mesh().thickness * self.height.powi(3) / 12.0
    }

    /// Timoshenko beam theory tip deflection under tip force `p`:
    /// `δ = P L³/(3 E I) + P L/(κ G A)`, `κ = 5/6`, `G = E/(2(1+ν))`.
    pub fn timoshenko_tip_deflection(&self, p: f64) -> f64 {
        let m = self.model.material();
        let e = m.e0;
        let g = e / (2.0 * (1.0 + m.nu));
        let a = self.model.mesh().thickness * self.height;
        p * self.length.powi(3) / (3.0 * e * self.inertia()) + p * self.length / (5.0 / 6.0 * g * a)
    }
}

/// The paper's stage problem (Section 2.1, Fig. 2b, DECISIONS.md): the 0.12 × 0.06 × 0.01 m domain,
/// PEA1 on the left and PEA2 on the right edge at mid-height, acting along x through grounded
/// springs `K_pea` (Eq. (2)–(3)), input ports on rollers (`u_y = 0`), output at the centre of
/// the top edge, and small passive-solid patches at the three ports.
#[derive(Debug, Clone)]
pub struct Stage {
    /// The model.
    pub model: Model,
    /// Left input node (PEA1).
    pub input_left: usize,
    /// Right input node (PEA2).
    pub input_right: usize,
    /// Output node (top centre).
    pub output: usize,
    /// PEA stiffness, N/m.
    pub k_pea: f64,
}

impl Stage {
    /// Paper defaults (Table 1, Table 3) on an `nl × nw` mesh: K_pea = 250 N/µm.
    pub fn paper(nl: usize, nw: usize, kinematics: Kinematics) -> Result<Self, ParamError> {
        Self::new(
            Material::paper(),
            kinematics,
            0.12,
            0.06,
            0.01,
            nl,
            nw,
            2.5e8,
        )
    }

    /// General constructor.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        material: Material,
        kinematics: Kinematics,
        length: f64,
        width: f64,
        thickness: f64,
        nl: usize,
        nw: usize,
        k_pea: f64,
    ) -> Result<Self, ParamError> {
        let mut mesh = Mesh::new(length, width, thickness, nl, nw)?;
        let input_left = mesh.nearest_node([0.0, 0.5 * width]);
        let input_right = mesh.nearest_node([length, 0.5 * width]);
        let output = mesh.nearest_node([0.5 * length, width]);
        // Passive solid patches of about 2×4 elements (at least one) around each port.
        let (hx, hy) = (2.0 * mesh.dx(), 2.0 * mesh.dy());
        for (c, lo, hi) in [
            (input_left, [0.0, -hy], [hx, hy]),
            (input_right, [-hx, -hy], [0.0, hy]),
            (output, [-hx, -hy], [hx, 0.0]),
        ] {
            let p = mesh.node_coords(c);
            let els =
                mesh.elements_in_box([p[0] + lo[0], p[1] + lo[1]], [p[0] + hi[0], p[1] + hi[1]]);
            mesh.set_passive(&els, Passive::Solid);
        }
        let mut bcs = BoundaryConditions::new();
        bcs.fix_node(input_left, Component::Y)
            .fix_node(input_right, Component::Y)
            .add_spring(2 * input_left, k_pea)
            .add_spring(2 * input_right, k_pea);
        let model = Model::new(mesh, material, kinematics, bcs)?;
        Ok(Self {
            model,
            input_left,
            input_right,
            output,
            k_pea,
        })
    }

    /// Load vector for nominal PEA strokes `x_nom1` (left) and `x_nom2` (right), m:
    /// forces `K_pea·x_nom,i` along x at the input nodes (global signs).
    pub fn pea_load(&self, x_nom1: f64, x_nom2: f64) -> Vec<f64> {
        let mut p = self.model.zero_vector();
        p[2 * self.input_left] += pea_force(self.k_pea, x_nom1);
        p[2 * self.input_right] += pea_force(self.k_pea, x_nom2);
        p
    }

    /// Uniform density `rho` with passive overrides applied.
    pub fn uniform_density(&self, rho: f64, rho_void: f64) -> Vec<f64> {
        let mut r = vec![rho; self.model.mesh().n_elements()];
        self.model.mesh().apply_passive(&mut r, rho_void);
        r
    }

    /// Reproducible pseudo-random densities in `[lo, hi]` (xorshift, seeded) with passive
    /// overrides applied.
    pub fn random_density(&self, lo: f64, hi: f64, seed: u64, rho_void: f64) -> Vec<f64> {
        let mut r = random_vector(self.model.mesh().n_elements(), lo, hi, seed);
        self.model.mesh().apply_passive(&mut r, rho_void);
        r
    }
}

/// Reproducible pseudo-random vector with entries in `[lo, hi]` (xorshift64*).
pub fn random_vector(n: usize, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s >> 12;
            s ^= s << 25;
            s ^= s >> 27;
            let x = (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
            lo + (hi - lo) * x
        })
        .collect()
}
