//! What is wrong with the content of a scene description: the error of its validation
//! (`validate.rs`) and of its codec (`types.rs`).

use crate::control::ControlError;
use crate::keys::KeyError;
use crate::name::NameError;

/// What is wrong with the content of a scene description.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// Invalid world name.
    #[error("world: {0}")]
    World(#[from] KeyError),
    /// Invalid scene name or path.
    #[error("scene: {0}")]
    Scene(ControlError),
    /// NaN or ±Inf.
    #[error("{path}: non-finite value")]
    NonFinite {
        /// Where.
        path: String,
    },
    /// A length, mass or step size that must be > 0 (or ≥ 0) is not.
    #[error("{path}: {value} is out of range (must be positive)")]
    NonPositive {
        /// Where.
        path: String,
        /// The value.
        value: f64,
    },
    /// `| ‖q‖ − 1 |` above the tolerance.
    #[error("{path}: quaternion norm {norm} is not 1")]
    NonUnitQuaternion {
        /// Where.
        path: String,
        /// `‖q‖`.
        norm: f64,
    },
    /// Too many entries in a list.
    #[error("{path}: {count} entries (at most {max})")]
    TooMany {
        /// Which list.
        path: String,
        /// Entries.
        count: usize,
        /// Bound.
        max: usize,
    },
    /// Too few entries in a list (convex hull, triangle mesh).
    #[error("{path}: {count} entries (at least {min})")]
    TooFew {
        /// Which list.
        path: String,
        /// Entries.
        count: usize,
        /// Bound.
        min: usize,
    },
    /// Empty body or joint name, or empty reference.
    #[error("{path}: empty name")]
    EmptyName {
        /// Where.
        path: String,
    },
    /// Name or reference above its bound.
    #[error("{path}: {len} bytes (at most {max})")]
    NameTooLong {
        /// Where.
        path: String,
        /// Length in bytes.
        len: usize,
        /// Bound.
        max: usize,
    },
    /// A control character in a name or reference.
    #[error("{path}: control character at byte {index}")]
    NameChar {
        /// Where.
        path: String,
        /// Byte offset.
        index: usize,
    },
    /// An actuator name that breaks the actuator name rules.
    #[error("{path}: {source}")]
    ActuatorName {
        /// Where.
        path: String,
        /// What is wrong.
        source: NameError,
    },
    /// Two bodies with one id.
    #[error("body id {id} appears twice")]
    DuplicateBodyId {
        /// The id.
        id: u32,
    },
    /// Two bodies, joints or actuators with one name.
    #[error("{path}: name {name:?} appears twice")]
    DuplicateName {
        /// Where (the second one).
        path: String,
        /// The name.
        name: String,
    },
    /// A joint naming a body id that is not in `bodies`.
    #[error("{path}: no body with id {id}")]
    UnknownBody {
        /// Where.
        path: String,
        /// The id.
        id: u32,
    },
    /// A joint whose parent is its child.
    #[error("{path}: parent and child are the same body")]
    SelfJoint {
        /// Where.
        path: String,
    },
    /// An actuator naming a joint that is not in `joints`.
    #[error("{path}: no joint named {name:?}")]
    UnknownJoint {
        /// Where.
        path: String,
        /// The name.
        name: String,
    },
    /// A binding naming an actuator that is not in `actuators`.
    #[error("{path}: no actuator named {name:?}")]
    UnknownActuator {
        /// Where.
        path: String,
        /// The name.
        name: String,
    },
    /// A binding to axis ≥ 32 or button ≥ 64.
    #[error("{path}: index {index} (must be below {max})")]
    BindingIndex {
        /// Where.
        path: String,
        /// The index.
        index: u8,
        /// Bound.
        max: usize,
    },
    /// Heightfield dimensions outside 2..=4096, or inline samples ≠ rows · cols.
    #[error("{path}: {rows} × {cols} heightfield with {samples:?} samples")]
    HeightfieldSize {
        /// Where.
        path: String,
        /// Rows.
        rows: u32,
        /// Columns.
        cols: u32,
        /// Inline samples, if inline.
        samples: Option<usize>,
    },
    /// A triangle index beyond the vertex list.
    #[error("{path}: vertex index {index} (mesh has {vertices} vertices)")]
    MeshIndex {
        /// Where.
        path: String,
        /// The index.
        index: u32,
        /// Vertices.
        vertices: usize,
    },
    /// Actuator limits with `lo > hi`.
    #[error("{path}: limits [{lo}, {hi}] are reversed")]
    Limits {
        /// Where.
        path: String,
        /// Lower limit.
        lo: f64,
        /// Upper limit.
        hi: f64,
    },
    /// A joint frame on a body that is neither the joint's child nor its parent (`null`, the
    /// world, only when the parent is the world).
    #[error("{path}: body {body:?} is neither the joint's child nor its parent")]
    FrameBody {
        /// Where.
        path: String,
        /// The frame's body (`None`: the world).
        body: Option<u32>,
    },
    /// A sensor whose joint has no `frame` (joint, cylinder and drum sensors report in it).
    #[error("{path}: joint {name:?} has no frame")]
    NoJointFrame {
        /// Where.
        path: String,
        /// The joint.
        name: String,
    },
    /// A cylinder sensor on a joint that is not prismatic (or `other`), a drum sensor on one that
    /// is not a hinge (or `other`).
    #[error("{path}: a {sensor} sensor cannot read a {joint} joint")]
    SensorJointKind {
        /// Where.
        path: String,
        /// The sensor's kind.
        sensor: &'static str,
        /// The joint's kind.
        joint: &'static str,
    },
    /// A body listed twice in one sensor's body list.
    #[error("{path}: body id {id} appears twice")]
    RepeatedBody {
        /// Where.
        path: String,
        /// The id.
        id: u32,
    },
    /// A negative value where ≥ 0 is required.
    #[error("{path}: {value} is negative")]
    Negative {
        /// Where.
        path: String,
        /// The value.
        value: f64,
    },
    /// The encoded payload exceeds the 16 MiB frame (encode only).
    #[error("encoded scene of {len} bytes exceeds the maximum frame")]
    TooLarge {
        /// Payload length.
        len: usize,
    },
}
