//! The physics server (`pivotsim-server serve`, the default command): the scene stepped at a
//! fixed `h` in real time (or at a set real-time factor, or as fast as possible), operator inputs
//! in and poses and solver stats out over Zenoh and iceoryx2.
//!
//! | file | concept |
//! |---|---|
//! | `engine.rs` | transport-free state machine: inputs, deadman, control, frames |
//! | `describe.rs` | the scene description for renderers and consoles |
//! | `zenoh_io.rs` | Zenoh: publishers, the `cmd/**` subscriber, the `scene` and `control` queryables |
//! | `wire.rs` | exhaustive conversions of solver variants, statuses and island stats to `msgs` |
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
pub mod wire;
#[cfg(feature = "zenoh")]
pub mod zenoh_io;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use thiserror::Error;
use tracing::{info, warn};

pub use engine::Engine;

/// Steps the loop may fall behind before it drops the backlog.
pub const MAX_CATCH_UP: u32 = 4;

/// Inbox capacity (inputs and control requests waiting for the loop).
pub const INBOX_CAPACITY: usize = 1024;

/// Longest deadman timeout accepted (one hour), in ms; the shortest is 1 ms.
pub const MAX_DEADMAN_MS: u64 = 3_600_000;

/// Longest step period `h / rtf` accepted (a minute): a smaller real-time factor is refused.
pub const MAX_STEP_PERIOD: Duration = Duration::from_secs(60);

/// Longest single sleep of the loop: Ctrl-C is seen within this even at a slow pace.
const MAX_SLEEP: Duration = Duration::from_millis(100);

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
    /// Simulated seconds per wall second; `None`: as fast as possible. A finite number `> 0`
    /// whose step period `h / rtf` is at most [`MAX_STEP_PERIOD`].
    pub realtime_factor: Option<f64>,
    /// Deadman timeout, from 1 ms to [`MAX_DEADMAN_MS`].
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
    /// Settings of the start scene overridden (`--set KEY=VALUE`), again at each reset of it.
    pub overrides: Vec<crate::scene::SceneOverride>,
    /// Time budget (µs) of the island solves of one step, for every scene loaded (`None`: the
    /// scene's own `max_solve_us`): the solver returns its best safe iterate when it is spent, so a
    /// step never overruns because of the solver (by more than one pivot step).
    pub max_solve_us: Option<f64>,
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
            overrides: Vec::new(),
            max_solve_us: None,
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
    /// Another server already serves this world name: two would interleave their streams.
    #[error(
        "world `{world}` is already served ({transport}: {detail}); stop that server or start this one with another --world"
    )]
    WorldTaken {
        /// The world name.
        world: String,
        /// Where the other server was seen: `zenoh` or `iceoryx2`.
        transport: &'static str,
        /// What was seen.
        detail: String,
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

/// The transports' side of the inbox (`pivotsim_link::inbox`): never blocks; drops are counted,
/// and a dropped control request is answered `busy` at once.
#[derive(Debug, Clone)]
pub struct InboxSender(pivotsim_link::InboxSender<Inbound>);

impl InboxSender {
    /// Offers an item; `false` (and a counted drop) when the inbox is full or closed.
    pub fn offer(&self, item: Inbound) -> bool {
        match self.0.offer(item) {
            Ok(()) => true,
            Err(Inbound::Control { bytes, reply }) => {
                let id = msgs::ControlRequest::peek_id(&bytes).unwrap_or(0);
                let r = msgs::ControlReply::error(id, msgs::ControlErrorCode::Busy, "server inbox full");
                let mut buf = Vec::new();
                if r.encode(&mut buf).is_ok() {
                    reply(buf);
                }
                false
            }
            Err(Inbound::Input { .. }) => false,
        }
    }
}

/// A bounded inbox of [`INBOX_CAPACITY`]: the sender for transports, the receiver for the loop.
pub fn inbox() -> (InboxSender, pivotsim_link::Inbox<Inbound>) {
    let (tx, rx) = pivotsim_link::inbox(INBOX_CAPACITY);
    (InboxSender(tx), rx)
}

/// One step's encoded frames, as the transports publish them.
#[derive(Debug, Clone, Copy)]
pub struct Frames<'a> {
    /// Pose frame (`poses`).
    pub poses: &'a [u8],
    /// Solver stats (`stats`).
    pub stats: &'a [u8],
    /// Signals (`signals`).
    pub signals: &'a [u8],
    /// Events (`events`); empty when the step had none: nothing is published.
    pub events: &'a [u8],
}

/// A transport as the loop sees it.
pub trait Transport {
    /// Publishes one step's frames; never blocks on subscribers.
    fn publish(&mut self, frames: Frames<'_>);
    /// Hands over inputs received since the last call (transports that poll).
    fn poll(&mut self, _inbox: &InboxSender) {}
    /// The scene description changed (load, reset).
    fn set_description(&mut self, _bytes: &[u8]) {}
    /// A short status for the status line.
    fn status(&mut self) -> String;
    /// One line for the start message: the transport, where it listens, its keys or services.
    fn describe(&self) -> String;
}

/// What the server announces once its transports are up (the CLI prints it as the start message).
#[derive(Debug, Clone, PartialEq)]
pub struct Started {
    /// Scene name.
    pub scene: String,
    /// Bodies in the scene.
    pub bodies: usize,
    /// Step `h` (s).
    pub timestep: f64,
    /// The pace: `real time`, `real-time factor X` or `as fast as possible`.
    pub pace: String,
    /// World name.
    pub world: String,
    /// One line per transport that is up ([`Transport::describe`]).
    pub transports: Vec<String>,
    /// The Zenoh endpoint a client on this host connects to (`None`: Zenoh is off).
    pub zenoh_connect_hint: Option<String>,
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
    run_with(config, shutdown, |_| {})
}

/// [`run`], calling `on_start` once every transport is up and before the first step.
pub fn run_with(
    config: &ServeConfig,
    shutdown: Arc<AtomicBool>,
    on_start: impl FnOnce(&Started),
) -> Result<ServeReport, ServeError> {
    let world = msgs::WorldName::new(config.world.clone())?;
    check_deadman(config.deadman)?;
    let mut engine = Engine::with_settings(
        &config.scene,
        world.clone(),
        config.deadman,
        &config.overrides,
        config.max_solve_us,
    )?;
    engine.set_paused(config.start_paused);
    if let Some(r) = config.realtime_factor {
        step_period(engine.scene().world.settings().timestep, r)?;
    }
    let (tx, rx) = inbox();
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
    let started = Started {
        scene: engine.scene().name.clone(),
        bodies: engine.scene().world.bodies().len(),
        timestep: engine.scene().world.settings().timestep,
        pace: match config.realtime_factor {
            None => "as fast as possible".into(),
            Some(r) if (r - 1.0).abs() < f64::EPSILON => "real time".into(),
            Some(r) => format!("real-time factor {r}"),
        },
        world: world.as_str().to_string(),
        transports: transports.iter().map(|t| t.describe()).collect(),
        zenoh_connect_hint: config.zenoh.as_ref().map(|z| z.listen.first().cloned().unwrap_or_default()),
    };
    info!(
        "serving scene `{}` as world `{}` (h = {:.4} s, {}), {} transport(s)",
        started.scene,
        started.world,
        started.timestep,
        started.pace,
        transports.len()
    );
    on_start(&started);
    let report = serve_loop(config, &mut engine, &mut transports, &tx, &rx, &shutdown);
    info!("server stopped after {} steps ({} overruns)", report.steps, report.overruns);
    Ok(report)
}

fn serve_loop(
    config: &ServeConfig,
    engine: &mut Engine,
    transports: &mut [Box<dyn Transport>],
    tx: &InboxSender,
    rx: &pivotsim_link::Inbox<Inbound>,
    shutdown: &AtomicBool,
) -> ServeReport {
    let start = Instant::now();
    let mut steps = 0u64;
    let mut overruns = 0u64;
    let mut counted_drops = 0u64;
    let mut next = Instant::now();
    let mut status = StatusWindow::new(engine);
    for t in transports.iter_mut() {
        t.set_description(engine.description());
        t.publish(engine.frames());
    }
    while !shutdown.load(Ordering::Relaxed) && config.max_steps.is_none_or(|m| steps < m) {
        for t in transports.iter_mut() {
            t.poll(tx);
        }
        let (described, republish) = drain_inbox(engine, rx);
        let d = rx.dropped();
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
                engine.encode_frames(pivotsim_link::wall_ns());
            }
            for t in transports.iter_mut() {
                t.publish(engine.frames());
            }
        }
        if stepped {
            steps += 1;
            status.record_step(engine);
        }
        status.report_if_due(config.status_interval, engine, transports);
        // Pacing (none after the last step of a bounded run).
        if config.max_steps.is_some_and(|m| steps >= m) {
            break;
        }
        let Some(rtf) = config.realtime_factor else { continue };
        if pace(&mut next, rtf, stepped, engine, shutdown) {
            overruns += 1;
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

/// Hands every waiting input and control request to the engine; returns whether a request
/// changed the scene description and whether one changed what the frames show.
fn drain_inbox(engine: &mut Engine, rx: &pivotsim_link::Inbox<Inbound>) -> (bool, bool) {
    let mut described = false;
    let mut republish = false;
    while let Some(item) = rx.try_recv() {
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
    (described, republish)
}

/// Waits until step `next` (advanced by one period at real-time factor `rtf`) is due; when it is
/// already late, counts an overrun if a step ran (returns `true`) and drops a backlog of more than
/// [`MAX_CATCH_UP`] periods.
fn pace(next: &mut Instant, rtf: f64, stepped: bool, engine: &mut Engine, shutdown: &AtomicBool) -> bool {
    // A scene loaded later may have another h: its period is held to the same bound.
    let period = step_period(engine.scene().world.settings().timestep, rtf).unwrap_or(MAX_STEP_PERIOD);
    *next += period;
    let now = Instant::now();
    let mut overrun = false;
    if now > *next {
        if stepped {
            overrun = true;
            engine.count_overrun();
        }
        if now - *next > period * MAX_CATCH_UP {
            *next = now;
        }
    } else {
        sleep_until(*next, shutdown);
    }
    overrun
}

/// The steps since the last status line: their count, solve time and the simulation time at the
/// line.
struct StatusWindow {
    since: Instant,
    steps: u64,
    sim: f64,
    solve_us: f64,
}

impl StatusWindow {
    /// A window opening now.
    fn new(engine: &Engine) -> Self {
        StatusWindow { since: Instant::now(), steps: 0, sim: engine.scene().world.time(), solve_us: 0.0 }
    }

    /// Counts the step just taken and its islands' solve time.
    fn record_step(&mut self, engine: &Engine) {
        self.steps += 1;
        self.solve_us += engine.scene().world.island_stats().iter().map(|s| s.solve_us).sum::<f64>();
    }

    /// Prints the status line (stderr on a terminal, else the log) once `interval` has passed since
    /// the last, and opens a new window.
    fn report_if_due(
        &mut self,
        interval: Option<Duration>,
        engine: &Engine,
        transports: &mut [Box<dyn Transport>],
    ) {
        if interval.is_none_or(|iv| self.since.elapsed() < iv) {
            return;
        }
        let dt = self.since.elapsed().as_secs_f64();
        let sim = engine.scene().world.time();
        let mut line = format!(
            "t = {sim:8.2} s  rtf {:5.2}  solve {:7.1} µs/step  inputs {} ok / {} rejected{}",
            (sim - self.sim) / dt,
            self.solve_us / self.steps.max(1) as f64,
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
        *self = StatusWindow { since: Instant::now(), steps: 0, sim, solve_us: 0.0 };
    }
}

/// The step period `h / rtf`, or why the real-time factor is refused.
pub fn step_period(timestep: f64, rtf: f64) -> Result<Duration, ServeError> {
    if !(rtf.is_finite() && rtf > 0.0) {
        return Err(ServeError::Option(format!("real-time factor {rtf:e} must be a finite number > 0")));
    }
    match Duration::try_from_secs_f64(timestep / rtf) {
        Ok(p) if p <= MAX_STEP_PERIOD => Ok(p),
        _ => Err(ServeError::Option(format!(
            "real-time factor {rtf:e} gives a step period of {:.3e} s (h = {timestep} s); at most {} s: \
             use a real-time factor of at least {:.3e}",
            timestep / rtf,
            MAX_STEP_PERIOD.as_secs(),
            timestep / MAX_STEP_PERIOD.as_secs_f64()
        ))),
    }
}

fn check_deadman(deadman: Duration) -> Result<(), ServeError> {
    if deadman.is_zero() || deadman > Duration::from_millis(MAX_DEADMAN_MS) {
        return Err(ServeError::Option(format!(
            "deadman timeout {deadman:?} must be from 1 ms to {MAX_DEADMAN_MS} ms (every input would trip a zero one)"
        )));
    }
    Ok(())
}

/// Sleeps until `deadline` in slices of at most [`MAX_SLEEP`], returning early on shutdown.
fn sleep_until(deadline: Instant, shutdown: &AtomicBool) {
    for _ in 0..=(MAX_STEP_PERIOD.as_millis() / MAX_SLEEP.as_millis()) {
        let now = Instant::now();
        if now >= deadline || shutdown.load(Ordering::Relaxed) {
            return;
        }
        std::thread::sleep((deadline - now).min(MAX_SLEEP));
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
