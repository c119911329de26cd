//! Named actuators (the inputs an operator, a script or the server's transports drive), the
//! default joystick mapping, and the scripted operator timeline.
//!
//! **Actuators.** Each has a value `u` in its `range` and drives joint motors or a coupling:
//!
//! | type | per target joint `k` (scale `s_k`) | neutral (deadman) |
//! |---|---|---|
//! | `velocity` | velocity motor: speed `s_k u`, force bound `max_force` | `u = 0`: hold still with `max_force` (brakes on) |
//! | `position` | position motor: target `s_k u`, speed bound `max_speed`, `max_force` | hold: `u` ← current coordinate `/ s_1` |
//! | `brake` | velocity motor at speed 0 with force bound `u · max_force` (`u ∈ [0, 1]`), none at 0 | `u = 1` |
//! | `clutch` | coupling torque bound `u · max_force` (`u ∈ [0, 1]`) | `u = 0` (disengaged) |
//!
//! A value outside the range is clamped (a stick pushed past its end); a non-finite value is
//! refused with [`InputError`] and changes nothing. With `rate`, the applied value follows the
//! commanded one at most `rate` units per second (a hydraulic valve's slew), deadman included.
//! Actuators are applied to the world before every step ([`Controls::apply`]); applying
//! allocates nothing.
//!
//! **Script.** Entries at times `t` set actuator values (with `ramp` > 0: over `ramp` seconds
//! `T`, from the value `u₀` at `t₀`, by default (`profile = "smooth"`) along the smooth step
//!
//! ```text
//!   u(t) = u₀ + (u₁ − u₀) σ(τ),   σ(τ) = 3τ² − 2τ³,   τ = (t − t₀) / T ∈ [0, 1],
//! ```
//!
//! whose rate `6 (u₁ − u₀) τ (1 − τ) / T` starts and ends at zero and peaks at 1.5 × the mean at
//! `τ = ½`, with the acceleration bounded by `6 |u₁ − u₀| / T²`: a scripted operator moves a lever
//! as a person does, never as a step of its rate. A linear ramp of a position actuator's target is
//! a step of the cylinder's speed — a jolt the load feels: the crane's telescope/luff ramp raised
//! `hoist-overload` (1.86× static) two steps after it started. `profile = "linear"` keeps
//! `σ(τ) = τ`) and fire events: `attach` (latch a disabled joint where the
//! bodies are now) and `detach`. [`Script::advance`] is called with the time of the step about
//! to be taken.

use std::collections::HashMap;

use thiserror::Error;

use crate::dynamics::{ControlError, CouplingId, FreeAxis, JointId, JointMotor, World};

/// What an actuator drives (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ActuatorKind {
    /// Velocity motors.
    Velocity,
    /// Position motors.
    Position,
    /// Brakes: zero-speed motors with a variable force bound.
    Brake,
    /// A clutch: a coupling's torque bound.
    Clutch,
}

impl ActuatorKind {
    /// Name in scene files.
    pub fn name(self) -> &'static str {
        match self {
            ActuatorKind::Velocity => "velocity",
            ActuatorKind::Position => "position",
            ActuatorKind::Brake => "brake",
            ActuatorKind::Clutch => "clutch",
        }
    }
}

/// Where an actuator goes when its input stops (the deadman) or on reset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Neutral {
    /// This value.
    Value(f64),
    /// The current coordinate of the first target joint (position actuators).
    Hold,
}

/// A joint axis driven by an actuator, with its scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorTarget {
    /// The joint.
    pub joint: JointId,
    /// Its free axis.
    pub axis: FreeAxis,
    /// Scale `s_k` from the actuator value to the motor's speed or target.
    pub scale: f64,
}

/// A named actuator (module doc).
#[derive(Debug, Clone)]
pub struct Actuator {
    pub(crate) name: String,
    pub(crate) kind: ActuatorKind,
    pub(crate) targets: Vec<ActuatorTarget>,
    pub(crate) coupling: Option<CouplingId>,
    pub(crate) max_force: f64,
    pub(crate) max_speed: f64,
    pub(crate) range: (f64, f64),
    pub(crate) neutral: Neutral,
    pub(crate) rate: Option<f64>,
    /// A cable drum: takes winch commands on the wire.
    pub(crate) winch: bool,
    /// Commanded value.
    pub(crate) value: f64,
    /// Value applied in the last step (follows `value` at `rate`).
    pub(crate) applied: f64,
    /// Value at load (for reset).
    pub(crate) initial: f64,
    /// A fault acting on it (`faults.rs`).
    pub(crate) fault: ActuatorFault,
}

/// A fault on an actuator's hydraulics or brake (`faults.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub enum ActuatorFault {
    /// Healthy.
    #[default]
    None,
    /// Hose burst: its joints go limp (no motor at all).
    Limp,
    /// Sticking valve: the applied value stays where it is, whatever is commanded.
    Frozen,
    /// Brake fade: the force bound is scaled by this factor (1 → healthy, 0 → no force).
    Fade(f64),
}

impl Actuator {
    /// Name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Type.
    pub fn kind(&self) -> ActuatorKind {
        self.kind
    }
    /// Allowed value range.
    pub fn range(&self) -> (f64, f64) {
        self.range
    }
    /// Commanded value.
    pub fn value(&self) -> f64 {
        self.value
    }
    /// Value applied in the last step.
    pub fn applied(&self) -> f64 {
        self.applied
    }
    /// Driven joint axes.
    pub fn targets(&self) -> &[ActuatorTarget] {
        &self.targets
    }
    /// Neutral.
    pub fn neutral(&self) -> Neutral {
        self.neutral
    }
    /// Force (N) or torque (N m) bound.
    pub fn max_force(&self) -> f64 {
        self.max_force
    }
    /// Whether it is a cable drum (takes winch commands).
    pub fn is_winch(&self) -> bool {
        self.winch
    }
    /// The fault acting on it.
    pub fn fault(&self) -> ActuatorFault {
        self.fault
    }
    /// Scale of the first target (1 for a clutch): physical speed or target per unit of value.
    pub fn unit_scale(&self) -> f64 {
        self.targets.first().map_or(1.0, |t| t.scale)
    }
}

/// A refused input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InputError {
    /// No actuator of this name.
    #[error("unknown actuator `{0}`")]
    UnknownActuator(String),
    /// No actuator of this index.
    #[error("actuator index {0} out of range")]
    BadIndex(usize),
    /// NaN or infinite value.
    #[error("actuator `{actuator}`: non-finite value {value}")]
    NonFinite {
        /// The actuator.
        actuator: String,
        /// The value.
        value: f64,
    },
}

/// The scene's actuators.
#[derive(Debug, Clone, Default)]
pub struct Controls {
    pub(crate) actuators: Vec<Actuator>,
    pub(crate) names: HashMap<String, usize>,
}

impl Controls {
    /// All actuators, in file order.
    pub fn actuators(&self) -> &[Actuator] {
        &self.actuators
    }

    /// Index of an actuator by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.get(name).copied()
    }

    /// Actuator by name.
    pub fn get(&self, name: &str) -> Option<&Actuator> {
        self.index(name).map(|i| &self.actuators[i])
    }

    /// Commands actuator `name` to `value` (clamped to its range).
    pub fn set(&mut self, name: &str, value: f64) -> Result<(), InputError> {
        let i = self.index(name).ok_or_else(|| InputError::UnknownActuator(name.to_string()))?;
        self.set_index(i, value)
    }

    /// Commands actuator `i` to `value` (clamped to its range).
    pub fn set_index(&mut self, i: usize, value: f64) -> Result<(), InputError> {
        let a = self.actuators.get_mut(i).ok_or(InputError::BadIndex(i))?;
        if !value.is_finite() {
            return Err(InputError::NonFinite { actuator: a.name.clone(), value });
        }
        a.value = value.clamp(a.range.0, a.range.1);
        Ok(())
    }

    /// Sends every actuator to its neutral (the deadman; module doc).
    pub fn neutralize(&mut self, world: &World) {
        for a in &mut self.actuators {
            a.value = match a.neutral {
                Neutral::Value(v) => v,
                Neutral::Hold => hold_value(a, world),
            }
            .clamp(a.range.0, a.range.1);
        }
    }

    /// Back to the values at load; the applied values jump there too, faults are cleared.
    pub fn reset(&mut self) {
        for a in &mut self.actuators {
            a.value = a.initial;
            a.applied = a.initial;
            a.fault = ActuatorFault::None;
        }
    }

    /// Puts a fault on actuator `i` (`faults.rs`); `false` if there is none.
    pub fn set_fault(&mut self, i: usize, fault: ActuatorFault) -> bool {
        match self.actuators.get_mut(i) {
            Some(a) => {
                a.fault = fault;
                true
            }
            None => false,
        }
    }

    /// Moves the applied values toward the commanded ones (rate limits over `h`) and writes the
    /// motors and couplings. No allocation.
    pub fn apply(&mut self, world: &mut World, h: f64) -> Result<(), ControlError> {
        for a in &mut self.actuators {
            if a.fault != ActuatorFault::Frozen {
                a.applied = match a.rate {
                    Some(r) => a.applied + (a.value - a.applied).clamp(-r * h, r * h),
                    None => a.value,
                };
            }
            let u = a.applied;
            let max_force = match a.fault {
                ActuatorFault::Fade(k) => a.max_force * k,
                _ => a.max_force,
            };
            for t in &a.targets {
                let motor = match a.kind {
                    _ if a.fault == ActuatorFault::Limp => None,
                    ActuatorKind::Velocity => Some(JointMotor::velocity(t.scale * u, max_force)),
                    ActuatorKind::Position => Some(JointMotor::position(t.scale * u, a.max_speed, max_force)),
                    ActuatorKind::Brake if u > 0.0 => Some(JointMotor::velocity(0.0, u * max_force)),
                    ActuatorKind::Brake => None,
                    ActuatorKind::Clutch => continue,
                };
                world.set_joint_axis_motor(t.joint, t.axis, motor)?;
            }
            if let (ActuatorKind::Clutch, Some(c)) = (a.kind, a.coupling) {
                world.set_coupling_max_torque(c, Some(u * max_force))?;
            }
        }
        Ok(())
    }
}

/// The value that holds a position actuator's first joint where it is.
fn hold_value(a: &Actuator, world: &World) -> f64 {
    a.targets
        .first()
        .and_then(|t| world.joint_axis_coordinate(t.joint, t.axis).map(|s| s / t.scale))
        .filter(|v| v.is_finite())
        .unwrap_or(a.value)
}

/// A one-off event of the timeline or a button.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneEvent {
    /// Latch a joint at the bodies' current relative pose.
    Attach(JointId),
    /// Release a joint.
    Detach(JointId),
}

impl SceneEvent {
    /// Carries the event out.
    pub fn fire(self, world: &mut World) -> Result<(), ControlError> {
        match self {
            SceneEvent::Attach(j) => world.set_joint_enabled(j, true, true),
            SceneEvent::Detach(j) => world.set_joint_enabled(j, false, false),
        }
    }
}

/// One entry of the timeline.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptEntry {
    /// Time (s).
    pub t: f64,
    /// Actuator values to reach (actuator index, value).
    pub set: Vec<(usize, f64)>,
    /// Ramp duration (s; 0: at once).
    pub ramp: f64,
    /// How the ramp moves (module doc).
    pub profile: RampProfile,
    /// Event fired at `t`.
    pub event: Option<SceneEvent>,
}

/// The shape of a scripted ramp (module doc, **Script**).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum RampProfile {
    /// `σ(τ) = 3τ² − 2τ³`: the rate starts and ends at zero (the default).
    #[default]
    Smooth,
    /// `σ(τ) = τ`: a constant rate from the first step (a step of a position target's speed).
    Linear,
}

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct Ramp {
    profile: RampProfile,
    pub(crate) actuator: usize,
    from: f64,
    to: f64,
    t0: f64,
    t1: f64,
}

/// The scripted operator timeline (module doc).
#[derive(Debug, Clone, Default)]
pub struct Script {
    pub(crate) entries: Vec<ScriptEntry>,
    pub(crate) next: usize,
    pub(crate) ramps: Vec<Ramp>,
}

impl Script {
    pub(crate) fn new(mut entries: Vec<ScriptEntry>, actuators: usize) -> Self {
        entries.sort_by(|a, b| a.t.total_cmp(&b.t));
        Script { entries, next: 0, ramps: Vec::with_capacity(actuators) }
    }

    /// The entries, by time.
    pub fn entries(&self) -> &[ScriptEntry] {
        &self.entries
    }

    /// Whether the timeline has no entries.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Back to the start.
    pub fn reset(&mut self) {
        self.next = 0;
        self.ramps.clear();
    }

    /// Fires the entries due at time `t` (those with `entry.t ≤ t` not yet fired) and advances the
    /// ramps to `t`.
    pub fn advance(
        &mut self,
        t: f64,
        controls: &mut Controls,
        world: &mut World,
    ) -> Result<(), ControlError> {
        while let Some(e) = self.entries.get(self.next) {
            if e.t > t + 1e-9 {
                break;
            }
            for &(i, to) in &e.set {
                self.ramps.retain(|r| r.actuator != i);
                if e.ramp > 0.0 {
                    let from = controls.actuators[i].value;
                    self.ramps.push(Ramp {
                        profile: e.profile,
                        actuator: i,
                        from,
                        to,
                        t0: e.t,
                        t1: e.t + e.ramp,
                    });
                } else {
                    // Entries were validated finite at load.
                    let _ = controls.set_index(i, to);
                }
            }
            if let Some(ev) = e.event {
                ev.fire(world)?;
            }
            self.next += 1;
        }
        for r in &self.ramps {
            let tau = ((t - r.t0) / (r.t1 - r.t0)).clamp(0.0, 1.0);
            let f = match r.profile {
                RampProfile::Smooth => smooth_step(tau),
                RampProfile::Linear => tau,
            };
            let _ = controls.set_index(r.actuator, r.from + f * (r.to - r.from));
        }
        self.ramps.retain(|r| t < r.t1);
        Ok(())
    }
}

/// `σ(τ) = 3τ² − 2τ³` (module doc, **Script**): 0 → 1 with zero slope at both ends.
fn smooth_step(tau: f64) -> f64 {
    tau * tau * (3.0 - 2.0 * tau)
}

/// How a joystick axis drives its actuator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisMode {
    /// Value = `scale · axis`.
    Direct,
    /// Value changes at `scale · axis` per second (a lever that stays where it was left).
    Rate,
}

/// One mapped joystick axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoyAxis {
    /// Axis index in the joystick message.
    pub index: usize,
    /// Actuator index.
    pub actuator: usize,
    /// Scale.
    pub scale: f64,
    /// Dead zone: `|axis|` below it reads 0.
    pub deadzone: f64,
    /// Direct or rate.
    pub mode: AxisMode,
}

/// What a button does while pressed (values) or on press (events).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ButtonAction {
    /// Set an actuator to a value.
    Set {
        /// Actuator index.
        actuator: usize,
        /// Value.
        value: f64,
    },
    /// Fire an event.
    Event(SceneEvent),
}

/// One mapped button.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoyButton {
    /// Button index.
    pub index: usize,
    /// Action.
    pub action: ButtonAction,
}

/// The default joystick mapping of a scene.
#[derive(Debug, Clone, Default)]
pub struct JoystickMap {
    /// Mapped axes.
    pub axes: Vec<JoyAxis>,
    /// Mapped buttons.
    pub buttons: Vec<JoyButton>,
    pub(crate) last_buttons: Vec<bool>,
}

impl JoystickMap {
    pub(crate) fn new(axes: Vec<JoyAxis>, buttons: Vec<JoyButton>) -> Self {
        let n = buttons.iter().map(|b| b.index + 1).max().unwrap_or(0);
        JoystickMap { axes, buttons, last_buttons: vec![false; n] }
    }

    /// Applies one joystick reading (axes in `[−1, 1]`, buttons pressed or not) held for `h`
    /// seconds. Missing axes or buttons read as centred / released; non-finite axes are refused
    /// before anything changes.
    pub fn apply(
        &mut self,
        axes: &[f64],
        buttons: &[bool],
        h: f64,
        controls: &mut Controls,
        world: &mut World,
    ) -> Result<(), JoystickError> {
        if let Some((i, &v)) = axes.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(JoystickError::NonFiniteAxis { index: i, value: v });
        }
        for m in &self.axes {
            let raw = axes.get(m.index).copied().unwrap_or(0.0).clamp(-1.0, 1.0);
            let x = if raw.abs() < m.deadzone { 0.0 } else { raw };
            let a = &controls.actuators[m.actuator];
            let value = match m.mode {
                AxisMode::Direct => m.scale * x,
                AxisMode::Rate => a.value + m.scale * x * h,
            };
            controls.set_index(m.actuator, value).map_err(JoystickError::Input)?;
        }
        for b in &self.buttons {
            let pressed = buttons.get(b.index).copied().unwrap_or(false);
            let was = std::mem::replace(&mut self.last_buttons[b.index], pressed);
            match b.action {
                ButtonAction::Set { actuator, value } if pressed => {
                    controls.set_index(actuator, value).map_err(JoystickError::Input)?;
                }
                ButtonAction::Event(e) if pressed && !was => e.fire(world).map_err(JoystickError::Control)?,
                _ => {}
            }
        }
        Ok(())
    }
}

/// A refused joystick reading.
#[derive(Debug, Error)]
pub enum JoystickError {
    /// NaN or infinite axis.
    #[error("joystick axis {index}: non-finite value {value}")]
    NonFiniteAxis {
        /// Axis index.
        index: usize,
        /// Value.
        value: f64,
    },
    /// An actuator refused the value.
    #[error(transparent)]
    Input(InputError),
    /// The world refused an event.
    #[error(transparent)]
    Control(ControlError),
}
