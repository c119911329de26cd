//! `pivotsim-ros2-bridge`: the pivotsim server seen from ROS 2, with no ROS installation needed to
//! build or run it (DDS in pure Rust: `ros2-client` over RustDDS).
//!
//! The bridge is a separate process and a Zenoh client of the server: it subscribes to
//! `pivotsim/<world>/poses`, `…/stats`, `…/signals` and `…/events`, queries `…/scene` for body
//! names and shapes, and publishes `/tf`, `/tf_static`, `/pivotsim/pose_array`, `/pivotsim/markers`,
//! `/pivotsim/diagnostics` and `/clock`; the server's operator signals as a
//! `geometry_msgs/WrenchStamped` per force sensor (`/pivotsim/signals/<sensor>`), every channel
//! in one `std_msgs/Float64MultiArray` (`/pivotsim/signal_values`, names on `/pivotsim/signal_names`),
//! the contact states as coloured arrows (`/pivotsim/contact_markers`) and each event as a line on
//! `/rosout`; it subscribes to `/joy` and puts each valid `sensor_msgs/Joy` as a joystick frame of its
//! own source on `pivotsim/<world>/cmd/joystick`, where the server applies the scene's joystick
//! mapping, its validation, its rejection counters and its deadman. The step loop cannot be
//! stalled by ROS: the server only ever publishes to Zenoh with congestion control *drop*, and
//! whatever the DDS side does happens in this other process.
//!
//! | module | concept |
//! |---|---|
//! | [`ros_msgs`] | the ROS message types (serde structs in `.msg` field order) |
//! | [`convert`] | frames → ROS messages (poses, shapes, wrenches, signal arrays, contact arrows, event log lines), `Joy` → joystick frames, diagnostics |
//! | [`zenoh_link`] | the Zenoh client: latest frames, scene queries, joystick puts |
//! | [`dds`] | DDS participant (domain, interfaces) and the topics' QoS (feature `ros2`) |
//! | `bridge` | the loop: [`run`] (feature `ros2`) |
//!
//! See `bridge/README.md` for topics, QoS, loopback discovery and the tests.

pub mod convert;
#[cfg(feature = "ros2")]
pub mod dds;
pub mod ros_msgs;
pub mod zenoh_link;

#[cfg(feature = "ros2")]
mod bridge;
#[cfg(feature = "ros2")]
pub use bridge::run;

use std::net::IpAddr;
use std::path::PathBuf;
use std::time::Duration;

pub use convert::StampSource;

/// Topic names the bridge uses on the ROS side.
pub mod topics {
    /// Transforms of the moving bodies.
    pub const TF: &str = "/tf";
    /// Transforms of the static bodies.
    pub const TF_STATIC: &str = "/tf_static";
    /// Every body's pose.
    pub const POSES: &str = "/pivotsim/pose_array";
    /// The bodies' shapes.
    pub const MARKERS: &str = "/pivotsim/markers";
    /// Solver, input and bridge diagnostics.
    pub const STATS: &str = "/pivotsim/diagnostics";
    /// Simulation time.
    pub const CLOCK: &str = "/clock";
    /// Operator input (default; `--joy-topic`).
    pub const JOY: &str = "/joy";
    /// Every signal channel's value, in channel order.
    pub const SIGNALS: &str = "/pivotsim/signal_values";
    /// The channel names of `SIGNALS`, one per line (latched).
    pub const SIGNAL_NAMES: &str = "/pivotsim/signal_names";
    /// Contact states as arrows.
    pub const CONTACT_MARKERS: &str = "/pivotsim/contact_markers";
    /// Events as log lines.
    pub const ROSOUT: &str = "/rosout";
    /// Prefix of the per-sensor wrench topics ([`wrench`]), each `geometry_msgs/msg/WrenchStamped`.
    pub const WRENCH_PREFIX: &str = crate::convert::WRENCH_TOPIC_PREFIX;

    /// Every topic the bridge publishes with its ROS type (`package/msg/Name`), but the
    /// per-sensor wrenches ([`WRENCH_PREFIX`]): what a layout of this path may name. None of these
    /// names carries another type on the live view and recording path (`pivotsim-client
    /// foxglove`/`record`) but `/tf`, each path's transform tree (`client/README.md`).
    pub fn published() -> Vec<(&'static str, String)> {
        use crate::ros_msgs::*;
        fn ty<M: RosType>() -> String {
            format!("{}/msg/{}", M::PACKAGE, M::NAME)
        }
        vec![
            (TF, ty::<TFMessage>()),
            (TF_STATIC, ty::<TFMessage>()),
            (POSES, ty::<PoseArray>()),
            (MARKERS, ty::<MarkerArray>()),
            (STATS, ty::<DiagnosticArray>()),
            (CLOCK, ty::<Clock>()),
            (SIGNALS, ty::<Float64MultiArray>()),
            (SIGNAL_NAMES, ty::<RosString>()),
            (CONTACT_MARKERS, ty::<MarkerArray>()),
            (ROSOUT, ty::<Log>()),
        ]
    }

    /// The wrench topic of a force sensor named `sensor` (sanitized: [`crate::convert::topic_token`];
    /// the bridge adds `_2`, `_3`, … when two names sanitize alike).
    pub fn wrench(sensor: &str) -> String {
        format!("{}{}", crate::convert::WRENCH_TOPIC_PREFIX, crate::convert::topic_token(sensor))
    }
}

/// How the bridge runs.
#[derive(Debug, Clone)]
pub struct BridgeConfig {
    /// World name: the `<world>` of the server's keys.
    pub world: String,
    /// Zenoh endpoints of the server (peer mode, no multicast scouting).
    pub connect: Vec<String>,
    /// A Zenoh configuration file instead (routers, multi-host rigs); `connect` still applies.
    pub zenoh_config: Option<PathBuf>,
    /// DDS domain id (`ROS_DOMAIN_ID`).
    pub domain_id: u16,
    /// Local interface addresses DDS may use (empty: all; `127.0.0.1`: this host only).
    pub dds_interfaces: Vec<IpAddr>,
    /// Frame every body is placed in.
    pub world_frame: String,
    /// Clock of the stamps.
    pub stamp: StampSource,
    /// Topic of the operator input.
    pub joy_topic: String,
    /// Node name.
    pub node_name: String,
    /// Period of `/pivotsim/diagnostics`.
    pub stats_period: Duration,
    /// Period at which the markers are sent again (for subscribers without transient-local
    /// durability).
    pub markers_period: Duration,
    /// Joystick source id of the forwarded frames (`None`: random).
    pub source_id: Option<u32>,
    /// Log the counters every interval (`None`: never).
    pub log_interval: Option<Duration>,
    /// Length of the contact arrows per newton of contact force (m/N).
    pub force_scale: f64,
}

impl Default for BridgeConfig {
    fn default() -> Self {
        BridgeConfig {
            world: pivotsim_msgs::DEFAULT_WORLD.into(),
            connect: vec!["tcp/127.0.0.1:7447".into()],
            zenoh_config: None,
            domain_id: 0,
            dds_interfaces: Vec::new(),
            world_frame: "world".into(),
            stamp: StampSource::Sim,
            joy_topic: topics::JOY.into(),
            node_name: "pivotsim_bridge".into(),
            stats_period: Duration::from_millis(100),
            markers_period: Duration::from_secs(1),
            source_id: None,
            log_interval: Some(Duration::from_secs(10)),
            force_scale: 0.001,
        }
    }
}

/// What the bridge did, when it stops.
#[derive(Debug, Clone, Default)]
pub struct BridgeReport {
    /// Pose frames received.
    pub pose_frames: u64,
    /// `/tf` messages published.
    pub tf_published: u64,
    /// The `/joy` counters.
    pub joy: convert::JoyCounters,
    /// Failed ROS publishes.
    pub ros_publish_failed: u64,
    /// The signals and events counters.
    pub signals: convert::SignalCounters,
    /// `WrenchStamped` messages published.
    pub wrenches_published: u64,
}
