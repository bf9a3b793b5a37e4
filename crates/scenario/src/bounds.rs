//! Checks that need more than one field: what the selectors pick on the mesh (ports on
//! distinct nodes, no port on a support that blocks it, no selector that picks nothing), a
//! structure held against rigid-body motion, unique trajectory names, trajectories the
//! sampled loop can follow, and the memory and time a scenario would take, estimated before
//! any work starts and refused over the documented limits ([`LIMITS`]).
//!
//! The selectors are resolved here exactly as the FE model resolves them (nodes at
//! `(i·dx, j·dy)`, nearest node by rounding, boxes inclusive with a tolerance of 1e-9 element
//! sizes; elements by centroid), so `flexstage check` refuses what `run` would refuse later.

// `!(x <= bound)` on purpose: a NaN fails every bound.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::design::{Edge, Fix, Selector};
use crate::error::{RangeError, Result, ScenarioError};
use crate::{ObjectiveKind, Scenario, Trajectory};

/// The documented limits of a scenario, in the order of [`LIMITS`].
pub mod limit {
    /// Longest name (scenario and trajectories), in characters: names become folder names.
    pub const NAME_CHARS: usize = 64;
    /// Elements of the design mesh (the fine preset has 28 800).
    pub const ELEMENTS: usize = 250_000;
    /// Estimated memory of the design stage, allocated at its peak \[bytes\] (16 GiB; the
    /// fine preset allocates about 9 GiB, of which about 2.2 GB is resident).
    pub const DESIGN_BYTES: f64 = 16.0 * 1024.0 * 1024.0 * 1024.0;
    /// Estimated linear-solve work of the design stage [floating-point operations]
    /// (about a day at 10 GFLOP/s).
    pub const DESIGN_FLOPS: f64 = 1e15;
    /// Samples of one tracking record (`duration / sample_time`).
    pub const TRACK_SAMPLES: f64 = 1e7;
    /// Plant integration steps of one tracking record (`samples × substeps`).
    pub const TRACK_STEPS: f64 = 2e8;
    /// Fewest samples of one tracking record (its settling and error figures need a few).
    pub const MIN_TRACK_SAMPLES: f64 = 10.0;
    /// Shortest controller sample time \[s\] (a 10 MHz loop).
    pub const MIN_SAMPLE_TIME: f64 = 1e-7;
    /// Largest trajectory amplitude \[m\], whatever the stroke.
    pub const MAX_AMPLITUDE: f64 = 1e-3;
    /// Modal work of one record on the digital twin (`samples × substeps × modes`, modes at
    /// least `twin.min_modes`): about five minutes at the twin's measured 3·10⁷ mode-steps a
    /// second (16 modes, 20 substeps, 10 kHz: 98 ms per simulated second, docs/performance.md).
    pub const TWIN_MODE_STEPS: f64 = 1e10;
    /// Estimated memory of one simulated record (its columns, 8 bytes a value) \[bytes\]
    /// (2 GiB).
    pub const RECORD_BYTES: f64 = 2.0 * 1024.0 * 1024.0 * 1024.0;
}

/// The limits as (what, limit) rows, for documentation and messages.
pub const LIMITS: [(&str, &str); 11] = [
    (
        "scenario and trajectory names",
        "1 to 64 letters, digits, '-', '_'",
    ),
    ("design mesh elements nl × nw", "≤ 250 000, each side ≥ 4"),
    ("design memory estimate (allocated at the peak)", "≤ 16 GiB"),
    ("design work estimate", "≤ 1e15 flop"),
    (
        "samples of one record (tracking, stage identification)",
        "≤ 1e7",
    ),
    (
        "plant steps of one record (samples × substeps, × oversampling)",
        "≤ 2e8",
    ),
    (
        "twin work of one tracking record (samples × substeps × modes)",
        "≤ 1e10",
    ),
    (
        "memory of one record (samples × columns × 8 bytes)",
        "≤ 2 GiB",
    ),
    (
        "samples of one record, at least",
        "10 (tracking), 200 (stage identification)",
    ),
    ("controller sample time", "≥ 1e-7 s"),
    (
        "trajectory frequency",
        "< Nyquist 1/(2 T_s); amplitude ≤ α·max_stroke and ≤ 1 mm",
    ),
];

/// Memory and work of the design stage, estimated from the mesh, the load cases and the
/// filter before any work starts.
///
/// The memory is what the design allocates at its peak, an upper bound of what it keeps
/// resident (pages allocated zeroed and never written are not resident). Everything that grows
/// is counted: each realization's FE workspace keeps, per load case, a tangent matrix, the
/// Anderson history, the equilibrium and adjoint solve blocks (five responses), the block-PCG
/// buffers and the warm starts, `VECTORS_PER_CASE` vectors of the DOFs in all, and the
/// element forces (64 bytes an element); per workspace a preconditioner and one fallback
/// factor per group (`FACTORS_PER_SET`, 12 bytes a non-zero of L) with their element
/// buffers; the final analysis keeps as many sets again while the optimizer's are alive
/// ([`DesignEstimate::sets`]); the density filter holds 12 bytes per pair of elements within
/// its radius; and the process itself (`RUNTIME_BYTES`: threads, allocator arenas, code).
/// Measured against `VmPeak` (allocated) and `VmHWM` (resident) of `flexstage design
/// --max-iterations 2` for 16–800 samples on 48 × 24 and 96 × 48 meshes, robust and not:
/// within +3 % to +15 % of the allocated peak, and above the resident one
/// (docs/DECISIONS.md, "Input bounds and fault handling").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignEstimate {
    /// Degrees of freedom, 2 (nl + 1)(nw + 1).
    pub dofs: f64,
    /// Non-zeros of the Cholesky factor (nested-dissection fill of a 2D grid, 8·n·log2 n).
    pub factor_nonzeros: f64,
    /// Load cases solved per iteration (samples × 3 realizations when robust, with the
    /// projection that it needs).
    pub load_cases: f64,
    /// Filter radius in element sizes: `optimization.filter_radius`, or with `robust` the
    /// radius that the minimum sizes of `[limits]` need (flexstage-topopt's length scale).
    pub filter_radius: f64,
    /// Element pairs of the density filter (elements within the radius of each element).
    pub filter_entries: f64,
    /// Memory \[bytes\] (allocated at the peak; see the type's docs).
    pub bytes: f64,
    /// Work \[flop\]: per iteration and load case, 3 Newton steps of one factorization
    /// (nnz(L)^1.5 / n flop, nested dissection) and a solve; building the filter (each
    /// element visits the square around its radius) and applying it (twice an iteration per
    /// realization).
    pub flops: f64,
}

/// Vectors of the DOFs an FE workspace allocates per load case: the tangent's lower triangle
/// (≈ 9.5), residual and start (2), Anderson history (13), the equilibrium and adjoint blocks
/// (10), block PCG (20), warm starts (≤ 6) and the solver's scratch.
pub const VECTORS_PER_CASE: f64 = 62.0;

/// Factorizations per workspace: the preconditioner and one fallback per group of cases.
pub const FACTORS_PER_SET: f64 = 3.0;

/// What the process allocates whatever the problem: threads and their allocator arenas,
/// code, the scenario \[bytes\] (256 MiB; measured 230–270 MB of `VmPeak` for the smallest
/// designs).
pub const RUNTIME_BYTES: f64 = 256.0 * 1024.0 * 1024.0;

/// `m(0.75)`: the smallest blueprint member of a threshold 0.75 in units of the filter radius
/// (flexstage-topopt's length scale, Qian & Sigmund 2013): the robust formulation's radius is at
/// least `min_size / m(0.75)`.
const MIN_SIZE_AT_MAX_OFFSET: f64 = 0.943;

impl DesignEstimate {
    /// The estimate of a scenario's design stage.
    pub fn of(s: &Scenario) -> DesignEstimate {
        let (nl, nw) = (s.mesh.nl as f64, s.mesh.nw as f64);
        let ne = nl * nw;
        let dofs = 2.0 * (nl + 1.0) * (nw + 1.0);
        let factor_nonzeros = 8.0 * dofs * dofs.log2().max(1.0);
        let o = &s.optimization;
        let samples = match o.objective {
            ObjectiveKind::Workspace => o.samples as f64,
            ObjectiveKind::Displacement => 1.0,
        };
        let robust = Self::robust(s);
        let realizations = if robust { 3.0 } else { 1.0 };
        let load_cases = samples * realizations;
        let (dx, dy) = s.mesh.element_size();
        let h = (dx * dy).sqrt();
        let sizes = s.limits.min_hinge_thickness.max(s.limits.min_slot_width);
        let filter_radius = if robust {
            o.filter_radius
                .clamp(1.5, 20.0)
                .max(sizes / MIN_SIZE_AT_MAX_OFFSET / h)
        } else {
            o.filter_radius
        };
        let reach = (filter_radius.ceil() / (dx.min(dy) / h)).ceil();
        let window = ((2.0 * reach + 1.0).min(nl) * (2.0 * reach + 1.0).min(nw)).max(1.0);
        let filter_entries = ne
            * (std::f64::consts::PI * filter_radius * filter_radius)
                .max(1.0)
                .min(window);
        let per_case = 8.0 * VECTORS_PER_CASE * dofs + 64.0 * ne;
        let per_set = FACTORS_PER_SET * (12.0 * factor_nonzeros + 600.0 * ne);
        let bytes =
            Self::sets(s) * (per_set + samples * per_case) + 12.0 * filter_entries + RUNTIME_BYTES;
        let factor = factor_nonzeros.powf(1.5) / dofs;
        let iterations = o.max_iterations.max(1) as f64;
        let flops = iterations * load_cases * 3.0 * (factor + 4.0 * factor_nonzeros)
            + ne * window
            + iterations * realizations * 4.0 * filter_entries;
        DesignEstimate {
            dofs,
            factor_nonzeros,
            load_cases,
            filter_radius,
            filter_entries,
            bytes,
            flops,
        }
    }

    /// Sets of FE workspaces alive at the peak: one per realization of the optimizer, and as
    /// many again in the final analysis of the blueprint, eroded and dilated designs.
    pub fn sets(s: &Scenario) -> f64 {
        if Self::robust(s) { 6.0 } else { 2.0 }
    }

    /// Whether the robust formulation is on (it needs the projection).
    fn robust(s: &Scenario) -> bool {
        s.optimization.robust && s.optimization.projection.enabled
    }
}

/// Work and memory of one simulated record (a tracking run or the stage-identification
/// excitation), estimated before it is simulated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordEstimate {
    /// Samples, `duration / sample_time`.
    pub samples: f64,
    /// Plant integration steps, `samples × substeps`.
    pub steps: f64,
    /// Modal work on the digital twin, `steps × modes` (0 on a lumped plant).
    pub mode_steps: f64,
    /// Memory of the record \[bytes\], `samples × columns × 8`.
    pub bytes: f64,
}

/// Columns of a tracking record (time, reference, measured, true output, error, voltage and
/// nominal stroke per axis, ten estimates).
pub const TRACK_COLUMNS: usize = 23;

impl RecordEstimate {
    /// The estimate of a record of `duration` \[s\] sampled every `sample_time` \[s\], with
    /// `substeps` plant steps a sample, `modes` twin modes (0 for a lumped plant) and
    /// `columns` recorded series.
    pub fn new(
        duration: f64,
        sample_time: f64,
        substeps: usize,
        modes: usize,
        columns: usize,
    ) -> Self {
        let samples = duration / sample_time;
        let steps = samples * substeps.max(1) as f64;
        RecordEstimate {
            samples,
            steps,
            mode_steps: steps * modes as f64,
            bytes: samples * columns as f64 * 8.0,
        }
    }

    /// A tracking record of `duration` \[s\] of scenario `s` on its twin (modes at least
    /// `twin.min_modes`).
    pub fn track(s: &Scenario, duration: f64) -> Self {
        let sim = &s.simulation;
        Self::new(
            duration,
            sim.sample_time,
            sim.substeps,
            s.twin.min_modes,
            TRACK_COLUMNS,
        )
    }

    /// `Ok` when the record has at least `min_samples` samples and every figure is within its
    /// limit ([`limit`]); else a [`RangeError`] on `field` (the option or field that set
    /// `duration`) that gives the estimate.
    pub fn check(&self, field: &str, duration: f64, min_samples: f64) -> Result<()> {
        if self.samples.is_nan() || self.samples < min_samples {
            return Err(RangeError::number(
                field,
                duration,
                format!(
                    "a record of at least {min_samples} samples; this one has {:.3e}",
                    self.samples
                ),
            )
            .into());
        }
        let finite = [self.samples, self.steps, self.mode_steps, self.bytes]
            .iter()
            .all(|x| x.is_finite());
        if finite
            && self.samples <= limit::TRACK_SAMPLES
            && self.steps <= limit::TRACK_STEPS
            && self.mode_steps <= limit::TWIN_MODE_STEPS
            && self.bytes <= limit::RECORD_BYTES
        {
            return Ok(());
        }
        Err(RangeError::number(
            field,
            duration,
            format!(
                "a record within the limits of {:e} samples, {:e} plant steps, {:e} twin \
                 mode-steps and {} GiB; this one needs {:.3e} samples, {:.3e} plant steps, \
                 {:.3e} mode-steps and {:.3} GiB",
                limit::TRACK_SAMPLES,
                limit::TRACK_STEPS,
                limit::TWIN_MODE_STEPS,
                limit::RECORD_BYTES / GIB,
                self.samples,
                self.steps,
                self.mode_steps,
                self.bytes / GIB
            ),
        )
        .into())
    }
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// Every check of this module.
pub(crate) fn validate(s: &Scenario) -> Result<()> {
    mesh_size(s)?;
    stiffness_contrast(s)?;
    if s.ports.is_empty() {
        ports(s)?;
        rigid_body_modes(s)?;
    } else {
        mechanism_ports(s)?;
    }
    trajectories(s)
}

fn mesh_size(s: &Scenario) -> Result<()> {
    let elements = s.mesh.nl * s.mesh.nw;
    if elements > limit::ELEMENTS {
        return Err(RangeError::new(
            "mesh.nl × mesh.nw",
            format!("{} × {} = {elements}", s.mesh.nl, s.mesh.nw),
            format!("at most {} elements", limit::ELEMENTS),
        )
        .into());
    }
    let e = DesignEstimate::of(s);
    if !(e.bytes <= limit::DESIGN_BYTES) {
        return Err(RangeError::new(
            "mesh.nl, mesh.nw, optimization.samples, optimization.robust, filter radius",
            format!(
                "{} × {} elements, {} samples × {} realization(s), a filter of {} elements' \
                 radius: an estimated {:.1} GiB",
                s.mesh.nl,
                s.mesh.nw,
                s.optimization.samples,
                if DesignEstimate::robust(s) { 3 } else { 1 },
                crate::compact(e.filter_radius),
                e.bytes / GIB
            ),
            format!(
                "at most {:.0} GiB of memory (allocated at the peak: per load case and \
                 realization {} vectors of the {} DOFs, {} sets of FE workspaces, factors, \
                 the filter; docs/DECISIONS.md)",
                limit::DESIGN_BYTES / GIB,
                VECTORS_PER_CASE,
                e.dofs,
                DesignEstimate::sets(s)
            ),
        )
        .into());
    }
    if !(e.flops <= limit::DESIGN_FLOPS) {
        return Err(RangeError::new(
            "mesh.nl, mesh.nw, optimization.samples, optimization.max_iterations, filter radius",
            format!(
                "an estimated {:.1e} flop of linear solves and filtering",
                e.flops
            ),
            format!("at most {:.0e} flop (about a day)", limit::DESIGN_FLOPS),
        )
        .into());
    }
    Ok(())
}

/// Margin of [`stiffness_contrast`] over the solver's round-off level.
const CONTRAST_MARGIN: f64 = 10.0;

/// The stiffnesses the FE solver can resolve together. Its factorization refuses a pivot at
/// or below `n·ε·max a_ii` (a floating structure's zero pivot after round-off; flexstage-fem's
/// `singular_pivot_threshold`), and a void region's pivots are about `E_min·t` while the
/// largest diagonal is about `E0·t` plus the stiffest spring. So that only a floating
/// structure trips that test, `E0·t` and each spring must stay below half of
/// `E_min·t / (10·n·ε)`: a solid or a spring stiffer than that was refused as "the structure
/// floats" (`E0 = 1e308`, `output_spring = 1e308`), and is refused here by its own range.
fn stiffness_contrast(s: &Scenario) -> Result<()> {
    let m = &s.material;
    let dofs = 2.0 * (s.mesh.nl as f64 + 1.0) * (s.mesh.nw as f64 + 1.0);
    let t = s.mesh.thickness;
    let cap = m.min_modulus * t / (CONTRAST_MARGIN * dofs * f64::EPSILON) / 2.0;
    let why = |unit: &str, limit: f64| {
        format!(
            "at most {limit:.3e} {unit}: half the stiffness the solver resolves against the \
             void (material.min_modulus × mesh.thickness / (10·n·ε), n = {dofs} DOFs)"
        )
    };
    if !(m.youngs_modulus * t <= cap) {
        return Err(RangeError::number(
            "material.youngs_modulus",
            m.youngs_modulus,
            why("Pa", cap / t),
        )
        .into());
    }
    let mut springs = vec![(
        "optimization.output_spring".to_string(),
        s.optimization.output_spring,
    )];
    if s.ports.is_empty() {
        springs.push(("actuators.stiffness".into(), s.actuators.stiffness));
    }
    for (i, p) in s.ports.iter().enumerate() {
        springs.push((format!("ports[{i}].spring"), p.spring));
    }
    for (field, k) in springs {
        if !(k <= cap) {
            return Err(RangeError::number(field, k, why("N/m", cap)).into());
        }
    }
    Ok(())
}

/// Node coordinates of the mesh grid, as the FE mesh numbers them (i along x, j along y).
struct Grid {
    nl: usize,
    nw: usize,
    dx: f64,
    dy: f64,
}

impl Grid {
    fn of(s: &Scenario) -> Grid {
        let (dx, dy) = s.mesh.element_size();
        Grid {
            nl: s.mesh.nl,
            nw: s.mesh.nw,
            dx,
            dy,
        }
    }

    fn xy(&self, (i, j): (usize, usize)) -> [f64; 2] {
        [i as f64 * self.dx, j as f64 * self.dy]
    }

    /// Nodes a selector picks, as (i, j).
    fn nodes(&self, sel: &Selector) -> Vec<(usize, usize)> {
        match sel {
            Selector::Nearest { point } => {
                let i = (point[0] / self.dx).round().clamp(0.0, self.nl as f64) as usize;
                let j = (point[1] / self.dy).round().clamp(0.0, self.nw as f64) as usize;
                vec![(i, j)]
            }
            Selector::Edge { edge } => match edge {
                Edge::Left => (0..=self.nw).map(|j| (0, j)).collect(),
                Edge::Right => (0..=self.nw).map(|j| (self.nl, j)).collect(),
                Edge::Bottom => (0..=self.nl).map(|i| (i, 0)).collect(),
                Edge::Top => (0..=self.nl).map(|i| (i, self.nw)).collect(),
            },
            Selector::Box { min, max } => {
                let tol = 1e-9 * self.dx.min(self.dy);
                let mut out = Vec::new();
                for j in 0..=self.nw {
                    for i in 0..=self.nl {
                        let [x, y] = self.xy((i, j));
                        if x >= min[0] - tol
                            && x <= max[0] + tol
                            && y >= min[1] - tol
                            && y <= max[1] + tol
                        {
                            out.push((i, j));
                        }
                    }
                }
                out
            }
        }
    }

    /// Does a box pick at least one element centroid?
    fn box_has_element(&self, min: [f64; 2], max: [f64; 2]) -> bool {
        (0..self.nw).any(|j| {
            let y = (j as f64 + 0.5) * self.dy;
            y >= min[1]
                && y <= max[1]
                && (0..self.nl).any(|i| {
                    let x = (i as f64 + 0.5) * self.dx;
                    x >= min[0] && x <= max[0]
                })
        })
    }
}

fn inconsistent(fields: impl Into<String>, reason: impl Into<String>) -> ScenarioError {
    ScenarioError::Inconsistent {
        fields: fields.into(),
        reason: reason.into(),
    }
}

fn finite_box(field: &str, sel: &Selector) -> Result<()> {
    if let Selector::Box { min, max } = sel {
        for (what, p) in [("min", min), ("max", max)] {
            if !(p[0].is_finite() && p[1].is_finite()) {
                return Err(RangeError::new(
                    format!("{field}.{what}"),
                    format!("[{:e}, {:e}]", p[0], p[1]),
                    "a point of finite coordinates [m]",
                )
                .into());
            }
        }
    }
    Ok(())
}

/// The one node a port selector picks.
fn port(grid: &Grid, field: &str, sel: &Selector) -> Result<(usize, usize)> {
    finite_box(field, sel)?;
    match grid.nodes(sel).as_slice() {
        [n] => Ok(*n),
        nodes => Err(RangeError::new(
            field,
            format!("a selector that picks {} nodes", nodes.len()),
            "exactly one node (use kind = \"nearest\" or a box around one node)",
        )
        .into()),
    }
}

fn ports(s: &Scenario) -> Result<()> {
    let grid = Grid::of(s);
    let p1 = port(&grid, "actuators.pea1", &s.actuators.pea1)?;
    let p2 = port(&grid, "actuators.pea2", &s.actuators.pea2)?;
    let out = port(&grid, "output.at", &s.output.at)?;
    let at = |n| {
        let [x, y] = grid.xy(n);
        format!("the node at ({x:e}, {y:e}) m")
    };
    if p1 == p2 {
        return Err(inconsistent(
            "actuators.pea1, actuators.pea2",
            format!("both inputs select {}", at(p1)),
        ));
    }
    for (name, p) in [("actuators.pea1", p1), ("actuators.pea2", p2)] {
        if out == p {
            return Err(inconsistent(
                format!("output.at, {name}"),
                format!("the output selects the input node, {}", at(p)),
            ));
        }
    }
    for (i, sup) in s.supports.iter().enumerate() {
        let field = format!("supports[{i}].at");
        finite_box(&field, &sup.at)?;
        let nodes = grid.nodes(&sup.at);
        if nodes.is_empty() {
            return Err(RangeError::new(
                field,
                "a box that picks no node",
                "a selector that picks at least one node",
            )
            .into());
        }
        if nodes.contains(&out) {
            return Err(inconsistent(
                format!("{field}, output.at"),
                format!("the support holds the output port, {}", at(out)),
            ));
        }
        if matches!(sup.fix, Fix::X | Fix::Xy) {
            for (name, p) in [("actuators.pea1", p1), ("actuators.pea2", p2)] {
                if nodes.contains(&p) {
                    return Err(inconsistent(
                        format!("supports[{i}].fix, {name}"),
                        format!(
                            "the support fixes x at the input node {}, along which the PEA pushes",
                            at(p)
                        ),
                    ));
                }
            }
        }
    }
    for (i, r) in s.regions.iter().enumerate() {
        let field = format!("regions[{i}].at");
        finite_box(&field, &r.at)?;
        if let Selector::Box { min, max } = &r.at {
            if !grid.box_has_element(*min, *max) {
                return Err(RangeError::new(
                    field,
                    format!(
                        "[{:e}, {:e}] .. [{:e}, {:e}]",
                        min[0], min[1], max[0], max[1]
                    ),
                    format!(
                        "a box that holds at least one element centroid (elements of {:e} × \
                         {:e} m: mesh.length / mesh.nl × mesh.width / mesh.nw)",
                        grid.dx, grid.dy
                    ),
                )
                .into());
            }
        }
    }
    Ok(())
}

/// Rank of the rigid-body motions (x, y translation, rotation) that the supports, the PEA
/// springs and the output spring hold: a constraint on DOF x at (x, y) holds (1, 0, −y), on
/// DOF y holds (0, 1, x). Fewer than 3 independent rows leaves a floating structure whose
/// stiffness is singular.
fn rigid_body_modes(s: &Scenario) -> Result<()> {
    let grid = Grid::of(s);
    let mut rows: Vec<[f64; 3]> = Vec::new();
    let x_row = |[_, y]: [f64; 2]| [1.0, 0.0, -y / s.mesh.length];
    let y_row = |[x, _]: [f64; 2]| [0.0, 1.0, x / s.mesh.length];
    for sup in &s.supports {
        for n in grid.nodes(&sup.at) {
            let p = grid.xy(n);
            if matches!(sup.fix, Fix::X | Fix::Xy) {
                rows.push(x_row(p));
            }
            if matches!(sup.fix, Fix::Y | Fix::Xy) {
                rows.push(y_row(p));
            }
        }
    }
    let node = |sel: &Selector| grid.xy(grid.nodes(sel)[0]);
    let (p1, p2, out) = (
        node(&s.actuators.pea1),
        node(&s.actuators.pea2),
        node(&s.output.at),
    );
    rows.push(x_row(p1));
    rows.push(x_row(p2));
    if s.optimization.output_spring > 0.0 {
        rows.push(y_row(out));
        let (a, b, c) = (x_row(out), x_row(p1), x_row(p2));
        rows.push([0, 1, 2].map(|k| a[k] - 0.5 * b[k] - 0.5 * c[k]));
    }
    let rank = rank3(&rows);
    if rank < 3 {
        let free = [
            "one rigid-body motion is",
            "two rigid-body motions are",
            "all three rigid-body motions are",
        ][2 - rank.min(2)];
        return Err(inconsistent(
            "supports, optimization.output_spring",
            format!(
                "the structure floats ({free} held by nothing: singular stiffness); add \
                 [[supports]] (e.g. fix = \"y\" at the input nodes) or set output_spring > 0"
            ),
        ));
    }
    Ok(())
}

// ---- General mechanism problems (`[[ports]]`, design stage) ----

/// The `[[ports]]` of a general mechanism problem on the mesh: each port and the output on
/// exactly one node, all distinct, no support fixing a port's driven DOF or holding the
/// output, and the supports with the input and output springs holding every rigid-body
/// motion.
fn mechanism_ports(s: &Scenario) -> Result<()> {
    let grid = Grid::of(s);
    let out = port(&grid, "output.at", &s.output.at)?;
    let at = |n| {
        let [x, y] = grid.xy(n);
        format!("the node at ({x:e}, {y:e}) m")
    };
    let mut nodes = Vec::with_capacity(s.ports.len());
    for (i, p) in s.ports.iter().enumerate() {
        let field = format!("ports[{i}].at");
        let n = port(&grid, &field, &p.at)?;
        if n == out {
            return Err(inconsistent(
                format!("{field}, output.at"),
                format!("the output selects the input node, {}", at(n)),
            ));
        }
        if let Some(j) = nodes.iter().position(|&m| m == n) {
            return Err(inconsistent(
                format!("ports[{j}].at, {field}"),
                format!("both ports select {}", at(n)),
            ));
        }
        nodes.push(n);
    }
    let mut rows: Vec<[f64; 3]> = Vec::new();
    let row = |c: usize, [x, y]: [f64; 2]| match c {
        0 => [1.0, 0.0, -y / s.mesh.length],
        _ => [0.0, 1.0, x / s.mesh.length],
    };
    for (i, sup) in s.supports.iter().enumerate() {
        let field = format!("supports[{i}].at");
        finite_box(&field, &sup.at)?;
        let held = grid.nodes(&sup.at);
        if held.is_empty() {
            return Err(RangeError::new(
                field,
                "a box that picks no node",
                "a selector that picks at least one node",
            )
            .into());
        }
        let fixes = |c: usize| matches!((sup.fix, c), (Fix::Xy, _) | (Fix::X, 0) | (Fix::Y, 1));
        for (k, (p, &n)) in s.ports.iter().zip(&nodes).enumerate() {
            if held.contains(&n) && fixes(p.component()) {
                return Err(inconsistent(
                    format!("supports[{i}].fix, ports[{k}]"),
                    format!(
                        "the support fixes the DOF that port {k} drives, at {}",
                        at(n)
                    ),
                ));
            }
        }
        let d = s.output.unit_direction().unwrap_or([0.0, 0.0]);
        if held.contains(&out) && (0..2).all(|c| d[c] == 0.0 || fixes(c)) {
            return Err(inconsistent(
                format!("{field}, output.at, output.direction"),
                format!(
                    "the support fixes the output port {} along output.direction: its \
                     displacement cannot be maximized",
                    at(out)
                ),
            ));
        }
        for n in held {
            for c in (0..2).filter(|&c| fixes(c)) {
                rows.push(row(c, grid.xy(n)));
            }
        }
    }
    for (p, &n) in s.ports.iter().zip(&nodes) {
        rows.push(row(p.component(), grid.xy(n)));
    }
    if s.optimization.output_spring > 0.0 {
        if let Some([dx, dy]) = s.output.unit_direction() {
            let (a, b) = (row(0, grid.xy(out)), row(1, grid.xy(out)));
            rows.push([0, 1, 2].map(|k| dx * a[k] + dy * b[k]));
        }
    }
    if rank3(&rows) < 3 {
        return Err(inconsistent(
            "supports, ports, optimization.output_spring",
            "the structure floats (a rigid-body motion is held by neither a support nor a \
             port or output spring: singular stiffness); add [[supports]]",
        ));
    }
    Ok(())
}

/// Numerical rank of rows of 3 (Gaussian elimination with partial pivoting, relative
/// tolerance 1e-9).
fn rank3(rows: &[[f64; 3]]) -> usize {
    let mut m: Vec<[f64; 3]> = rows.to_vec();
    let scale = m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    let tol = 1e-9 * scale.max(f64::MIN_POSITIVE);
    let mut rank = 0;
    for col in 0..3 {
        let Some((piv, _)) = m
            .iter()
            .enumerate()
            .skip(rank)
            .map(|(i, r)| (i, r[col].abs()))
            .filter(|(_, v)| *v > tol)
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            continue;
        };
        m.swap(rank, piv);
        let p = m[rank];
        for r in m.iter_mut().skip(rank + 1) {
            let f = r[col] / p[col];
            for (x, pk) in r.iter_mut().zip(p) {
                *x -= f * pk;
            }
        }
        rank += 1;
    }
    rank
}

fn trajectories(s: &Scenario) -> Result<()> {
    let ts = s.simulation.sample_time;
    if ts < limit::MIN_SAMPLE_TIME {
        return Err(RangeError::number(
            "simulation.sample_time",
            ts,
            format!("a number in [{:e}, 0.1] s", limit::MIN_SAMPLE_TIME),
        )
        .into());
    }
    let nyquist = 0.5 / ts;
    let stroke = s.stage.truth.alpha.abs() * s.actuators.max_stroke;
    let max_amp = stroke.min(limit::MAX_AMPLITUDE);
    let mut seen = std::collections::BTreeMap::new();
    for (i, t) in s.trajectories.iter().enumerate() {
        let field = format!("trajectories[{i}]");
        if let Some(first) = seen.insert(t.name().to_string(), i) {
            return Err(inconsistent(
                format!("trajectories[{first}].name, {field}.name"),
                format!(
                    "both are named {:?}; names must be unique (they name the output files)",
                    t.name()
                ),
            ));
        }
        let (fmax, amps, duration): (f64, Vec<(String, f64)>, f64) = match t {
            Trajectory::Lissajous {
                ratio,
                amplitude,
                frequency,
                duration,
                ..
            } => (
                frequency * ratio.max(1.0),
                vec![
                    (format!("{field}.amplitude[0]"), amplitude[0]),
                    (format!("{field}.amplitude[1]"), amplitude[1]),
                ],
                *duration,
            ),
            Trajectory::Circle {
                radius,
                frequency,
                duration,
                ..
            } => (
                *frequency,
                vec![(format!("{field}.radius"), *radius)],
                *duration,
            ),
        };
        if fmax >= nyquist {
            return Err(RangeError::number(
                format!("{field}.frequency"),
                fmax,
                format!("a highest frequency below the Nyquist frequency 1/(2 T_s) = {nyquist:e} Hz of simulation.sample_time"),
            )
            .into());
        }
        for (name, a) in amps {
            if a > max_amp {
                return Err(RangeError::number(
                    name,
                    a,
                    format!("at most {max_amp:e} m (the stroke |stage.truth.alpha| · actuators.max_stroke, and at most 1 mm)"),
                )
                .into());
            }
        }
        RecordEstimate::track(s, duration).check(
            &format!("{field}.duration"),
            duration,
            limit::MIN_TRACK_SAMPLES,
        )?;
    }
    Ok(())
}
