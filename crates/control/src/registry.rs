//! The controllers, in one list ([`CONTROLLERS`]). A controller is one module of this crate
//! and one entry here: a [`Controller`] with its name (in `flexstage track --variant`, file
//! names and tables), its label for people, whether it runs by default, and how it is designed
//! for a stage ([`Controller::design`]); the design it returns says how it steps
//! ([`Design::build`]) and whether it is linear ([`Design::linear`]: margins from its
//! transfer function, else by sine injection). `track`, the assessment and the CLI take
//! their choices from this list and never match on a name.
//!
//! A design takes only what the [`Stage`] offers: the scenario's settings ([`Setup`]), the
//! stage's sampled response when there is one to tune on (a [`LoopPlant`]: the twin's exact
//! modal response today, a measured response later), what a response identification gives
//! of it ([`ResponseFit`]) and, for a design sized by its margins, a [`MarginProbe`] that
//! measures them on the stage's linear loop. Intermediate results that several designs use
//! (the PI + notch's notches, the backstepping's gain scale) are computed once per stage
//! ([`Stage::shared`]).
//!
//! # Adding a controller
//! Write its module (the controller, implementing `StageControl`; its design, implementing
//! [`Design`]; a `pub static` [`Controller`] entry with a design function) and add that entry
//! to [`CONTROLLERS`]. Nothing else changes: `track --variant` accepts its name, `track`
//! and the assessment run it (when [`Controller::default`]), `metrics.csv`, `margins.csv`,
//! `montecarlo.csv` and the sweep get its rows under its name, and the report shows them.

use std::any::Any;
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::Arc;

use flexstage_identify::measured::LiftedResponse;
use flexstage_identify::response::ResponseFit;
use flexstage_scenario::StageParams;
use flexstage_sim::experiment::StageControl;
use flexstage_sim::modal::LoopPlant;
use flexstage_sim::trajectory::Reference;

use crate::actuator::ActuatorParams;
use crate::error::Result;
use crate::experiment::Setup;
use crate::feedforward::FirFeedForward;
use crate::margins::{MarginParams, Margins};
use crate::pi_notch::PiNotchParams;
use crate::target::TargetLaw;
use crate::target_backstepping::BacksteppingLaw;
use crate::tuning::TuningParams;

/// Every controller, in report order (the default controller first). One line per
/// controller.
pub static CONTROLLERS: [&Controller; 6] = [
    &crate::pi_notch::PI_NOTCH_FF,
    &crate::controller::ROBUST,
    &crate::controller::NONROBUST,
    &crate::pid::PID_FF,
    &crate::pid::PID_FF_SCENARIO,
    &crate::damping::PPF_PI_FF,
];

/// The default controller (DECISIONS.md, "Default controller").
pub static DEFAULT: &Controller = &crate::pi_notch::PI_NOTCH_FF;

/// A controller `track`, the assessment and the report know (module docs).
pub struct Controller {
    /// Its name in `flexstage track --variant`, file names and tables (unique).
    pub name: &'static str,
    /// Its label for people.
    pub label: &'static str,
    /// Whether `track` and the assessment run it when no controller is named; otherwise it
    /// runs only when asked for by name.
    pub default: bool,
    /// How it is set up or tuned for a stage: its design, or `None` when the stage does not
    /// give what the design needs (it is then not run there).
    pub design: DesignFn,
}

/// A controller's design procedure: its design for a stage, or `None` when the stage does not
/// give what the design needs ([`Controller::design`]).
pub type DesignFn = fn(&Stage<'_>) -> Result<Option<Arc<dyn Design>>>;

impl Controller {
    /// The controller named `name` ([`Controller::name`]).
    pub fn by_name(name: &str) -> Option<&'static Controller> {
        CONTROLLERS.iter().copied().find(|c| c.name == name)
    }

    /// The controllers that run by default, in report order.
    pub fn defaults() -> Vec<&'static Controller> {
        CONTROLLERS.iter().copied().filter(|c| c.default).collect()
    }
}

impl PartialEq for Controller {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Eq for Controller {}

impl std::fmt::Debug for Controller {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.name)
    }
}

impl std::fmt::Display for Controller {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name)
    }
}

/// A design compared with another of any type: [`Design`]'s supertrait, implemented for
/// every type with `PartialEq`, so that designs compare as values
/// (`PartialEq for dyn Design`): two designs are equal when they are of one type and equal
/// there.
pub trait DesignEq: Any {
    /// Whether `other` is of this design's type and equal to it.
    fn design_eq(&self, other: &dyn Any) -> bool;

    /// This design as `Any`, to be compared with ([`DesignEq::design_eq`]).
    fn design_any(&self) -> &dyn Any;
}

impl<T: PartialEq + Any> DesignEq for T {
    fn design_eq(&self, other: &dyn Any) -> bool {
        other.downcast_ref::<T>() == Some(self)
    }

    fn design_any(&self) -> &dyn Any {
        self
    }
}

/// Designs compare by value ([`DesignEq`]): equal when of one type with equal settings.
impl PartialEq for dyn Design {
    fn eq(&self, other: &dyn Design) -> bool {
        self.design_eq(other.design_any())
    }
}

/// A controller designed for a stage: how it steps. Designs compare by value
/// ([`DesignEq`]: the type needs `PartialEq`).
pub trait Design: DesignEq + std::fmt::Debug + Send + Sync {
    /// The controller following `reference`, with the actuator stage `actuator` (the
    /// compensator's Bouc–Wen model, the compensation mode, the stroke and the amplifier
    /// range) and predicting over `delay` samples of rig delay (a controller that does not
    /// predict ignores it).
    fn build(
        &self,
        actuator: ActuatorParams,
        delay: usize,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>>;

    /// Its gains as the linear PI(D) + notch + feed-forward structure when the controller is
    /// that (margins from its transfer function); `None` for a nonlinear controller
    /// (margins by sine injection).
    fn linear(&self) -> Option<&PiNotchParams> {
        None
    }

    /// Its feed-forward filter when it has one of its own ([`crate::feedforward`]); `None`
    /// for the static inverse G_dc⁻¹ q_d (or a feed-forward that is no filter of the
    /// reference, as the backstepping's).
    fn feedforward(&self) -> Option<&FirFeedForward> {
        None
    }

    /// The law a real-time target runs for it with the actuator stage `actuator`
    /// ([`crate::target`]: the one the simulated controller steps); `None` for a controller
    /// that has none (the backstepping).
    fn target(&self, actuator: ActuatorParams) -> Result<Option<TargetLaw>> {
        let _ = actuator;
        Ok(None)
    }

    /// The backstepping law a real-time target runs for it with the actuator stage
    /// `actuator`, predicting over `delay` samples ([`crate::target_backstepping`]: the one
    /// the simulated controller steps); `None` for a controller that is no backstepping.
    fn backstepping(
        &self,
        actuator: ActuatorParams,
        delay: usize,
    ) -> Result<Option<BacksteppingLaw>> {
        let _ = (actuator, delay);
        Ok(None)
    }
}

/// Measures a designed controller's margins on a stage's linear loop (sine injection on the
/// running loop with the rig's delay), for designs sized by their margins.
pub trait MarginProbe {
    /// Loop-at-a-time margins of `design` searched with `params`; `None` when its closed
    /// loop is unstable.
    fn margins(&self, design: &dyn Design, params: &MarginParams) -> Result<Option<[Margins; 2]>>;
}

/// What a design may use (module docs).
pub struct Stage<'a> {
    /// The scenario's settings: the backstepping's, the scenario's PID gains, the actuator
    /// stage, the rig.
    pub setup: &'a Setup,
    /// The stage's sampled response x_nom → measurement with the rig's delay and sensor
    /// chain, to tune on; `None` when the stage offers none (the lumped plant).
    pub response: Option<&'a dyn LoopPlant>,
    /// What a response identification gives of the stage (static gain, output modes below
    /// Nyquist); `None` without a response.
    pub fit: Option<ResponseFit>,
    /// Margins measured on the stage's linear loop; `None` when they cannot be measured.
    pub probe: Option<&'a dyn MarginProbe>,
    /// The tuning procedure's settings (margin targets, search budget).
    pub tuning: TuningParams,
    /// The lifted response of the stage's output measured with a fast ADC
    /// ([`crate::feedforward::FeedForward::Lifted`]); `None` without one.
    pub lifted: Option<&'a LiftedResponse>,
    shared: RefCell<HashMap<&'static str, Rc<dyn Any>>>,
}

impl<'a> Stage<'a> {
    /// A stage known only by the scenario's settings (no response, no probe): every
    /// controller with its scenario settings, none tuned.
    pub fn scenario(setup: &'a Setup) -> Stage<'a> {
        Stage::new(setup, None, None, None, TuningParams::default())
    }

    /// A stage with a sampled response `response`, its response fit `fit` and a margin
    /// probe, tuned with `tuning`.
    pub fn new(
        setup: &'a Setup,
        response: Option<&'a dyn LoopPlant>,
        fit: Option<ResponseFit>,
        probe: Option<&'a dyn MarginProbe>,
        tuning: TuningParams,
    ) -> Stage<'a> {
        Stage {
            setup,
            response,
            fit,
            probe,
            tuning,
            lifted: None,
            shared: RefCell::new(HashMap::new()),
        }
    }

    /// This stage tuned with `tuning` instead: the results its designs share that do not
    /// depend on the margin targets (the feed-forward fits, the backstepping's sizing by
    /// sine injection) are carried over, the loop-shaping tunings (`tuning::*`) are not.
    pub fn with_tuning(&self, tuning: TuningParams) -> Stage<'a> {
        let shared = self
            .shared
            .borrow()
            .iter()
            .filter(|(k, _)| !k.starts_with("tuning::"))
            .map(|(k, v)| (*k, Rc::clone(v)))
            .collect();
        Stage {
            setup: self.setup,
            response: self.response,
            fit: self.fit,
            probe: self.probe,
            tuning,
            lifted: self.lifted,
            shared: RefCell::new(shared),
        }
    }

    /// The controllers' lumped model on this stage and its coupling k_c: the scenario's
    /// controller model (Table 4's guess, or identified parameters) fitted to the stage's
    /// response fit when there is one ([`crate::fit::fitted_model`]).
    pub fn controller_model(&self) -> (StageParams, f64) {
        let c = &self.setup.controller;
        match &self.fit {
            Some(fit) => crate::fit::fitted_model(&c.model, c.coupling, fit),
            None => (c.model.clone(), c.coupling),
        }
    }

    /// A result that several designs use, computed by `f` the first time `key` is asked
    /// for on this stage (each module keeps its keys private).
    pub fn shared<T: Clone + 'static>(
        &self,
        key: &'static str,
        f: impl FnOnce() -> Result<T>,
    ) -> Result<T> {
        if let Some(v) = self.shared.borrow().get(key) {
            let v = v.downcast_ref::<T>().expect("one type per key");
            return Ok(v.clone());
        }
        let v = f()?;
        self.shared.borrow_mut().insert(key, Rc::new(v.clone()));
        Ok(v)
    }
}

/// The controllers designed for one stage, in report order.
#[derive(Debug, Clone)]
pub struct Designs {
    designs: Vec<(&'static Controller, Arc<dyn Design>)>,
    /// The designs that run under the learning layer where they differ
    /// ([`Designs::for_learning`]).
    learning: Vec<(&'static Controller, Arc<dyn Design>)>,
    /// The controllers whose design needs what the stage does not offer.
    pub not_designed: Vec<&'static Controller>,
}

impl Designs {
    /// Designs every controller of [`CONTROLLERS`] for `stage`.
    pub fn for_stage(stage: &Stage<'_>) -> Result<Designs> {
        let mut d = Designs {
            designs: Vec::new(),
            learning: Vec::new(),
            not_designed: Vec::new(),
        };
        for &c in &CONTROLLERS {
            match (c.design)(stage)? {
                Some(design) => d.designs.push((c, design)),
                None => d.not_designed.push(c),
            }
        }
        // The designs under learning: the tuned ones again with the widened margin
        // targets, on a stage with a response to tune on.
        if let (Some(tuning), Some(_)) = (stage.tuning.for_learning(), stage.response) {
            let widened = stage.with_tuning(tuning);
            for (c, own) in &d.designs {
                // Kept where it differs (the backstepping's sizing is carried over).
                if let Some(design) = (c.design)(&widened)?
                    && *design != **own
                {
                    d.learning.push((*c, design));
                }
            }
        }
        Ok(d)
    }

    /// The design of `c`, if it was designed for this stage.
    pub fn get(&self, c: &Controller) -> Option<&Arc<dyn Design>> {
        self.designs.iter().find(|(k, _)| *k == c).map(|(_, d)| d)
    }

    /// Whether `c` runs under the learning layer with a design of its own (one that differs
    /// from [`Designs::get`]'s).
    pub fn differs_under_learning(&self, c: &Controller) -> bool {
        self.learning.iter().any(|(k, _)| *k == c)
    }

    /// The designs as they run under the learning layer ([`Designs::for_learning`] for
    /// every controller).
    pub fn under_learning(&self) -> Designs {
        Designs {
            designs: self
                .designs
                .iter()
                .map(|(c, d)| (*c, Arc::clone(self.for_learning(c).unwrap_or(d))))
                .collect(),
            learning: Vec::new(),
            not_designed: self.not_designed.clone(),
        }
    }

    /// The design of `c` that runs under the learning layer: tuned to the margin targets
    /// widened by `TuningParams::learning_widening` where the stage offers a response to
    /// tune on, else [`Designs::get`]'s.
    pub fn for_learning(&self, c: &Controller) -> Option<&Arc<dyn Design>> {
        self.learning
            .iter()
            .find(|(k, _)| *k == c)
            .map(|(_, d)| d)
            .or_else(|| self.get(c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Goal: the list is a usable index: names unique and plain (file and CLI names),
    /// found by name, the default controller first and run by default, and each
    /// controller's design from the scenario alone either given or refused for want of a
    /// response (never an error).
    #[test]
    fn the_registry_is_one_consistent_list() {
        for (i, c) in CONTROLLERS.iter().enumerate() {
            assert!(
                !c.name.is_empty()
                    && c.name
                        .chars()
                        .all(|ch| ch.is_ascii_lowercase() || ch.is_ascii_digit() || ch == '-'),
                "{c}"
            );
            assert!(!c.label.is_empty());
            assert_eq!(Controller::by_name(c.name), Some(*c));
            assert!(
                CONTROLLERS[..i].iter().all(|k| k.name != c.name),
                "{c} twice"
            );
        }
        assert_eq!(CONTROLLERS[0], DEFAULT);
        assert!(DEFAULT.default);
        assert_eq!(Controller::by_name("all"), None);
        let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let stage = Stage::scenario(&setup);
        let designs = Designs::for_stage(&stage).unwrap();
        for c in CONTROLLERS {
            assert!(designs.get(c).is_some() != designs.not_designed.contains(&c));
        }
        // Without a response the PI + notch cannot be tuned.
        assert!(designs.not_designed.contains(&DEFAULT));
        // With one (two decoupled 1 %-damped modes, one sample of delay), every controller
        // is designed.
        let designs = crate::samples::decoupled_designs(&setup).unwrap();
        assert!(
            designs.not_designed.is_empty(),
            "{:?}",
            designs.not_designed
        );
        assert!(designs.get(DEFAULT).unwrap().linear().is_some());
    }

    /// Goal: designs compare by value (`PartialEq for dyn Design`): a design equals a copy of
    /// itself and its designing again, not the same design with one gain changed by one part
    /// in 10¹², not a design of another type with the same gains (the PI + notch with and
    /// without its feed-forward), and the robust backstepping not the non-robust one.
    #[test]
    fn designs_compare_by_value_and_type() {
        use crate::pi_notch::{PiNotchParams, WithFeedForward};
        let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let designs = crate::samples::decoupled_designs(&setup).unwrap();
        let pi = designs.get(DEFAULT).unwrap();
        let params: PiNotchParams = *pi.linear().unwrap();
        let feedforward = pi.feedforward().unwrap().clone();
        let with = |params| -> Arc<dyn Design> {
            Arc::new(WithFeedForward {
                params,
                feedforward: feedforward.clone(),
            })
        };
        assert!(*with(params) == **pi);
        let mut changed = params;
        changed.axes[1].ki *= 1.0 + 1e-12;
        assert!(*with(changed) != **pi);
        let bare: Arc<dyn Design> = Arc::new(params);
        // Both ways: each side's type is checked against the other's.
        assert!(*bare != **pi);
        assert!(**pi != *bare);
        let copy: Arc<dyn Design> = Arc::new(params);
        assert!(*bare == *copy);
        let (robust, nonrobust) = (
            designs.get(&crate::controller::ROBUST).unwrap(),
            designs.get(&crate::controller::NONROBUST).unwrap(),
        );
        assert!(**robust != **nonrobust);
        // Designed again, every design equals its first designing.
        let again = crate::samples::decoupled_designs(&setup).unwrap();
        for c in CONTROLLERS {
            assert!(**designs.get(c).unwrap() == **again.get(c).unwrap(), "{c}");
        }
    }

    /// Goal: the designs under learning ([`Designs::for_learning`]) are the tuned ones again
    /// with the margin targets widened by `TuningParams::learning_widening`: on the sampled
    /// loop of two decoupled modes the PI + notch and the PID under learning meet 12 dB / 60°
    /// (the defaults 6 dB / 40° widened by 6 dB / 20°); the PI + notch's own design does
    /// not, and under learning its crossover falls below 60 % of its own; exactly the
    /// designs that sit on the margin targets (the PI + notch, the PPF) differ under learning
    /// ([`Designs::differs_under_learning`]), not the PID (its own meets the widened targets
    /// here), the scenario PID (not tuned) nor the backstepping (its sizing carried over);
    /// without a widening there are no separate designs.
    #[test]
    fn designs_under_learning_meet_the_widened_margins() {
        use crate::tuning::{TuningParams, loop_margins};
        let setup = crate::experiment::Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let designs = crate::samples::decoupled_designs(&setup).unwrap();
        let plant = flexstage_sim::modal::ModalPlant::new(
            flexstage_sim::samples::decoupled_modes(),
            1e-4,
            1,
        )
        .unwrap();
        let m = TuningParams::default().margins;
        for c in [&crate::pi_notch::PI_NOTCH_FF, &crate::pid::PID_FF] {
            let own = designs.get(c).unwrap().linear().copied().unwrap();
            let learning = designs.for_learning(c).unwrap().linear().copied().unwrap();
            let (mo, ml) = (
                loop_margins(&plant, &own, &m).unwrap(),
                loop_margins(&plant, &learning, &m).unwrap(),
            );
            assert!(ml.iter().all(|x| x.meets(12.0, 60.0)), "{c}: {ml:?}");
            // The PI + notch's own design sits on its targets, so under learning its
            // bandwidth halves; the PID's own already meets the widened ones here.
            let pi = std::ptr::eq(c, &crate::pi_notch::PI_NOTCH_FF);
            assert_eq!(!mo.iter().all(|x| x.meets(12.0, 60.0)), pi, "{c}: {mo:?}");
            for a in 0..2 {
                let (ko, kl) = (own.axes[a].ki, learning.axes[a].ki);
                let (wo, wl) = (mo[a].gain_crossover, ml[a].gain_crossover);
                assert!(
                    kl <= ko && wl <= wo,
                    "{c} axis {a}: ki {ko} → {kl}, {wo} → {wl} Hz"
                );
                assert!(!pi || wl < 0.6 * wo, "{c} axis {a}: {wo} → {wl} Hz");
            }
        }
        // The designs on their margin targets differ under learning; the PID's own already
        // meets the widened ones here (so it tunes to the same), and those not tuned to the
        // targets (the scenario PID) or whose sizing is carried over (the backstepping) do not.
        let differ: Vec<&str> = CONTROLLERS
            .iter()
            .filter(|c| designs.differs_under_learning(c))
            .map(|c| c.name)
            .collect();
        assert_eq!(differ, ["pi-notch-ff", "ppf-pi-ff"]);
        for c in CONTROLLERS {
            let (own, learning) = (designs.get(c).unwrap(), designs.for_learning(c).unwrap());
            assert_eq!(
                **own != **learning,
                designs.differs_under_learning(c),
                "{c}"
            );
        }
        // No widening: the learning layer runs on the designs themselves.
        let modes = flexstage_sim::samples::decoupled_modes();
        let fit = flexstage_identify::response::ResponseFit::from_modes(&modes, 5000.0, 0.1);
        let tuning = TuningParams {
            learning_widening: [0.0; 2],
            ..TuningParams::default()
        };
        let stage = Stage::new(&setup, Some(&plant), Some(fit), None, tuning);
        let plain = Designs::for_stage(&stage).unwrap();
        assert!(plain.learning.is_empty());
        let c = &crate::pi_notch::PI_NOTCH_FF;
        assert!(std::ptr::eq(
            &**plain.for_learning(c).unwrap(),
            &**plain.get(c).unwrap()
        ));
    }
}
