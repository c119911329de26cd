//! The two transports as the console sees them: a stream of received frames (poses, stats,
//! inputs), input publishing, and (Zenoh only) the `scene` and `control` queries.
//!
//! Received frames are handed over through a bounded channel ([`Inbox`]): Zenoh delivers them in
//! subscriber callbacks, iceoryx2 in a polling thread that owns the node and its subscribers.
//! Each frame is stamped with its receive time (ns since the UNIX epoch) where it arrives, so
//! latency probes do not count the time a frame waits in the channel. A full channel drops the
//! frame and counts it ([`Inbox::dropped`]); nothing blocks a transport thread.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::sync_channel;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;
use pivotsim_msgs as msgs;
use pivotsim_msgs::{Topic, WorldName};
use zenoh::Wait;

use crate::stop::interrupted;

pub use pivotsim_link::wall_ns as now_ns;

/// Which transport carries frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TransportKind {
    /// Zenoh peer session (TCP, any host).
    Zenoh,
    /// iceoryx2 shared memory (same host only).
    Iceoryx2,
}

/// How to reach the server over Zenoh.
#[derive(Debug, Clone)]
pub struct ZenohOptions {
    /// Endpoints to connect to (the server's listener).
    pub connect: Vec<String>,
    /// Endpoints to listen on (none by default).
    pub listen: Vec<String>,
    /// A Zenoh configuration file (credentials, routers); the endpoints are added to it.
    pub config_file: Option<std::path::PathBuf>,
}

/// What the transports need of the command line: where the server is, which world, and how long
/// to wait for it.
#[derive(Debug, Clone)]
pub struct Server {
    /// Zenoh endpoints and configuration.
    pub zenoh: ZenohOptions,
    /// The world.
    pub world: WorldName,
    /// How long to wait for a Zenoh peer.
    pub timeout: Duration,
}

impl Server {
    /// Opens a Zenoh session to the server ([`ZenohLink::open`]).
    pub fn open_zenoh(&self) -> Result<ZenohLink> {
        ZenohLink::open(&self.zenoh, &self.world, self.timeout)
    }
}

/// A frame as received.
#[derive(Debug, Clone)]
pub struct Received {
    /// What it arrived on (`None`: a key or service that is not a known topic).
    pub topic: Option<Topic>,
    /// Receive time (ns since the UNIX epoch), taken as the transport handed it over.
    pub recv_ns: u64,
    /// The frame bytes.
    pub bytes: Vec<u8>,
}

/// Frames delivered by the transports, with a drop counter (`pivotsim_link::inbox`).
pub type Inbox = pivotsim_link::Inbox<Received>;
/// The sending side of an [`Inbox`], cloned into callbacks and threads.
pub type InboxSender = pivotsim_link::InboxSender<Received>;
pub use pivotsim_link::inbox;

// ---------------------------------------------------------------------------------------------
// Zenoh

/// The client's Zenoh configuration: a peer, multicast scouting off, listening on `listen`
/// (nothing by default), connecting to `connect` (`pivotsim_link::zenoh_config`).
pub fn zenoh_config(opts: &ZenohOptions) -> Result<zenoh::Config> {
    let e = pivotsim_link::zenoh_config::ZenohEndpoints {
        listen: opts.listen.clone(),
        connect: opts.connect.clone(),
        config_file: opts.config_file.clone(),
        ..Default::default()
    };
    Ok(e.config()?)
}

/// How long the server's token must be visible while control requests end without a reply before
/// the client calls them refused (declarations may take a moment to reach a new session).
pub const REFUSED_AFTER: Duration = Duration::from_millis(500);

/// A Zenoh session connected to the server.
pub struct ZenohLink {
    session: zenoh::Session,
    world: WorldName,
    subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
}

impl std::fmt::Debug for ZenohLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohLink").field("world", &self.world).finish()
    }
}

impl ZenohLink {
    /// The session (for declarations of its own: a controller's liveliness token).
    pub fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// Opens the session and waits (at most `timeout`) until it is connected to at least one peer.
    pub fn open(opts: &ZenohOptions, world: &WorldName, timeout: Duration) -> Result<ZenohLink> {
        let session = zenoh::open(zenoh_config(opts)?)
            .wait()
            .map_err(|e| anyhow!("zenoh: cannot open a session: {e}"))?;
        let deadline = Instant::now() + timeout;
        loop {
            let peers = session.info().peers_zid().wait().count();
            if peers > 0 {
                break;
            }
            if Instant::now() >= deadline || interrupted() {
                bail!(
                    "zenoh: no peer reachable at {} within {:.1} s (is `pivotsim-server serve` running?)",
                    opts.connect.join(", "),
                    timeout.as_secs_f64()
                );
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        Ok(ZenohLink { session, world: world.clone(), subscribers: Vec::new() })
    }

    /// Subscribes to `key`, handing frames to `tx` tagged with the key's topic.
    pub fn subscribe_key(&mut self, key: String, tx: &InboxSender) -> Result<()> {
        let tx = tx.clone();
        let sub = self
            .session
            .declare_subscriber(key.clone())
            .callback(move |sample| {
                let recv_ns = now_ns();
                let topic = msgs::parse_key(sample.key_expr().as_str()).ok().map(|(_, t)| t);
                let _ =
                    tx.offer(Received { topic, recv_ns, bytes: sample.payload().to_bytes().into_owned() });
            })
            .wait()
            .map_err(|e| anyhow!("zenoh: cannot subscribe to {key}: {e}"))?;
        self.subscribers.push(sub);
        Ok(())
    }

    /// Subscribes to the given topics of the world (inputs through one `cmd/**` subscriber).
    pub fn subscribe(&mut self, topics: &[Topic], tx: &InboxSender) -> Result<()> {
        let mut inputs = false;
        for &t in topics {
            if Topic::INPUTS.contains(&t) {
                if !inputs {
                    inputs = true;
                    self.subscribe_key(msgs::inputs_wildcard(&self.world), tx)?;
                }
            } else {
                self.subscribe_key(self.world.key(t), tx)?;
            }
        }
        Ok(())
    }

    /// Declares a publisher for an input topic and waits (at most `timeout`) until the server's
    /// subscriber matches it, so that the first frame is not lost.
    pub fn input_publisher(
        &self,
        topic: Topic,
        timeout: Duration,
    ) -> Result<zenoh::pubsub::Publisher<'static>> {
        let key = self.world.key(topic);
        let p = self
            .session
            .declare_publisher(key.clone())
            .encoding(zenoh::bytes::Encoding::APPLICATION_OCTET_STREAM)
            .wait()
            .map_err(|e| anyhow!("zenoh: cannot declare a publisher on {key}: {e}"))?;
        let deadline = Instant::now() + timeout;
        while !p.matching_status().wait().map(|m| m.matching()).unwrap_or(false) {
            if Instant::now() >= deadline || interrupted() {
                bail!("zenoh: nobody subscribes to {key} (no server for world `{}`?)", self.world);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        Ok(p)
    }

    /// Queries `key` with an optional payload; returns the first reply's payload, or `None` when no
    /// queryable answered. Errors on a reply error or when `timeout` passes without a reply.
    pub fn query(&self, key: &str, payload: Option<Vec<u8>>, timeout: Duration) -> Result<Option<Vec<u8>>> {
        let mut get = self.session.get(key).timeout(timeout);
        if let Some(p) = payload {
            get = get.payload(p);
        }
        let replies = get.wait().map_err(|e| anyhow!("zenoh: query {key}: {e}"))?;
        let wait = timeout + Duration::from_millis(100);
        match replies.recv_timeout(wait) {
            Ok(Some(reply)) => match reply.result() {
                Ok(sample) => Ok(Some(sample.payload().to_bytes().into_owned())),
                Err(e) => {
                    let msg = e.payload().try_to_string().map(|s| s.into_owned()).unwrap_or_default();
                    if msg.contains("Timeout") || msg.is_empty() {
                        bail!("zenoh: no reply to {key} within {:.1} s", timeout.as_secs_f64())
                    } else {
                        bail!("zenoh: query {key} failed: {msg}")
                    }
                }
            },
            // The query finished without any reply: nobody answered.
            Err(_) => Ok(None),
            Ok(None) => bail!("zenoh: no reply to {key} within {:.1} s", timeout.as_secs_f64()),
        }
    }

    /// Queries `key` until a queryable answers (a session may need a moment before the server's
    /// queryable is known), retrying while nobody answered, for at most `timeout` in all.
    pub fn query_retrying(&self, key: &str, payload: Option<Vec<u8>>, timeout: Duration) -> Result<Vec<u8>> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now()).max(Duration::from_millis(50));
            if let Some(r) = self.query(key, payload.clone(), left)? {
                return Ok(r);
            }
            if Instant::now() >= deadline || interrupted() {
                bail!("zenoh: nothing answers {key} (no server for world `{}`?)", self.world);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The server's scene description.
    pub fn scene(&self, timeout: Duration) -> Result<msgs::SceneDescription> {
        let bytes = self.query_retrying(&self.world.key(Topic::Scene), None, timeout)?;
        msgs::SceneDescription::decode(&bytes).context("the scene reply does not decode")
    }

    /// Sends a control request and returns the decoded reply.
    ///
    /// A request is sent again only while no queryable answered at all (the server never saw it),
    /// so a `step` is never applied twice.
    ///
    /// A server with access control (README, "Who may steer the world") finishes a query it
    /// refuses at once with no reply. When the server's liveliness token
    /// (`pivotsim/<world>/server`) stays visible for [`REFUSED_AFTER`] while every request ends
    /// without a reply, the request is reported as refused instead of retried until the timeout.
    pub fn control(&self, req: &msgs::ControlRequest, timeout: Duration) -> Result<msgs::ControlReply> {
        let mut buf = Vec::new();
        req.encode(&mut buf).context("control request")?;
        let key = self.world.key(Topic::Control);
        let deadline = Instant::now() + timeout;
        let mut alive_since: Option<Instant> = None;
        loop {
            let left = deadline.saturating_duration_since(Instant::now()).max(Duration::from_millis(50));
            if let Some(bytes) = self.query(&key, Some(buf.clone()), left)? {
                return msgs::ControlReply::decode(&bytes).context("the control reply does not decode");
            }
            if self.server_alive(Duration::from_millis(200)) {
                let since = *alive_since.get_or_insert_with(Instant::now);
                if since.elapsed() >= REFUSED_AFTER {
                    bail!(
                        "refused: the server of world `{}` is up but does not answer control requests \
                         from this session: its access control refuses them for these credentials \
                         (--zenoh-config)",
                        self.world
                    );
                }
            } else {
                alive_since = None;
            }
            if Instant::now() >= deadline || interrupted() {
                bail!("zenoh: nothing answers {key} (no server for world `{}`?)", self.world);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Whether the server's liveliness token of this world answers within `timeout`.
    pub fn server_alive(&self, timeout: Duration) -> bool {
        let Ok(replies) = self.session.liveliness().get(self.world.server_token()).timeout(timeout).wait()
        else {
            return false;
        };
        matches!(replies.recv_timeout(timeout + Duration::from_millis(50)), Ok(Some(r)) if r.result().is_ok())
    }
}

// ---------------------------------------------------------------------------------------------
// iceoryx2

/// Longest initial input frame on the `cmd` service (a boom command of 16 targets is 672 bytes).
pub const IOX_INPUT_SLICE: usize = 4096;

type IoxService = pivotsim_link::iox::ByteService;

fn iox_err(what: &str) -> impl Fn(&dyn std::fmt::Debug) -> anyhow::Error + '_ {
    move |e| anyhow!("iceoryx2: {what}: {e:?}")
}

fn iox_node() -> Result<Node<ipc::Service>> {
    Ok(pivotsim_link::iox::node("pivotsim-client")?)
}

fn iox_service(node: &Node<ipc::Service>, world: &WorldName, topic: Topic) -> Result<IoxService> {
    let name = pivotsim_link::iox::service_name(world, topic)?;
    Ok(pivotsim_link::iox::open_service(node, &name)?)
}

/// A thread polling iceoryx2 subscribers into an inbox; stops when dropped.
pub struct IoxReceiver {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for IoxReceiver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IoxReceiver")
    }
}

impl IoxReceiver {
    /// Opens the services of `topics` (inputs: the one `cmd` service) and polls them every
    /// `poll` (zero: spin, yielding the CPU between polls).
    pub fn start(
        world: &WorldName,
        topics: &[Topic],
        tx: &InboxSender,
        poll: Duration,
    ) -> Result<IoxReceiver> {
        let names = iox_topics(topics)?;
        let world = world.clone();
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = sync_channel::<Result<()>>(1);
        let tx = tx.clone();
        let stop2 = stop.clone();
        let thread = std::thread::Builder::new()
            .name("iox-recv".into())
            .spawn(move || {
                let (node, services, subs) = match iox_subscribe(&world, &names) {
                    Ok(v) => {
                        let _ = ready_tx.send(Ok(()));
                        v
                    }
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return;
                    }
                };
                iox_poll(&subs, &tx, &stop2, poll);
                drop(subs);
                drop(services);
                drop(node);
            })
            .context("cannot start the iceoryx2 thread")?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(IoxReceiver { stop, thread: Some(thread) }),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(e)
            }
            Err(_) => {
                let _ = thread.join();
                bail!("iceoryx2: the receiving thread stopped")
            }
        }
    }
}

/// A subscriber of a byte service.
type IoxSubscriber = iceoryx2::port::subscriber::Subscriber<ipc::Service, [u8], ()>;

/// The node, the services and a subscriber per service (with the topic its frames carry).
type IoxSubscriptions = (Node<ipc::Service>, Vec<IoxService>, Vec<(Option<Topic>, IoxSubscriber)>);

/// The services `topics` need, as (the topic received frames carry, the topic to open): inputs
/// share the one `cmd` service, where the frame's own kind names the topic (`None`).
fn iox_topics(topics: &[Topic]) -> Result<Vec<(Option<Topic>, Topic)>> {
    let mut names: Vec<(Option<Topic>, Topic)> = Vec::new();
    for &t in topics {
        match t {
            Topic::Poses | Topic::Stats | Topic::Signals | Topic::Events => names.push((Some(t), t)),
            t if Topic::INPUTS.contains(&t) => {
                if !names.iter().any(|(known, _)| known.is_none()) {
                    names.push((None, t));
                }
            }
            _ => bail!("iceoryx2 carries no {} service", t.suffix()),
        }
    }
    Ok(names)
}

/// A subscriber on each service of `names` (from [`iox_topics`]), with the node and the services
/// they live in.
fn iox_subscribe(world: &WorldName, names: &[(Option<Topic>, Topic)]) -> Result<IoxSubscriptions> {
    let node = iox_node()?;
    let mut subs = Vec::new();
    let mut services = Vec::new();
    for (topic, open_as) in names {
        let s = iox_service(&node, world, *open_as)?;
        let sub = s
            .subscriber_builder()
            .buffer_size(msgs::IOX_SUBSCRIBER_BUFFER)
            .create()
            .map_err(|e| iox_err(&format!("cannot subscribe to {}", s.name()))(&e))?;
        subs.push((*topic, sub));
        services.push(s);
    }
    Ok((node, services, subs))
}

/// Hands the samples of `subs` to `tx` until `stop`, waiting `poll` (zero: yielding the CPU) after
/// a round that found none.
fn iox_poll(subs: &[(Option<Topic>, IoxSubscriber)], tx: &InboxSender, stop: &AtomicBool, poll: Duration) {
    while !stop.load(Ordering::Relaxed) {
        let mut any = false;
        for (topic, sub) in subs {
            // Bounded per round so that one busy service cannot starve the others.
            for _ in 0..64 {
                match sub.receive() {
                    Ok(Some(sample)) => {
                        let recv_ns = now_ns();
                        let bytes = sample.payload().to_vec();
                        // Inputs on `cmd`: the frame's own kind names the topic.
                        let topic = topic.or_else(|| input_topic(&bytes));
                        let _ = tx.offer(Received { topic, recv_ns, bytes });
                        any = true;
                    }
                    Ok(None) => break,
                    Err(_) => break,
                }
            }
        }
        if !any {
            if poll.is_zero() {
                std::thread::yield_now();
            } else {
                std::thread::sleep(poll);
            }
        }
    }
}

impl Drop for IoxReceiver {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The input topic of a frame by its header kind.
pub fn input_topic(bytes: &[u8]) -> Option<Topic> {
    let h = msgs::header::peek(bytes).ok()?;
    Topic::INPUTS.into_iter().find(|t| t.kind() == Some(h.kind))
}

/// An iceoryx2 publisher on the world's `cmd` service.
pub struct IoxInputs {
    publisher: Publisher<ipc::Service, [u8], ()>,
    service: IoxService,
    _node: Node<ipc::Service>,
}

impl std::fmt::Debug for IoxInputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IoxInputs")
    }
}

impl IoxInputs {
    /// Opens (or creates) the `cmd` service and a publisher on it.
    pub fn open(world: &WorldName) -> Result<IoxInputs> {
        let node = iox_node()?;
        let service = iox_service(&node, world, Topic::Joystick)?;
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(IOX_INPUT_SLICE)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| iox_err("cannot create the cmd publisher")(&e))?;
        Ok(IoxInputs { publisher, service, _node: node })
    }

    /// Subscribers of the `cmd` service (the server is one).
    pub fn subscribers(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }

    /// Publishes one frame; returns how many subscribers got it.
    pub fn send(&self, bytes: &[u8]) -> Result<usize> {
        let sample = self.publisher.loan_slice_uninit(bytes.len()).map_err(|e| iox_err("loan")(&e))?;
        let sample = sample.write_from_slice(bytes);
        sample.send().map_err(|e| iox_err("send")(&e))
    }
}

// ---------------------------------------------------------------------------------------------
// Both

/// Where inputs go.
#[derive(Debug)]
pub enum InputSink {
    /// One Zenoh publisher per input topic (declared on first use).
    Zenoh { publishers: Vec<(Topic, zenoh::pubsub::Publisher<'static>)> },
    /// The iceoryx2 `cmd` service.
    Iox(IoxInputs),
}

impl InputSink {
    /// Where the frames go: Zenoh publishers (declared on first use), or the iceoryx2 `cmd` service
    /// once the server subscribes to it.
    pub fn open(transport: TransportKind, world: &WorldName, timeout: Duration) -> Result<InputSink> {
        Ok(match transport {
            TransportKind::Zenoh => InputSink::Zenoh { publishers: Vec::new() },
            TransportKind::Iceoryx2 => {
                let p = IoxInputs::open(world)?;
                wait_iox_subscriber(&p, timeout)?;
                InputSink::Iox(p)
            }
        })
    }

    /// Publishes an encoded input frame on its topic.
    pub fn send(
        &mut self,
        link: Option<&ZenohLink>,
        topic: Topic,
        bytes: &[u8],
        timeout: Duration,
    ) -> Result<()> {
        match self {
            InputSink::Zenoh { publishers } => {
                let i = match publishers.iter().position(|(t, _)| *t == topic) {
                    Some(i) => i,
                    None => {
                        let link = link.ok_or_else(|| anyhow!("no zenoh session"))?;
                        publishers.push((topic, link.input_publisher(topic, timeout)?));
                        publishers.len() - 1
                    }
                };
                publishers[i].1.put(bytes.to_vec()).wait().map_err(|e| anyhow!("zenoh: put: {e}"))
            }
            InputSink::Iox(p) => {
                let n = p.send(bytes)?;
                if n == 0 {
                    bail!(
                        "iceoryx2: nobody subscribes to the cmd service (no server for this world on this host?)"
                    );
                }
                Ok(())
            }
        }
    }
}

/// Waits until the iceoryx2 `cmd` service has a subscriber (the server), at most `timeout`.
pub fn wait_iox_subscriber(p: &IoxInputs, timeout: Duration) -> Result<()> {
    let deadline = Instant::now() + timeout;
    while p.subscribers() == 0 {
        if Instant::now() >= deadline || interrupted() {
            bail!("iceoryx2: nobody subscribes to the cmd service (no server for this world on this host?)");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(())
}

/// Frames of some topics over one transport, with the Zenoh session when there is one.
#[derive(Debug)]
pub struct Stream {
    /// Received frames.
    pub inbox: Inbox,
    zenoh: Option<ZenohLink>,
    _iox: Option<IoxReceiver>,
}

impl Stream {
    /// Subscribes to `topics` of `server` over `transport`. Zenoh: `zenoh` is used if given, else a session
    /// is opened. iceoryx2: services are polled every `poll` (zero: spin); `zenoh` is kept for
    /// queries.
    pub fn open(
        server: &Server,
        transport: TransportKind,
        topics: &[Topic],
        capacity: usize,
        poll: Duration,
        zenoh: Option<ZenohLink>,
    ) -> Result<Stream> {
        let (tx, inbox) = inbox(capacity);
        match transport {
            TransportKind::Zenoh => {
                let mut link = match zenoh {
                    Some(l) => l,
                    None => server.open_zenoh()?,
                };
                link.subscribe(topics, &tx)?;
                Ok(Stream { inbox, zenoh: Some(link), _iox: None })
            }
            TransportKind::Iceoryx2 => {
                let r = IoxReceiver::start(&server.world, topics, &tx, poll)?;
                Ok(Stream { inbox, zenoh, _iox: Some(r) })
            }
        }
    }

    /// The Zenoh session, if any.
    pub fn zenoh(&self) -> Option<&ZenohLink> {
        self.zenoh.as_ref()
    }
}
