//! iceoryx2 transport for same-host subscribers: the same frames as on Zenoh, zero-copy through
//! shared memory. Services (payload `[u8]`, one frame per sample):
//!
//! | service | direction | frames |
//! |---|---|---|
//! | `pivotsim/<world>/poses` | out | pose frames |
//! | `pivotsim/<world>/stats` | out | stats frames |
//! | `pivotsim/<world>/signals` | out | signals frames |
//! | `pivotsim/<world>/events` | out | events frames (at the steps that have events) |
//! | `pivotsim/<world>/cmd` | in | any input frame (its kind decides) |
//! | `pivotsim/<world>/control` | request → response | control request frame → control reply frame (request-response) |
//!
//! **Control.** The loop owns the transport and polls it ([`Transport::poll`]): each poll hands
//! the inputs received so far to the inbox, then the control requests (so an input sent before a
//! request reaches the loop before it). A request's `ActiveRequest` stays here, under a token; the
//! reply closure the loop calls sends the reply bytes with that token through a channel, and the
//! next [`Transport::poll`] or [`Transport::flush`] sends them as the request's one response and
//! drops the request (which ends the client's pending response). The loop polls right after a
//! lockstep request's last step, so the reply leaves as soon as it exists. Bounded: at most
//! [`MAX_PENDING_CONTROL`] requests are held (more are answered `busy` at once); a request whose
//! client went away (its pending response dropped, or the process died) is dropped at the next
//! poll, and its reply, when the loop produces it, finds nobody and is discarded.
//!
//! **Controllers.** A lockstep controller on this host names its iceoryx2 node with its controller
//! token, `pivotsim/<world>/controller/<id>` (the Zenoh liveliness key). Every
//! [`CONTROLLER_SCAN`] the transport lists this host's nodes (`ControllerWatch`): a node with
//! such a name that appears is a controller that joined, one that is gone — it exited, or its
//! process died (iceoryx2 tells a dead node by its released monitoring lock; the scan also removes
//! the dead node's stale resources) — a controller lost; both reach the loop as
//! [`Inbound::Controller`].
//!
//! The server's publishers discard a sample for a subscriber whose buffer is full (a stalled
//! subscriber loses frames, the loop never waits); safe overflow keeps the newest frames. On
//! start, the resources of dead nodes (a server or client killed with SIGKILL) are removed; on
//! drop (Ctrl-C, end of run) the node releases everything it created. Subscribers and input
//! publishers open the services with default settings (`open_or_create`).

use std::collections::BTreeSet;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::time::{Duration, Instant};

use iceoryx2::active_request::ActiveRequest;
use iceoryx2::node::{NodeDetails, NodeView};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use pivotsim_link::iox as link;
use pivotsim_msgs as msgs;
use tracing::{info, warn};

use super::config::ServeError;
use super::transport::{ErrorThrottle, Frames, INBOX_CAPACITY, Inbound, InboxSender, Transport};

/// Bytes a published frame may take before the publisher reallocates (a pose frame of 500 bodies).
pub const INITIAL_FRAME_BYTES: usize = 64 * 1024;
/// Inputs drained per loop iteration.
const MAX_INPUTS_PER_POLL: usize = 256;
/// Control requests received and not yet answered that the transport holds; beyond them a new
/// request is answered `busy` at once (the service itself admits `CONTROL_CLIENTS ×
/// CONTROL_REQUESTS_PER_CLIENT` = 32).
pub const MAX_PENDING_CONTROL: usize = 32;
/// Control requests received per poll.
const MAX_CONTROL_PER_POLL: usize = 16;
/// How often the transport lists this host's nodes for lockstep controllers (a killed controller
/// is seen within this, well inside the 1 s the rig needs).
pub const CONTROLLER_SCAN: Duration = Duration::from_millis(200);

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
type ControlServer = Server<ipc::Service, [u8], (), [u8], ()>;
type ControlRequest = ActiveRequest<ipc::Service, [u8], (), [u8], ()>;

/// The `control` service's server port and the requests it holds until the loop answers them.
struct Control {
    server: ControlServer,
    /// Requests under way, by token.
    pending: Vec<(u64, ControlRequest)>,
    next_token: u64,
    /// Reply closures send `(token, reply)` here; [`Control::send_replies`] takes them.
    replies_tx: SyncSender<(u64, Vec<u8>)>,
    replies: Receiver<(u64, Vec<u8>)>,
    throttle: ErrorThrottle,
    _service: link::ControlService,
}

impl Control {
    fn open(node: &Node<ipc::Service>, world: &msgs::WorldName) -> Result<Control, ServeError> {
        let service = link::open_control_service(node, &link::control_service_name(world)).map_err(err)?;
        let server = service
            .server_builder()
            .initial_max_slice_len(link::CONTROL_REPLY_BYTES)
            // A client that does not take its response never blocks the loop.
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .create()
            .map_err(|e| err(format!("control server: {e:?}")))?;
        // Every closure the loop may still hold: the inbox's and the held requests'.
        let (replies_tx, replies) = sync_channel(INBOX_CAPACITY + MAX_PENDING_CONTROL);
        Ok(Control {
            server,
            pending: Vec::with_capacity(MAX_PENDING_CONTROL),
            next_token: 0,
            replies_tx,
            replies,
            throttle: ErrorThrottle::default(),
            _service: service,
        })
    }

    /// Sends the replies the loop produced, each as its request's one response, and drops the
    /// requests (ending the clients' pending responses); replies to requests dropped meanwhile go
    /// nowhere.
    fn send_replies(&mut self) {
        while let Ok((token, bytes)) = self.replies.try_recv() {
            if let Some(i) = self.pending.iter().position(|(t, _)| *t == token) {
                let (_, request) = self.pending.swap_remove(i);
                if let Err(e) = respond(&request, &bytes) {
                    self.throttle.fail("iceoryx2 control reply", &e);
                }
            }
        }
    }

    /// Drops requests whose client went away, then hands new requests to the loop.
    fn poll(&mut self, inbox: &InboxSender) {
        self.send_replies();
        self.pending.retain(|(_, r)| r.is_connected());
        for _ in 0..MAX_CONTROL_PER_POLL {
            let request = match self.server.receive() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(e) => {
                    self.throttle.fail("iceoryx2 control", &format!("{e:?}"));
                    break;
                }
            };
            let bytes = request.payload().to_vec();
            if self.pending.len() >= MAX_PENDING_CONTROL {
                let id = msgs::ControlRequest::peek_id(&bytes).unwrap_or(0);
                let reply = msgs::ControlReply::error(
                    id,
                    msgs::ControlErrorCode::Busy,
                    "too many control requests under way",
                );
                let mut buf = Vec::new();
                if reply.encode(&mut buf).is_ok()
                    && let Err(e) = respond(&request, &buf)
                {
                    self.throttle.fail("iceoryx2 control reply", &e);
                }
                continue;
            }
            let token = self.next_token;
            self.next_token = self.next_token.wrapping_add(1);
            self.pending.push((token, request));
            let tx = self.replies_tx.clone();
            // A full inbox answers `busy` through the closure at once: sent below.
            inbox.offer(Inbound::Control {
                bytes,
                reply: Box::new(move |r| match tx.try_send((token, r)) {
                    Ok(()) | Err(TrySendError::Disconnected(_)) => {}
                    Err(TrySendError::Full(_)) => {
                        warn!("iceoryx2: control reply dropped (reply channel full)")
                    }
                }),
            });
        }
        self.send_replies();
    }
}

/// The lockstep controllers of one world on this host: iceoryx2 nodes named
/// `pivotsim/<world>/controller/<id>`.
struct ControllerWatch {
    /// `pivotsim/<world>/controller/`.
    prefix: String,
    present: BTreeSet<String>,
    seen: BTreeSet<String>,
    next: Instant,
    throttle: ErrorThrottle,
}

impl ControllerWatch {
    fn new(world: &msgs::WorldName) -> ControllerWatch {
        let any = world.controller_tokens();
        ControllerWatch {
            prefix: any.trim_end_matches('*').to_string(),
            present: BTreeSet::new(),
            seen: BTreeSet::new(),
            next: Instant::now(),
            throttle: ErrorThrottle::default(),
        }
    }

    /// At most every [`CONTROLLER_SCAN`]: lists the nodes, cleans dead controllers' resources and
    /// tells the loop which controllers joined and which went away.
    fn poll(&mut self, inbox: &InboxSender) {
        let now = Instant::now();
        if now < self.next {
            return;
        }
        self.next = now + CONTROLLER_SCAN;
        self.seen.clear();
        let (prefix, seen) = (&self.prefix, &mut self.seen);
        let id_of = |details: &Option<NodeDetails>| {
            details.as_ref().and_then(|d| d.name().as_str().strip_prefix(prefix.as_str()).map(String::from))
        };
        let listed = Node::<ipc::Service>::list(Config::global_config(), |state| {
            match state {
                NodeState::Alive(view) => {
                    if let Some(id) = id_of(view.details()) {
                        seen.insert(id);
                    }
                }
                NodeState::Dead(view) => {
                    if id_of(view.details()).is_some()
                        && let Err(e) = view.try_remove_stale_resources()
                    {
                        warn!("iceoryx2: cannot clean a dead controller's resources: {e:?}");
                    }
                }
                NodeState::Inaccessible(_) | NodeState::Undefined(_) => {}
            }
            CallbackProgression::Continue
        });
        if let Err(e) = listed {
            // Cannot tell: keep the controllers known, try again at the next scan.
            self.throttle.fail("iceoryx2 node list", &format!("{e:?}"));
            return;
        }
        for id in self.present.difference(&self.seen) {
            inbox.offer(Inbound::Controller { id: id.clone(), present: false });
        }
        for id in self.seen.difference(&self.present) {
            inbox.offer(Inbound::Controller { id: id.clone(), present: true });
        }
        std::mem::swap(&mut self.present, &mut self.seen);
    }
}

/// Sends `bytes` as the response to `request`.
fn respond(request: &ControlRequest, bytes: &[u8]) -> Result<(), String> {
    let response = request.loan_slice_uninit(bytes.len()).map_err(|e| format!("{e:?}"))?;
    response.write_from_slice(bytes).send().map_err(|e| format!("{e:?}"))
}

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
    control: Control,
    controllers: ControllerWatch,
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
        let control = Control::open(&node, world)?;
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
            control,
            controllers: ControllerWatch::new(world),
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
        // After the inputs: an input sent before a request reaches the loop first.
        self.control.poll(inbox);
        self.controllers.poll(inbox);
    }

    fn flush(&mut self) {
        self.control.send_replies();
    }

    fn polled(&self) -> bool {
        true
    }

    fn status(&mut self) -> String {
        format!("iceoryx2: {} subscriber(s)", self.poses_service.dynamic_config().number_of_subscribers())
    }

    fn describe(&self) -> String {
        format!(
            "iceoryx2 (same host, shared memory): services {}/{{poses, stats, signals, events, cmd}}, request-response {}/control",
            self.prefix, self.prefix
        )
    }
}
