//! Parameter groups of the design stage: domain, material, actuators, supports, output port,
//! passive regions and the optimization settings (paper Section 2, Tables 1–3, DECISIONS.md).

use serde::{Deserialize, Serialize};

use crate::error::{Result, ScenarioError, check, count, non_negative, positive, within};

/// The rectangular design domain and its Q4 discretization (Table 3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mesh {
    /// Length l along x \[m\], in [1e-4, 10]. Table 3: 0.12.
    pub length: f64,
    /// Width w along y \[m\], in [1e-4, 10]. Table 3: 0.06.
    pub width: f64,
    /// Out-of-plane thickness t \[m\], in [1e-6, 1]. Table 3: 0.01.
    pub thickness: f64,
    /// Elements along x, n_l in [4, 4000]. Table 3: 120.
    pub nl: usize,
    /// Elements along y, n_w in [4, 4000]. Table 3: 60.
    pub nw: usize,
}

impl Mesh {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        // A compliant stage is between a tenth of a millimetre and ten metres across.
        within("mesh.length", self.length, 1e-4, 10.0)?;
        within("mesh.width", self.width, 1e-4, 10.0)?;
        within("mesh.thickness", self.thickness, 1e-6, 1.0)?;
        // At least 4 elements a side: the three ports must fall on distinct nodes away from
        // the corners (a 1 × 1 mesh has a degenerate workspace of NaN area).
        count("mesh.nl", self.nl, 4, 4000)?;
        count("mesh.nw", self.nw, 4, 4000)?;
        Ok(())
    }

    /// Element side lengths (dx, dy) \[m\].
    pub fn element_size(&self) -> (f64, f64) {
        (self.length / self.nl as f64, self.width / self.nw as f64)
    }

    /// Is the point inside the domain (with a tolerance of half an element)?
    pub fn contains(&self, p: [f64; 2]) -> bool {
        let (dx, dy) = self.element_size();
        p[0] >= -0.5 * dx
            && p[0] <= self.length + 0.5 * dx
            && p[1] >= -0.5 * dy
            && p[1] <= self.width + 0.5 * dy
    }
}

/// Linear-elastic solid material with SIMP interpolation (Table 3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus E0 of the solid \[Pa\]. Table 3: 73e9 (aluminium 6061).
    pub youngs_modulus: f64,
    /// Young's modulus E_min given to void \[Pa\], 0 < E_min < E0, and E0 (like every
    /// spring) at most what the solver resolves against it (a contrast of about
    /// 1e11 on the quick mesh; `flexstage check` names the bound). Table 3: 1e3.
    pub min_modulus: f64,
    /// Poisson ratio ν, in (−1, 0.5). Table 3: 0.33.
    pub poisson_ratio: f64,
    /// Mass density ρ0 [kg/m³]. Table 3: 2710.
    pub density: f64,
}

impl Material {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        positive("material.youngs_modulus", self.youngs_modulus)?;
        positive("material.min_modulus", self.min_modulus)?;
        if self.min_modulus >= self.youngs_modulus {
            return Err(ScenarioError::Inconsistent {
                fields: "material.min_modulus, material.youngs_modulus".into(),
                reason: format!(
                    "min_modulus ({:e}) must be smaller than youngs_modulus ({:e})",
                    self.min_modulus, self.youngs_modulus
                ),
            });
        }
        check(
            "material.poisson_ratio",
            self.poisson_ratio,
            self.poisson_ratio > -1.0 && self.poisson_ratio < 0.5,
            "a number in (-1, 0.5)",
        )?;
        positive("material.density", self.density)
    }
}

/// Picks nodes or elements of the mesh by geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Selector {
    /// The node nearest to a point \[m\].
    Nearest {
        /// (x, y) \[m\].
        #[serde(deserialize_with = "crate::strict::array")]
        point: [f64; 2],
    },
    /// Every node on one edge of the domain.
    Edge {
        /// Which edge.
        edge: Edge,
    },
    /// Every node (or element centroid) inside an axis-aligned box \[m\].
    Box {
        /// Lower-left corner (x, y) \[m\].
        #[serde(deserialize_with = "crate::strict::array")]
        min: [f64; 2],
        /// Upper-right corner (x, y) \[m\].
        #[serde(deserialize_with = "crate::strict::array")]
        max: [f64; 2],
    },
}

/// An edge of the rectangular domain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Edge {
    /// x = 0.
    Left,
    /// x = l.
    Right,
    /// y = 0.
    Bottom,
    /// y = w.
    Top,
}

impl Selector {
    fn validate(&self, field: &str, mesh: &Mesh) -> Result<()> {
        let inside = |p: [f64; 2], what: &str| {
            if mesh.contains(p) {
                Ok(())
            } else {
                Err(ScenarioError::OutOfRange(crate::RangeError {
                    field: format!("{field}.{what}"),
                    value: format!("[{:e}, {:e}]", p[0], p[1]),
                    expected: format!(
                        "a point inside the domain [0, {:e}] x [0, {:e}] m",
                        mesh.length, mesh.width
                    ),
                }))
            }
        };
        match self {
            Selector::Nearest { point } => inside(*point, "point"),
            Selector::Edge { .. } => Ok(()),
            Selector::Box { min, max } => {
                if min[0] > max[0] || min[1] > max[1] {
                    return Err(ScenarioError::Inconsistent {
                        fields: format!("{field}.min, {field}.max"),
                        reason: "min must not exceed max in x or y".into(),
                    });
                }
                Ok(())
            }
        }
    }
}

/// Which displacement components a support fixes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Fix {
    /// u_x = 0 (a roller that slides along y).
    X,
    /// u_y = 0 (a roller that slides along x).
    Y,
    /// u_x = u_y = 0 (clamped).
    Xy,
}

/// A support: the selected nodes have the given components fixed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Support {
    /// Components fixed.
    pub fix: Fix,
    /// Nodes supported.
    pub at: Selector,
}

/// Table 2: the sign convention that relates PEA strokes to the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Configuration {
    /// Compressive inputs (PEA1 →, PEA2 ←) give maximum y_out.
    Regular,
    /// Compressive inputs give minimum y_out (output along −y), for narrow domains.
    Reversed,
}

/// The smallest stroke amplitude \[m\] (1 nm).
pub const MIN_STROKE: f64 = 1e-9;

/// The two piezo actuators (Table 1, Eq. 2–3, DECISIONS.md).
///
/// Each PEA acts on its input node as a grounded spring `stiffness` along x plus the force
/// `stiffness · x_nom`, with global signs (positive x_nom pushes the tip along +x).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Actuators {
    /// PEA stiffness K_pea [N/m]. Table 1: 250 N/µm = 2.5e8.
    pub stiffness: f64,
    /// Maximum nominal stroke max x_nom \[m\], in [2e-9, 1]. Table 1: 60e-6.
    pub max_stroke: f64,
    /// Blocking force f_block \[N\]. Table 1: 1.5e4.
    pub blocking_force: f64,
    /// Half range of the preloaded nominal stroke \[m\]: x_nom ∈ [−a, a], a in
    /// [1e-9, max_stroke/2]. Section 4.1: 30e-6.
    pub stroke_amplitude: f64,
    /// Table 2 configuration.
    pub configuration: Configuration,
    /// Input node of PEA1.
    pub pea1: Selector,
    /// Input node of PEA2.
    pub pea2: Selector,
}

impl Actuators {
    /// Checks every field.
    pub fn validate(&self, mesh: &Mesh) -> Result<()> {
        positive("actuators.stiffness", self.stiffness)?;
        // A stroke below a nanometre is below any sensor of Section 4.1 (7.5 nm); its
        // workspace, ∝ a², underflowed to 0 at a = 1e-308 (area 0, "NaN × the input stroke
        // square"). A metre is beyond any piezo actuator.
        within(
            "actuators.max_stroke",
            self.max_stroke,
            2.0 * MIN_STROKE,
            1.0,
        )?;
        positive("actuators.blocking_force", self.blocking_force)?;
        check(
            "actuators.stroke_amplitude",
            self.stroke_amplitude,
            self.stroke_amplitude >= MIN_STROKE && 2.0 * self.stroke_amplitude <= self.max_stroke,
            &format!(
                "a number in [{MIN_STROKE:e}, max_stroke/2 = {:e}] m",
                0.5 * self.max_stroke
            ),
        )?;
        self.pea1.validate("actuators.pea1", mesh)?;
        self.pea2.validate("actuators.pea2", mesh)
    }
}

/// The output port (Figure 2b, Eq. 7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// The output node.
    pub at: Selector,
    /// Tilt θ of the target output frame \[deg\] (Figure 4b, Eq. 22); 0 is the normal setup.
    pub tilt_deg: f64,
    /// Direction `d` of the output displacement to maximize (`objective = "displacement"`):
    /// any non-zero finite vector, normalized on use. Unset: `(sin θ, cos θ)` of `tilt_deg`
    /// (negated in the reversed configuration). Required with `[[ports]]`.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::strict::option_array"
    )]
    pub direction: Option<[f64; 2]>,
}

impl Output {
    /// Checks every field.
    pub fn validate(&self, mesh: &Mesh) -> Result<()> {
        self.at.validate("output.at", mesh)?;
        within("output.tilt_deg", self.tilt_deg, -89.0, 89.0)?;
        if let Some(d) = self.direction {
            direction("output.direction", d, false)?;
        }
        Ok(())
    }

    /// The unit direction `d` of `direction`, if given.
    pub fn unit_direction(&self) -> Option<[f64; 2]> {
        self.direction.map(|d| {
            let n = d[0].hypot(d[1]);
            [d[0] / n, d[1] / n]
        })
    }
}

/// Checks a direction vector: finite and non-zero; with `axis`, along x or y.
fn direction(field: &str, d: [f64; 2], axis: bool) -> Result<()> {
    let shown = format!("[{:e}, {:e}]", d[0], d[1]);
    let n = d[0].hypot(d[1]);
    if !(n.is_finite() && n > 1e-12) {
        return Err(crate::RangeError::new(
            field,
            shown,
            "a finite non-zero vector [x, y] (it is normalized on use)",
        )
        .into());
    }
    if axis && d[0] != 0.0 && d[1] != 0.0 {
        return Err(crate::RangeError::new(
            field,
            shown,
            "a vector along x or y, [±a, 0] or [0, ±a] (a port drives one DOF)",
        )
        .into());
    }
    Ok(())
}

/// An input port of a general mechanism problem (`[[ports]]`, e.g. Sigmund's displacement
/// inverter or a gripper): on one node, along x or y, a grounded input spring `k_in` and the
/// load `f = k_in · x_nom` (Eq. 2–3 for a PEA of stiffness `k_in` and nominal stroke `x_nom`).
/// Give the load either as a `force` f \[N\] or as the free `displacement` x_nom \[m\] of
/// the source (a displacement source with internal stiffness `k_in`); both act along
/// `direction`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Port {
    /// The input node (exactly one).
    pub at: Selector,
    /// Direction of the load, along x or y (`[±1, 0]` or `[0, ±1]`).
    #[serde(deserialize_with = "crate::strict::array")]
    pub direction: [f64; 2],
    /// Input spring `k_in` \[N/m\], > 0: the source's stiffness.
    pub spring: f64,
    /// Input force f \[N\] along `direction` (exclusive with `displacement`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force: Option<f64>,
    /// Free stroke x_nom \[m\] of the source along `direction` (exclusive with `force`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement: Option<f64>,
}

impl Port {
    /// Checks every field; `field` is the TOML path (e.g. `ports[0]`).
    pub fn validate(&self, field: &str, mesh: &Mesh) -> Result<()> {
        self.at.validate(&format!("{field}.at"), mesh)?;
        direction(&format!("{field}.direction"), self.direction, true)?;
        positive(&format!("{field}.spring"), self.spring)?;
        match (self.force, self.displacement) {
            (Some(f), None) => check(
                &format!("{field}.force"),
                f,
                f.is_finite() && f != 0.0,
                "a finite non-zero force [N]",
            ),
            (None, Some(x)) => check(
                &format!("{field}.displacement"),
                x,
                x.is_finite() && x != 0.0 && x.abs() <= 1.0,
                "a non-zero stroke in [-1, 1] m",
            ),
            (f, x) => Err(ScenarioError::Inconsistent {
                fields: format!("{field}.force, {field}.displacement"),
                reason: format!(
                    "give exactly one of force and displacement (force = {f:?}, displacement = {x:?})"
                ),
            }),
        }
    }

    /// The DOF component the port drives: 0 = x, 1 = y.
    pub fn component(&self) -> usize {
        usize::from(self.direction[0] == 0.0)
    }

    /// The signed nominal stroke along the driven DOF's +axis \[m\]: `x_nom` or `f / k_in`,
    /// times the sign of `direction`.
    pub fn nominal_stroke(&self) -> f64 {
        let x = self
            .displacement
            .unwrap_or_else(|| self.force.unwrap_or(0.0) / self.spring);
        x * self.direction[self.component()].signum()
    }
}

/// A passive element region whose density is not designed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Solid (ρ = 1) or void (ρ = ρ_min).
    pub kind: RegionKind,
    /// The elements whose centroid is selected.
    pub at: Selector,
}

/// Kind of a passive region.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RegionKind {
    /// Always full material.
    Solid,
    /// Always void.
    Void,
}

fn default_true() -> bool {
    true
}

fn default_stagnation_window() -> usize {
    20
}

fn default_stagnation_tolerance() -> f64 {
    1e-3
}

/// Topology-optimization settings (Table 3, Eq. 5, DECISIONS.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Optimization {
    /// SIMP penalty p, in [1, 6]. Table 3: 3.
    pub penalty: f64,
    /// Pseudo-density lower bound ρ_min, in (0, 0.1]. Table 3: 1e-6.
    pub rho_min: f64,
    /// Maximum number of design iterations. Table 3: 1000.
    pub max_iterations: usize,
    /// Input samples p_m on the perimeter of the stroke square (multiple of 4). Table 3: 40.
    pub samples: usize,
    /// Initial uniform density, in (ρ_min, 1]. The paper is silent; default equal to
    /// `volume_fraction` (a feasible start).
    pub initial_density: f64,
    /// Density-filter radius in element sizes, in [0, 20] (0 = off). DECISIONS.md: a filter by
    /// default. With `robust`, the smallest radius: the minimum sizes of `limits` may need more.
    pub filter_radius: f64,
    /// Upper bound on the volume fraction of the design domain, in (0, 1]; 1 disables the
    /// constraint (the paper states none). Default 0.235: the paper's stage weighs 46 g (Table
    /// 4, weighed), 23.5 % of the 195 g solid domain (DECISIONS.md, "Constraints").
    pub volume_fraction: f64,
    /// Stop when the largest density change falls below this, in (0, 1).
    pub change_tolerance: f64,
    /// Finite-element kinematics during optimization: geometrically nonlinear (Appendix A)
    /// or linear (small strain, the classic mechanism codes).
    pub kinematics: KinematicsKind,
    /// What is maximized: the workspace area (Eq. 4–5) or a single output displacement (the
    /// displacement inverter of the classic codes).
    pub objective: ObjectiveKind,
    /// Stiffness [N/m] of the load the output port drives, ≥ 0; 0 = none. It acts on the
    /// output's motion relative to the moving frame of Eq. (22): on `u_oy`, and on
    /// `u_ox − ½(u_in1 + u_in2)` (a rigid translation of the floating stage loads nothing).
    /// Default 4e6 N/m, the paper's measured output stiffness (Table 4, K_qo ≈ 3.8–4.0e6): the
    /// design must push its output against a load as stiff as the stage the paper built, so it
    /// transmits force, not only motion (without a load the workspace optimum moves the output
    /// through void "hinges"). DECISIONS.md, "Output load".
    pub output_spring: f64,
    /// Strain-energy bound Σ0 \[J\] of Eq. (5), ≥ 0; 0 = derived from the allowable stress:
    /// `Σ0 = (1 − ν) σ_a² V* / E0` with `σ_a = limits.fatigue_strength / limits.safety_factor`
    /// and `V*` the material volume — the most energy the material can store without exceeding
    /// σ_a anywhere (DECISIONS.md, "Strain-energy bound").
    pub strain_energy_limit: f64,
    /// Largest angle \[deg\] between the differential output and the tilted target axis θ
    /// (`output.tilt_deg`), in (0, 45]; only used when θ ≠ 0.
    pub tilt_tolerance_deg: f64,
    /// Stop when additionally the KKT residual of the MMA problem is below this, > 0
    /// (Svanberg's kktcheck max norm of the scaled problem per unit max(1, |f0|)).
    pub kkt_tolerance: f64,
    /// Stagnation window W \[iterations\], in [0, 10000]; 0 = off. At the final β the run also
    /// stops when, over the last W iterations, the objective varied by at most
    /// `stagnation_tolerance` (relative), every update's mean |Δx| was below
    /// `change_tolerance`, the constraints hold and (without the robust formulation) the KKT
    /// residual is below `kkt_tolerance`. Default 20.
    #[serde(default = "default_stagnation_window")]
    pub stagnation_window: usize,
    /// Relative objective variation over the stagnation window, in (0, 1). Default 1e-3: the
    /// worst case of the robust formulation wobbles by a few 1e-4 at a stationary design.
    #[serde(default = "default_stagnation_tolerance")]
    pub stagnation_tolerance: f64,
    /// Mirror symmetry about the vertical centre line x = l/2: one design variable for each
    /// element and its mirror image, so the design is symmetric by construction. Needs a
    /// mirror-symmetric problem (supports, ports, passive regions) and `output.tilt_deg = 0`.
    /// Default true (the normal configuration).
    #[serde(default = "default_true")]
    pub mirror_symmetry: bool,
    /// Robust formulation (Wang, Lazarov & Sigmund 2011): maximize the worst workspace of the
    /// eroded, intermediate (blueprint) and dilated designs, with the thresholds and the filter
    /// radius mapped from `limits.min_hinge_thickness` and `limits.min_slot_width`
    /// (DECISIONS.md, "Robust formulation"). Default true.
    #[serde(default = "default_true")]
    pub robust: bool,
    /// Strain-energy constraint Σ ≤ Σ0 of Eq. (5) (`strain_energy_limit`). Default true; the
    /// classic mechanism codes (inverter, gripper) state none.
    #[serde(default = "default_true")]
    pub energy_constraint: bool,
    /// Fatigue stress constraint: aggregated von Mises stress of the (eroded) design at the
    /// four Table 2 extreme inputs ≤ `limits.fatigue_strength / limits.safety_factor`
    /// (DECISIONS.md, "Stress constraint"). Default true.
    #[serde(default = "default_true")]
    pub stress_constraint: bool,
    /// Heaviside projection with β continuation (DECISIONS.md filtering).
    pub projection: Projection,
    /// Additive Yeoh hyperelasticity in low-density elements (Appendix A, Eq. A2–A4).
    pub additive: Additive,
}

/// Finite-element kinematics used by the optimizer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KinematicsKind {
    /// Total Lagrangian, Green–Lagrange strain (Eq. A1).
    Nonlinear,
    /// Small strain, linear elasticity.
    Linear,
}

/// The optimization objective.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectiveKind {
    /// Maximize the shoelace area of the output polygon (Eq. 4).
    Workspace,
    /// Maximize the output displacement `d · u_out` along `output.direction` (or the tilt
    /// axis): for the two PEAs under the compressive input (PEA1 +a, PEA2 −a), for
    /// `[[ports]]` under their loads; with the output spring.
    Displacement,
}

/// Smoothed Heaviside projection `ρ̄ = (tanh βη + tanh β(ρ̃−η)) / (tanh βη + tanh β(1−η))`
/// of the filtered densities, with β doubled every `interval` iterations from 1 to `beta_max`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Projection {
    /// Use the projection.
    pub enabled: bool,
    /// Final β, in [1, 1024].
    pub beta_max: f64,
    /// Iterations between doublings of β, ≥ 1.
    pub interval: usize,
    /// Threshold η, in (0, 1).
    pub eta: f64,
}

/// The additive hyperelastic material of Appendix A (Eq. A2–A4, Table 3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Additive {
    /// Use it during optimization (never in the final analysis). Default false: at the paper's
    /// stroke (strains ≈ 1e-3) it changes neither the topology nor the workspace area
    /// (DECISIONS.md, "Additive material"), and it costs a third of every assembly.
    pub enabled: bool,
    /// Initial hyper-elastic coefficient as a fraction of E0. Table 3: 1e-5.
    pub initial_coefficient: f64,
    /// Von Mises strain threshold ε* of the c2 update (Eq. A3). Table 3: 0.5.
    pub strain_threshold: f64,
}

impl Optimization {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        within("optimization.penalty", self.penalty, 1.0, 6.0)?;
        check(
            "optimization.rho_min",
            self.rho_min,
            self.rho_min > 0.0 && self.rho_min <= 0.1,
            "a number in (0, 0.1]",
        )?;
        count(
            "optimization.max_iterations",
            self.max_iterations,
            0,
            100_000,
        )?;
        count("optimization.samples", self.samples, 4, 4000)?;
        if self.samples % 4 != 0 {
            return Err(ScenarioError::OutOfRange(crate::RangeError {
                field: "optimization.samples".into(),
                value: self.samples.to_string(),
                expected: "a multiple of 4 (the samples walk the four sides of the stroke square)"
                    .into(),
            }));
        }
        check(
            "optimization.initial_density",
            self.initial_density,
            self.initial_density > self.rho_min && self.initial_density <= 1.0,
            "a number in (rho_min, 1]",
        )?;
        within("optimization.filter_radius", self.filter_radius, 0.0, 20.0)?;
        check(
            "optimization.volume_fraction",
            self.volume_fraction,
            self.volume_fraction > 0.0 && self.volume_fraction <= 1.0,
            "a number in (0, 1]",
        )?;
        check(
            "optimization.change_tolerance",
            self.change_tolerance,
            self.change_tolerance > 0.0 && self.change_tolerance < 1.0,
            "a number in (0, 1)",
        )?;
        non_negative("optimization.output_spring", self.output_spring)?;
        non_negative("optimization.strain_energy_limit", self.strain_energy_limit)?;
        check(
            "optimization.tilt_tolerance_deg",
            self.tilt_tolerance_deg,
            self.tilt_tolerance_deg > 0.0 && self.tilt_tolerance_deg <= 45.0,
            "a number in (0, 45]",
        )?;
        positive("optimization.kkt_tolerance", self.kkt_tolerance)?;
        check(
            "optimization.stagnation_window",
            self.stagnation_window as f64,
            self.stagnation_window <= 10_000,
            "an integer in [0, 10000]",
        )?;
        check(
            "optimization.stagnation_tolerance",
            self.stagnation_tolerance,
            self.stagnation_tolerance > 0.0 && self.stagnation_tolerance < 1.0,
            "a number in (0, 1)",
        )?;
        within(
            "optimization.projection.beta_max",
            self.projection.beta_max,
            1.0,
            1024.0,
        )?;
        count(
            "optimization.projection.interval",
            self.projection.interval,
            1,
            100_000,
        )?;
        check(
            "optimization.projection.eta",
            self.projection.eta,
            self.projection.eta > 0.0 && self.projection.eta < 1.0,
            "a number in (0, 1)",
        )?;
        non_negative(
            "optimization.additive.initial_coefficient",
            self.additive.initial_coefficient,
        )?;
        positive(
            "optimization.additive.strain_threshold",
            self.additive.strain_threshold,
        )
    }
}

/// What the built stage must withstand and what the workshop can make: the fatigue strength
/// with its safety factor, and the smallest hinge and slot (DECISIONS.md, "Stress constraint",
/// "Robust formulation"). Defaults: aluminium 6061-T6 and wire EDM.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Fatigue strength of the solid material \[Pa\], > 0: the fully reversed stress amplitude
    /// it survives for the design life. Al 6061-T6: 96.5e6 (5·10⁸ cycles, R. R. Moore
    /// rotating beam; ASM Handbook Vol. 2, 1990, and the Aluminum Association's data).
    pub fatigue_strength: f64,
    /// Tensile yield strength \[Pa\], ≥ fatigue_strength. Al 6061-T6: 276e6 (same sources).
    pub yield_strength: f64,
    /// Safety factor on the fatigue strength, in [1, 10]: the allowable stress is
    /// `fatigue_strength / safety_factor`. Default 1.5.
    pub safety_factor: f64,
    /// How much the design mesh under-estimates the peak stress of a hinge, in [1, 10]: the
    /// optimizer keeps the design-mesh stress below `allowable / mesh_stress_factor`. Default 2
    /// (measured 2–3× between the 1 mm design mesh and refined re-analyses of hinges); the
    /// body-fitted re-analysis of the exported outline checks it.
    pub mesh_stress_factor: f64,
    /// Smallest solid member (hinge) thickness the workshop can make \[m\], > 0. Default 0.5 mm.
    pub min_hinge_thickness: f64,
    /// Smallest void (slot) width \[m\], > 0, e.g. the wire-EDM kerf. Default 0.4 mm.
    pub min_slot_width: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            fatigue_strength: 96.5e6,
            yield_strength: 276e6,
            safety_factor: 1.5,
            mesh_stress_factor: 2.0,
            min_hinge_thickness: 0.5e-3,
            min_slot_width: 0.4e-3,
        }
    }
}

impl Limits {
    /// The allowable stress `fatigue_strength / safety_factor` \[Pa\].
    pub fn allowable_stress(&self) -> f64 {
        self.fatigue_strength / self.safety_factor
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        // The ranges export's verification accepts (flexstage-verify): from a pascal (far
        // below any material; a subnormal strength made the allowable stress 0) to 10 GPa.
        within("limits.fatigue_strength", self.fatigue_strength, 1.0, 1e10)?;
        within("limits.yield_strength", self.yield_strength, 1.0, 1e10)?;
        if self.fatigue_strength > self.yield_strength {
            return Err(ScenarioError::Inconsistent {
                fields: "limits.fatigue_strength, limits.yield_strength".into(),
                reason: format!(
                    "the fatigue strength ({:e} Pa) cannot exceed the yield strength ({:e} Pa)",
                    self.fatigue_strength, self.yield_strength
                ),
            });
        }
        within("limits.safety_factor", self.safety_factor, 1.0, 10.0)?;
        within(
            "limits.mesh_stress_factor",
            self.mesh_stress_factor,
            1.0,
            10.0,
        )?;
        // From a micrometre to the 5 cm export's verification accepts.
        within(
            "limits.min_hinge_thickness",
            self.min_hinge_thickness,
            1e-6,
            0.05,
        )?;
        within("limits.min_slot_width", self.min_slot_width, 1e-6, 0.05)
    }
}

/// Validates a list of supports against the mesh.
pub(crate) fn validate_supports(supports: &[Support], mesh: &Mesh) -> Result<()> {
    for (i, s) in supports.iter().enumerate() {
        s.at.validate(&format!("supports[{i}].at"), mesh)?;
    }
    Ok(())
}

/// Validates a list of passive regions against the mesh.
pub(crate) fn validate_regions(regions: &[Region], mesh: &Mesh) -> Result<()> {
    for (i, r) in regions.iter().enumerate() {
        r.at.validate(&format!("regions[{i}].at"), mesh)?;
    }
    Ok(())
}

/// Checks the `[[ports]]` of a general mechanism problem against the groups they interact
/// with (the node-level checks, e.g. a port on a support, are in `bounds`).
pub(crate) fn validate_ports(s: &crate::Scenario) -> Result<()> {
    if s.ports.is_empty() {
        return Ok(());
    }
    count("ports (number of [[ports]])", s.ports.len(), 1, 2)?;
    for (i, p) in s.ports.iter().enumerate() {
        p.validate(&format!("ports[{i}]"), &s.mesh)?;
    }
    let o = &s.optimization;
    let inconsistent = |fields: &str, reason: &str| {
        Err(ScenarioError::Inconsistent {
            fields: fields.into(),
            reason: reason.into(),
        })
    };
    if o.objective != ObjectiveKind::Displacement {
        return inconsistent(
            "ports, optimization.objective",
            "[[ports]] state a mechanism whose output displacement is maximized: set \
             optimization.objective = \"displacement\" (the workspace objective needs the two \
             PEAs of [actuators])",
        );
    }
    if s.output.direction.is_none() {
        return inconsistent(
            "ports, output.direction",
            "[[ports]] need output.direction, the direction of the output displacement to \
             maximize (e.g. [-1.0, 0.0])",
        );
    }
    if o.stress_constraint {
        return inconsistent(
            "ports, optimization.stress_constraint",
            "the fatigue stress constraint is evaluated at the Table 2 stroke corners of the \
             two-PEA stage; set optimization.stress_constraint = false for [[ports]] problems",
        );
    }
    if s.output.tilt_deg != 0.0 {
        return inconsistent(
            "ports, output.tilt_deg",
            "the tilt requirement belongs to the two-PEA workspace; with [[ports]] give the \
             output direction in output.direction and set tilt_deg = 0",
        );
    }
    Ok(())
}
