//! The scene file's syntax: serde types mirroring `scenes/README.md` one to one. Unknown fields are
//! refused by serde (with their location); meaning (references, ranges, finiteness) is checked by
//! `build/`, which locates its errors through the [`Spanned`] tables.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

/// A whole scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneFile {
    pub scene: Spanned<SceneSection>,
    #[serde(default)]
    pub material: Vec<Spanned<MaterialDef>>,
    #[serde(default)]
    pub body: Vec<Spanned<BodyDef>>,
    #[serde(default)]
    pub joint: Vec<Spanned<JointDef>>,
    #[serde(default)]
    pub coupling: Vec<Spanned<CouplingDef>>,
    #[serde(default)]
    pub spring: Vec<Spanned<SpringDef>>,
    #[serde(default)]
    pub repeat: Vec<Spanned<RepeatDef>>,
    #[serde(default)]
    pub cable: Vec<Spanned<CableDef>>,
    #[serde(default)]
    pub buoyancy: Vec<Spanned<BuoyancyDef>>,
    #[serde(default)]
    pub actuator: Vec<Spanned<ActuatorDef>>,
    #[serde(default)]
    pub joystick: Option<Spanned<JoystickDef>>,
    #[serde(default)]
    pub script: Vec<Spanned<ScriptDef>>,
    #[serde(default)]
    pub sensor: Vec<Spanned<SensorDef>>,
    #[serde(default)]
    pub event: Vec<Spanned<EventDef>>,
    #[serde(default)]
    pub fault: Vec<Spanned<FaultDef>>,
}

/// `[scene]`: name, text and world settings.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneSection {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub duration: Option<f64>,
    pub timestep: Option<f64>,
    pub gravity: Option<[f64; 3]>,
    pub variant: Option<String>,
    pub compliance: Option<f64>,
    pub contact_compliance: Option<f64>,
    pub contact_margin: Option<f64>,
    pub swept_contacts: Option<bool>,
    pub friction: Option<f64>,
    pub max_pivot_steps: Option<usize>,
    pub max_solve_us: Option<f64>,
    pub newton_first: Option<bool>,
    pub safeguard_after_update: Option<bool>,
    pub prox_outer: Option<bool>,
    pub murty_after: Option<usize>,
    pub ipm_after: Option<usize>,
    pub ipm_cold_after: Option<usize>,
    pub projected_arc: Option<usize>,
    pub polish_sweeps: Option<usize>,
    pub pgs_sweeps: Option<usize>,
    pub exact_bilateral: Option<bool>,
    pub projection_iterations: Option<usize>,
    pub joint_error_tolerance: Option<f64>,
    pub max_substeps: Option<usize>,
    pub warm_start: Option<bool>,
    pub gyroscopic: Option<bool>,
    pub geometric_stiffness: Option<String>,
    pub max_speed: Option<f64>,
    pub energy_margin: Option<f64>,
    pub max_joint_error: Option<f64>,
}

/// `[[material]]`: friction of a pair of named materials.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialDef {
    pub a: String,
    pub b: String,
    pub friction: f64,
}

/// `[[body]]` (also inside `[[repeat]]`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BodyDef {
    pub name: String,
    pub kind: Option<String>,
    pub mass: Option<f64>,
    pub inertia: Option<[f64; 3]>,
    #[serde(default)]
    pub position: [f64; 3],
    pub rotation: Option<[f64; 3]>,
    pub quaternion: Option<[f64; 4]>,
    pub velocity: Option<[f64; 3]>,
    pub angular_velocity: Option<[f64; 3]>,
    pub damping: Option<[f64; 2]>,
    pub groups: Option<[u32; 2]>,
    #[serde(default)]
    pub shape: Vec<Spanned<ShapeDef>>,
}

/// `[[body.shape]]`: one collider of the body.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ShapeDef {
    #[serde(rename = "type")]
    pub kind: String,
    pub size: Option<[f64; 3]>,
    pub radius: Option<f64>,
    pub length: Option<f64>,
    pub normal: Option<[f64; 3]>,
    pub points: Option<Vec<[f64; 3]>>,
    #[serde(default)]
    pub position: [f64; 3],
    pub rotation: Option<[f64; 3]>,
    pub friction: Option<f64>,
    pub material: Option<String>,
    /// Heightfield: rows of heights (m), `size` its x/y extent and a z scale.
    pub heights: Option<Vec<Vec<f64>>>,
    /// Stairs: step count, rise and run (m); width from `size[1]`.
    pub steps: Option<usize>,
    pub rise: Option<f64>,
    pub run: Option<f64>,
    /// Hills: amplitude (m), wavelength (m) and grid resolution (cells per side).
    pub amplitude: Option<f64>,
    pub wavelength: Option<f64>,
    pub cells: Option<usize>,
    /// Triangle mesh: vertices and index triples.
    pub vertices: Option<Vec<[f64; 3]>>,
    pub triangles: Option<Vec<[u32; 3]>>,
}

impl ShapeDef {
    /// The first type-specific field that is set but not in `allowed`.
    pub fn stray_field(&self, allowed: &[&str]) -> Option<&'static str> {
        [
            ("size", self.size.is_some()),
            ("radius", self.radius.is_some()),
            ("length", self.length.is_some()),
            ("normal", self.normal.is_some()),
            ("points", self.points.is_some()),
            ("heights", self.heights.is_some()),
            ("steps", self.steps.is_some()),
            ("rise", self.rise.is_some()),
            ("run", self.run.is_some()),
            ("amplitude", self.amplitude.is_some()),
            ("wavelength", self.wavelength.is_some()),
            ("cells", self.cells.is_some()),
            ("vertices", self.vertices.is_some()),
            ("triangles", self.triangles.is_some()),
        ]
        .into_iter()
        .find(|(f, set)| *set && !allowed.contains(f))
        .map(|(f, _)| f)
    }
}

/// `[[joint]]` (also inside `[[repeat]]`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JointDef {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub a: String,
    pub b: Option<String>,
    pub anchor: [f64; 3],
    pub axis: Option<[f64; 3]>,
    pub axis2: Option<[f64; 3]>,
    pub limits: Option<[f64; 2]>,
    pub motor: Option<MotorDef>,
    pub compliance: Option<f64>,
    pub stabilization: Option<f64>,
    #[serde(default)]
    pub collide_connected: bool,
    pub enabled: Option<bool>,
    /// In a repeat: first instance that has this joint (default 0).
    pub from: Option<usize>,
}

/// A joint's initial motor.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MotorDef {
    pub speed: Option<f64>,
    pub target: Option<f64>,
    pub max_speed: Option<f64>,
    pub max_force: f64,
    pub gain: Option<f64>,
}

/// `[[coupling]]`: gear or differential between joints.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CouplingDef {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub joints: Vec<String>,
    pub ratio: f64,
    pub max_torque: Option<f64>,
    pub compliance: Option<f64>,
}

/// `[[spring]]`: a linear spring–damper between two world points at load time.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SpringDef {
    pub name: String,
    pub a: String,
    pub anchor_a: [f64; 3],
    pub b: Option<String>,
    pub anchor_b: [f64; 3],
    pub rest_length: Option<f64>,
    pub stiffness: f64,
    #[serde(default)]
    pub damping: f64,
}

/// `[[cable]]`: a steel wire rope of capsule segments on ball joints (`dynamics/chain.rs`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CableDef {
    pub name: String,
    pub start: [f64; 3],
    pub direction: [f64; 3],
    pub length: f64,
    pub segments: usize,
    pub diameter: f64,
    pub mass: Option<f64>,
    pub a: Option<String>,
    pub b: Option<String>,
    pub sag: Option<f64>,
    pub drum: Option<String>,
    pub drum_radius: Option<f64>,
    pub compliance: Option<f64>,
    pub damping: Option<[f64; 2]>,
}

/// `[[buoyancy]]`: a box hull floating in water (`dynamics/buoyancy.rs`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BuoyancyDef {
    pub name: String,
    pub body: String,
    pub size: [f64; 3],
    #[serde(default)]
    pub centre: [f64; 3],
    pub grid: [usize; 2],
    #[serde(default)]
    pub level: f64,
    pub density: Option<f64>,
    #[serde(default)]
    pub linear_drag: f64,
    #[serde(default)]
    pub quadratic_drag: f64,
    pub wave: Option<WaveDef>,
}

/// A buoyancy's prescribed wave of the water level.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct WaveDef {
    pub amplitude: f64,
    pub period: f64,
    #[serde(default)]
    pub phase: f64,
}

/// `[[repeat]]`: bodies, joints and springs written once, instantiated `count` times.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RepeatDef {
    pub count: Option<usize>,
    pub step: Option<[f64; 3]>,
    pub offsets: Option<Vec<[f64; 3]>>,
    #[serde(default)]
    pub body: Vec<Spanned<BodyDef>>,
    #[serde(default)]
    pub joint: Vec<Spanned<JointDef>>,
    #[serde(default)]
    pub spring: Vec<Spanned<SpringDef>>,
}

/// `[[actuator]]`: a named input.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ActuatorDef {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: String,
    #[serde(default)]
    pub joints: Vec<String>,
    pub coupling: Option<String>,
    #[serde(default, deserialize_with = "one_or_many")]
    pub scale: Option<Vec<f64>>,
    pub axis: Option<String>,
    pub max_force: f64,
    pub max_speed: Option<f64>,
    pub range: Option<[f64; 2]>,
    pub neutral: Option<f64>,
    pub initial: Option<f64>,
    pub rate: Option<f64>,
    #[serde(default)]
    pub winch: bool,
}

/// `scale = 2.0` or `scale = [2.0, -2.0]` (README: one number or one per joint).
fn one_or_many<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Vec<f64>>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum OneOrMany {
        One(f64),
        Many(Vec<f64>),
    }
    Ok(Some(match OneOrMany::deserialize(d)? {
        OneOrMany::One(x) => vec![x],
        OneOrMany::Many(v) => v,
    }))
}

/// `[joystick]`: the default mapping of a gamepad to actuators.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JoystickDef {
    #[serde(default)]
    pub axis: Vec<Spanned<JoyAxisDef>>,
    #[serde(default)]
    pub button: Vec<Spanned<JoyButtonDef>>,
}

/// `[[joystick.axis]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JoyAxisDef {
    pub index: usize,
    pub actuator: String,
    pub scale: Option<f64>,
    pub deadzone: Option<f64>,
    pub mode: Option<String>,
}

/// `[[joystick.button]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JoyButtonDef {
    pub index: usize,
    pub actuator: Option<String>,
    pub value: Option<f64>,
    pub event: Option<String>,
    pub joint: Option<String>,
}

/// `[[script]]`: a timed entry of the operator timeline.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ScriptDef {
    pub t: f64,
    #[serde(default)]
    pub set: BTreeMap<String, f64>,
    pub ramp: Option<f64>,
    pub profile: Option<String>,
    pub event: Option<String>,
    pub joint: Option<String>,
}

/// `[[sensor]]`: a signal computed from the solved impulses every step.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SensorDef {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub joint: Option<String>,
    pub cable: Option<String>,
    pub bodies: Option<Vec<String>>,
    /// Bodies left out of `bodies = ["*"]`.
    pub exclude: Option<Vec<String>>,
    pub with: Option<Vec<String>>,
    pub touch: Option<f64>,
}

/// `[[event]]`: a threshold on a sensor channel.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct EventDef {
    pub name: String,
    pub channel: String,
    pub above: Option<f64>,
    pub below: Option<f64>,
    pub hysteresis: Option<f64>,
    pub hold: Option<f64>,
}

/// `[[fault]]`: a scripted fault.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FaultDef {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub joint: Option<String>,
    pub actuator: Option<String>,
    pub sensor: Option<String>,
    pub t: Option<f64>,
    pub tension: Option<f64>,
    pub to: Option<f64>,
    pub ramp: Option<f64>,
}
