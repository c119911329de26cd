//! `foxglove`: a world live in Foxglove, over the Foxglove WebSocket protocol (the official SDK's
//! server), without ROS.
//!
//! A client of the server like `watch` and `record`: it subscribes to the world's pose and stats
//! frames (Zenoh or iceoryx2), asks the scene description, and republishes them on the channels of
//! [`crate::fox::topics`] — the same topics and schemas `record` writes, so one layout opens both.
//! The server stays free of the SDK (and its tokio runtime), its loop never waits on a viewer, and
//! any host that reaches the server can run a view.
//!
//! The scene's shapes (`/pivotsim/scene`, `foxglove.SceneUpdate`) and its description
//! (`/pivotsim/description`) are sent once per scene to everyone subscribed, and again to each
//! client that subscribes later (a late joiner), to that client only. A new scene (the server's
//! `control load` or `reset`: the simulation time goes back, or the pose frames' body count no
//! longer matches) is asked again and replaces the entities; unanswered asks back off from 1 s to
//! 32 s.
//!
//! The signals frames become `/pivotsim/signals` (the sensor channels, plottable) and
//! `/pivotsim/contacts` (the contact states) and `/pivotsim/contact_forces` (the contact forces as
//! arrows, `foxglove.SceneUpdate`), the events frames `/pivotsim/events`
//! ([`crate::fox::signals`]).
//!
//! Message timestamps (log time and header stamps) follow `--clock`: the simulation time of the
//! frame (the default, as the ROS 2 path stamps `/tf` and `/clock`), or the server's wall time
//! (`wall_time_ns`) for transforms and poses and the receive time for the rest.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, anyhow, bail};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::fox::front::Front;
use crate::fox::topics::{self, ChannelSpec};
use crate::fox::{self, Clock, frames, scene};
use crate::net::{Received, Stream, TransportKind};
use crate::stop::{interrupted, secs};
use crate::tojson;
use crate::util::{SequenceGaps, scene_best_effort};

/// `foxglove` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Transport to read the world from.
    #[arg(long, value_enum, default_value = "zenoh")]
    pub transport: TransportKind,
    /// Address the WebSocket server binds (loopback by default; `0.0.0.0` for other hosts).
    #[arg(long, default_value = "127.0.0.1", value_name = "ADDR")]
    pub host: String,
    /// WebSocket port (0: any free port, printed at the start).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Stop after this many seconds (default: at Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Stop after this many pose frames.
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Message timestamps: the simulation time (as the ROS 2 bridge's `/clock` and `/tf`, so the
    /// two paths' recordings overlay) or the wall clock (server wall time for poses, receive time
    /// for the rest).
    #[arg(long, value_enum, default_value = "sim")]
    pub clock: Clock,
}

/// The latest scene, encoded, for late subscribers.
#[derive(Debug, Default)]
struct Latched {
    scene: Option<Vec<u8>>,
    description: Option<Vec<u8>>,
    /// Their log time (the view's clock when they were published).
    stamp: u64,
}

/// Sends the latched scene to a client that subscribes to its channels after it was published.
struct LateJoiners {
    scene: Arc<RawChannel>,
    description: Arc<RawChannel>,
    latched: Arc<Mutex<Latched>>,
}

impl ServerListener for LateJoiners {
    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        let latched = self.latched.lock().unwrap_or_else(|e| e.into_inner());
        let (raw, bytes) = if channel.id() == self.scene.id() {
            (&self.scene, &latched.scene)
        } else if channel.id() == self.description.id() {
            (&self.description, &latched.description)
        } else {
            return;
        };
        if let Some(b) = bytes {
            raw.log_with_meta_to_sink(b, PartialMetadata::with_log_time(latched.stamp), client.sink_id());
        }
    }
}

/// The channels of the live view.
struct Channels {
    tf: Arc<RawChannel>,
    scene: Arc<RawChannel>,
    description: Arc<RawChannel>,
    poses: Arc<RawChannel>,
    stats: Arc<RawChannel>,
    signals: Arc<RawChannel>,
    contacts: Arc<RawChannel>,
    contact_forces: Arc<RawChannel>,
    events: Arc<RawChannel>,
    health: Arc<RawChannel>,
}

fn channel(ctx: &Arc<Context>, spec: ChannelSpec) -> Result<Arc<RawChannel>> {
    ChannelBuilder::new(spec.topic.clone())
        .message_encoding(spec.encoding)
        .schema(spec.schema)
        .context(ctx)
        .build_raw()
        .map_err(|e| anyhow!("foxglove: channel {}: {e}", spec.topic))
}

impl Channels {
    fn new(ctx: &Arc<Context>) -> Result<Channels> {
        Ok(Channels {
            tf: channel(ctx, topics::tf())?,
            scene: channel(ctx, topics::scene())?,
            description: channel(ctx, topics::description())?,
            poses: channel(ctx, topics::poses())?,
            stats: channel(ctx, topics::stats())?,
            signals: channel(ctx, topics::signals())?,
            contacts: channel(ctx, topics::contacts())?,
            contact_forces: channel(ctx, topics::contact_forces())?,
            events: channel(ctx, topics::events())?,
            health: channel(ctx, topics::view_health())?,
        })
    }
}

/// What was sent so far, and what never arrived: per stream, the steps the server published that
/// this view never received (sequence gaps: lost in the transport or its inbox).
#[derive(Debug, Default)]
struct Counts {
    poses: u64,
    stats: u64,
    signals: u64,
    events: u64,
    scenes: u64,
    malformed: u64,
    poses_gaps: SequenceGaps,
    stats_gaps: SequenceGaps,
    signals_gaps: SequenceGaps,
}

/// The live view: channels, latched scene, the scene as known, the counts.
struct View<'a> {
    ch: Channels,
    latched: Arc<Mutex<Latched>>,
    scene: Option<msgs::SceneDescription>,
    last_sim_time: f64,
    /// The simulation time went back since the scene was last answered (a reset or load seen
    /// while an ask was backing off must still be asked, at the end of the wait).
    went_back: bool,
    last_scene_ask: Option<Instant>,
    /// Wait before asking again: 1 s, doubled after each unanswered ask up to 32 s (an ask blocks
    /// up to a second when nobody answers, e.g. an iceoryx2-only server).
    scene_retry: Duration,
    common: &'a Common,
    clock: Clock,
    n: Counts,
}

impl View<'_> {
    /// Publishes `s` (shapes and description) to everyone and latches it for late joiners.
    fn set_scene(&mut self, s: msgs::SceneDescription) -> Result<()> {
        let now = crate::net::now_ns();
        let stamp = self.clock.stamp(self.last_sim_time, now);
        let shapes = scene::scene_update(&s, frames::timestamp(stamp));
        if shapes.skipped > 0 {
            eprintln!("pivotsim-client: {} colliders not drawn (heightfields by reference)", shapes.skipped);
        }
        let scene = topics::encode(&shapes.update);
        let description = serde_json::to_vec(&s)?;
        // Broadcast and latch under the lock that `on_subscribe` takes: a client that subscribes
        // meanwhile gets the old scene before the new one or the new one only, never new then old.
        let meta = PartialMetadata::with_log_time(stamp);
        let mut latched = self.latched.lock().unwrap_or_else(|e| e.into_inner());
        self.ch.scene.log_with_meta(&scene, meta);
        self.ch.description.log_with_meta(&description, meta);
        *latched = Latched { scene: Some(scene), description: Some(description), stamp };
        drop(latched);
        eprintln!("pivotsim-client: scene `{}`: {} bodies as scene entities", s.scene, s.bodies.len());
        self.scene = Some(s);
        self.n.scenes += 1;
        Ok(())
    }

    /// Asks the scene again when the frame says it changed or none is known, at most once per
    /// `scene_retry`.
    fn check_scene(
        &mut self,
        v: &msgs::PoseFrameView<'_>,
        link: Option<&crate::net::ZenohLink>,
    ) -> Result<()> {
        self.went_back |= v.sim_time() < self.last_sim_time;
        self.last_sim_time = v.sim_time();
        let stale = match &self.scene {
            None => true,
            Some(s) => self.went_back || s.bodies.len() != v.bodies().len(),
        };
        if !stale || self.last_scene_ask.is_some_and(|t| t.elapsed() < self.scene_retry) {
            return Ok(());
        }
        self.last_scene_ask = Some(Instant::now());
        match scene_best_effort(self.common, link, Duration::from_secs(1)) {
            Some(s) => {
                self.scene_retry = Duration::from_secs(1);
                self.went_back = false;
                self.set_scene(s)
            }
            None => {
                self.scene_retry = (self.scene_retry * 2).min(Duration::from_secs(32));
                Ok(())
            }
        }
    }

    /// One received frame; `true` for a frame from the server that decoded.
    fn frame(&mut self, r: &Received, link: Option<&crate::net::ZenohLink>) -> Result<bool> {
        match r.topic {
            Some(Topic::Poses) => {
                let Ok(v) = msgs::PoseFrameView::parse(&r.bytes) else {
                    self.n.malformed += 1;
                    return Ok(false);
                };
                self.check_scene(&v, link)?;
                self.n.poses_gaps.see(v.sequence());
                let stamp = self.clock.stamp(v.sim_time(), v.wall_time_ns());
                let meta = PartialMetadata::with_log_time(stamp);
                let tf = frames::frame_transforms_at(&v, self.scene.as_ref(), stamp);
                self.ch.tf.log_with_meta(&topics::encode(&tf), meta);
                let json = tojson::pose_json(&v, self.scene.as_ref(), |_| true);
                self.ch.poses.log_with_meta(&serde_json::to_vec(&json)?, meta);
                self.n.poses += 1;
                Ok(true)
            }
            Some(Topic::Stats) => {
                let Ok(s) = msgs::SolverStats::decode(&r.bytes) else {
                    self.n.malformed += 1;
                    return Ok(false);
                };
                self.n.stats_gaps.see(s.sequence);
                let json = serde_json::to_vec(&tojson::stats_json(&s))?;
                let stamp = self.clock.stamp(s.sim_time, r.recv_ns);
                self.ch.stats.log_with_meta(&json, PartialMetadata::with_log_time(stamp));
                self.n.stats += 1;
                Ok(true)
            }
            Some(Topic::Signals) => {
                let Ok(s) = msgs::SignalsFrame::decode(&r.bytes) else {
                    self.n.malformed += 1;
                    return Ok(false);
                };
                self.n.signals_gaps.see(s.sequence);
                let stamp = self.clock.stamp(s.sim_time, r.recv_ns);
                let meta = PartialMetadata::with_log_time(stamp);
                let json = serde_json::to_vec(&fox::signals::signals_json(&s))?;
                self.ch.signals.log_with_meta(&json, meta);
                let json = serde_json::to_vec(&fox::signals::contacts_json(&s, self.scene.as_ref()))?;
                self.ch.contacts.log_with_meta(&json, meta);
                let arrows = fox::signals::contact_forces(&s, frames::timestamp(stamp));
                self.ch.contact_forces.log_with_meta(&topics::encode(&arrows), meta);
                self.n.signals += 1;
                Ok(true)
            }
            Some(Topic::Events) => {
                let Ok(e) = msgs::EventsFrame::decode(&r.bytes) else {
                    self.n.malformed += 1;
                    return Ok(false);
                };
                let json = serde_json::to_vec(&fox::signals::events_json(&e))?;
                let stamp = self.clock.stamp(e.sim_time, r.recv_ns);
                self.ch.events.log_with_meta(&json, PartialMetadata::with_log_time(stamp));
                self.n.events += 1;
                Ok(true)
            }
            _ => Ok(false),
        }
    }
}

/// What the view lost, per stream: steps never received from the server (sequence gaps),
/// frames its inbox dropped (all streams), messages a viewer's queue dropped (per topic).
#[derive(Debug)]
struct Health {
    received: [(&'static str, u64, u64); 3],
    inbox_dropped: u64,
    viewers: Vec<(String, u64, u64)>,
    clients: u64,
}

impl Health {
    /// Everything lost: steps never received and messages dropped towards viewers.
    fn lost(&self) -> u64 {
        self.received.iter().map(|r| r.2).sum::<u64>() + self.viewers.iter().map(|v| v.2).sum::<u64>()
    }

    /// One line: the streams and topics that lost something.
    fn summary(&self) -> String {
        let mut parts: Vec<String> = self
            .received
            .iter()
            .filter(|r| r.2 > 0)
            .map(|r| format!("{} {} never received", r.0, r.2))
            .collect();
        parts.extend(
            self.viewers.iter().filter(|v| v.2 > 0).map(|v| format!("{} {} dropped to viewers", v.0, v.2)),
        );
        parts.join(", ")
    }

    /// The `/pivotsim/view_health` message ([`topics::view_health`]).
    fn json(&self) -> serde_json::Value {
        let streams: serde_json::Map<String, serde_json::Value> = self
            .received
            .iter()
            .map(|(s, n, g)| (s.to_string(), serde_json::json!({"received": n, "never_received": g})))
            .collect();
        let viewers: serde_json::Map<String, serde_json::Value> = self
            .viewers
            .iter()
            .map(|(t, n, d)| (t.clone(), serde_json::json!({"relayed": n, "dropped": d})))
            .collect();
        serde_json::json!({
            "streams": streams, "inbox_dropped": self.inbox_dropped, "viewers": viewers,
            "clients": self.clients, "lost": self.lost(),
        })
    }

    /// The end-of-run table.
    fn table(&self) -> String {
        let mut out =
            String::from("pivotsim-client: per stream (from the server): received, never received\n");
        for (s, n, g) in &self.received {
            out.push_str(&format!("  {s:<10} {n:>10} {g:>8}\n"));
        }
        out.push_str(&format!("  (inbox dropped {} frames of all streams)\n", self.inbox_dropped));
        out.push_str(&format!(
            "pivotsim-client: per topic (to {} viewer connections): relayed, dropped\n",
            self.clients
        ));
        for (t, n, d) in &self.viewers {
            out.push_str(&format!("  {t:<28} {n:>10} {d:>8}\n"));
        }
        out
    }
}

impl View<'_> {
    fn health(&self, stream: &Stream, front: &Front) -> Health {
        let n = &self.n;
        Health {
            received: [
                ("poses", n.poses, n.poses_gaps.skipped),
                ("stats", n.stats, n.stats_gaps.skipped),
                ("signals", n.signals, n.signals_gaps.skipped),
            ],
            inbox_dropped: stream.inbox.dropped(),
            viewers: front.delivery().snapshot(),
            clients: front.delivery().clients(),
        }
    }
}

/// Runs `foxglove`: the stream, the WebSocket server, then frames until the end, the count,
/// Ctrl-C or a silence longer than `--timeout`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let world = common.world()?;
    let stream = Stream::open(
        &common.server()?,
        args.transport,
        &[Topic::Poses, Topic::Stats, Topic::Signals, Topic::Events],
        1024,
        Duration::from_micros(500),
        None,
    )?;
    let ctx = Context::new();
    let ch = Channels::new(&ctx)?;
    let latched = Arc::new(Mutex::new(Latched::default()));
    let listener = LateJoiners {
        scene: ch.scene.clone(),
        description: ch.description.clone(),
        latched: latched.clone(),
    };
    let info = HashMap::from([("world".to_string(), world.to_string())]);
    let server = foxglove::WebSocketServer::new()
        .name(format!("pivotsim {world}"))
        // The SDK listens on loopback only, behind the relay (`fox::front`) that owns the view's
        // address and also accepts `foxglove.websocket.v1`.
        .bind("127.0.0.1", 0)
        .server_info(info)
        .listener(Arc::new(listener))
        .context(&ctx)
        .start_blocking()
        .context("foxglove: cannot start the SDK's server on 127.0.0.1")?;
    let front = Front::start(&args.host, args.port, SocketAddr::from(([127, 0, 0, 1], server.port())))?;
    eprintln!(
        "pivotsim-client: world `{world}` via {:?} on ws://{}:{} (Foxglove: Open connection → Foxglove WebSocket; Ctrl-C stops)",
        args.transport,
        args.host,
        front.addr().port()
    );
    let mut view = View {
        ch,
        latched,
        scene: None,
        last_sim_time: 0.0,
        went_back: false,
        last_scene_ask: None,
        scene_retry: Duration::from_secs(1),
        common,
        clock: args.clock,
        n: Counts::default(),
    };
    if let Some(s) = scene_best_effort(common, stream.zenoh(), common.timeout_or(2.0)) {
        view.set_scene(s)?;
    } else {
        eprintln!("pivotsim-client: no scene description yet: no shapes until the server answers");
    }
    view.last_scene_ask = Some(Instant::now());
    let outcome = serve(&stream, &mut view, &server, &front, common, args);
    let health = view.health(&stream, &front);
    drop(front);
    server.stop().wait_blocking();
    let n = &view.n;
    eprintln!(
        "pivotsim-client: sent {} transforms, {} stats, {} signals, {} events, {} scenes ({} malformed skipped, {} dropped)",
        n.poses,
        n.stats,
        n.signals,
        n.events,
        n.scenes,
        n.malformed,
        health.lost()
    );
    eprint!("{}", health.table());
    outcome?;
    Ok(ExitCode::SUCCESS)
}

/// Republishes frames until Ctrl-C, `--duration`, `--count` or a silence of `--timeout`; once a
/// second, publishes the view's health (`/pivotsim/view_health`) and, when something was lost
/// since, warns on stderr and in Foxglove's problems list (a status message).
fn serve(
    stream: &Stream,
    view: &mut View<'_>,
    server: &foxglove::WebSocketServerHandle,
    front: &Front,
    common: &Common,
    args: &Args,
) -> Result<()> {
    let end = args.duration.map(|d| Instant::now() + secs(d));
    let idle = common.timeout.map(secs);
    let mut last_frame = Instant::now();
    let mut last_health = Instant::now();
    let mut lost = 0;
    loop {
        if last_health.elapsed() >= Duration::from_secs(1) {
            last_health = Instant::now();
            let h = view.health(stream, front);
            let stamp = view.clock.stamp(view.last_sim_time, crate::net::now_ns());
            view.ch
                .health
                .log_with_meta(&serde_json::to_vec(&h.json())?, PartialMetadata::with_log_time(stamp));
            if h.lost() > lost {
                lost = h.lost();
                let msg = format!("live view: {} messages lost so far ({})", lost, h.summary());
                eprintln!("pivotsim-client: {msg}");
                server.publish_status(foxglove::websocket::Status::warning(msg).with_id("pivotsim-lost"));
            }
        }
        if interrupted()
            || end.is_some_and(|e| Instant::now() >= e)
            || args.count.is_some_and(|c| view.n.poses >= c)
        {
            return Ok(());
        }
        if let Some(idle) = idle
            && last_frame.elapsed() >= idle
        {
            bail!("no frames for {:.1} s", idle.as_secs_f64());
        }
        let Some(r) = stream.inbox.recv_timeout(Duration::from_millis(50)) else { continue };
        if view.frame(&r, stream.zenoh())? {
            last_frame = Instant::now();
        }
    }
}
