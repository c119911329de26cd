//! iceoryx2 transport for same-host subscribers: the same frames as on Zenoh, zero-copy through
//! shared memory. Services (payload `[u8]`, one frame per sample):
//!
//! | service | direction | frames |
//! |---|---|---|
//! | `pivotsim/<world>/poses` | out | pose frames |
//! | `pivotsim/<world>/stats` | out | stats frames |
//! | `pivotsim/<world>/cmd` | in | any input frame (its kind decides) |
//!
//! The server's publishers discard a sample for a subscriber whose buffer is full (a stalled
//! subscriber loses frames, the loop never waits); safe overflow keeps the newest frames. On
//! start, the resources of dead nodes (a server or client killed with SIGKILL) are removed; on
//! drop (Ctrl-C, end of run) the node releases everything it created. Subscribers and input
//! publishers open the services with default settings (`open_or_create`).

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use pivotsim_link::iox as link;
use pivotsim_msgs as msgs;
use tracing::{info, warn};

use super::config::ServeError;
use super::transport::{ErrorThrottle, Frames, Inbound, InboxSender, Transport};

/// Bytes a published frame may take before the publisher reallocates (a pose frame of 500 bodies).
pub const INITIAL_FRAME_BYTES: usize = 64 * 1024;
/// Inputs drained per loop iteration.
const MAX_INPUTS_PER_POLL: usize = 256;

fn err(e: impl std::fmt::Display) -> ServeError {
    ServeError::Transport { transport: "iceoryx2", message: e.to_string() }
}

/// Removes the shared-memory resources of dead nodes; returns how many nodes were cleaned.
pub fn clean_dead_nodes() -> usize {
    let mut cleaned = 0;
    let r = Node::<ipc::Service>::list(Config::global_config(), |state| {
        if let NodeState::<ipc::Service>::Dead(view) = state {
            match view.try_remove_stale_resources() {
                Ok(_) => cleaned += 1,
                Err(e) => warn!("iceoryx2: cannot clean a dead node's resources: {e:?}"),
            }
        }
        CallbackProgression::Continue
    });
    if let Err(e) = r {
        warn!("iceoryx2: cannot list nodes: {e:?}");
    }
    cleaned
}

type Service = link::ByteService;

/// The server's iceoryx2 side.
pub struct IoxTransport {
    poses: Publisher<ipc::Service, [u8], ()>,
    stats: Publisher<ipc::Service, [u8], ()>,
    signals: Publisher<ipc::Service, [u8], ()>,
    events: Publisher<ipc::Service, [u8], ()>,
    inputs: Subscriber<ipc::Service, [u8], ()>,
    poses_service: Service,
    _stats_service: Service,
    _signals_service: Service,
    _events_service: Service,
    _cmd_service: Service,
    throttle: ErrorThrottle,
    prefix: String,
    // Declared last: dropped after the ports and services.
    _node: Node<ipc::Service>,
}

impl std::fmt::Debug for IoxTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IoxTransport")
    }
}

impl IoxTransport {
    /// Cleans up after dead nodes, then creates the node, services and ports of `world`.
    pub fn open(world: &msgs::WorldName) -> Result<IoxTransport, ServeError> {
        // iceoryx2 logs to stderr on its own; keep it to errors unless IOX2_LOG_LEVEL says otherwise.
        set_log_level_from_env_or(LogLevel::Error);
        let cleaned = clean_dead_nodes();
        if cleaned > 0 {
            info!("iceoryx2: removed the resources of {cleaned} dead node(s)");
        }
        let node = link::node("pivotsim-server").map_err(err)?;
        let open = |t: msgs::Topic| link::open_service(&node, &link::service_name(world, t)?);
        let poses_service = open(msgs::Topic::Poses).map_err(err)?;
        let stats_service = open(msgs::Topic::Stats).map_err(err)?;
        let signals_service = open(msgs::Topic::Signals).map_err(err)?;
        let events_service = open(msgs::Topic::Events).map_err(err)?;
        let cmd_service = open(msgs::Topic::Joystick).map_err(err)?;
        let publisher = |s: &Service| {
            s.publisher_builder()
                .initial_max_slice_len(INITIAL_FRAME_BYTES)
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .backpressure_strategy(BackpressureStrategy::DiscardData)
                .create()
                .map_err(|e| err(format!("{e:?}")))
        };
        let poses = publisher(&poses_service)?;
        // Another live server of this world on this host publishes here too: refuse, rather than
        // interleave two streams under one name (dead servers' ports were cleaned above).
        let publishers = poses_service.dynamic_config().number_of_publishers();
        if publishers > 1 {
            return Err(ServeError::WorldTaken {
                world: world.as_str().to_string(),
                transport: "iceoryx2",
                detail: format!(
                    "{} already has {} publisher(s) on this host",
                    poses_service.name(),
                    publishers - 1
                ),
            });
        }
        let stats = publisher(&stats_service)?;
        let signals = publisher(&signals_service)?;
        let events = publisher(&events_service)?;
        let inputs = cmd_service.subscriber_builder().create().map_err(|e| err(format!("{e:?}")))?;
        Ok(IoxTransport {
            poses,
            stats,
            signals,
            events,
            inputs,
            poses_service,
            _stats_service: stats_service,
            _signals_service: signals_service,
            _events_service: events_service,
            _cmd_service: cmd_service,
            throttle: ErrorThrottle::default(),
            prefix: format!("{}/{}", msgs::KEY_PREFIX, world.as_str()),
            _node: node,
        })
    }

    fn send(p: &Publisher<ipc::Service, [u8], ()>, bytes: &[u8]) -> Result<(), String> {
        let sample = p.loan_slice_uninit(bytes.len()).map_err(|e| format!("{e:?}"))?;
        let sample = sample.write_from_slice(bytes);
        sample.send().map(|_| ()).map_err(|e| format!("{e:?}"))
    }
}

impl Transport for IoxTransport {
    fn publish(&mut self, frames: Frames<'_>) {
        if let Err(e) = Self::send(&self.poses, frames.poses) {
            self.throttle.fail("iceoryx2 poses", &e);
        }
        if let Err(e) = Self::send(&self.stats, frames.stats) {
            self.throttle.fail("iceoryx2 stats", &e);
        }
        if let Err(e) = Self::send(&self.signals, frames.signals) {
            self.throttle.fail("iceoryx2 signals", &e);
        }
        if !frames.events.is_empty()
            && let Err(e) = Self::send(&self.events, frames.events)
        {
            self.throttle.fail("iceoryx2 events", &e);
        }
    }

    fn poll(&mut self, inbox: &InboxSender) {
        for _ in 0..MAX_INPUTS_PER_POLL {
            match self.inputs.receive() {
                Ok(Some(sample)) => {
                    inbox.offer(Inbound::Input { topic: None, bytes: sample.payload().to_vec() });
                }
                Ok(None) => break,
                Err(e) => {
                    self.throttle.fail("iceoryx2 inputs", &format!("{e:?}"));
                    break;
                }
            }
        }
    }

    fn polled(&self) -> bool {
        true
    }

    fn status(&mut self) -> String {
        format!("iceoryx2: {} subscriber(s)", self.poses_service.dynamic_config().number_of_subscribers())
    }

    fn describe(&self) -> String {
        format!(
            "iceoryx2 (same host, shared memory): services {}/{{poses, stats, signals, events, cmd}}",
            self.prefix
        )
    }
}
