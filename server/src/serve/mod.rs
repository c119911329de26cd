//! The physics server (`pivotsim-server serve`, the default command): the scene stepped at a
//! fixed `h` in real time (or at a set real-time factor, or as fast as possible), operator inputs
//! in and poses and solver stats out over Zenoh and iceoryx2.
//!
//! | file | concept |
//! |---|---|
//! | `config.rs` | what the server runs and how, and why it could not start |
//! | `engine.rs` | transport-free state machine: inputs, deadman, control, frames |
//! | `journal.rs` | what changed the world before each step, and keyframes, for recordings |
//! | `loader.rs` | scenes for `load_scene` and `reset`: confined, size-bounded, built off the step thread |
//! | `transport.rs` | what the loop and its transports share: the inbox, one step's frames, the trait |
//! | `replay.rs` | recordings read back, compared state by state with the replay |
//! | `pacing.rs` | real-time pacing and the status line |
//! | `describe.rs` | the scene description for renderers and consoles |
//! | `zenoh_io.rs` | Zenoh: publishers, the `cmd/**` subscriber, the `scene` and `control` queryables |
//! | `zenoh_refused.rs` | Zenoh: counting the puts its access control refuses (adminspace metrics) |
//! | `wire.rs` | exhaustive conversions of solver variants, statuses and island stats to `msgs` |
//! | `iox.rs` | iceoryx2: the same frames over shared memory for same-host subscribers, and inputs |
//!
//! **The loop.** One thread owns the engine. Transports hand inputs and control requests to it
//! through a bounded inbox (a full inbox drops and counts, it never blocks a transport thread);
//! the loop drains the inbox, steps, and publishes the step's frames. Publishing never waits for a
//! subscriber: Zenoh publishers drop under congestion, iceoryx2 publishers discard when a
//! subscriber's buffer is full; a publisher error is logged (rate-limited) and the next step tries
//! again. While paused the loop keeps publishing the last state's poses, stats and signals (same
//! sequence, fresh wall time and input counters) at the step rate; an events frame goes out once.
//! A lockstep request (`step`, `run_until`) is taken one step per turn of the loop, without
//! pacing: each step's frames are published before the next step, inputs that arrived meanwhile
//! apply from the next step, and the reply goes out after the last step's frames.
//! A `load_scene` or `reset` goes to the loader thread (`loader.rs`); the loop keeps stepping and
//! swaps the built scene in between two steps, then replies. Sequence numbers never restart: the
//! new scene's first frames carry the next one (the simulation time restarts at 0). Pacing is in
//! `pacing.rs`: step `k` is due at `t₀ + k h / rtf`, and the loop never runs more than
//! [`MAX_CATCH_UP`] steps behind, so a stall does not cause a burst of catch-up steps.

pub mod config;
pub mod describe;
pub mod engine;
#[cfg(feature = "iceoryx2")]
pub mod iox;
pub mod journal;
pub mod loader;
pub mod pacing;
pub mod replay;
pub mod transport;
pub mod wire;
#[cfg(feature = "zenoh")]
pub mod zenoh_io;
#[cfg(feature = "zenoh")]
pub mod zenoh_refused;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use tracing::info;

pub use config::{ControllerLost, MAX_DEADMAN_MS, MAX_STEP_PERIOD, ServeConfig, ServeError, ZenohOptions};
pub use engine::Engine;
pub use pacing::{MAX_CATCH_UP, step_period};
pub use transport::{ErrorThrottle, Frames, INBOX_CAPACITY, Inbound, InboxSender, Transport, inbox};

use pacing::{StatusWindow, pace};

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
    /// What a replay did (all zero when the server replayed nothing).
    pub replay: engine::ReplayProgress,
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
    config::check_deadman(config.deadman)?;
    let policy = loader::LoadPolicy::new(&config.scene_dirs, config.max_scene_bytes)
        .map_err(|e| ServeError::Option(e.to_string()))?
        .with_delay(config.slow_load);
    let mut engine = Engine::with_settings(
        &config.scene,
        world.clone(),
        config.deadman,
        &config.overrides,
        config.max_solve_us,
    )?;
    engine.set_load_policy(policy);
    engine.set_threads(config.threads).map_err(|e| ServeError::Option(e.to_string()))?;
    engine.set_snapshot_dir(config.snapshot_dir.clone());
    engine.set_keyframe_every(config.keyframes);
    engine.set_paused(config.start_paused);
    engine.set_on_controller_lost(config.on_controller_lost);
    run_engine(config, engine, shutdown, on_start)
}

/// [`run_with`] for an engine already built (a replay's, `replay.rs`): the configuration's
/// transports, pace and bounds; its scene options are the engine's business.
pub fn run_engine(
    config: &ServeConfig,
    mut engine: Engine,
    shutdown: Arc<AtomicBool>,
    on_start: impl FnOnce(&Started),
) -> Result<ServeReport, ServeError> {
    let world = msgs::WorldName::new(config.world.clone())?;
    let mut loader = loader::Loader::spawn()
        .map_err(|e| ServeError::Option(format!("cannot start the scene loader thread: {e}")))?;
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
    let report = serve_loop(config, &mut engine, &mut loader, &mut transports, &tx, &rx, &shutdown);
    info!("server stopped after {} steps ({} overruns)", report.steps, report.overruns);
    Ok(ServeReport { replay: engine.replay_progress().clone(), ..report })
}

fn serve_loop(
    config: &ServeConfig,
    engine: &mut Engine,
    loader: &mut loader::Loader,
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
    let mut lockstep: Option<Lockstep> = None;
    let mut last_request = start;
    // The start state's frames, stamped now (the engine built them before any clock mattered).
    engine.encode_frames(pivotsim_link::wall_ns());
    for t in transports.iter_mut() {
        t.set_description(engine.description());
        t.publish(engine.frames());
    }
    while !shutdown.load(Ordering::Relaxed) && config.max_steps.is_none_or(|m| steps < m) {
        for t in transports.iter_mut() {
            t.poll(tx);
        }
        let (mut described, mut republish) = drain_inbox(engine, loader, rx, &mut lockstep);
        // A scene built off this thread swaps in here, between two steps.
        if let Some(pending) = loader.finished() {
            let (loaded, reply) = pending;
            let generation = engine.generation();
            reply(engine.finish_load(loaded));
            described |= engine.generation() != generation;
            republish = true;
        }
        // Replies a transport sends itself (iceoryx2) leave now, not at its next poll.
        for t in transports.iter_mut() {
            t.flush();
        }
        let d = rx.dropped();
        while counted_drops < d {
            engine.count_dropped();
            counted_drops += 1;
        }
        for t in transports.iter_mut() {
            engine.count_refused(t.take_refused());
        }
        if described {
            for t in transports.iter_mut() {
                t.set_description(engine.description());
            }
        }
        // A lockstep request takes its next step now (the world is paused meanwhile).
        if let Some((mut job, reply)) = lockstep.take() {
            let more = engine.lockstep_step(&mut job);
            for t in transports.iter_mut() {
                t.publish(engine.frames());
            }
            steps += 1;
            status.record_step(engine);
            match more {
                true => lockstep = Some((job, reply)),
                false => {
                    reply(engine.finish_steps(&job));
                    for t in transports.iter_mut() {
                        t.flush();
                    }
                }
            }
            if config.max_steps.is_some_and(|m| steps >= m) {
                break;
            }
            // The state was just published: the next re-send, if the world stays paused, is a
            // period away.
            next = Instant::now() + paused_period(engine);
            last_request = Instant::now();
            continue;
        }
        let stepped = engine.tick(Instant::now());
        // Paused, the last state is published at the step rate (same sequence), so that consoles
        // keep seeing the world and the input counters.
        let resend = engine.is_paused() && Instant::now() >= next;
        if stepped || republish || resend {
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
        // Paused: re-sent at the step rate (real time), and any request wakes the loop at once
        // (a lockstep controller's round trip never waits for the re-send period).
        if engine.is_paused() {
            if resend {
                next = Instant::now() + paused_period(engine);
            }
            let polled = transports.iter().any(|t| t.polled());
            wait_paused(next, last_request, polled, transports, tx, rx, shutdown);
            if rx.wait(Duration::ZERO) {
                last_request = Instant::now();
            }
            continue;
        }
        // As fast as possible steps without waiting.
        let Some(rtf) = config.realtime_factor else {
            next = Instant::now();
            continue;
        };
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
        replay: engine::ReplayProgress::default(),
    }
}

/// How long after the last request a paused loop with a polled transport (iceoryx2) keeps polling
/// at [`FAST_POLL`] before falling back to [`SLOW_POLL`].
pub const ACTIVE_WINDOW: Duration = Duration::from_millis(100);
/// The poll interval while a controller is active (a same-host lockstep round trip waits half of
/// it on average).
pub const FAST_POLL: Duration = Duration::from_micros(50);
/// The poll interval of a quiet paused loop.
pub const SLOW_POLL: Duration = Duration::from_millis(2);

/// The re-send period of a paused world: the step period in real time.
fn paused_period(engine: &Engine) -> Duration {
    step_period(engine.scene().world.settings().timestep, 1.0).unwrap_or(config::MAX_STEP_PERIOD)
}

/// A paused loop's wait: until `deadline` (the next re-send) or an item in the inbox, whichever
/// comes first. Transports that push (Zenoh) wake it through the inbox; polled ones (iceoryx2)
/// are polled every [`FAST_POLL`] within [`ACTIVE_WINDOW`] of the last request, else every
/// [`SLOW_POLL`].
fn wait_paused(
    deadline: Instant,
    last_request: Instant,
    polled: bool,
    transports: &mut [Box<dyn Transport>],
    tx: &InboxSender,
    rx: &pivotsim_link::Inbox<Inbound>,
    shutdown: &AtomicBool,
) {
    // Bounded: a period is at most MAX_STEP_PERIOD, and every slice waits at least FAST_POLL.
    let max_slices = config::MAX_STEP_PERIOD.as_micros() / FAST_POLL.as_micros() + 1;
    for _ in 0..max_slices {
        let now = Instant::now();
        if now >= deadline || shutdown.load(Ordering::Relaxed) {
            return;
        }
        let mut slice = (deadline - now).min(pacing::MAX_SLEEP);
        if polled {
            for t in transports.iter_mut() {
                t.poll(tx);
            }
            let poll = if now < last_request + ACTIVE_WINDOW { FAST_POLL } else { SLOW_POLL };
            slice = slice.min(poll);
        }
        if rx.wait(slice) {
            return;
        }
    }
}

/// A lockstep request under way and where its reply goes.
type Lockstep = (engine::StepJob, Box<dyn FnOnce(Vec<u8>) + Send>);

/// Hands every waiting input and control request to the engine (a scene load to the loader
/// thread, a lockstep request to `lockstep`, or `busy` while one of either is under way); returns
/// whether a request changed the scene description and whether one changed what the frames show.
fn drain_inbox(
    engine: &mut Engine,
    loader: &mut loader::Loader,
    rx: &pivotsim_link::Inbox<Inbound>,
    lockstep: &mut Option<Lockstep>,
) -> (bool, bool) {
    let mut described = false;
    let mut republish = false;
    while let Some(item) = rx.try_recv() {
        match item {
            Inbound::Input { topic, bytes } => {
                let _ = engine.handle_input(topic, &bytes, Instant::now());
            }
            Inbound::Controller { id, present } => {
                engine.controller(&id, present);
                republish = true;
            }
            Inbound::Control { bytes, reply } => {
                let (generation, seq) = (engine.generation(), engine.sequence());
                match engine.begin_control(&bytes) {
                    engine::ControlStep::Reply(r) => reply(r),
                    engine::ControlStep::Steps(job) if lockstep.is_some() => reply(Engine::error_reply(
                        job.id,
                        msgs::ControlErrorCode::Busy,
                        "another lockstep request is under way",
                    )),
                    engine::ControlStep::Steps(job) => *lockstep = Some((job, reply)),
                    engine::ControlStep::Load(job) => {
                        if let Err((job, reply)) = loader.submit(job, reply) {
                            reply(Engine::error_reply(
                                job.id,
                                msgs::ControlErrorCode::Busy,
                                "a scene load is under way",
                            ));
                        }
                    }
                }
                described |= engine.generation() != generation;
                republish |= described || engine.sequence() != seq;
            }
        }
    }
    (described, republish)
}
