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
//! Message timestamps: the server's wall time (`wall_time_ns`) for transforms and poses, the
//! receive time for stats, signals, contacts and events.

use std::collections::HashMap;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, anyhow, bail};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::fox::topics::{self, ChannelSpec};
use crate::fox::{self, frames, scene};
use crate::net::{Received, Stream, TransportKind};
use crate::stop::{interrupted, secs};
use crate::tojson;
use crate::util::scene_best_effort;

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
}

/// The latest scene, encoded, for late subscribers.
#[derive(Debug, Default)]
struct Latched {
    scene: Option<Vec<u8>>,
    description: Option<Vec<u8>>,
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
            raw.log_to_sink(b, client.sink_id());
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
        })
    }
}

/// What was sent so far.
#[derive(Debug, Default)]
struct Counts {
    poses: u64,
    stats: u64,
    signals: u64,
    events: u64,
    scenes: u64,
    malformed: u64,
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
    n: Counts,
}

impl View<'_> {
    /// Publishes `s` (shapes and description) to everyone and latches it for late joiners.
    fn set_scene(&mut self, s: msgs::SceneDescription) -> Result<()> {
        let now = crate::net::now_ns();
        let shapes = scene::scene_update(&s, frames::timestamp(now));
        if shapes.skipped > 0 {
            eprintln!("pivotsim-client: {} colliders not drawn (heightfields by reference)", shapes.skipped);
        }
        let scene = topics::encode(&shapes.update);
        let description = serde_json::to_vec(&s)?;
        // Broadcast and latch under the lock that `on_subscribe` takes: a client that subscribes
        // meanwhile gets the old scene before the new one or the new one only, never new then old.
        let meta = PartialMetadata::with_log_time(now);
        let mut latched = self.latched.lock().unwrap_or_else(|e| e.into_inner());
        self.ch.scene.log_with_meta(&scene, meta);
        self.ch.description.log_with_meta(&description, meta);
        *latched = Latched { scene: Some(scene), description: Some(description) };
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
                let meta = PartialMetadata::with_log_time(v.wall_time_ns());
                let tf = frames::frame_transforms(&v, self.scene.as_ref());
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
                let json = serde_json::to_vec(&tojson::stats_json(&s))?;
                self.ch.stats.log_with_meta(&json, PartialMetadata::with_log_time(r.recv_ns));
                self.n.stats += 1;
                Ok(true)
            }
            Some(Topic::Signals) => {
                let Ok(s) = msgs::SignalsFrame::decode(&r.bytes) else {
                    self.n.malformed += 1;
                    return Ok(false);
                };
                let meta = PartialMetadata::with_log_time(r.recv_ns);
                let json = serde_json::to_vec(&fox::signals::signals_json(&s))?;
                self.ch.signals.log_with_meta(&json, meta);
                let json = serde_json::to_vec(&fox::signals::contacts_json(&s, self.scene.as_ref()))?;
                self.ch.contacts.log_with_meta(&json, meta);
                let arrows = fox::signals::contact_forces(&s, frames::timestamp(r.recv_ns));
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
                self.ch.events.log_with_meta(&json, PartialMetadata::with_log_time(r.recv_ns));
                self.n.events += 1;
                Ok(true)
            }
            _ => Ok(false),
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
        .bind(args.host.clone(), args.port)
        .server_info(info)
        .listener(Arc::new(listener))
        .context(&ctx)
        .start_blocking()
        .with_context(|| format!("foxglove: cannot serve on {}:{}", args.host, args.port))?;
    eprintln!(
        "pivotsim-client: world `{world}` via {:?} on ws://{}:{} (Foxglove: Open connection → Foxglove WebSocket; Ctrl-C stops)",
        args.transport,
        args.host,
        server.port()
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
        n: Counts::default(),
    };
    if let Some(s) = scene_best_effort(common, stream.zenoh(), common.timeout_or(2.0)) {
        view.set_scene(s)?;
    } else {
        eprintln!("pivotsim-client: no scene description yet: no shapes until the server answers");
    }
    view.last_scene_ask = Some(Instant::now());
    let outcome = serve(&stream, &mut view, common, args);
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
        stream.inbox.dropped()
    );
    outcome?;
    Ok(ExitCode::SUCCESS)
}

/// Republishes frames until Ctrl-C, `--duration`, `--count` or a silence of `--timeout`.
fn serve(stream: &Stream, view: &mut View<'_>, common: &Common, args: &Args) -> Result<()> {
    let end = args.duration.map(|d| Instant::now() + secs(d));
    let idle = common.timeout.map(secs);
    let mut last_frame = Instant::now();
    loop {
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
