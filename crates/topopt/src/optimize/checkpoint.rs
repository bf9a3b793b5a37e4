//! Checkpoints of the design loop: a JSON header with the scalars and the history, then the
//! vectors (design, MMA state, additive material, warm starts), little-endian `f64`.

use flexstage_mma::MmaState;
use serde::{Deserialize, Serialize};

use super::{IterationRecord, Optimizer, OptimizerParams, Scales};
use crate::error::{Result, TopoptError};
use crate::problem::Problem;
use crate::responses::ResponseKind;

/// Version of the checkpoint format: 2 added the adjoint warm starts, 3 the realizations of
/// the robust formulation, the stress normalization and the volume target.
const CHECKPOINT_VERSION: u32 = 3;

const MAGIC: &[u8; 8] = b"FSTOPCK1";

/// Serializable scalars of a checkpoint.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CheckpointHeader {
    version: u32,
    n: usize,
    m: usize,
    cases: usize,
    realizations: usize,
    dofs: usize,
    iteration: usize,
    beta: f64,
    last_change: f64,
    last_mean_change: f64,
    scales: Option<Scales>,
    stress_norm: Option<f64>,
    volume_target: Option<f64>,
    mma_iteration: usize,
    mma_z: f64,
    mma_zet: f64,
    history: Vec<IterationRecord>,
    has_yeoh: bool,
}

fn bad(reason: &str) -> TopoptError {
    TopoptError::Format {
        what: "checkpoint".into(),
        reason: reason.into(),
    }
}

/// Sequential reader of the vectors after the header.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn vector(&mut self) -> Result<Vec<f64>> {
        let l = self
            .bytes
            .get(self.pos..self.pos + 8)
            .ok_or_else(|| bad("truncated vector length"))?;
        let len = u64::from_le_bytes(l.try_into().expect("8 bytes")) as usize;
        self.pos += 8;
        let data = self
            .bytes
            .get(self.pos..self.pos + 8 * len)
            .ok_or_else(|| bad("truncated vector"))?;
        self.pos += 8 * len;
        Ok(data
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect())
    }

    /// A vector that must have `len` entries (`what` names it in the error).
    fn vector_of(&mut self, len: usize, what: &str) -> Result<Vec<f64>> {
        let v = self.vector()?;
        if v.len() != len {
            return Err(bad(&format!(
                "{what} has {} entries, expected {len}",
                v.len()
            )));
        }
        Ok(v)
    }
}

impl<'p> Optimizer<'p> {
    /// A checkpoint of the state before the next iteration (binary, self-describing).
    pub fn checkpoint(&self) -> Vec<u8> {
        let st = self.mma.state();
        let header = CheckpointHeader {
            version: CHECKPOINT_VERSION,
            n: self.x.len(),
            m: self.mma.m(),
            cases: self.evaluator.problem.cases.len(),
            realizations: self.evaluator.evaluators.len(),
            dofs: self.evaluator.problem.model.n_dofs(),
            iteration: self.iteration,
            beta: self.beta,
            last_change: self.last_change,
            last_mean_change: self.last_mean_change,
            scales: self.scales,
            stress_norm: self.stress_norm,
            volume_target: self.volume_target,
            mma_iteration: st.iteration,
            mma_z: st.z,
            mma_zet: st.zet,
            history: self.history.clone(),
            has_yeoh: self.yeoh.is_some(),
        };
        let json = serde_json::to_vec(&header).expect("checkpoint header serializes");
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(json.len() as u64).to_le_bytes());
        out.extend_from_slice(&json);
        let mut vecs: Vec<&[f64]> = vec![
            &self.x, &st.xold1, &st.xold2, &st.low, &st.upp, &st.lam, &st.y, &st.mu, &st.s,
            &st.xsi, &st.eta,
        ];
        if let Some(y) = &self.yeoh {
            vecs.push(&y.c2);
        }
        // Per realization and case: the warm starts of the next evaluation (displacements,
        // then each response's adjoint, empty when there is none yet).
        for ev in &self.evaluator.evaluators {
            for cs in &ev.cases {
                vecs.push(&cs.u);
                for q in ResponseKind::FE {
                    vecs.push(cs.adjoint(q));
                }
            }
        }
        for v in vecs {
            out.extend_from_slice(&(v.len() as u64).to_le_bytes());
            for x in v {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out
    }

    /// Rebuilds an optimizer from [`Optimizer::checkpoint`] bytes, for the same problem and
    /// parameters; the run then continues as if uninterrupted.
    pub fn resume(problem: &'p Problem, params: OptimizerParams, bytes: &[u8]) -> Result<Self> {
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            return Err(bad("not a flexstage checkpoint (bad magic)"));
        }
        let hl = u64::from_le_bytes(bytes[8..16].try_into().expect("8 bytes")) as usize;
        let json = bytes
            .get(16..16 + hl)
            .ok_or_else(|| bad("truncated header"))?;
        let h: CheckpointHeader =
            serde_json::from_slice(json).map_err(|e| bad(&format!("header: {e}")))?;
        if h.version != CHECKPOINT_VERSION {
            return Err(bad(&format!(
                "checkpoint format version {} (this flexstage reads version {}); start the \
                 design again",
                h.version, CHECKPOINT_VERSION
            )));
        }
        let mut o = Optimizer::new(problem, params)?;
        if h.n != o.x.len()
            || h.m != o.mma.m()
            || h.cases != problem.cases.len()
            || h.realizations != o.evaluator.evaluators.len()
            || h.dofs != problem.model.n_dofs()
            || h.has_yeoh != o.yeoh.is_some()
        {
            return Err(bad(
                "checkpoint does not match the scenario (mesh, samples, constraints, robust \
                 formulation or additive material differ)",
            ));
        }
        let mut rd = Reader {
            bytes,
            pos: 16 + hl,
        };
        o.x = rd.vector_of(h.n, "design vector")?;
        let st = MmaState {
            iteration: h.mma_iteration,
            xold1: rd.vector()?,
            xold2: rd.vector()?,
            low: rd.vector()?,
            upp: rd.vector()?,
            lam: rd.vector()?,
            y: rd.vector()?,
            mu: rd.vector()?,
            s: rd.vector()?,
            xsi: rd.vector()?,
            eta: rd.vector()?,
            z: h.mma_z,
            zet: h.mma_zet,
        };
        o.mma.restore(&st)?;
        if let Some(y) = o.yeoh.as_mut() {
            y.c2 = rd.vector_of(y.c2.len(), "c2")?;
        }
        let nd = problem.model.n_dofs();
        for ev in o.evaluator.evaluators.iter_mut() {
            for cs in ev.cases.iter_mut() {
                cs.u = rd.vector_of(nd, "displacement")?;
                for q in ResponseKind::FE {
                    let lam = rd.vector()?;
                    if !lam.is_empty() && lam.len() != nd {
                        return Err(bad("adjoint length"));
                    }
                    cs.set_adjoint(q, lam);
                }
            }
        }
        o.iteration = h.iteration;
        o.beta = h.beta;
        o.last_change = h.last_change;
        o.last_mean_change = h.last_mean_change;
        o.scales = h.scales;
        o.stress_norm = h.stress_norm;
        o.volume_target = h.volume_target;
        o.history = h.history;
        Ok(o)
    }
}
