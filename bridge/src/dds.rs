//! The DDS side: a participant on a domain, optionally confined to some local interfaces, and the
//! QoS of every topic (as RViz and the tf2 libraries expect them).
//!
//! **Discovery.** RustDDS announces itself (SPDP) to the multicast group `239.255.0.1` on every
//! multicast-capable interface *and*, by unicast, to the well-known discovery ports of the first
//! participants on `127.0.0.1`, so two participants on one host find each other even when the
//! loopback interface has no multicast (the Linux default for `lo`). With
//! [`BridgeConfig::dds_interfaces`](crate::BridgeConfig::dds_interfaces) = `[127.0.0.1]` only the
//! loopback address is advertised and no interface is used for multicast: everything stays on
//! this host (the tests run so). Sockets still bind `0.0.0.0` (RustDDS has no option to bind
//! one address), so a participant elsewhere on the same domain could still send to them: pick an
//! unused domain id for isolation.

use std::net::IpAddr;
use std::time::Duration;

use anyhow::{Context as _, anyhow};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{Context, MessageTypeName, Name, Node, NodeName, NodeOptions, QosProfile};

use crate::ros_msgs::RosType;

/// A ROS context on `domain_id`, using only the local interfaces in `interfaces` (empty: all).
pub fn context(domain_id: u16, interfaces: &[IpAddr]) -> anyhow::Result<Context> {
    let mut b = DomainParticipantBuilder::new(domain_id);
    if !interfaces.is_empty() {
        b = b.with_only_networks(interfaces.iter().copied());
    }
    let dp = b.build().map_err(|e| anyhow!("DDS participant on domain {domain_id}: {e:?}"))?;
    Context::from_domain_participant(dp).map_err(|e| anyhow!("ROS context: {e:?}"))
}

/// A node without rosout and parameter services (the bridge has neither logs nor parameters to
/// offer over ROS).
pub fn node(context: &Context, name: &str) -> anyhow::Result<Node> {
    let name = NodeName::new("/", name).map_err(|e| anyhow!("node name {name:?}: {e:?}"))?;
    context
        .new_node(name, NodeOptions::new().enable_rosout(false).start_parameter_services(false))
        .map_err(|e| anyhow!("ROS node: {e:?}"))
}

/// A topic of type `M` named `name` (absolute, e.g. `/pivotsim/pose_array`).
pub fn topic<M: RosType>(
    node: &mut Node,
    name: &str,
    qos: &QosProfile,
) -> anyhow::Result<ros2_client::dds::rustdds::Topic> {
    let n = Name::parse(name).map_err(|e| anyhow!("topic name {name:?}: {e:?}"))?;
    node.create_topic(&n, MessageTypeName::new(M::PACKAGE, M::NAME), qos)
        .map_err(|e| anyhow!("{e:?}"))
        .with_context(|| format!("topic {name}"))
}

/// QoS of the topics.
pub mod qos {
    use super::*;

    /// Streams at the step rate (`/tf`, `/pivotsim/pose_array`, `/clock`): reliable (tf2 listeners and
    /// RViz subscribe reliably; best-effort subscribers match too), volatile, keep the last 100
    /// (tf2's broadcaster depth); a full send window drops the message instead of waiting, so a
    /// stuck subscriber never slows the bridge.
    pub fn stream() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Fail)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 100 })
    }

    /// Latched state (`/tf_static`, `/pivotsim/markers`): reliable, transient-local, keep the last
    /// one, so that a late subscriber (RViz started after the bridge) gets it at once.
    pub fn latched() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Wait(Duration::from_millis(20)))
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 1 })
    }

    /// Signals, wrenches and contact arrows (per signals frame, at the step rate): reliable,
    /// volatile, keep the last 10 (a contact array can be large), never waiting.
    pub fn signals() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Fail)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 10 })
    }

    /// `/rosout` (the events): reliable, transient-local (as ROS 2's own rosout publishers, so
    /// both volatile and transient-local subscribers such as rqt_console match), keep the last
    /// 100, never waiting.
    pub fn rosout() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Fail)
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 100 })
    }

    /// Diagnostics: reliable, volatile, keep the last 10, never waiting.
    pub fn diagnostics() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Fail)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 10 })
    }

    /// `/joy` subscription: best-effort (matches reliable and best-effort publishers alike; the
    /// joy driver repeats its state, and the deadman covers losses), keep the last 10.
    pub fn joy() -> QosProfile {
        QosProfile::subscription_default().history(History::KeepLast { depth: 10 })
    }
}
