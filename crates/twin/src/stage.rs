//! The twin as a real-time [`Mechanics`]: every mode advanced with its exact first-order-hold
//! discretization per substep ([`crate::modal`]), the output recovered from the modes and
//! corrected for the geometric nonlinearity ([`crate::nonlinear`]). No allocation per step.
//!
//! Layout and cost: the modes are stored in blocks of four (one AVX2 register per
//! coefficient), the output and input-plate sums are accumulated in the same pass as the
//! update, the modal force at a substep node is computed once (p₁ of one substep, p₀ of the
//! next), and [`Mechanics::advance_sample`] runs the substeps of a whole sample in one call
//! dispatched once to the CPU's widest instruction set (`multiversion`). Fused multiply-adds
//! keep the results identical on every target. `cargo bench -p flexstage-twin`.

use flexstage_sim::rig::{Mechanics, floor_at};
use multiversion::multiversion;

use crate::modal::{DiscreteMode, ModalStage};
use crate::nonlinear::{Correction, NonlinearMap};

/// Modes per block: one AVX2 register of f64.
const LANES: usize = 4;
/// Four lanes of f64.
type Lanes = [f64; LANES];

/// The discrete data of [`LANES`] consecutive modes, each field one value per lane
/// (structure of arrays within the block, array of blocks over the modes), so that the
/// per-substep update of a block is a handful of element-wise 4-lane operations. The last
/// block is padded with silent modes (all zero: they stay at rest and contribute nothing).
#[derive(Debug, Clone, Copy, Default)]
struct Block {
    /// Φ row-major: Φ₀₀, Φ₀₁, Φ₁₀, Φ₁₁.
    phi: [Lanes; 4],
    /// Γ (constant part of the modal force).
    gamma: [Lanes; 2],
    /// Λ (ramp part of the modal force).
    lambda: [Lanes; 2],
    /// Modal force per unit x_nom1, x_nom2, base acceleration x, y.
    input: [Lanes; 4],
    /// Output q1, q2 and input-plate x_in1, x_in2 per unit modal coordinate.
    probe: [Lanes; 4],
    /// ω² \[1/s²\].
    omega2: Lanes,
    /// 1/ω² (quasi-static modal compliance).
    compliance: Lanes,
    /// ∂(ω²)/∂x_in per mode (zeros for the linear twin).
    stiffening: [Lanes; 2],
}

/// The modal state (η, η̇) of one block, and the scratch slot of the modal force at the
/// current substep node.
#[derive(Debug, Clone, Copy, Default)]
struct BlockState {
    eta: Lanes,
    rate: Lanes,
    force: Lanes,
}

/// The twin's mechanics for substeps of `h` (module docs).
#[derive(Debug, Clone)]
pub struct TwinStage {
    h: f64,
    order: usize,
    blocks: Vec<Block>,
    state: Vec<BlockState>,
    /// The geometric-nonlinearity correction of the output (`None`: linear twin).
    correction: Option<Correction>,
    /// `[q1, q2, x_in1, x_in2]` of the current modal state (linear output and input plates),
    /// kept up to date by every state change so that [`Mechanics::output`] and
    /// [`Mechanics::inputs`] cost no pass over the modes.
    probe: [f64; 4],
}

/// The modal forces `p = in·u` of every mode for the load `u` (x_nom1, x_nom2, base
/// acceleration x, y) into the state's force slot: the p₀ of the next substep.
#[inline(always)]
fn load_forces(blocks: &[Block], state: &mut [BlockState], u: [f64; 4]) {
    for (b, st) in blocks.iter().zip(state.iter_mut()) {
        for l in 0..LANES {
            st.force[l] = modal_force(b, l, u);
        }
    }
}

/// `in·u` of lane `l` of block `b`.
#[inline(always)]
fn modal_force(b: &Block, l: usize, u: [f64; 4]) -> f64 {
    let i = [b.input[0][l], b.input[1][l], b.input[2][l], b.input[3][l]];
    i[0].mul_add(u[0], i[1].mul_add(u[1], i[2].mul_add(u[2], i[3] * u[3])))
}

/// One substep of every mode, `s₊ = Φ s + Γ p₀ + Λ (p₁ − p₀)` with `p = in·u` minus the
/// operating-point stiffening `(s·x_in)(η − p₀/ω²)` held over the substep
/// ([`crate::nonlinear`]); p₀ is the force slot of the state ([`load_forces`]), p₁ = in·u₁
/// replaces it. Returns the probe `[q1, q2, x_in1, x_in2]` of the new state, accumulated in
/// the same pass (four partial sums per probe, one per lane). Fused multiply-adds (`mul_add`,
/// correctly rounded on every target, so the result does not depend on the CPU the loop was
/// dispatched for).
#[inline(always)]
fn substep(blocks: &[Block], state: &mut [BlockState], u1: [f64; 4], x_in: [f64; 2]) -> [f64; 4] {
    let mut acc = [[0.0; LANES]; 4];
    for (b, st) in blocks.iter().zip(state.iter_mut()) {
        for l in 0..LANES {
            let mut p0 = st.force[l];
            let p1 = modal_force(b, l, u1);
            st.force[l] = p1;
            let (e, v) = (st.eta[l], st.rate[l]);
            let sigma = b.stiffening[0][l].mul_add(x_in[0], b.stiffening[1][l] * x_in[1]);
            let g = sigma * (-p0).mul_add(b.compliance[l], e);
            // The held term shifts p₀ and p₁ alike: the ramp p₁ − p₀ is unchanged.
            let dp = p1 - p0;
            p0 -= g;
            let e1 = b.phi[0][l].mul_add(
                e,
                b.phi[1][l].mul_add(v, b.gamma[0][l].mul_add(p0, b.lambda[0][l] * dp)),
            );
            let v1 = b.phi[2][l].mul_add(
                e,
                b.phi[3][l].mul_add(v, b.gamma[1][l].mul_add(p0, b.lambda[1][l] * dp)),
            );
            st.eta[l] = e1;
            st.rate[l] = v1;
            for (a, row) in acc.iter_mut().zip(&b.probe) {
                a[l] = row[l].mul_add(e1, a[l]);
            }
        }
    }
    acc.map(|a| (a[0] + a[1]) + (a[2] + a[3]))
}

/// The substeps of one sample ([`Mechanics::advance_sample`]): x_nom at the nodes `path`,
/// the floor by [`floor_at`]; the output after each substep into `q` if given. One call (one
/// CPU dispatch) per sample; the forces at a node are computed once, as p₁ of one substep
/// and p₀ of the next. Returns the final probe.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn advance_path(
    blocks: &[Block],
    state: &mut [BlockState],
    correction: Option<&Correction>,
    mut probe: [f64; 4],
    path: &[[f64; 2]],
    floor: [[f64; 2]; 2],
    mut q: Option<&mut [[f64; 2]]>,
) -> [f64; 4] {
    let n = path.len() - 1;
    let load = |k: usize, f: [f64; 2]| [path[k][0], path[k][1], f[0], f[1]];
    load_forces(blocks, state, load(0, floor_at(floor, 0, n)[0]));
    for k in 0..n {
        let x_in = if correction.is_some() {
            [probe[2], probe[3]]
        } else {
            [0.0; 2]
        };
        probe = substep(blocks, state, load(k + 1, floor_at(floor, k, n)[1]), x_in);
        if let Some(q) = q.as_deref_mut() {
            q[k] = output_of(correction, probe);
        }
    }
    probe
}

/// The output of a probe: the linear output plus the correction at its x_in.
#[inline(always)]
fn output_of(correction: Option<&Correction>, probe: [f64; 4]) -> [f64; 2] {
    let mut q = [probe[0], probe[1]];
    if let Some(c) = correction {
        let d = c.eval([probe[2], probe[3]]);
        q[0] += d[0];
        q[1] += d[1];
    }
    q
}

/// The probe `[q1, q2, x_in1, x_in2]` of a state (as accumulated by [`substep`]).
fn probe_of(blocks: &[Block], state: &[BlockState]) -> [f64; 4] {
    let mut acc = [[0.0; LANES]; 4];
    for (b, st) in blocks.iter().zip(state) {
        for (a, row) in acc.iter_mut().zip(&b.probe) {
            for l in 0..LANES {
                a[l] += row[l] * st.eta[l];
            }
        }
    }
    acc.map(|a| (a[0] + a[1]) + (a[2] + a[3]))
}

impl TwinStage {
    /// The mechanics of `modal` (and the nonlinear correction, if any) for substep `h` \[s\],
    /// at rest.
    pub fn new(modal: &ModalStage, nonlinear: Option<NonlinearMap>, h: f64) -> TwinStage {
        let order = modal.modes.len();
        let mut blocks = vec![Block::default(); order.div_ceil(LANES)];
        for (k, mode) in modal.modes.iter().enumerate() {
            let (b, l) = (&mut blocks[k / LANES], k % LANES);
            let d = DiscreteMode::new(mode, h);
            for i in 0..4 {
                b.phi[i][l] = d.phi[i];
                b.input[i][l] = mode.input[i];
            }
            for i in 0..2 {
                b.gamma[i][l] = d.gamma[i];
                b.lambda[i][l] = d.lambda[i];
                b.probe[i][l] = mode.output[i];
                b.probe[2 + i][l] = mode.plates[i];
            }
            let w2 = (std::f64::consts::TAU * mode.frequency).powi(2);
            b.omega2[l] = w2;
            b.compliance[l] = 1.0 / w2;
            if let Some(s) = nonlinear.as_ref().and_then(|nl| nl.stiffening.get(k)) {
                b.stiffening[0][l] = s[0];
                b.stiffening[1][l] = s[1];
            }
        }
        let state = vec![BlockState::default(); blocks.len()];
        TwinStage {
            h,
            order,
            blocks,
            state,
            correction: nonlinear.as_ref().map(NonlinearMap::evaluator),
            probe: [0.0; 4],
        }
    }

    /// Number of modes.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The modal state (η, η̇) of every mode.
    pub fn modal_state(&self) -> Vec<[f64; 2]> {
        (0..self.order)
            .map(|k| {
                let st = &self.state[k / LANES];
                [st.eta[k % LANES], st.rate[k % LANES]]
            })
            .collect()
    }

    /// Sets the modal state (η, η̇) of every mode (length = [`TwinStage::order`]).
    pub fn set_modal_state(&mut self, state: &[[f64; 2]]) {
        for (k, s) in state.iter().enumerate().take(self.order) {
            let st = &mut self.state[k / LANES];
            st.eta[k % LANES] = s[0];
            st.rate[k % LANES] = s[1];
        }
        self.probe = probe_of(&self.blocks, &self.state);
    }

    /// The mechanical energy `Σ ½(η̇² + ω² η²)` of the reduced system \[J\] (modes are
    /// mass-normalized).
    pub fn energy(&self) -> f64 {
        self.blocks
            .iter()
            .zip(&self.state)
            .flat_map(|(b, st)| {
                (0..LANES).map(|l| 0.5 * (st.rate[l].powi(2) + b.omega2[l] * st.eta[l].powi(2)))
            })
            .sum()
    }

    /// The linear output (without the nonlinear correction) \[m\].
    #[inline]
    pub fn linear_output(&self) -> [f64; 2] {
        [self.probe[0], self.probe[1]]
    }
}

impl Mechanics for TwinStage {
    fn substep_time(&self) -> f64 {
        self.h
    }

    #[inline]
    fn advance(&mut self, x_nom: [[f64; 2]; 2], floor: [[f64; 2]; 2]) {
        // One substep is a sample of one substep: the floor's ends are the substep's.
        self.advance_sample(&x_nom, floor, None);
    }

    #[inline]
    fn output(&self) -> [f64; 2] {
        output_of(self.correction.as_ref(), self.probe)
    }

    fn advance_sample(
        &mut self,
        path: &[[f64; 2]],
        floor: [[f64; 2]; 2],
        q: Option<&mut [[f64; 2]]>,
    ) {
        self.probe = advance_path(
            &self.blocks,
            &mut self.state,
            self.correction.as_ref(),
            self.probe,
            path,
            floor,
            q,
        );
    }

    #[inline]
    fn inputs(&self) -> [f64; 2] {
        [self.probe[2], self.probe[3]]
    }
}
