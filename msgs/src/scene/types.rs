//! The scene description's types, bounds, frame encoding and look-ups.
//!
//! Units are SI, frames right-handed with z up. A body's colliders are placed in the body frame
//! whose world pose the pose frames carry (`position`, unit quaternion `orientation` as
//! `[x, y, z, w]`). Capsules and cylinders lie along their local z axis; a heightfield is a grid
//! over local x (columns) and y (rows), centred on the origin, heights along z.

use crate::codes::ActuatorMode;
use crate::header::{DecodeError, Kind};
use crate::input::{InputCommand, InputError};
use crate::json;

use super::error::SceneError;

/// Most bodies.
pub const MAX_SCENE_BODIES: usize = 65_535;
/// Most colliders on one body.
pub const MAX_COLLIDERS_PER_BODY: usize = 64;
/// Most joints.
pub const MAX_SCENE_JOINTS: usize = 65_535;
/// Most actuators.
pub const MAX_SCENE_ACTUATORS: usize = 1024;
/// Most joystick bindings (one per axis and button).
pub const MAX_BINDINGS: usize = 96;
/// Longest body or joint name, in bytes.
pub const MAX_NAME_LEN: usize = 64;
/// Longest mesh or heightfield reference, in bytes.
pub const MAX_REFERENCE_LEN: usize = 1024;
/// Most vertices of a convex hull.
pub const MAX_HULL_VERTICES: usize = 4096;
/// Most rows, and most columns, of a heightfield.
pub const MAX_HEIGHTFIELD_DIM: u32 = 4096;
/// Most inline heightfield samples.
pub const MAX_HEIGHTFIELD_SAMPLES: usize = 262_144;
/// Most inline triangle-mesh vertices.
pub const MAX_MESH_VERTICES: usize = 65_536;
/// Most inline triangle-mesh triangles.
pub const MAX_MESH_TRIANGLES: usize = 131_072;
/// Most sensors (a signals frame has at most 4096 channels).
pub const MAX_SCENE_SENSORS: usize = 4096;

/// Everything a renderer needs about a world.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDescription {
    /// World name (the `<world>` of the keys).
    pub world: String,
    /// Scene name or path (1..=256 bytes, no control characters).
    pub scene: String,
    /// Step size (s), > 0.
    pub timestep: f64,
    /// Gravity (m/s²).
    pub gravity: [f64; 3],
    /// Bodies; ids and names unique.
    pub bodies: Vec<BodyInfo>,
    /// Joints; names unique.
    pub joints: Vec<JointInfo>,
    /// Actuators; names unique.
    pub actuators: Vec<ActuatorInfo>,
    /// Default joystick mapping.
    pub joystick: Vec<JoystickBinding>,
    /// Sensors (the scene's `[[sensor]]`s, in the order of their channels in the signals frames);
    /// names unique. Optional: absent (and not written) when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<SensorInfo>,
}

/// How a body moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BodyKind {
    /// Moved by forces and constraints.
    #[default]
    Dynamic,
    /// Scripted velocity.
    Kinematic,
    /// Never moves.
    Static,
}

/// One rigid body.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyInfo {
    /// Id used by pose frames and joints.
    pub id: u32,
    /// Name (1..=64 bytes, no control characters).
    pub name: String,
    /// How it moves.
    pub kind: BodyKind,
    /// Mass (kg): > 0 for dynamic bodies, ≥ 0 (ignored) otherwise.
    pub mass: f64,
    /// Collision shapes in the body frame.
    pub colliders: Vec<Collider>,
    /// Shapes drawn but not collided, in the body frame: a `[[cable]]`'s segment capsules (its
    /// segments do not collide). Absent (and not written) when empty. A renderer draws
    /// [`BodyInfo::shapes`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub visuals: Vec<Collider>,
}

impl BodyInfo {
    /// Everything to draw: the colliders, then the visual-only shapes.
    pub fn shapes(&self) -> impl Iterator<Item = &Collider> {
        self.colliders.iter().chain(&self.visuals)
    }
}

/// A shape placed in its body's frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Collider {
    /// The shape.
    pub shape: Shape,
    /// Offset in the body frame (m).
    pub position: [f64; 3],
    /// Rotation into the body frame, unit quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

/// Collision (and render) geometry. Every length is > 0 (m).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// Sphere.
    Ball {
        /// Radius.
        radius: f64,
    },
    /// Box centred on the origin.
    Box {
        /// Half extents along x, y, z.
        half_extents: [f64; 3],
    },
    /// Capsule along local z: a cylinder of `2 · half_height` plus two hemispheres.
    Capsule {
        /// Radius.
        radius: f64,
        /// Half the length of the cylindrical part.
        half_height: f64,
    },
    /// Cylinder along local z.
    Cylinder {
        /// Radius.
        radius: f64,
        /// Half the length.
        half_height: f64,
    },
    /// Convex hull of 4..=4096 points.
    ConvexHull {
        /// Points of the hull (m).
        vertices: Vec<[f64; 3]>,
    },
    /// Grid of heights over local x (columns) and y (rows), centred on the origin.
    Heightfield {
        /// Rows (along y), 2..=4096.
        rows: u32,
        /// Columns (along x), 2..=4096.
        cols: u32,
        /// Size of the grid along x and y (m), > 0.
        extent: [f64; 2],
        /// Heights, row-major (`heights[r · cols + c]`), or a reference.
        heights: HeightData,
    },
    /// Triangle mesh.
    Trimesh {
        /// Vertices and triangles, or a reference.
        mesh: MeshData,
    },
}

/// Heightfield samples: inline (`rows · cols ≤ 262 144` finite values) or a reference.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum HeightData {
    /// `{"inline": [h, …]}`.
    Inline(Vec<f64>),
    /// `{"reference": "path-or-uri"}` resolved by the renderer (1..=1024 bytes).
    Reference(String),
}

/// Triangle-mesh data: inline (≤ 65 536 vertices, 1..=131 072 triangles) or a reference.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum MeshData {
    /// `{"inline": {"vertices": [[x, y, z], …], "triangles": [[i, j, k], …]}}`, counter-clockwise
    /// seen from outside; indices into `vertices`.
    Inline {
        /// Vertices (m).
        vertices: Vec<[f64; 3]>,
        /// Vertex indices.
        triangles: Vec<[u32; 3]>,
    },
    /// `{"reference": "path-or-uri"}` resolved by the renderer (1..=1024 bytes).
    Reference(String),
}

/// Joint types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointKind {
    /// All six relative degrees of freedom locked.
    Fixed,
    /// Rotation about one axis.
    Hinge,
    /// Translation along one axis.
    Prismatic,
    /// Spherical.
    Ball,
    /// Anything else (cables, gears, couplings): drawn as a link between the bodies.
    Other,
}

/// One joint of the tree.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointInfo {
    /// Name (1..=64 bytes, no control characters).
    pub name: String,
    /// Type.
    pub kind: JointKind,
    /// Parent body id; `null` attaches the child to the world.
    pub parent: Option<u32>,
    /// Child body id (≠ parent).
    pub child: u32,
    /// The joint's frame, in which the server expresses the joint's reaction (joint, cylinder and
    /// drum sensors). Optional: absent (and not written) when unknown.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<JointFrame>,
}

/// A joint frame fixed on a body: origin at the joint's anchor, x = the joint axis (for joints
/// without an axis, such as ball joints, a fixed direction the scene chose).
///
/// The pivotsim server puts it on the child (the joint's body A): the frame in which its joint
/// sensors report the joint's force and torque on the child, torque about the anchor.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointFrame {
    /// The body the frame is fixed on: the joint's `child` or `parent` id, or `null` for the world
    /// (only when `parent` is `null`).
    pub body: Option<u32>,
    /// Origin (the anchor) in the body frame (m).
    pub position: [f64; 3],
    /// Rotation joint frame → body frame, unit quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

/// One sensor of the scene (`[[sensor]]` of a scene file): its name (its channels are
/// `{name}/{channel}` in the signals frames), what it measures and the joints or bodies it reads.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SensorInfo {
    /// `fx fy fz tx ty tz`: the joint's force and torque on its frame's body, torque about the
    /// anchor, in the joint's `frame`.
    Joint {
        /// Name (channel name rules: 1..=32 bytes of `[A-Za-z0-9_.\-/]`).
        name: String,
        /// The joint (in `joints`, with a `frame`).
        joint: String,
    },
    /// `tension`: the magnitude of the joint's force (no direction).
    Tension {
        /// Name.
        name: String,
        /// The joint (in `joints`).
        joint: String,
    },
    /// `force`: the x component (along the axis) of the joint's force in its `frame`.
    Cylinder {
        /// Name.
        name: String,
        /// The joint (in `joints`, `prismatic` or `other`, with a `frame`).
        joint: String,
    },
    /// `torque`: the x component (about the axis) of the joint's torque in its `frame`.
    Drum {
        /// Name.
        name: String,
        /// The joint (in `joints`, `hinge` or `other`, with a `frame`).
        joint: String,
    },
    /// `0 … n`, `hook`, `max`: the force magnitudes at a cable's joints, top first.
    Cable {
        /// Name.
        name: String,
        /// The cable's joints, top first (in `joints`; at least one).
        joints: Vec<String>,
    },
    /// `fx fy fz` (world frame) and magnitudes and counts: the contact force on `bodies` from
    /// `with` (`null`: every other body).
    ContactSum {
        /// Name.
        name: String,
        /// The bodies measured (ids, at least one, no repeats).
        bodies: Vec<u32>,
        /// What they touch (ids, at least one, no repeats), or `null`.
        with: Option<Vec<u32>>,
    },
    /// `distance percent supports stabilizing overturning`: the tipping margin of a machine.
    Tipping {
        /// Name.
        name: String,
        /// The machine with its load (ids, at least one, no repeats).
        bodies: Vec<u32>,
        /// Contacts closer than this count as support (m, ≥ 0).
        touch: f64,
    },
    /// No channels: the contact records of the points touching `bodies`.
    Contacts {
        /// Name.
        name: String,
        /// The bodies watched (ids, at least one, no repeats).
        bodies: Vec<u32>,
    },
}

impl SensorInfo {
    /// Its name.
    pub fn name(&self) -> &str {
        match self {
            SensorInfo::Joint { name, .. }
            | SensorInfo::Tension { name, .. }
            | SensorInfo::Cylinder { name, .. }
            | SensorInfo::Drum { name, .. }
            | SensorInfo::Cable { name, .. }
            | SensorInfo::ContactSum { name, .. }
            | SensorInfo::Tipping { name, .. }
            | SensorInfo::Contacts { name, .. } => name,
        }
    }

    /// Its `kind` as on the wire (`joint`, `contact_sum`, …).
    pub fn kind_name(&self) -> &'static str {
        match self {
            SensorInfo::Joint { .. } => "joint",
            SensorInfo::Tension { .. } => "tension",
            SensorInfo::Cylinder { .. } => "cylinder",
            SensorInfo::Drum { .. } => "drum",
            SensorInfo::Cable { .. } => "cable",
            SensorInfo::ContactSum { .. } => "contact_sum",
            SensorInfo::Tipping { .. } => "tipping",
            SensorInfo::Contacts { .. } => "contacts",
        }
    }

    /// The one joint a joint, tension, cylinder or drum sensor reads.
    pub fn joint(&self) -> Option<&str> {
        match self {
            SensorInfo::Joint { joint, .. }
            | SensorInfo::Tension { joint, .. }
            | SensorInfo::Cylinder { joint, .. }
            | SensorInfo::Drum { joint, .. } => Some(joint),
            _ => None,
        }
    }
}

/// What an actuator drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActuatorKind {
    /// A motor on a joint's free axis (boom functions, wheels).
    Motor,
    /// A cable drum (takes winch commands).
    Winch,
}

/// A named actuator that inputs can address.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorInfo {
    /// Name (actuator name rules: 1..=32 bytes of `[A-Za-z0-9_.\-/]`).
    pub name: String,
    /// What it drives.
    pub kind: ActuatorKind,
    /// Joint it drives, by name (`null` when it drives no joint of the list).
    pub joint: Option<String>,
    /// Mode of its neutral command and of boom commands.
    pub mode: ActuatorMode,
    /// Range the server clamps targets to, in `mode`'s unit (`lo ≤ hi`), if any.
    pub limits: Option<[f64; 2]>,
}

/// Which joystick control a binding reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JoystickInput {
    /// `{"axis": i}`, `i < 32`.
    Axis(u8),
    /// `{"button": i}`, `i < 64`.
    Button(u8),
}

/// Default mapping of a joystick control to an actuator: an axis gives `scale · value`, a button
/// gives `scale` while pressed and 0 otherwise; several bindings of one actuator add up.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JoystickBinding {
    /// Control read.
    pub input: JoystickInput,
    /// Actuator name (must be in `actuators`).
    pub actuator: String,
    /// Mode of the resulting command.
    pub mode: ActuatorMode,
    /// Factor (finite).
    pub scale: f64,
}

impl SceneDescription {
    /// Clears `buf` and writes the frame (validated first). On error `buf` is left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), SceneError> {
        buf.clear();
        self.validate()?;
        json::encode(buf, Kind::SceneDescription, self).map_err(|len| SceneError::TooLarge { len })
    }

    /// Decodes and validates a frame.
    pub fn decode(bytes: &[u8]) -> Result<SceneDescription, DecodeError<SceneError>> {
        let s: SceneDescription = json::decode(bytes, Kind::SceneDescription)?;
        s.validate().map_err(DecodeError::Invalid)?;
        Ok(s)
    }

    /// The body with id `id`.
    pub fn body(&self, id: u32) -> Option<&BodyInfo> {
        self.bodies.iter().find(|b| b.id == id)
    }

    /// The joint named `name`.
    pub fn joint(&self, name: &str) -> Option<&JointInfo> {
        self.joints.iter().find(|j| j.name == name)
    }

    /// The frames the wrench-reading sensors (joint, cylinder, drum) report in, once per joint in
    /// sensor order: the frame's body (`None`: the world), the joint's name and its frame. Joints
    /// without a frame, or whose frame is on a body the description lacks, are left out. The ROS 2
    /// bridge's `/tf_static` and the Foxglove view's `/tf` both publish these as `joint/<joint>`.
    pub fn sensed_joint_frames(&self) -> Vec<(Option<&BodyInfo>, &str, &JointFrame)> {
        let mut out: Vec<(Option<&BodyInfo>, &str, &JointFrame)> = Vec::new();
        for s in &self.sensors {
            let (SensorInfo::Joint { joint, .. }
            | SensorInfo::Cylinder { joint, .. }
            | SensorInfo::Drum { joint, .. }) = s
            else {
                continue;
            };
            if out.iter().any(|(_, j, _)| *j == joint.as_str()) {
                continue;
            }
            let Some(f) = self.joint(joint).and_then(|j| j.frame.as_ref()) else { continue };
            let body = match f.body {
                Some(id) => match self.body(id) {
                    Some(b) => Some(b),
                    None => continue,
                },
                None => None,
            };
            out.push((body, joint, f));
        }
        out
    }

    /// The sensor named `name`.
    pub fn sensor(&self, name: &str) -> Option<&SensorInfo> {
        self.sensors.iter().find(|s| s.name() == name)
    }

    /// The actuator named `name`.
    pub fn actuator(&self, name: &str) -> Option<&ActuatorInfo> {
        self.actuators.iter().find(|a| a.name == name)
    }

    /// Checks that every actuator an input names exists (and is a winch for winch commands).
    pub fn check_input(&self, input: &InputCommand) -> Result<(), InputError> {
        let known = |name: &str| {
            self.actuator(name).ok_or_else(|| InputError::UnknownActuator { name: name.to_owned() })
        };
        match input {
            InputCommand::Joystick(_) => Ok(()),
            InputCommand::Winch(w) => match known(w.actuator.as_str())?.kind {
                ActuatorKind::Winch => Ok(()),
                ActuatorKind::Motor => {
                    Err(InputError::WrongActuatorKind { name: w.actuator.to_string(), expected: "winch" })
                }
            },
            InputCommand::Boom(b) => {
                b.targets.iter().try_for_each(|t| known(t.actuator.as_str()).map(|_| ()))
            }
            InputCommand::Actuator(a) => known(a.actuator.as_str()).map(|_| ()),
        }
    }
}
