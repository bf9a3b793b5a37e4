//! Closed-loop analysis on the nominal linear model: the sampled closed loop of the
//! backstepping controller and the exact ZOH discretization of Eq. (36), linearized at rest,
//! and its poles (python-control's `feedback` + `poles` for this sampled-data loop).

use nalgebra::{Complex, DMatrix};

use crate::actuator::Compensation;
use crate::controller::{BacksteppingController, ControllerParams, STATE_LEN};
use crate::error::Result;
use flexstage_sim::experiment::StageControl;
use flexstage_sim::linalg::{c2d, poles};
use flexstage_sim::model::StageModel;
use flexstage_sim::trajectory::{Reference, Shape};

/// Size of the closed-loop state: plant z (8) and controller state ([`STATE_LEN`]).
pub const LOOP_LEN: usize = 8 + STATE_LEN;

/// The closed-loop transition matrix x_{k+1} = A_cl x_k of the controller `params` (with the
/// ideal actuator: the model's input is x_nom) on the linear plant `plant` (Eq. 36, exact ZOH
/// discretization at the controller's sample time), linearized at rest with zero reference.
///
/// The loop is linear there (the boundary layers are linear near zero; with sgn() the
/// robust terms are switched off for this computation), so each column is one
/// central difference of the loop map. Returns the [`LOOP_LEN`]² matrix.
pub fn closed_loop_matrix(params: &ControllerParams, plant: &StageModel) -> Result<DMatrix<f64>> {
    let mut p = params.clone();
    p.actuator.compensation = Compensation::Ideal;
    // The plant here has no delay, so the controller predicts over none.
    p.delay = 0;
    if p.law.boundary_layer.contains(&0.0) {
        p.law.robust = false;
    }
    let t = p.observer.sample_time;
    let (phi, gamma) = c2d(&plant.b_dyn(), &plant.input_dyn(), t)?;
    let reference = Reference {
        shape: Shape::Step { target: [0.0; 2] },
        smooth_start: 0.0,
    };
    let base = BacksteppingController::new(&p, reference)?;
    let map = |x: &[f64; LOOP_LEN]| -> [f64; LOOP_LEN] {
        let mut c = base.clone();
        let mut cs = [0.0; STATE_LEN];
        cs.copy_from_slice(&x[8..]);
        c.set_state(&cs);
        let cmd = c.step([x[0], x[1]]);
        let z = nalgebra::DVector::from_column_slice(&x[..8]);
        let u = nalgebra::DVector::from_column_slice(&cmd.x_nom);
        let zn = &phi * z + &gamma * u;
        let mut out = [0.0; LOOP_LEN];
        out[..8].copy_from_slice(zn.as_slice());
        out[8..].copy_from_slice(&c.state());
        out
    };
    let mut a = DMatrix::zeros(LOOP_LEN, LOOP_LEN);
    // The loop is linear near rest; a tiny perturbation keeps every clamp inactive.
    let h = 1e-12;
    for j in 0..LOOP_LEN {
        let mut xp = [0.0; LOOP_LEN];
        let mut xm = [0.0; LOOP_LEN];
        xp[j] = h;
        xm[j] = -h;
        let (fp, fm) = (map(&xp), map(&xm));
        for i in 0..LOOP_LEN {
            a[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    Ok(a)
}

/// The closed-loop poles (eigenvalues of [`closed_loop_matrix`]), sorted by decreasing
/// modulus.
pub fn closed_loop_poles(
    params: &ControllerParams,
    plant: &StageModel,
) -> Result<Vec<Complex<f64>>> {
    let mut p = poles(&closed_loop_matrix(params, plant)?)?;
    p.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    Ok(p)
}
