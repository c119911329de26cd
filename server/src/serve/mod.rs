//! The physics server (`pivotsim-server serve`, the default command): the scene stepped at a
//! fixed `h` in real time (or at a set real-time factor, or as fast as possible), operator inputs
//! in and poses and solver stats out over Zenoh and iceoryx2.
//!
//! | file | concept |
//! |---|---|
//! | `engine.rs` | transport-free state machine: inputs, deadman, control, frames |
//! | `describe.rs` | the scene description for renderers and consoles |
//! | `zenoh_io.rs` | Zenoh: publishers, the `cmd/**` subscriber, the `scene` and `control` queryables |
//! | `iox.rs` | iceoryx2: the same frames over shared memory for same-host subscribers, and inputs |
//!
//! **The loop.** One thread owns the engine. Transports hand inputs and control requests to it
//! through a bounded inbox (a full inbox drops and counts, it never blocks a transport thread);
//! the loop drains the inbox, steps, and publishes the step's frames. Publishing never waits for a
//! subscriber: Zenoh publishers drop under congestion, iceoryx2 publishers discard when a
//! subscriber's buffer is full; a publisher error is logged (rate-limited) and the next step tries
//! again. While paused the loop keeps publishing the last state (same sequence, fresh wall time
//! and input counters) at the step rate. Sequence numbers never restart, also not on `reset` or
//! `load_scene` (the simulation time does). Timing: step `k` is due at `t₀ + k h / rtf`; a step that ends after its deadline counts
//! an overrun, and the loop never runs more than [`MAX_CATCH_UP`] steps behind (beyond, it drops
//! the backlog and counts it), so a stall does not cause a burst of catch-up steps.

pub mod describe;
pub mod engine;
#[cfg(feature = "iceoryx2")]
pub mod iox;
#[cfg(feature = "zenoh")]
pub mod zenoh_io;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use thiserror::Error;
use tracing::{info, warn};

pub use engine::Engine;

/// Steps the loop may fall behind before it drops the backlog.
pub const MAX_CATCH_UP: u32 = 4;

/// Inbox capacity (inputs and control requests waiting for the loop).
pub const INBOX_CAPACITY: usize = 1024;

/// Zenoh settings of the server.
#[derive(Debug, Clone)]
pub struct ZenohOptions {
    /// Endpoints to listen on (default `tcp/127.0.0.1:7447`).
    pub listen: Vec<String>,
    /// Endpoints to connect to (routers, other peers).
    pub connect: Vec<String>,
    /// A Zenoh configuration file (JSON5) for rigs and routers; `listen`/`connect` still apply.
    pub config_file: Option<PathBuf>,
    /// Multicast scouting (off by default: everything stays on the given endpoints).
    pub multicast_scouting: bool,
}

impl Default for ZenohOptions {
    fn default() -> Self {
        ZenohOptions {
            listen: vec!["tcp/127.0.0.1:7447".into()],
            connect: Vec::new(),
            config_file: None,
            multicast_scouting: false,
        }
    }
}

/// What the server runs and how.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// Built-in scene name or scene file.
    pub scene: String,
    /// World name: the `<world>` of every key and service.
    pub world: String,
    /// Simulated seconds per wall second; `None`: as fast as possible.
    pub realtime_factor: Option<f64>,
    /// Deadman timeout.
    pub deadman: Duration,
    /// Zenoh (`None`: off).
    pub zenoh: Option<ZenohOptions>,
    /// iceoryx2 shared memory.
    pub iceoryx2: bool,
    /// One-line status every interval (`None`: never; the CLI sets it when stderr is a terminal).
    pub status_interval: Option<Duration>,
    /// Stop after this many steps (benchmarks, tests).
    pub max_steps: Option<u64>,
    /// Start paused.
    pub start_paused: bool,
}

impl Default for ServeConfig {
    fn default() -> Self {
        ServeConfig {
            scene: "pendulum".into(),
            world: msgs::DEFAULT_WORLD.into(),
            realtime_factor: Some(1.0),
            deadman: Duration::from_millis(250),
            zenoh: Some(ZenohOptions::default()),
            iceoryx2: true,
            status_interval: None,
            max_steps: None,
            start_paused: false,
        }
    }
}

/// Why the server could not start.
#[derive(Debug, Error)]
pub enum ServeError {
    /// The scene did not load.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// A bad world name.
    #[error("world name: {0}")]
    World(#[from] msgs::KeyError),
    /// A bad option.
    #[error("{0}")]
    Option(String),
    /// A transport did not start.
    #[error("{transport}: {message}")]
    Transport {
        /// `zenoh` or `iceoryx2`.
        transport: &'static str,
        /// What failed.
        message: String,
    },
    /// The transport is not compiled in.
    #[error("{0} support is not compiled in (cargo feature `{0}`)")]
    NotCompiled(&'static str),
}

/// Something a transport received for the loop.
pub enum Inbound {
    /// An input frame on a topic (`None`: the frame's own kind decides).
    Input {
        /// Topic it arrived on.
        topic: Option<msgs::Topic>,
        /// The frame.
        bytes: Vec<u8>,
    },
    /// A control request and where its reply goes.
    Control {
        /// The request frame.
        bytes: Vec<u8>,
        /// Sends the encoded reply.
        reply: Box<dyn FnOnce(Vec<u8>) + Send>,
    },
}

impl std::fmt::Debug for Inbound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Inbound::Input { topic, bytes } => write!(f, "Input({topic:?}, {} bytes)", bytes.len()),
            Inbound::Control { bytes, .. } => write!(f, "Control({} bytes)", bytes.len()),
        }
    }
}

/// The transports' side of the inbox: never blocks; drops are counted.
#[derive(Debug, Clone)]
pub struct InboxSender {
    tx: SyncSender<Inbound>,
    dropped: Arc<AtomicU64>,
}

impl InboxSender {
    /// Offers an item; `false` (and a counted drop) when the inbox is full or closed.
    pub fn offer(&self, item: Inbound) -> bool {
        match self.tx.try_send(item) {
            Ok(()) => true,
            Err(TrySendError::Full(item) | TrySendError::Disconnected(item)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
                if let Inbound::Control { reply, .. } = item {
                    let r = msgs::ControlReply::error(0, msgs::ControlErrorCode::Busy, "server inbox full");
                    let mut buf = Vec::new();
                    if r.encode(&mut buf).is_ok() {
                        reply(buf);
                    }
                }
                false
            }
        }
    }
}

/// A bounded inbox: the sender for transports, the receiver for the loop.
pub fn inbox() -> (InboxSender, Receiver<Inbound>, Arc<AtomicU64>) {
    let (tx, rx) = sync_channel(INBOX_CAPACITY);
    let dropped = Arc::new(AtomicU64::new(0));
    (InboxSender { tx, dropped: dropped.clone() }, rx, dropped)
}

/// A transport as the loop sees it.
pub trait Transport {
    /// Publishes one step's frames; never blocks on subscribers.
    fn publish(&mut self, poses: &[u8], stats: &[u8]);
    /// Hands over inputs received since the last call (transports that poll).
    fn poll(&mut self, _inbox: &InboxSender) {}
    /// The scene description changed (load, reset).
    fn set_description(&mut self, _bytes: &[u8]) {}
    /// A short status for the status line.
    fn status(&mut self) -> String;
}

/// What the server did, when it stops.
#[derive(Debug, Clone, PartialEq)]
pub struct ServeReport {
    /// Steps taken.
    pub steps: u64,
    /// Loop overruns.
    pub overruns: u64,
    /// Wall time (s).
    pub wall_s: f64,
    /// Simulated time at the end (s).
    pub sim_time: f64,
    /// Input counters at the end.
    pub inputs: msgs::InputHealth,
}

/// Runs the server until `shutdown` is set (or `max_steps`); the in-process entry point that
/// tests and the CLI share.
pub fn run(config: &ServeConfig, shutdown: Arc<AtomicBool>) -> Result<ServeReport, ServeError> {
    let world = msgs::WorldName::new(config.world.clone())?;
    let mut engine = Engine::new(&config.scene, world.clone(), config.deadman)?;
    engine.set_paused(config.start_paused);
    if let Some(r) = config.realtime_factor.filter(|r| !(r.is_finite() && *r > 0.0)) {
        return Err(ServeError::Option(format!("real-time factor {r} must be a finite number > 0")));
    }
    let (tx, rx, dropped) = inbox();
    let mut transports: Vec<Box<dyn Transport>> = Vec::new();
    // iceoryx2 first: once Zenoh answers, every service exists.
    if config.iceoryx2 {
        #[cfg(feature = "iceoryx2")]
        transports.push(Box::new(iox::IoxTransport::open(&world)?));
        #[cfg(not(feature = "iceoryx2"))]
        return Err(ServeError::NotCompiled("iceoryx2"));
    }
    if let Some(z) = &config.zenoh {
        #[cfg(feature = "zenoh")]
        transports.push(Box::new(zenoh_io::ZenohTransport::open(
            z,
            &world,
            tx.clone(),
            engine.description(),
        )?));
        #[cfg(not(feature = "zenoh"))]
        {
            let _ = z;
            return Err(ServeError::NotCompiled("zenoh"));
        }
    }
    info!(
        "serving scene `{}` as world `{}` (h = {:.4} s, {}), {} transport(s)",
        engine.scene().name,
        world.as_str(),
        engine.scene().world.settings().timestep,
        match config.realtime_factor {
            Some(r) => format!("real-time factor {r}"),
            None => "as fast as possible".into(),
        },
        transports.len()
    );
    let report = serve_loop(config, &mut engine, &mut transports, &tx, &rx, &dropped, &shutdown);
    info!("server stopped after {} steps ({} overruns)", report.steps, report.overruns);
    Ok(report)
}

fn serve_loop(
    config: &ServeConfig,
    engine: &mut Engine,
    transports: &mut [Box<dyn Transport>],
    tx: &InboxSender,
    rx: &Receiver<Inbound>,
    dropped: &AtomicU64,
    shutdown: &AtomicBool,
) -> ServeReport {
    let start = Instant::now();
    let mut steps = 0u64;
    let mut overruns = 0u64;
    let mut counted_drops = 0u64;
    let mut next = Instant::now();
    let mut last_status = Instant::now();
    let mut status_steps = 0u64;
    let mut status_sim = engine.scene().world.time();
    let mut status_solve_us = 0.0;
    for t in transports.iter_mut() {
        t.set_description(engine.description());
        t.publish(engine.pose_frame(), engine.stats_frame());
    }
    while !shutdown.load(Ordering::Relaxed) && config.max_steps.is_none_or(|m| steps < m) {
        for t in transports.iter_mut() {
            t.poll(tx);
        }
        let mut described = false;
        let mut republish = false;
        while let Ok(item) = rx.try_recv() {
            match item {
                Inbound::Input { topic, bytes } => {
                    let _ = engine.handle_input(topic, &bytes, Instant::now());
                }
                Inbound::Control { bytes, reply } => {
                    let (generation, seq) = (engine.generation(), engine.sequence());
                    reply(engine.handle_control(&bytes));
                    described |= engine.generation() != generation;
                    republish |= described || engine.sequence() != seq;
                }
            }
        }
        let d = dropped.load(Ordering::Relaxed);
        while counted_drops < d {
            engine.count_dropped();
            counted_drops += 1;
        }
        if described {
            for t in transports.iter_mut() {
                t.set_description(engine.description());
            }
        }
        let stepped = engine.tick(Instant::now());
        // Paused, the last state is published at the step rate (same sequence), so that consoles
        // keep seeing the world and the input counters.
        if stepped || republish || engine.is_paused() {
            if !stepped {
                engine.encode_frames(engine::wall_ns());
            }
            for t in transports.iter_mut() {
                t.publish(engine.pose_frame(), engine.stats_frame());
            }
        }
        if stepped {
            steps += 1;
            status_steps += 1;
            status_solve_us += engine.scene().world.island_stats().iter().map(|s| s.solve_us).sum::<f64>();
        }
        if config.status_interval.is_some_and(|iv| last_status.elapsed() >= iv) {
            let dt = last_status.elapsed().as_secs_f64();
            let sim = engine.scene().world.time();
            let mut line = format!(
                "t = {sim:8.2} s  rtf {:5.2}  solve {:7.1} µs/step  inputs {} ok / {} rejected{}",
                (sim - status_sim) / dt,
                status_solve_us / status_steps.max(1) as f64,
                engine.health().accepted,
                engine.health().rejected_total(),
                if engine.health().deadman_active { "  DEADMAN" } else { "" },
            );
            for t in transports.iter_mut() {
                line.push_str("  ");
                line.push_str(&t.status());
            }
            if std::io::stderr().is_terminal() {
                eprintln!("{line}");
            } else {
                info!("{line}");
            }
            (last_status, status_steps, status_sim, status_solve_us) = (Instant::now(), 0, sim, 0.0);
        }
        // Pacing.
        let Some(rtf) = config.realtime_factor else { continue };
        let period = Duration::from_secs_f64(engine.scene().world.settings().timestep / rtf);
        next += period;
        let now = Instant::now();
        if now > next {
            if stepped {
                overruns += 1;
                engine.count_overrun();
            }
            if now - next > period * MAX_CATCH_UP {
                next = now;
            }
        } else {
            std::thread::sleep(next - now);
        }
    }
    ServeReport {
        steps,
        overruns,
        wall_s: start.elapsed().as_secs_f64(),
        sim_time: engine.scene().world.time(),
        inputs: *engine.health(),
    }
}

/// Rate-limited warning for publisher failures: logs the first and then every 1000th.
#[derive(Debug, Default)]
pub struct ErrorThrottle {
    count: u64,
}

impl ErrorThrottle {
    /// Records a failure; logs it when due.
    pub fn fail(&mut self, what: &str, e: &dyn std::fmt::Display) {
        if self.count.is_multiple_of(1000) {
            warn!("{what}: {e} ({} failures so far; retrying every step)", self.count + 1);
        }
        self.count += 1;
    }
}
