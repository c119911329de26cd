//! The ROS 2 messages the bridge sends and receives, as plain serde structs whose field order and
//! types are those of the `.msg` definitions (ROS 2 Humble and newer): serialized with CDR by the
//! DDS layer, they are byte-compatible with `rclcpp`/`rclpy` nodes, RViz and Foxglove. Each type's
//! [`RosType`] gives its ROS package and name (the DDS type name is then
//! `<package>::msg::dds_::<Name>_`, e.g. `tf2_msgs::msg::dds_::TFMessage_`).
//!
//! This module has no DDS dependency: it builds without the `ros2` feature.

use serde::{Deserialize, Serialize};

/// A ROS message type: its package and name (`tf2_msgs`, `TFMessage`).
pub trait RosType {
    /// ROS package.
    const PACKAGE: &'static str;
    /// Message name within the package.
    const NAME: &'static str;

    /// The DDS type name, `<package>::msg::dds_::<Name>_`.
    fn dds_type_name() -> String {
        format!("{}::msg::dds_::{}_", Self::PACKAGE, Self::NAME)
    }
}

macro_rules! ros_type {
    ($t:ty, $pkg:literal, $name:literal) => {
        impl RosType for $t {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
        }
    };
}

/// `builtin_interfaces/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, `< 10⁹`.
    pub nanosec: u32,
}

impl Time {
    /// A time from seconds (rounded to the nanosecond; negative or non-finite gives 0, beyond
    /// `i32::MAX` seconds saturates).
    pub fn from_secs_f64(t: f64) -> Time {
        if !(t.is_finite() && t > 0.0) {
            return Time::default();
        }
        Time::from_nanos((t * 1e9).round().min(i64::MAX as f64) as i64)
    }

    /// A time from nanoseconds (negative gives 0).
    pub fn from_nanos(ns: i64) -> Time {
        let ns = ns.max(0);
        let sec = (ns / 1_000_000_000).min(i64::from(i32::MAX)) as i32;
        Time { sec, nanosec: (ns % 1_000_000_000) as u32 }
    }

    /// Nanoseconds since the epoch of the clock.
    pub fn as_nanos(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }
}
ros_type!(Time, "builtin_interfaces", "Time");

/// `builtin_interfaces/Duration`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds.
    pub nanosec: u32,
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Time stamp.
    pub stamp: Time,
    /// Frame of the data.
    pub frame_id: String,
}

/// `geometry_msgs/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Point {
    /// From `[x, y, z]`.
    pub fn from_array(p: [f64; 3]) -> Point {
        Point { x: p[0], y: p[1], z: p[2] }
    }
}

/// `geometry_msgs/Quaternion` (`x, y, z, w`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

impl Quaternion {
    /// From `[x, y, z, w]`.
    pub fn from_array(q: [f64; 4]) -> Quaternion {
        Quaternion { x: q[0], y: q[1], z: q[2], w: q[3] }
    }
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseArray {
    /// Stamp and frame (`world`).
    pub header: Header,
    /// Poses.
    pub poses: Vec<Pose>,
}
ros_type!(PoseArray, "geometry_msgs", "PoseArray");

/// `geometry_msgs/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`: the pose of `child_frame_id` in `header.frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// Child frame in the parent frame.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TFMessage {
    /// Transforms.
    pub transforms: Vec<TransformStamped>,
}
ros_type!(TFMessage, "tf2_msgs", "TFMessage");

/// `rosgraph_msgs/Clock`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Clock {
    /// Simulation time.
    pub clock: Time,
}
ros_type!(Clock, "rosgraph_msgs", "Clock");

/// `sensor_msgs/Joy`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Joy {
    /// Stamp.
    pub header: Header,
    /// Axes, nominally in `[-1, 1]`.
    pub axes: Vec<f32>,
    /// Buttons, 0 or 1.
    pub buttons: Vec<i32>,
}
ros_type!(Joy, "sensor_msgs", "Joy");

/// `diagnostic_msgs/KeyValue`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`DiagnosticStatus::OK`] … [`DiagnosticStatus::STALE`].
    pub level: u8,
    /// Name of the component.
    pub name: String,
    /// One line.
    pub message: String,
    /// Hardware id.
    pub hardware_id: String,
    /// Values.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// Level OK.
    pub const OK: u8 = 0;
    /// Level WARN.
    pub const WARN: u8 = 1;
    /// Level ERROR.
    pub const ERROR: u8 = 2;
    /// Level STALE.
    pub const STALE: u8 = 3;

    /// The value of `key`, if present.
    pub fn value(&self, key: &str) -> Option<&str> {
        self.values.iter().find(|kv| kv.key == key).map(|kv| kv.value.as_str())
    }
}

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp.
    pub header: Header,
    /// One status per component.
    pub status: Vec<DiagnosticStatus>,
}
ros_type!(DiagnosticArray, "diagnostic_msgs", "DiagnosticArray");

impl DiagnosticArray {
    /// The status named `name`, if present.
    pub fn get(&self, name: &str) -> Option<&DiagnosticStatus> {
        self.status.iter().find(|s| s.name == name)
    }
}

/// `std_msgs/ColorRGBA`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// Red, 0..=1.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Alpha.
    pub a: f32,
}

/// `sensor_msgs/CompressedImage` (only as the empty `texture` of a marker).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Header.
    pub header: Header,
    /// Format.
    pub format: String,
    /// Data.
    pub data: Vec<u8>,
}

/// `visualization_msgs/UVCoordinate`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// u.
    pub u: f32,
    /// v.
    pub v: f32,
}

/// `visualization_msgs/MeshFile`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MeshFile {
    /// File name.
    pub filename: String,
    /// Contents.
    pub data: Vec<u8>,
}

/// `visualization_msgs/Marker` (the Humble-and-newer layout, with texture and embedded-mesh
/// fields).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Marker {
    /// Stamp (0: the latest transform) and frame.
    pub header: Header,
    /// Namespace (the body name).
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// [`Marker::CUBE`], …
    #[serde(rename = "type")]
    pub type_: i32,
    /// [`Marker::ADD`] or [`Marker::DELETEALL`].
    pub action: i32,
    /// Pose in the header's frame.
    pub pose: Pose,
    /// Size (m).
    pub scale: Vector3,
    /// Colour.
    pub color: ColorRGBA,
    /// 0: forever.
    pub lifetime: Duration,
    /// Re-transformed into its frame every update.
    pub frame_locked: bool,
    /// Points (triangle lists, sphere lists).
    pub points: Vec<Point>,
    /// Per-point colours (unused: empty).
    pub colors: Vec<ColorRGBA>,
    /// Texture (unused).
    pub texture_resource: String,
    /// Texture (unused).
    pub texture: CompressedImage,
    /// Texture coordinates (unused).
    pub uv_coordinates: Vec<UVCoordinate>,
    /// Text (unused).
    pub text: String,
    /// Mesh URI (meshes given by reference).
    pub mesh_resource: String,
    /// Embedded mesh (unused).
    pub mesh_file: MeshFile,
    /// Use the mesh's own materials.
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// Type: arrow (with two `points`: from the first to the second).
    pub const ARROW: i32 = 0;
    /// Type: box.
    pub const CUBE: i32 = 1;
    /// Type: sphere.
    pub const SPHERE: i32 = 2;
    /// Type: cylinder along z.
    pub const CYLINDER: i32 = 3;
    /// Type: spheres at `points`.
    pub const SPHERE_LIST: i32 = 7;
    /// Type: mesh file.
    pub const MESH_RESOURCE: i32 = 10;
    /// Type: triangles, three `points` each.
    pub const TRIANGLE_LIST: i32 = 11;
    /// Action: add or modify.
    pub const ADD: i32 = 0;
    /// Action: delete every marker (of `ns`, or all when empty).
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MarkerArray {
    /// Markers.
    pub markers: Vec<Marker>,
}
ros_type!(MarkerArray, "visualization_msgs", "MarkerArray");

/// `geometry_msgs/Wrench`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Wrench {
    /// Force (N).
    pub force: Vector3,
    /// Torque (N m).
    pub torque: Vector3,
}

/// `geometry_msgs/WrenchStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WrenchStamped {
    /// Stamp and the frame the wrench is expressed in.
    pub header: Header,
    /// Force and torque.
    pub wrench: Wrench,
}
ros_type!(WrenchStamped, "geometry_msgs", "WrenchStamped");

/// `std_msgs/MultiArrayDimension`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// Label of the dimension.
    pub label: String,
    /// Elements along it.
    pub size: u32,
    /// Stride (elements) of the dimension.
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// Dimensions, outermost first.
    pub dim: Vec<MultiArrayDimension>,
    /// Padding elements at the front of `data`.
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// Layout.
    pub layout: MultiArrayLayout,
    /// Values.
    pub data: Vec<f64>,
}
ros_type!(Float64MultiArray, "std_msgs", "Float64MultiArray");

/// `std_msgs/String`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RosString {
    /// Text.
    pub data: String,
}
ros_type!(RosString, "std_msgs", "String");

/// `rcl_interfaces/Log` (what `/rosout` carries).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Log {
    /// When.
    pub stamp: Time,
    /// [`Log::DEBUG`] … [`Log::FATAL`].
    pub level: u8,
    /// Logger name.
    pub name: String,
    /// The line.
    pub msg: String,
    /// Source file (empty).
    pub file: String,
    /// Function (empty).
    pub function: String,
    /// Line (0).
    pub line: u32,
}
ros_type!(Log, "rcl_interfaces", "Log");

impl Log {
    /// Level DEBUG.
    pub const DEBUG: u8 = 10;
    /// Level INFO.
    pub const INFO: u8 = 20;
    /// Level WARN.
    pub const WARN: u8 = 30;
    /// Level ERROR.
    pub const ERROR: u8 = 40;
    /// Level FATAL.
    pub const FATAL: u8 = 50;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_type_names_follow_the_ros_convention() {
        assert_eq!(TFMessage::dds_type_name(), "tf2_msgs::msg::dds_::TFMessage_");
        assert_eq!(MarkerArray::dds_type_name(), "visualization_msgs::msg::dds_::MarkerArray_");
        assert_eq!(Clock::dds_type_name(), "rosgraph_msgs::msg::dds_::Clock_");
        assert_eq!(WrenchStamped::dds_type_name(), "geometry_msgs::msg::dds_::WrenchStamped_");
        assert_eq!(Float64MultiArray::dds_type_name(), "std_msgs::msg::dds_::Float64MultiArray_");
        assert_eq!(RosString::dds_type_name(), "std_msgs::msg::dds_::String_");
        assert_eq!(Log::dds_type_name(), "rcl_interfaces::msg::dds_::Log_");
    }

    #[test]
    fn time_conversions_round_to_the_nanosecond() {
        assert_eq!(Time::from_secs_f64(1.5), Time { sec: 1, nanosec: 500_000_000 });
        assert_eq!(Time::from_secs_f64(-1.0), Time::default());
        assert_eq!(Time::from_secs_f64(f64::NAN), Time::default());
        assert_eq!(Time::from_nanos(2_000_000_001).as_nanos(), 2_000_000_001);
        let t = 1.0 / 60.0 * 7.0;
        assert_eq!(Time::from_secs_f64(t).as_nanos(), (t * 1e9).round() as i64);
    }
}
