//! Faults: what an instructor (or the scene's timeline) breaks on a machine, reported as events of
//! the signals (`crate::signals`).
//!
//! | fault | target | effect |
//! |---|---|---|
//! | `break` | joint | the joint is disabled (a rope or cable parts), at a time or when the force it carried in a step exceeds `tension` |
//! | `hose_burst` | actuator | its joints go limp: no motor force at all |
//! | `brake_fade` | actuator | its force bound ramps linearly to the fraction `to` of itself over `ramp` seconds |
//! | `stick_valve` | actuator | the applied value freezes where it is; commands are ignored |
//! | `dropout` | sensor | its channels read 0 and are flagged invalid |
//!
//! A fault with a time fires at the first step that starts at or after it; one without a time and
//! without a tension fires at the next step (a live request). A tension-triggered break reads the
//! force magnitude `|F_A|` the joint carried in the step just solved and disables the joint before
//! the next one, so it parts at the limit to within one step's change of the tension. Each fault
//! fires once and is one [`EventKind::Fault`] event; a refused live request is one
//! [`EventKind::FaultRejected`] event and a typed [`FaultError`], never a panic.

use thiserror::Error;

use super::controls::{ActuatorFault, ActuatorKind, Controls};
use crate::dynamics::{ControlError, JointId, World};
use crate::signals::{Event, EventKind, EventName, Signals};

/// What a fault does.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum FaultAction {
    /// Disable a joint.
    Break {
        /// The joint.
        joint: JointId,
    },
    /// An actuator goes limp.
    HoseBurst {
        /// Actuator index.
        actuator: usize,
    },
    /// An actuator's force bound fades.
    BrakeFade {
        /// Actuator index.
        actuator: usize,
        /// Final fraction of the bound, in [0, 1].
        to: f64,
        /// Seconds of the ramp (≥ 0).
        ramp: f64,
    },
    /// An actuator's applied value freezes.
    StickValve {
        /// Actuator index.
        actuator: usize,
    },
    /// A sensor drops out.
    Dropout {
        /// Sensor index.
        sensor: usize,
    },
}

/// When a fault fires.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum FaultTrigger {
    /// At this simulation time (s).
    At(f64),
    /// When the broken joint's force exceeds this (N); `Break` only.
    Tension(f64),
    /// At the next step (a live request).
    Now,
}

/// A fault, declared or requested.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Fault {
    /// Its name (the event's name).
    pub name: EventName,
    /// What it does.
    pub action: FaultAction,
    /// When.
    pub trigger: FaultTrigger,
    /// When it fired (s), if it has.
    pub fired_at: Option<f64>,
}

/// A fault request by name (an instructor station; `pivotsim-client fault`).
#[derive(Debug, Clone, PartialEq)]
pub struct FaultRequest {
    /// `break`, `hose_burst`, `brake_fade`, `stick_valve` or `dropout`.
    pub kind: String,
    /// Joint, actuator or sensor name.
    pub target: String,
    /// Break limit (N): the rope parts when its tension exceeds it; absent: now.
    pub tension: Option<f64>,
    /// Brake fade: the final fraction of the bound (default 0).
    pub to: Option<f64>,
    /// Brake fade: ramp duration (s, default 0).
    pub ramp: Option<f64>,
}

/// Why a fault was refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FaultError {
    /// Not one of the fault kinds.
    #[error("unknown fault kind `{0}` (break, hose_burst, brake_fade, stick_valve, dropout)")]
    UnknownKind(String),
    /// No joint of this name.
    #[error("no joint named `{0}`")]
    UnknownJoint(String),
    /// No actuator of this name.
    #[error("no actuator named `{0}`")]
    UnknownActuator(String),
    /// No sensor of this name.
    #[error("no sensor named `{0}`")]
    UnknownSensor(String),
    /// A brake fade on an actuator that is not a brake.
    #[error("actuator `{0}` is not a brake")]
    NotABrake(String),
    /// A number that is NaN, infinite or out of its range.
    #[error("`{field}` = {value} is out of range ({range})")]
    BadValue {
        /// The field.
        field: &'static str,
        /// The value.
        value: f64,
        /// What is allowed.
        range: &'static str,
    },
    /// The scene's fault list is full.
    #[error("too many faults (at most {0})")]
    TooMany(usize),
    /// The world refused the change.
    #[error(transparent)]
    Control(#[from] ControlError),
}

/// Most faults a scene holds (declared and requested).
pub const MAX_FAULTS: usize = 256;

/// The scene's faults.
#[derive(Debug, Clone, Default)]
pub struct Faults {
    list: Vec<Fault>,
}

impl Faults {
    /// The faults, declared first, then requested.
    pub fn list(&self) -> &[Fault] {
        &self.list
    }

    /// Resolves a request against the scene's joints, actuators and sensors (checks only).
    pub fn resolve(
        req: &FaultRequest,
        world: &World,
        controls: &Controls,
        signals: &Signals,
        at: Option<f64>,
    ) -> Result<Fault, FaultError> {
        let num = |field: &'static str, v: Option<f64>, ok: fn(f64) -> bool, range: &'static str| match v {
            Some(x) if !ok(x) => Err(FaultError::BadValue { field, value: x, range }),
            _ => Ok(v),
        };
        let at = num("t", at, |x| x.is_finite() && x >= 0.0, "finite, ≥ 0")?;
        let tension = num("tension", req.tension, |x| x.is_finite() && x > 0.0, "finite, > 0")?;
        let actuator =
            || controls.index(&req.target).ok_or_else(|| FaultError::UnknownActuator(req.target.clone()));
        let action = match req.kind.as_str() {
            "break" => FaultAction::Break {
                joint: world
                    .joint_id(&req.target)
                    .ok_or_else(|| FaultError::UnknownJoint(req.target.clone()))?,
            },
            "hose_burst" => FaultAction::HoseBurst { actuator: actuator()? },
            "stick_valve" => FaultAction::StickValve { actuator: actuator()? },
            "brake_fade" => {
                let i = actuator()?;
                if controls.actuators()[i].kind() != ActuatorKind::Brake {
                    return Err(FaultError::NotABrake(req.target.clone()));
                }
                let to = num("to", req.to, |x| (0.0..=1.0).contains(&x), "0 to 1")?.unwrap_or(0.0);
                let ramp =
                    num("ramp", req.ramp, |x| x.is_finite() && x >= 0.0, "finite, ≥ 0")?.unwrap_or(0.0);
                FaultAction::BrakeFade { actuator: i, to, ramp }
            }
            "dropout" => FaultAction::Dropout {
                sensor: signals
                    .sensor_index(&req.target)
                    .ok_or_else(|| FaultError::UnknownSensor(req.target.clone()))?,
            },
            other => return Err(FaultError::UnknownKind(other.to_string())),
        };
        if tension.is_some() && !matches!(action, FaultAction::Break { .. }) {
            return Err(FaultError::BadValue {
                field: "tension",
                value: tension.unwrap_or(0.0),
                range: "break only",
            });
        }
        let trigger = match (at, tension) {
            (_, Some(t)) => FaultTrigger::Tension(t),
            (Some(t), None) => FaultTrigger::At(t),
            (None, None) => FaultTrigger::Now,
        };
        Ok(Fault { name: EventName::new(&req.target), action, trigger, fired_at: None })
    }

    /// Adds a fault (declared: the builder; requested: [`super::Scene::request_fault`]).
    pub fn push(&mut self, mut f: Fault, signals: &mut Signals) -> Result<(), FaultError> {
        if self.list.len() >= MAX_FAULTS {
            return Err(FaultError::TooMany(MAX_FAULTS));
        }
        if let (FaultAction::Break { joint }, FaultTrigger::Tension(_)) = (f.action, f.trigger) {
            signals.watch_joint(joint);
        }
        f.fired_at = None;
        self.list.reserve(MAX_FAULTS - self.list.len());
        signals.reserve_events(1);
        self.list.push(f);
        Ok(())
    }

    /// Before a step at time `t`: fires timed and immediate faults, ramps brake fades.
    pub fn before_step(
        &mut self,
        t: f64,
        world: &mut World,
        controls: &mut Controls,
        signals: &mut Signals,
    ) -> Result<(), ControlError> {
        let eps = 1e-9 * world.settings().timestep;
        for f in &mut self.list {
            let due = match f.trigger {
                FaultTrigger::At(at) => at <= t + eps,
                FaultTrigger::Now => true,
                FaultTrigger::Tension(_) => false,
            };
            if f.fired_at.is_none() && due {
                fire(f, t, 0.0, 0.0, world, controls, signals)?;
            }
            if let (FaultAction::BrakeFade { actuator, to, ramp }, Some(t0)) = (f.action, f.fired_at) {
                let s = if ramp > 0.0 { ((t - t0) / ramp).clamp(0.0, 1.0) } else { 1.0 };
                controls.set_fault(actuator, ActuatorFault::Fade(1.0 - (1.0 - to) * s));
            }
        }
        Ok(())
    }

    /// After a step that ended at time `t` (the signals evaluated): tension-triggered breaks.
    pub fn after_step(
        &mut self,
        t: f64,
        world: &mut World,
        controls: &mut Controls,
        signals: &mut Signals,
    ) -> Result<(), ControlError> {
        for f in &mut self.list {
            if let (None, FaultAction::Break { joint }, FaultTrigger::Tension(limit)) =
                (f.fired_at, f.action, f.trigger)
                && let Some(tension) = signals.joint_force(joint)
                && tension > limit
            {
                fire(f, t, tension, limit, world, controls, signals)?;
            }
        }
        Ok(())
    }

    /// Takes over `list` (a snapshot's, checked by the caller: at most [`MAX_FAULTS`], indices in
    /// range), with when each fired; the joints of tension-triggered breaks are watched again.
    pub(crate) fn restore(&mut self, list: &[Fault], signals: &mut Signals) {
        self.list.clear();
        self.list.reserve(MAX_FAULTS);
        for f in list {
            if let (FaultAction::Break { joint }, FaultTrigger::Tension(_)) = (f.action, f.trigger) {
                signals.watch_joint(joint);
            }
            signals.reserve_events(1);
            self.list.push(f.clone());
        }
    }

    /// Forgets the faults that fired (a reset: declared ones fire again, requested ones go).
    pub fn reset(&mut self, declared: usize) {
        self.list.truncate(declared);
        for f in &mut self.list {
            f.fired_at = None;
        }
    }
}

fn fire(
    f: &mut Fault,
    t: f64,
    value: f64,
    level: f64,
    world: &mut World,
    controls: &mut Controls,
    signals: &mut Signals,
) -> Result<(), ControlError> {
    match f.action {
        FaultAction::Break { joint } => world.set_joint_enabled(joint, false, false)?,
        FaultAction::HoseBurst { actuator } => {
            controls.set_fault(actuator, ActuatorFault::Limp);
        }
        FaultAction::StickValve { actuator } => {
            controls.set_fault(actuator, ActuatorFault::Frozen);
        }
        FaultAction::BrakeFade { actuator, .. } => {
            controls.set_fault(actuator, ActuatorFault::Fade(1.0));
        }
        FaultAction::Dropout { sensor } => {
            signals.set_dropout(sensor, true);
        }
    }
    f.fired_at = Some(t);
    signals.push_event(Event { kind: EventKind::Fault, name: f.name, time: t, value, level });
    Ok(())
}
