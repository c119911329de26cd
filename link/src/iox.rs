//! iceoryx2 for pivotsim: a node per process (signals left to the process), and a world's byte
//! services (payload `[u8]`, one frame per sample) opened with the server's settings — safe
//! overflow and a subscriber buffer of [`msgs::IOX_SUBSCRIBER_BUFFER`] — so that whichever side
//! creates a service first, the other opens it. A service created by someone else with other
//! settings is opened as it is.

use iceoryx2::prelude::*;
use pivotsim_msgs as msgs;

/// A publish-subscribe service of byte frames.
pub type ByteService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, [u8], ()>;

/// An iceoryx2 call that failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("iceoryx2: {what}: {detail}")]
pub struct IoxError {
    /// What was attempted.
    pub what: String,
    /// iceoryx2's error.
    pub detail: String,
}

fn error(what: impl Into<String>) -> impl FnOnce(&dyn std::fmt::Debug) -> IoxError {
    let what = what.into();
    move |e| IoxError { what, detail: format!("{e:?}") }
}

/// A node named `name` (e.g. `pivotsim-server`); Ctrl-C stays with the process's own handler.
pub fn node(name: &str) -> Result<Node<ipc::Service>, IoxError> {
    let node_name: NodeName = name.try_into().map_err(|e| error(format!("node name {name}"))(&e))?;
    NodeBuilder::new()
        .name(&node_name)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| error("cannot create a node")(&e))
}

/// The service of `topic` in `world` ([`msgs::WorldName::iox_service`]); the queryables have
/// none.
pub fn service_name(world: &msgs::WorldName, topic: msgs::Topic) -> Result<String, IoxError> {
    world.iox_service(topic).ok_or_else(|| IoxError {
        what: format!("{} service", topic.suffix()),
        detail: "carried by Zenoh only".into(),
    })
}

/// Opens or creates the byte service `name` with the server's settings.
pub fn open_service(node: &Node<ipc::Service>, name: &str) -> Result<ByteService, IoxError> {
    let sn: ServiceName = name.try_into().map_err(|e| error(format!("service name {name}"))(&e))?;
    let created = node
        .service_builder(&sn)
        .publish_subscribe::<[u8]>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(msgs::IOX_SUBSCRIBER_BUFFER)
        .open_or_create();
    match created {
        Ok(s) => Ok(s),
        Err(e) => {
            tracing::warn!("iceoryx2: {name}: {e:?}; opening the existing service with its own settings");
            node.service_builder(&sn)
                .publish_subscribe::<[u8]>()
                .open()
                .map_err(|e| error(format!("cannot open service {name}"))(&e))
        }
    }
}
