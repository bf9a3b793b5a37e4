//! The core embedded in a 10 kHz loop: static buffers, setpoints from outside at every tick,
//! `step(measurement, reference) -> x_nom`, then the target's own inverse-hysteresis stage
//! (here flexstage-control's `Actuator`) and the plant (here the lumped stage in its rig, with
//! delay and sensor noise). Nothing in the loop allocates. After 10 periods of the 3:1
//! Lissajous the learning layer is frozen and the RMS error of the last period is printed.
//!
//! `cargo run --release -p flexstage-control --example embed`

use flexstage_control::actuator::{Actuator, Compensation};
use flexstage_control::experiment::Setup;
use flexstage_control_core::{Controller, Ilc, IlcBuffers, IlcParams, PidGains, PidLaw};
use flexstage_sim::experiment::Command;
use flexstage_sim::model::StageModel;
use flexstage_sim::rig::StagePlant;

/// Samples per period: the 3:1 Lissajous at 2 Hz, 10 kHz.
const N: usize = 5000;

/// The setpoint the host sends at tick k [m] (in a product: from the motion planner).
fn setpoint(k: usize, t: f64) -> [f64; 2] {
    let w = std::f64::consts::TAU * 2.0 * k as f64 * t;
    [8e-6 * (3.0 * w).sin(), 16e-6 * w.sin()]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scenario = flexstage_scenario::Scenario::paper();
    let setup = Setup::from_scenario(&scenario);
    let t = setup.controller.observer.sample_time;
    let g = StageModel::new(&setup.controller.model)?
        .dc_gain()?
        .try_inverse()
        .ok_or("singular static gain")?;
    let gains = PidGains {
        kp: setup.pid.kp,
        ki: setup.pid.ki,
        kd: setup.pid.kd,
    };
    let stroke = setup.controller.actuator.stroke;
    let law = PidLaw::new(
        [gains; 2],
        [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]],
        t,
        stroke,
    )?;
    // On a target these are `static mut` arrays or a linker section; here on the stack.
    let (mut b1, mut b2, mut b3, mut b4) =
        ([[0.0; 2]; N], [[0.0; 2]; N], [[0.0; 2]; N], [[0.0; 2]; N]);
    let learning = IlcParams {
        period: N,
        gain: 0.5,
        lead: 6,
        q_half_width: 2,
    };
    let buffers = IlcBuffers {
        learned: &mut b1[..],
        applied: &mut b2[..],
        error: &mut b3[..],
        error_now: &mut b4[..],
    };
    let mut controller = Controller {
        law,
        learning: Some(Ilc::new(learning, buffers)?),
    };
    let mut actuator_params = setup.controller.actuator;
    actuator_params.compensation = Compensation::Inverse;
    let mut actuator = Actuator::new(actuator_params)?;
    let mut plant = setup.lumped_plant()?;
    let periods = 12;
    let (mut sum, mut count) = ([0.0; 2], 0);
    for k in 0..periods * N {
        if k == 10 * N {
            if let Some(ilc) = &mut controller.learning {
                ilc.set_learning(false);
            }
        }
        // --- the 10 kHz interrupt ---
        let y = plant.measure();
        let r = setpoint(k, t);
        let x_nom = controller.step(y, r);
        let a = actuator.command(x_nom, t);
        let cmd = Command {
            voltage: a.voltage,
            x_nom: a.x_nom,
            reference: r,
            saturated: a.saturated,
            dropout: false,
        };
        // --- end of the interrupt ---
        if k >= (periods - 1) * N {
            let q = plant.output();
            for i in 0..2 {
                sum[i] += (q[i] - r[i]) * (q[i] - r[i]);
            }
            count += 1;
        }
        plant.apply(&cmd);
    }
    let rms = sum.map(|s| (s / count as f64).sqrt() * 1e9);
    println!(
        "last period (learning frozen after 10): RMS error against the true output {:.1}/{:.1} nm",
        rms[0], rms[1]
    );
    Ok(())
}
