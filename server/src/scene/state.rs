//! What of a scene carries from one step to the next beyond its world (a snapshot, `snapshot/`):
//! each actuator's command, applied value and fault; the script's position and running ramps; the
//! faults, declared and requested, with when they fired; the signals' state
//! (`signals/state.rs`). The world's own state is [`WorldState`](crate::dynamics::WorldState).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::Scene;
use super::controls::{ActuatorFault, Ramp};
use super::faults::{Fault, FaultAction, MAX_FAULTS};
use crate::dynamics::{WorldState, WorldStateError};
use crate::signals::{SignalsState, SignalsStateError};

/// An actuator's state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ActuatorState {
    /// Commanded value.
    pub value: f64,
    /// Value applied in the last step.
    pub applied: f64,
    /// Fault acting on it.
    pub fault: ActuatorFault,
}

/// A scene's state: the world's and the rest (module doc).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneState {
    /// The world.
    pub world: WorldState,
    /// Actuators, in file order.
    pub actuators: Vec<ActuatorState>,
    /// Index of the next script entry to fire.
    pub(crate) script_next: usize,
    /// Ramps running.
    pub(crate) ramps: Vec<Ramp>,
    /// Faults, declared then requested.
    pub faults: Vec<Fault>,
    /// Signals.
    pub signals: SignalsState,
    /// The joystick mapping's buttons as last read (a button's event fires on its press).
    pub(crate) joystick_buttons: Vec<bool>,
}

/// Why a state does not fit a scene (it is another scene's, or damaged).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SceneStateError {
    /// The world's part.
    #[error("world: {0}")]
    World(#[from] WorldStateError),
    /// The signals' part.
    #[error("signals: {0}")]
    Signals(#[from] SignalsStateError),
    /// Another number of actuators, faults or script entries, or an index beyond them.
    #[error("{what}: {found} does not fit the scene ({expected})")]
    Mismatch {
        /// What.
        what: &'static str,
        /// The scene's count or bound.
        expected: usize,
        /// The state's.
        found: usize,
    },
    /// A value that is NaN or infinite.
    #[error("{0} is not finite")]
    NonFinite(&'static str),
}

impl Scene {
    /// The scene's state (module doc); fails only where the world's does.
    pub fn state(&self) -> Result<SceneState, WorldStateError> {
        Ok(SceneState {
            world: self.world.state()?,
            actuators: (self.controls.actuators.iter())
                .map(|a| ActuatorState { value: a.value, applied: a.applied, fault: a.fault })
                .collect(),
            script_next: self.script.next,
            ramps: self.script.ramps.clone(),
            faults: self.faults.list().to_vec(),
            signals: self.signals.state(),
            joystick_buttons: self.joystick.last_buttons.clone(),
        })
    }

    /// Puts `state` back, checked against the scene first: on an error nothing has changed. The
    /// signals' channels are evaluated again from the restored world.
    pub fn restore_state(&mut self, state: &SceneState) -> Result<(), SceneStateError> {
        self.check_state(state)?;
        self.signals.check_state(&state.signals)?;
        self.world.restore_state(&state.world)?;
        self.signals.restore_state(&state.signals)?;
        for (a, s) in self.controls.actuators.iter_mut().zip(&state.actuators) {
            (a.value, a.applied, a.fault) = (s.value, s.applied, s.fault);
        }
        self.script.next = state.script_next;
        self.script.ramps.clone_from(&state.ramps);
        self.faults.restore(&state.faults, &mut self.signals);
        self.joystick.last_buttons.clone_from(&state.joystick_buttons);
        self.signals.evaluate(&self.world);
        Ok(())
    }

    fn check_state(&self, s: &SceneState) -> Result<(), SceneStateError> {
        let mismatch = |what, expected, found| Err(SceneStateError::Mismatch { what, expected, found });
        let actuators = self.controls.actuators.len();
        if s.actuators.len() != actuators {
            return mismatch("actuators", actuators, s.actuators.len());
        }
        if s.actuators.iter().any(|a| !(a.value.is_finite() && a.applied.is_finite())) {
            return Err(SceneStateError::NonFinite("an actuator's value"));
        }
        let buttons = self.joystick.last_buttons.len();
        if s.joystick_buttons.len() != buttons {
            return mismatch("joystick buttons", buttons, s.joystick_buttons.len());
        }
        let entries = self.script.entries.len();
        if s.script_next > entries {
            return mismatch("script position", entries, s.script_next);
        }
        if let Some(r) = s.ramps.iter().find(|r| r.actuator >= actuators) {
            return mismatch("ramp actuator", actuators, r.actuator);
        }
        if s.faults.len() > MAX_FAULTS || s.faults.len() < self.declared_faults {
            return mismatch("faults", self.declared_faults, s.faults.len());
        }
        let (joints, sensors) = (self.world.joints().len(), self.signals.sensors().len());
        for f in &s.faults {
            let (index, bound, what) = match f.action {
                FaultAction::Break { joint } => (joint.index(), joints, "fault joint"),
                FaultAction::HoseBurst { actuator }
                | FaultAction::StickValve { actuator }
                | FaultAction::BrakeFade { actuator, .. } => (actuator, actuators, "fault actuator"),
                FaultAction::Dropout { sensor } => (sensor, sensors, "fault sensor"),
            };
            if index >= bound {
                return mismatch(what, bound, index);
            }
        }
        Ok(())
    }
}
