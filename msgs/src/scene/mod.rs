//! Scene description (kind `0x0102`, JSON): what a renderer or an operator console needs to know
//! about a world — bodies with their collision shapes, the joint tree, the actuators and the
//! default joystick mapping, and (optional) the joints' frames and the sensors. Served by the
//! `scene` queryable.

mod error;
mod types;
mod validate;

pub use error::SceneError;
pub use types::{
    ActuatorInfo, ActuatorKind, BodyInfo, BodyKind, Collider, HeightData, JointFrame, JointInfo, JointKind,
    JoystickBinding, JoystickInput, MAX_BINDINGS, MAX_COLLIDERS_PER_BODY, MAX_HEIGHTFIELD_DIM,
    MAX_HEIGHTFIELD_SAMPLES, MAX_HULL_VERTICES, MAX_MESH_TRIANGLES, MAX_MESH_VERTICES, MAX_NAME_LEN,
    MAX_REFERENCE_LEN, MAX_SCENE_ACTUATORS, MAX_SCENE_BODIES, MAX_SCENE_JOINTS, MAX_SCENE_SENSORS, MeshData,
    SceneDescription, SensorInfo, Shape,
};
