//! iceoryx2 for pivotsim: a node per process (signals left to the process), and a world's byte
//! services (payload `[u8]`, one frame per sample) opened with the server's settings — safe
//! overflow and a subscriber buffer of [`msgs::IOX_SUBSCRIBER_BUFFER`] — so that whichever side
//! creates a service first, the other opens it. A service created by someone else with other
//! settings is opened as it is.
//!
//! The world's control requests travel on a request-response service of the same name as the
//! Zenoh queryable, `pivotsim/<world>/control` ([`control_service_name`]): request and response
//! payloads `[u8]`, one control request frame per request and one control reply frame per
//! response, the bytes of `msgs/README.md` (the same as on Zenoh).

use iceoryx2::prelude::*;
use pivotsim_msgs as msgs;

/// A publish-subscribe service of byte frames.
pub type ByteService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, [u8], ()>;

/// A request-response service of byte frames (the world's `control`).
pub type ControlService =
    iceoryx2::service::port_factory::request_response::PortFactory<ipc::Service, [u8], (), [u8], ()>;

/// Largest control request frame (header and the JSON payload's bound, `msgs/README.md`).
pub const CONTROL_REQUEST_BYTES: usize = msgs::HEADER_LEN + 4096;
/// Largest control reply frame.
pub const CONTROL_REPLY_BYTES: usize = msgs::HEADER_LEN + 16384;
/// Requests one client may have under way at once on the control service (a lockstep controller
/// needs one; the rest is room for a console beside it).
pub const CONTROL_REQUESTS_PER_CLIENT: usize = 4;
/// Clients the control service admits at once.
pub const CONTROL_CLIENTS: usize = 8;

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

/// The request-response service of a world's control requests: `pivotsim/<world>/control`, the
/// Zenoh queryable's key.
pub fn control_service_name(world: &msgs::WorldName) -> String {
    world.key(msgs::Topic::Control)
}

/// Opens or creates the control service `name` with the server's settings: at most
/// [`CONTROL_CLIENTS`] clients with [`CONTROL_REQUESTS_PER_CLIENT`] requests under way each, no
/// fire-and-forget requests (every request is answered). A service created by someone else with
/// other settings is opened as it is.
pub fn open_control_service(node: &Node<ipc::Service>, name: &str) -> Result<ControlService, IoxError> {
    let sn: ServiceName = name.try_into().map_err(|e| error(format!("service name {name}"))(&e))?;
    let created = node
        .service_builder(&sn)
        .request_response::<[u8], [u8]>()
        .max_clients(CONTROL_CLIENTS)
        .max_active_requests_per_client(CONTROL_REQUESTS_PER_CLIENT)
        .enable_fire_and_forget_requests(false)
        .open_or_create();
    match created {
        Ok(s) => Ok(s),
        Err(e) => {
            tracing::warn!("iceoryx2: {name}: {e:?}; opening the existing service with its own settings");
            node.service_builder(&sn)
                .request_response::<[u8], [u8]>()
                .open()
                .map_err(|e| error(format!("cannot open service {name}"))(&e))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_frame_bounds_are_the_specs() {
        let max = |k: msgs::Kind| msgs::HEADER_LEN + k.max_payload_len();
        assert_eq!(CONTROL_REQUEST_BYTES, max(msgs::Kind::ControlRequest));
        assert_eq!(CONTROL_REPLY_BYTES, max(msgs::Kind::ControlReply));
    }

    #[test]
    fn the_control_service_is_the_queryables_key() {
        let w = msgs::WorldName::new("bay1").unwrap();
        assert_eq!(control_service_name(&w), "pivotsim/bay1/control");
    }
}
