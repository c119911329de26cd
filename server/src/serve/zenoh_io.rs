//! Zenoh transport: a peer session (listening on `tcp/127.0.0.1:7447` by default, multicast
//! scouting off unless asked), publishers `pivotsim/<world>/poses`, `…/stats` and `…/signals`
//! (congestion control *drop*, express: a slow subscriber loses frames, it never slows the
//! loop), the events publisher `…/events` (below), one subscriber on `…/cmd/**` for every input
//! topic, and the queryables `…/scene` (the encoded description) and `…/control` (requests
//! answered by the loop thread). With access control in the Zenoh configuration, the puts its
//! rules refuse are counted too (`zenoh_refused.rs`).
//!
//! Lockstep controllers hold the liveliness token `pivotsim/<world>/controller/<id>` while they
//! run; a liveliness subscriber (with history, so controllers already there count) turns each
//! token's appearance and disappearance into [`Inbound::Controller`]. Zenoh undeclares the token
//! of a controller that exits, is killed or whose link closes (the peer's TCP connection ends);
//! one whose host vanishes without closing the link goes when the session lease expires.
//!
//! Events (thresholds raised and cleared, faults, refused faults) are not frames: each is sent
//! once, and a lost one is lost for good. With *drop*, the events frame — the fourth message of a
//! step's burst, on the same priority queue as the three frames before it — was the one Zenoh
//! threw away when its transmit task had not emptied the queue within its drop wait (seen on a
//! loaded two-core machine: a live fault that never reached the ROS bridge). So events go out on
//! their own priority ([`EVENTS_PRIORITY`], a queue of their own, empty but for them) with
//! congestion control *block*, from a thread of their own fed by a bounded channel: the loop
//! hands the frame over without waiting, a congested link delays events instead of losing them,
//! and only a channel full of [`EVENTS_BACKLOG`] undelivered frames (a link stuck for that many
//! event steps) drops one, counted and logged.

use std::sync::mpsc::{SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, RwLock};
use std::thread::JoinHandle;
use std::time::Duration;

use pivotsim_msgs as msgs;
use zenoh::Wait;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::query::Queryable;

use super::config::{ServeError, ZenohOptions};
use super::transport::{ErrorThrottle, Frames, Inbound, InboxSender, Transport};
use super::zenoh_refused::{self, RefusedPuts};

fn err(e: impl std::fmt::Display) -> ServeError {
    ServeError::Transport { transport: "zenoh", message: e.to_string() }
}

/// The Zenoh configuration of the options (`pivotsim_link::zenoh_config`: a peer on the given
/// endpoints, multicast scouting off unless asked, or the configuration file).
pub fn config(opts: &ZenohOptions) -> Result<zenoh::Config, ServeError> {
    pivotsim_link::zenoh_config::ZenohEndpoints {
        listen: opts.listen.clone(),
        connect: opts.connect.clone(),
        config_file: opts.config_file.clone(),
        multicast_scouting: opts.multicast_scouting,
    }
    .config()
    .map_err(err)
}

/// How long a starting server asks whether another one already holds its world's token.
pub const CLAIM_TIMEOUT: Duration = Duration::from_millis(500);

/// Refuses `world` when another server reachable from `session` holds its liveliness token
/// (`pivotsim/<world>/server`); otherwise declares the token, held as long as the session lives.
fn claim_world(session: &zenoh::Session, world: &msgs::WorldName) -> Result<LivelinessToken, ServeError> {
    let key = world.server_token();
    let replies = session.liveliness().get(&key).timeout(CLAIM_TIMEOUT).wait().map_err(err)?;
    let deadline = std::time::Instant::now() + CLAIM_TIMEOUT + Duration::from_millis(200);
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
        match replies.recv_timeout(left) {
            Ok(Some(reply)) => {
                if let Ok(sample) = reply.result() {
                    return Err(ServeError::WorldTaken {
                        world: world.as_str().to_string(),
                        transport: "zenoh",
                        detail: format!("a server holds {}", sample.key_expr()),
                    });
                }
            }
            // Every reply is in (or the query timed out): nobody holds the token.
            Ok(None) | Err(_) => break,
        }
    }
    session.liveliness().declare_token(key).wait().map_err(err)
}

/// The priority of the events publisher: above the frames' (`Data`), so that events have a
/// transmit queue of their own that the frames never fill.
pub const EVENTS_PRIORITY: Priority = Priority::DataHigh;

/// The priority of the journal's publishers (`applied`, `keyframes`): below the frames', so that
/// a keyframe of some hundred kilobytes never delays a pose frame; blocking, like events.
pub const JOURNAL_PRIORITY: Priority = Priority::DataLow;

/// Frames handed to the reliable thread and not yet sent before the loop drops one.
pub const EVENTS_BACKLOG: usize = 256;

/// What the reliable thread publishes: events, applied frames, keyframes (index into its
/// publishers).
#[derive(Debug, Clone, Copy)]
enum Reliable {
    Events = 0,
    Applied = 1,
    Keyframes = 2,
}

/// The thread of the publishers whose frames must not be lost (events and the journal): sends
/// every frame it is handed, in order per publisher, blocking on congestion.
struct EventsSender {
    tx: Option<SyncSender<(Reliable, Vec<u8>)>>,
    thread: Option<JoinHandle<()>>,
    throttle: ErrorThrottle,
}

impl EventsSender {
    fn spawn(publishers: [Publisher<'static>; 3]) -> Result<EventsSender, ServeError> {
        let (tx, rx) = sync_channel::<(Reliable, Vec<u8>)>(EVENTS_BACKLOG);
        let thread = std::thread::Builder::new()
            .name("zenoh-events".into())
            .spawn(move || {
                let mut throttle = ErrorThrottle::default();
                for (to, frame) in rx {
                    if let Err(e) = publishers[to as usize].put(frame).wait() {
                        throttle.fail("zenoh events/journal", &e);
                    }
                }
            })
            .map_err(err)?;
        Ok(EventsSender { tx: Some(tx), thread: Some(thread), throttle: ErrorThrottle::default() })
    }

    /// Hands a frame to the thread without waiting; a full backlog drops it (counted).
    fn send(&mut self, to: Reliable, frame: &[u8]) {
        let Some(tx) = &self.tx else { return };
        match tx.try_send((to, frame.to_vec())) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => self
                .throttle
                .fail("zenoh events", &format!("{EVENTS_BACKLOG} frames undelivered, one dropped")),
            Err(TrySendError::Disconnected(_)) => {
                self.throttle.fail("zenoh events", &"the events thread ended")
            }
        }
    }
}

impl Drop for EventsSender {
    /// Closes the channel and waits for the thread to send what it holds (a put blocks at most
    /// until Zenoh gives up on a stuck link).
    fn drop(&mut self) {
        drop(self.tx.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The server's Zenoh side.
pub struct ZenohTransport {
    // Declared first: dropped (its queued events sent) while the session is open.
    events: EventsSender,
    // The access-control count's reader (with access control only): stopped before the session.
    refused: Option<RefusedPuts>,
    session: zenoh::Session,
    poses: Publisher<'static>,
    stats: Publisher<'static>,
    signals: Publisher<'static>,
    _inputs: Subscriber<()>,
    _scene: Queryable<()>,
    _control: Queryable<()>,
    _controllers: Subscriber<()>,
    _token: LivelinessToken,
    description: Arc<RwLock<Vec<u8>>>,
    throttle: ErrorThrottle,
    listen: Vec<String>,
    connect: Vec<String>,
    prefix: String,
}

impl std::fmt::Debug for ZenohTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohTransport").field("zid", &self.session.zid()).finish()
    }
}

impl ZenohTransport {
    /// Opens the session and declares everything for `world`.
    pub fn open(
        opts: &ZenohOptions,
        world: &msgs::WorldName,
        inbox: InboxSender,
        description: &[u8],
    ) -> Result<ZenohTransport, ServeError> {
        let mut zconfig = config(opts)?;
        let acl = zenoh_refused::enable_adminspace(&mut zconfig).map_err(err)?;
        let session = zenoh::open(zconfig).wait().map_err(err)?;
        let token = claim_world(&session, world)?;
        let publisher = |topic: msgs::Topic| {
            session
                .declare_publisher(world.key(topic))
                .congestion_control(CongestionControl::Drop)
                .express(true)
                .wait()
                .map_err(err)
        };
        let poses = publisher(msgs::Topic::Poses)?;
        let stats = publisher(msgs::Topic::Stats)?;
        let signals = publisher(msgs::Topic::Signals)?;
        let reliable = |topic: msgs::Topic, priority: Priority| {
            session
                .declare_publisher(world.key(topic))
                .congestion_control(CongestionControl::Block)
                .priority(priority)
                .express(true)
                .wait()
                .map_err(err)
        };
        let events = EventsSender::spawn([
            reliable(msgs::Topic::Events, EVENTS_PRIORITY)?,
            reliable(msgs::Topic::Applied, JOURNAL_PRIORITY)?,
            reliable(msgs::Topic::Keyframes, JOURNAL_PRIORITY)?,
        ])?;
        let tx = inbox.clone();
        let inputs = session
            .declare_subscriber(msgs::inputs_wildcard(world))
            .callback(move |sample| {
                let topic = msgs::parse_key(sample.key_expr().as_str()).ok().map(|(_, t)| t);
                let bytes = sample.payload().to_bytes().into_owned();
                match topic {
                    // A key under cmd/ that is no input topic: the loop counts it as a version
                    // mismatch (a frame that does not belong on its key).
                    Some(t) if msgs::Topic::INPUTS.contains(&t) => {
                        tx.offer(Inbound::Input { topic: Some(t), bytes });
                    }
                    _ => {
                        tx.offer(Inbound::Input { topic: Some(msgs::Topic::Scene), bytes });
                    }
                }
            })
            .wait()
            .map_err(err)?;
        let description = Arc::new(RwLock::new(description.to_vec()));
        let desc = description.clone();
        let scene_key = world.key(msgs::Topic::Scene);
        let scene = session
            .declare_queryable(scene_key.clone())
            .callback(move |q| {
                let bytes = desc.read().map(|d| d.clone()).unwrap_or_default();
                let _ = q.reply(scene_key.clone(), bytes).wait();
            })
            .wait()
            .map_err(err)?;
        let tx = inbox.clone();
        let controllers = session
            .liveliness()
            .declare_subscriber(world.controller_tokens())
            .history(true)
            .callback(move |sample| {
                let key = sample.key_expr().as_str();
                let id = key.rsplit('/').next().unwrap_or_default().to_string();
                let present = sample.kind() == zenoh::sample::SampleKind::Put;
                if !tx.offer(Inbound::Controller { id, present }) {
                    tracing::warn!("zenoh: controller token {key} changed with the inbox full (not seen)");
                }
            })
            .wait()
            .map_err(err)?;
        let control_key = world.key(msgs::Topic::Control);
        let control = session
            .declare_queryable(control_key.clone())
            .callback(move |q| {
                let bytes = q.payload().map(|p| p.to_bytes().into_owned()).unwrap_or_default();
                let key = control_key.clone();
                inbox.offer(Inbound::Control {
                    bytes,
                    reply: Box::new(move |r| {
                        let _ = q.reply(key, r).wait();
                    }),
                });
            })
            .wait()
            .map_err(err)?;
        let refused = match acl {
            Some(whatami) => Some(RefusedPuts::spawn(session.clone(), &whatami).map_err(err)?),
            None => None,
        };
        Ok(ZenohTransport {
            refused,
            session,
            poses,
            stats,
            signals,
            events,
            _inputs: inputs,
            _scene: scene,
            _control: control,
            _controllers: controllers,
            _token: token,
            description,
            throttle: ErrorThrottle::default(),
            listen: opts.listen.clone(),
            connect: opts.connect.clone(),
            prefix: format!("{}/{}", msgs::KEY_PREFIX, world.as_str()),
        })
    }
}

impl Transport for ZenohTransport {
    fn publish(&mut self, frames: Frames<'_>) {
        if let Err(e) = self.poses.put(frames.poses.to_vec()).wait() {
            self.throttle.fail("zenoh poses", &e);
        }
        if let Err(e) = self.stats.put(frames.stats.to_vec()).wait() {
            self.throttle.fail("zenoh stats", &e);
        }
        if let Err(e) = self.signals.put(frames.signals.to_vec()).wait() {
            self.throttle.fail("zenoh signals", &e);
        }
        if !frames.events.is_empty() {
            self.events.send(Reliable::Events, frames.events);
        }
        for a in frames.applied {
            self.events.send(Reliable::Applied, a);
        }
        if !frames.keyframe.is_empty() {
            self.events.send(Reliable::Keyframes, frames.keyframe);
        }
    }

    fn take_refused(&mut self) -> u64 {
        self.refused.as_ref().map_or(0, RefusedPuts::take)
    }

    fn set_description(&mut self, bytes: &[u8]) {
        if let Ok(mut d) = self.description.write() {
            d.clear();
            d.extend_from_slice(bytes);
        }
    }

    fn describe(&self) -> String {
        let mut d = format!("Zenoh peer {}", self.session.zid());
        if !self.listen.is_empty() {
            d.push_str(&format!(" listening on {}", self.listen.join(", ")));
        }
        if !self.connect.is_empty() {
            d.push_str(&format!(" connecting to {}", self.connect.join(", ")));
        }
        d.push_str(&format!(
            ": keys {}/{{poses, stats, signals, events, applied, keyframes, cmd/*, scene, control}}",
            self.prefix
        ));
        d
    }

    fn status(&mut self) -> String {
        let matched = self.poses.matching_status().wait().map(|m| m.matching()).unwrap_or(false);
        format!("zenoh: poses {}", if matched { "subscribed" } else { "no subscriber" })
    }
}
