//! The server's state machine, free of any transport: a scene, the operator inputs (validated,
//! latest-wins per source, deadman), control requests, and the encoded pose and stats frames of
//! every step. The transports only move bytes in and out of it, so that everything here is tested
//! in-process and bit for bit.
//!
//! **Inputs.** A frame is decoded and validated by `pivotsim-msgs` (NaN/Inf, ranges, sizes,
//! version, kind on its key), its sequence must be newer than the last accepted one of its source
//! (else *stale*), and every actuator it names must exist with the right kind; a rejected input is
//! counted by reason in the stats and changes nothing. Wire values are in physical units and
//! converted to actuator values (`describe.rs`): a winch command sets a drum speed, a boom command
//! sets each target in its actuator's own mode (a speed for a velocity actuator, a position for a
//! position actuator), an actuator command sets its value in its own mode, a joystick goes through
//! the scene's mapping (a `rate` binding moves its actuator's value at `scale · axis` per second).
//!
//! **Script and deadman.** Until the first accepted input the scene's scripted timeline drives the
//! actuators. From then on the operator does, and if no input is accepted for the deadman timeout
//! every actuator goes to its neutral (velocity motors hold, position motors hold where they are,
//! brakes on, clutches open), and the stats say so until the next input.
//! `reset` and `load_scene` hand control back to the script.
//!
//! **Loading.** `load_scene` and `reset` read and build their scene as a [`LoadJob`] under the
//! engine's [`LoadPolicy`] (`loader.rs`: built-in names, the start scene, files inside the scene
//! directories, regular and size-bounded). [`Engine::begin_control`] hands such a job back instead
//! of running it, so that the server's loop runs it on its loader thread and calls
//! [`Engine::finish_load`] at a step boundary; [`Engine::handle_control`] does both in turn (tests,
//! tools). The new scene's first frames carry a new `sequence` (the last one plus one): a repeated
//! sequence always means a repeat of the same state.

use std::collections::HashMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use tracing::{info, warn};

use std::sync::Arc;

use super::config::ControllerLost;
use super::describe::{actuator_mode, describe};
use super::journal::{DEFAULT_KEYFRAME_EVERY, Journal};
use super::loader::{LoadError, LoadJob, LoadPolicy, Loaded};
use super::replay::{Divergence, Keyframe, Recording, ReplayError, compare_poses, compare_snapshots};
use crate::dynamics::{BodyKind, Watchdog};
use crate::scene::{self, ActuatorKind, Scene, SceneError};
use crate::snapshot::Snapshot;
use crate::solver::Variant;

/// What a control request or a transport needs from the engine's status.
pub type Status = msgs::ServerStatus;

/// The server's state (module doc).
#[derive(Debug)]
pub struct Engine {
    scene_ref: String,
    scene: Scene,
    world_name: msgs::WorldName,
    description: Vec<u8>,
    paused: bool,
    sequence: u64,
    overruns: u32,
    health: msgs::InputHealth,
    last_seq: HashMap<u32, u64>,
    manual: bool,
    last_input: Option<Instant>,
    deadman: Duration,
    axes: [f64; msgs::MAX_AXES],
    buttons: [bool; msgs::MAX_BUTTONS],
    pose_buf: Vec<u8>,
    stats: msgs::SolverStats,
    stats_buf: Vec<u8>,
    /// The scene's channel names as wire names (built at each scene change).
    channel_names: Vec<msgs::ActuatorName>,
    signals: msgs::SignalsFrame,
    signals_buf: Vec<u8>,
    events: msgs::EventsFrame,
    /// The last step's events frame; empty when the step had none or was already published.
    events_buf: Vec<u8>,
    /// The sequence whose events were encoded last.
    events_sequence: Option<u64>,
    step_wall_us: f64,
    failure: Option<String>,
    generation: u64,
    watchdog: Watchdog,
    unstable: bool,
    /// Degraded island solves since the scene was (re)loaded (published every step).
    degraded: msgs::DegradedSolves,
    /// Scene settings overridden at start (`serve --set`), applied to the start scene and its resets.
    overrides: Vec<scene::SceneOverride>,
    start_scene: String,
    /// Server-wide solve time budget (`serve --max-solve-us`), applied to every scene loaded.
    max_solve_us: Option<f64>,
    /// Solver threads of every scene loaded ([`Engine::set_threads`]).
    threads: usize,
    /// What `load_scene` and `reset` may read.
    policy: Arc<LoadPolicy>,
    /// Where `snapshot` writes and `restore` reads (`serve --snapshot-dir`; none: both refused).
    snapshot_dir: Option<PathBuf>,
    /// What changed the world before each step, and keyframes (`journal.rs`).
    journal: Journal,
    /// Replaying a recording: the deadman never trips on the wall clock (the recording's trips
    /// are applied where they happened).
    replaying: bool,
    /// The recording a replay follows (`replay.rs`), until it ends, diverges or branches.
    replay: Option<Feed>,
    replay_progress: ReplayProgress,
    /// Lockstep controllers whose liveliness tokens are up.
    controllers: std::collections::BTreeSet<String>,
    on_controller_lost: ControllerLost,
    /// Controller events not yet published (the server's, not the scene's: not in `events_total`).
    controller_events: Vec<msgs::EventRecord>,
}

/// Most lockstep controllers tracked at once.
pub const MAX_CONTROLLERS: usize = 256;

/// A replay under way.
#[derive(Debug)]
struct Feed {
    recording: Arc<Recording>,
    /// Live inputs drive from this time on.
    branch: Option<f64>,
    /// The last sequence compared.
    checked: Option<u64>,
}

/// What a replay did so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayProgress {
    /// Replayed pose frames equal to the recorded ones.
    pub poses_compared: u64,
    /// Replayed states whose pose frame the recording lacks (not compared).
    pub poses_missing: u64,
    /// Keyframes compared with the replay's own snapshot.
    pub keyframes_compared: u64,
    /// The first difference (the replay stopped there).
    pub divergence: Option<Divergence>,
    /// The recording's end was reached.
    pub finished: bool,
    /// `--branch` was reached: live inputs drive.
    pub branched: bool,
}

/// What the replay does instead of, or before, a step.
enum ReplayStep {
    /// Step (the records of the step applied).
    Step,
    /// A new scene state was installed: it is the step.
    Installed,
    /// The replay stopped; the world is paused.
    Stop,
    /// The branch time is reached: no step now; live inputs drive the next ones.
    Branched,
}

/// What a control request asks of the loop ([`Engine::begin_control`]).
#[derive(Debug)]
pub enum ControlStep {
    /// Done: the encoded reply.
    Reply(Vec<u8>),
    /// A scene to load (`load_scene`, `reset`): run it, then [`Engine::finish_load`].
    Load(LoadJob),
    /// A lockstep request (`step`, `run_until`): [`Engine::lockstep_step`] until it returns
    /// `false`, publishing each step's frames, then [`Engine::finish_steps`].
    Steps(StepJob),
}

/// A lockstep request under way: the steps left and what the steps taken gave.
#[derive(Debug, Clone, PartialEq)]
pub struct StepJob {
    /// The request's id.
    pub id: u64,
    remaining: u32,
    report: msgs::StepReport,
}

impl Engine {
    /// Loads `scene_ref` (a built-in name or a path) for world `world_name`.
    pub fn new(
        scene_ref: &str,
        world_name: msgs::WorldName,
        deadman: Duration,
    ) -> Result<Engine, SceneError> {
        Engine::with_settings(scene_ref, world_name, deadman, &[], None)
    }

    /// [`Engine::new`] with the start scene's settings overridden (`--set KEY=VALUE`; again at every
    /// `reset` of it) and a solve time budget per step for every scene (`--max-solve-us`).
    pub fn with_settings(
        scene_ref: &str,
        world_name: msgs::WorldName,
        deadman: Duration,
        overrides: &[scene::SceneOverride],
        max_solve_us: Option<f64>,
    ) -> Result<Engine, SceneError> {
        let mut scene = scene::load_with(scene_ref, overrides)?;
        apply_budget(&mut scene, max_solve_us).map_err(|e| SceneError::Override {
            file: scene_ref.to_string(),
            source: scene::OverrideError::Key(format!("max_solve_us: {e}")),
        })?;
        Ok(Engine::from_scene(scene, scene_ref, world_name, deadman, overrides, max_solve_us))
    }

    /// The engine of a scene already built (its budget applied).
    fn from_scene(
        scene: Scene,
        scene_ref: &str,
        world_name: msgs::WorldName,
        deadman: Duration,
        overrides: &[scene::SceneOverride],
        max_solve_us: Option<f64>,
    ) -> Engine {
        let watchdog = Watchdog::new(&scene.world, scene.watchdog);
        let mut e = Engine {
            scene_ref: scene_ref.to_string(),
            scene,
            world_name,
            description: Vec::new(),
            paused: false,
            sequence: 0,
            overruns: 0,
            health: msgs::InputHealth::default(),
            last_seq: HashMap::new(),
            manual: false,
            last_input: None,
            deadman,
            axes: [0.0; msgs::MAX_AXES],
            buttons: [false; msgs::MAX_BUTTONS],
            pose_buf: Vec::new(),
            stats: msgs::SolverStats::default(),
            stats_buf: Vec::new(),
            channel_names: Vec::new(),
            signals: msgs::SignalsFrame::default(),
            signals_buf: Vec::new(),
            events: msgs::EventsFrame::default(),
            events_buf: Vec::new(),
            events_sequence: None,
            step_wall_us: 0.0,
            failure: None,
            generation: 0,
            watchdog,
            unstable: false,
            degraded: msgs::DegradedSolves::default(),
            overrides: Vec::new(),
            start_scene: String::new(),
            max_solve_us: None,
            threads: 1,
            policy: Arc::new(LoadPolicy::default()),
            snapshot_dir: None,
            journal: Journal::new(DEFAULT_KEYFRAME_EVERY),
            replaying: false,
            replay: None,
            replay_progress: ReplayProgress::default(),
            controllers: std::collections::BTreeSet::new(),
            on_controller_lost: ControllerLost::default(),
            controller_events: Vec::new(),
        };
        e.overrides = overrides.to_vec();
        e.start_scene = scene_ref.to_string();
        e.max_solve_us = max_solve_us;
        e.set_load_policy(LoadPolicy::default());
        e.scene_changed();
        e.encode_frames(0);
        e
    }

    /// The engine of a replay (`replay.rs`): the keyframe's scene, built from the text its
    /// snapshot carries, in the keyframe's state (sequence, operator flag, watchdog ledger),
    /// paused, with `recording` to follow from there (`branch`: live inputs drive from that time).
    /// The deadman never trips on the wall clock: the recording's trips are applied.
    pub fn replay(
        recording: Arc<Recording>,
        start: &Keyframe,
        world_name: msgs::WorldName,
        branch: Option<f64>,
    ) -> Result<Engine, ReplayError> {
        let snapshot_error = |source| ReplayError::Snapshot { sequence: start.sequence, source };
        let snap = Snapshot::from_bytes(&start.snapshot).map_err(snapshot_error)?;
        let scene = snap.to_scene().map_err(snapshot_error)?;
        let source = scene.source.clone();
        let mut e = Engine::from_scene(scene, &source, world_name, Duration::from_secs(1), &[], None);
        e.adopt(&snap, start.sequence);
        e.replaying = true;
        e.replay = Some(Feed { recording, branch, checked: Some(start.sequence) });
        e.encode_frames(pivotsim_link::wall_ns());
        Ok(e)
    }

    /// Takes over a snapshot's runner state as the state `sequence`: paused, operator flag and
    /// watchdog ledger from the snapshot.
    fn adopt(&mut self, snap: &Snapshot, sequence: u64) {
        self.watchdog =
            snap.watchdog.clone().unwrap_or_else(|| Watchdog::new(&self.scene.world, self.scene.watchdog));
        self.manual = snap.operator;
        self.paused = true;
        self.sequence = sequence;
        self.journal.new_scene_state();
    }

    /// How the replay went so far (all zero when this engine replays nothing).
    pub fn replay_progress(&self) -> &ReplayProgress {
        &self.replay_progress
    }

    /// Whether a recording still drives the world (neither ended, diverged nor branched).
    pub fn is_replaying(&self) -> bool {
        self.replay.is_some()
    }

    /// Before a replayed step: a new scene state the session installed at the next sequence, or
    /// the records applied before the next step; `false` when the replay stopped here (ended,
    /// diverged) and the world is paused.
    fn replay_before_step(&mut self) -> ReplayStep {
        let Some(feed) = &self.replay else { return ReplayStep::Step };
        let rec = feed.recording.clone();
        let branch = feed.branch;
        let h = self.scene.world.settings().timestep;
        if branch.is_some_and(|t| self.scene.world.time() + 0.5 * h >= t) {
            info!("replay branched at {:.4} s: live inputs drive from here", self.scene.world.time());
            self.replay = None;
            self.replaying = false;
            self.replay_progress.branched = true;
            return ReplayStep::Branched;
        }
        let next = self.sequence + 1;
        if next > rec.last_sequence() {
            info!("replay finished at sequence {} ({:.4} s)", self.sequence, self.scene.world.time());
            self.replay = None;
            self.replay_progress.finished = true;
            self.paused = branch.is_none();
            self.replaying = branch.is_none();
            return if self.paused { ReplayStep::Stop } else { ReplayStep::Step };
        }
        if let Some(k) = rec.scene_keyframe(next) {
            let installed = Snapshot::from_bytes(&k.snapshot).and_then(|s| s.to_scene().map(|sc| (s, sc)));
            return match installed {
                Ok((snap, scene)) => {
                    self.scene = scene;
                    self.scene_changed();
                    self.adopt(&snap, next);
                    self.paused = false;
                    ReplayStep::Installed
                }
                Err(e) => {
                    self.diverge(next, format!("the session's new scene state does not restore: {e}"));
                    ReplayStep::Stop
                }
            };
        }
        for r in rec.applied.get(&next).map(Vec::as_slice).unwrap_or_default() {
            match r.kind {
                msgs::AppliedKind::Input => {
                    if let Err(reason) = self.try_input(None, &r.bytes, Instant::now()) {
                        self.diverge(next, format!("a recorded input was refused ({})", reason.name()));
                        return ReplayStep::Stop;
                    }
                    self.health.accepted = self.health.accepted.saturating_add(1);
                }
                msgs::AppliedKind::Control => match msgs::ControlRequest::decode(&r.bytes) {
                    Ok(req) => {
                        self.journal.record(msgs::AppliedKind::Control, &r.bytes);
                        let _ = self.control(&req.command);
                    }
                    Err(e) => {
                        self.diverge(next, format!("a recorded control request does not decode: {e}"));
                        return ReplayStep::Stop;
                    }
                },
                msgs::AppliedKind::Deadman => self.trip_deadman(),
            }
        }
        ReplayStep::Step
    }

    /// After a new state's frames: its pose frame against the recorded one, and a periodic
    /// keyframe's snapshot against the replay's own.
    fn replay_check(&mut self) {
        let Some(feed) = &mut self.replay else { return };
        if feed.checked == Some(self.sequence) {
            return;
        }
        feed.checked = Some(self.sequence);
        let rec = feed.recording.clone();
        let p = &mut self.replay_progress;
        match rec.poses.get(&self.sequence) {
            Some(recorded) => {
                p.poses_compared += 1;
                if let Some(what) = compare_poses(&self.pose_buf, recorded) {
                    return self.diverge(self.sequence, what);
                }
            }
            None => p.poses_missing += 1,
        }
        if let Some(k) = rec.keyframe(self.sequence).filter(|k| k.reason != msgs::KeyframeReason::Scene) {
            let mine = Snapshot::capture(&self.scene, Some(&self.watchdog)).map(|mut s| {
                s.operator = self.manual;
                s
            });
            let what = match mine {
                Ok(s) => compare_snapshots(&s, &k.snapshot),
                Err(e) => Some(format!("no snapshot of the replay: {e}")),
            };
            self.replay_progress.keyframes_compared += 1;
            if let Some(what) = what {
                self.diverge(self.sequence, format!("keyframe: {what}"));
            }
        }
    }

    fn diverge(&mut self, sequence: u64, what: String) {
        let d = Divergence { sequence, sim_time: self.scene.world.time(), what };
        tracing::error!("replay {d}; stopped (paused) there");
        self.replay_progress.divergence = Some(d);
        self.replay = None;
        self.paused = true;
    }

    /// The deadman trips: every actuator to neutral (journaled).
    fn trip_deadman(&mut self) {
        self.journal.record(msgs::AppliedKind::Deadman, &[]);
        self.scene.controls.neutralize(&self.scene.world);
        self.health.deadman_active = true;
        self.health.deadman_trips = self.health.deadman_trips.saturating_add(1);
    }

    /// Sets what `load_scene` and `reset` may read (the start scene stays loadable).
    pub fn set_load_policy(&mut self, mut policy: LoadPolicy) {
        policy.trust_start_scene(&self.start_scene);
        self.policy = Arc::new(policy);
    }

    /// What to do when the last lockstep controller goes away (`serve --on-controller-lost`).
    pub fn set_on_controller_lost(&mut self, what: ControllerLost) {
        self.on_controller_lost = what;
    }

    /// A lockstep controller's liveliness token appeared or went away (Zenoh liveliness: a
    /// controller that exits, is killed or loses its link). Each change is an event
    /// (`controller-joined`, `controller-lost`, named by the controller's id), published with the
    /// next frames even while paused; when the last controller goes, the world pauses or resumes
    /// real time as configured (the lost event's `value` is 1 when it resumed).
    pub fn controller(&mut self, id: &str, present: bool) {
        let name = msgs::ActuatorName::new(id)
            .or_else(|_| msgs::ActuatorName::new("controller"))
            .expect("a valid name");
        let kind = match present {
            true if self.controllers.len() < MAX_CONTROLLERS && self.controllers.insert(id.to_string()) => {
                info!("lockstep controller `{id}` joined");
                msgs::EventCode::ControllerJoined
            }
            false if self.controllers.remove(id) => msgs::EventCode::ControllerLost,
            _ => return,
        };
        let mut value = 0.0;
        if kind == msgs::EventCode::ControllerLost {
            let last = self.controllers.is_empty();
            match self.on_controller_lost {
                ControllerLost::Resume if last => {
                    self.paused = false;
                    value = 1.0;
                    warn!("lockstep controller `{id}` lost: real time resumes");
                }
                ControllerLost::Pause if last => {
                    self.paused = true;
                    warn!("lockstep controller `{id}` lost: the world stays paused");
                }
                _ => warn!("lockstep controller `{id}` lost ({} left)", self.controllers.len()),
            }
        }
        if self.controller_events.len() < msgs::MAX_EVENTS {
            let time = self.scene.world.time();
            self.controller_events.push(msgs::EventRecord { name, kind, time, value, level: 0.0 });
        }
    }

    /// Lockstep controllers present.
    pub fn controllers(&self) -> usize {
        self.controllers.len()
    }

    /// Keyframes every `every` seconds of simulation time (`serve --keyframes`; 0: only at new
    /// scene states and on request); the current state gets one with its next frames.
    pub fn set_keyframe_every(&mut self, every: f64) {
        self.journal = Journal::new(every);
    }

    /// Sets where `snapshot` writes and `restore` reads (`None`: both are refused).
    pub fn set_snapshot_dir(&mut self, dir: Option<PathBuf>) {
        self.snapshot_dir = dir;
    }

    /// The file a `snapshot` or `restore` request names, inside the snapshot directory (the wire
    /// rules already refused absolute paths and `..`).
    fn snapshot_path(&self, path: &str) -> Result<PathBuf, (msgs::ControlErrorCode, String)> {
        match &self.snapshot_dir {
            Some(dir) => Ok(dir.join(path)),
            None => Err((
                msgs::ControlErrorCode::LoadRefused,
                "this server keeps no snapshots (serve --snapshot-dir)".into(),
            )),
        }
    }

    /// `snapshot`: the complete state, with the watchdog's ledger, to a file.
    fn write_snapshot(&self, path: &str) -> Result<(), (msgs::ControlErrorCode, String)> {
        let file = self.snapshot_path(path)?;
        let failed = |e: &dyn std::fmt::Display| {
            (msgs::ControlErrorCode::SnapshotFailed, format!("snapshot `{path}`: {e}"))
        };
        if let Some(parent) = file.parent() {
            std::fs::create_dir_all(parent).map_err(|e| failed(&e))?;
        }
        let snap = Snapshot::capture(&self.scene, Some(&self.watchdog)).map_err(|e| failed(&e))?;
        snap.write(&file).map_err(|e| failed(&e))?;
        info!("snapshot of `{}` at {:.3} s written to {}", self.scene.name, snap.time(), file.display());
        Ok(())
    }

    /// `restore`: a snapshot of the running scene put back, paused, with a new sequence; the
    /// script drives again until the next input (as after a load).
    fn restore_snapshot(&mut self, path: &str) -> Result<(), (msgs::ControlErrorCode, String)> {
        let file = self.snapshot_path(path)?;
        let failed = |e: &dyn std::fmt::Display| {
            (msgs::ControlErrorCode::SnapshotFailed, format!("restore `{path}`: {e}"))
        };
        let snap = Snapshot::read(&file).map_err(|e| failed(&e))?;
        snap.restore_into(&mut self.scene).map_err(|e| failed(&e))?;
        self.watchdog =
            snap.watchdog.clone().unwrap_or_else(|| Watchdog::new(&self.scene.world, self.scene.watchdog));
        self.paused = true;
        self.manual = false;
        self.last_input = None;
        self.health.deadman_active = false;
        self.failure = None;
        self.unstable = false;
        self.events_sequence = None;
        self.journal.new_scene_state();
        self.sequence += 1;
        self.encode_frames(pivotsim_link::wall_ns());
        info!("`{}` restored to {:.3} s from {}", self.scene.name, snap.time(), file.display());
        Ok(())
    }

    /// Solver threads for this scene and every scene loaded after it (`World::set_threads`: the
    /// result is the same to the bit; a replay does not depend on it).
    pub fn set_threads(&mut self, threads: usize) -> Result<(), crate::dynamics::ThreadsError> {
        self.scene.world.set_threads(threads)?;
        self.threads = threads;
        Ok(())
    }

    fn scene_changed(&mut self) {
        self.generation += 1;
        if self.scene.world.threads() != self.threads
            && let Err(e) = self.scene.world.set_threads(self.threads)
        {
            warn!("scene `{}`: {e}; its islands are solved in turn", self.scene.name);
        }
        let d = describe(&self.scene, self.world_name.as_str());
        self.description.clear();
        if let Err(e) = d.encode(&mut self.description) {
            warn!("scene description of `{}` does not fit the wire format: {e}", self.scene.name);
            self.description.clear();
        }
        self.manual = false;
        self.last_input = None;
        self.health.deadman_active = false;
        self.failure = None;
        self.watchdog = Watchdog::new(&self.scene.world, self.scene.watchdog);
        self.unstable = false;
        self.degraded = msgs::DegradedSolves::default();
        self.channel_names = super::wire::channel_names(&self.scene.signals);
        self.events_sequence = None;
    }

    /// Changes whenever the scene (and so its description) is replaced or reset.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The loaded scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The encoded scene description (empty if the scene does not fit the wire format).
    pub fn description(&self) -> &[u8] {
        &self.description
    }

    /// The last step's encoded pose frame.
    pub fn pose_frame(&self) -> &[u8] {
        &self.pose_buf
    }

    /// The last step's encoded stats frame.
    pub fn stats_frame(&self) -> &[u8] {
        &self.stats_buf
    }

    /// The last step's encoded signals frame.
    pub fn signals_frame(&self) -> &[u8] {
        &self.signals_buf
    }

    /// The last step's encoded events frame, empty when the step had no events or its events were
    /// already encoded (a paused world's republished frames carry none).
    pub fn events_frame(&self) -> &[u8] {
        &self.events_buf
    }

    /// The frames of the last step, as the transports publish them.
    pub fn frames(&self) -> super::transport::Frames<'_> {
        super::transport::Frames {
            poses: &self.pose_buf,
            stats: &self.stats_buf,
            signals: &self.signals_buf,
            events: &self.events_buf,
            applied: self.journal.applied(),
            keyframe: self.journal.keyframe(),
        }
    }

    /// Input counters.
    pub fn health(&self) -> &msgs::InputHealth {
        &self.health
    }

    /// Whether stepping is paused.
    pub fn is_paused(&self) -> bool {
        self.paused
    }

    /// Pauses or resumes.
    pub fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
    }

    /// Why the world stopped, if a step failed (the world keeps its last good state, paused).
    pub fn failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }

    /// Sequence number of the last step.
    pub fn sequence(&self) -> u64 {
        self.sequence
    }

    /// Counts an overrun of the real-time loop.
    pub fn count_overrun(&mut self) {
        self.overruns = self.overruns.saturating_add(1);
    }

    /// Counts an input dropped before it reached the engine (a full inbox).
    pub fn count_dropped(&mut self) {
        self.health.reject(msgs::RejectReason::Other);
    }

    /// Counts `n` inputs refused before they reached the engine (Zenoh's access control), as
    /// `other`.
    pub fn count_refused(&mut self, n: u64) {
        let c = &mut self.health.rejected[msgs::RejectReason::Other.code() as usize];
        *c = c.saturating_add(n);
    }

    /// The server state as a control reply reports it.
    pub fn status(&self) -> Status {
        Status {
            scene: self.scene.name.clone(),
            paused: self.paused,
            sequence: self.sequence,
            sim_time: self.scene.world.time(),
            variant: self.scene.world.settings().solver.variant.into(),
            steps: None,
        }
    }

    /// Validates and applies one input frame that arrived on `topic` (`None`: trust the frame's
    /// kind, e.g. a single-service transport); a rejection is counted and changes nothing.
    pub fn handle_input(
        &mut self,
        topic: Option<msgs::Topic>,
        bytes: &[u8],
        now: Instant,
    ) -> Result<(), msgs::RejectReason> {
        // A replay refuses live inputs until it ends or branches.
        let r = match self.replay.is_some() {
            true => Err(msgs::RejectReason::Other),
            false => self.try_input(topic, bytes, now),
        };
        match r {
            Ok(()) => self.health.accepted = self.health.accepted.saturating_add(1),
            Err(reason) => self.health.reject(reason),
        }
        r
    }

    fn try_input(
        &mut self,
        topic: Option<msgs::Topic>,
        bytes: &[u8],
        now: Instant,
    ) -> Result<(), msgs::RejectReason> {
        if let Some(t) = topic {
            let h = msgs::header::peek(bytes).map_err(|e| e.reject_reason())?;
            if Some(h.kind) != t.kind() {
                return Err(msgs::RejectReason::Version);
            }
        }
        let cmd = msgs::InputCommand::decode(bytes).map_err(|e| e.reject_reason())?;
        if self.last_seq.get(&cmd.source_id()).is_some_and(|&last| cmd.sequence() <= last) {
            return Err(msgs::RejectReason::Stale);
        }
        self.apply_input(&cmd)?;
        self.journal.record(msgs::AppliedKind::Input, bytes);
        self.last_seq.insert(cmd.source_id(), cmd.sequence());
        self.manual = true;
        self.last_input = Some(now);
        self.health.deadman_active = false;
        Ok(())
    }

    /// Actuator index of a wire name with the wire mode it accepts.
    fn actuator(&self, name: &str) -> Result<usize, msgs::RejectReason> {
        self.scene.controls.index(name).ok_or(msgs::RejectReason::UnknownActuator)
    }

    fn apply_input(&mut self, cmd: &msgs::InputCommand) -> Result<(), msgs::RejectReason> {
        let unknown = msgs::RejectReason::UnknownActuator;
        let controls = &self.scene.controls;
        // Check everything first, then apply: an input is all or nothing.
        let mut sets: [(usize, f64); msgs::MAX_BOOM_TARGETS] = [(0, 0.0); msgs::MAX_BOOM_TARGETS];
        let mut n = 0;
        match cmd {
            msgs::InputCommand::Joystick(j) => {
                for (dst, &a) in self.axes.iter_mut().zip(j.axes.iter()) {
                    *dst = f64::from(a);
                }
                for (i, b) in self.buttons.iter_mut().enumerate() {
                    *b = j.button(i);
                }
                let h = self.scene.world.settings().timestep;
                let sc = &mut self.scene;
                return sc
                    .joystick
                    .apply(&self.axes, &self.buttons, h, &mut sc.controls, &mut sc.world)
                    .map_err(|_| msgs::RejectReason::Other);
            }
            msgs::InputCommand::Winch(w) => {
                let i = self.actuator(w.actuator.as_str())?;
                if !controls.actuators()[i].is_winch() {
                    return Err(unknown);
                }
                sets[0] = (i, w.drum_speed / controls.actuators()[i].unit_scale());
                n = 1;
            }
            msgs::InputCommand::Boom(b) => {
                for t in &b.targets {
                    let i = self.actuator(t.actuator.as_str())?;
                    let a = &controls.actuators()[i];
                    let v = t.value / a.unit_scale();
                    if !matches!(a.kind(), ActuatorKind::Velocity | ActuatorKind::Position) {
                        return Err(unknown);
                    }
                    // Read in the actuator's own mode: a speed, or a position target.
                    sets[n] = (i, v);
                    n += 1;
                }
            }
            msgs::InputCommand::Actuator(c) => {
                let i = self.actuator(c.actuator.as_str())?;
                let a = &controls.actuators()[i];
                if actuator_mode(a.kind()) != c.mode {
                    return Err(msgs::RejectReason::WrongMode);
                }
                let v = match a.kind() {
                    ActuatorKind::Brake | ActuatorKind::Clutch if a.max_force() > 0.0 => {
                        c.value / a.max_force()
                    }
                    ActuatorKind::Brake | ActuatorKind::Clutch => 0.0,
                    _ => c.value / a.unit_scale(),
                };
                sets[0] = (i, v);
                n = 1;
            }
        }
        if sets[..n].iter().any(|s| !s.1.is_finite()) {
            return Err(msgs::RejectReason::NonFinite);
        }
        for &(i, v) in &sets[..n] {
            self.scene.controls.set_index(i, v).map_err(|_| msgs::RejectReason::NonFinite)?;
        }
        Ok(())
    }

    /// Decodes a control request, carries it out and returns the encoded reply; a `load_scene` or
    /// `reset` is read and built on the calling thread, a lockstep request's steps are taken in
    /// turn ([`Engine::begin_control`] splits them; only the last step's frames are then left to
    /// read).
    pub fn handle_control(&mut self, bytes: &[u8]) -> Vec<u8> {
        match self.begin_control(bytes) {
            ControlStep::Reply(r) => r,
            ControlStep::Load(job) => self.finish_load(job.run()),
            ControlStep::Steps(mut job) => {
                while self.lockstep_step(&mut job) {}
                self.finish_steps(&job)
            }
        }
    }

    /// The steps of a `step` request, or why not now.
    fn steps_for(&self, count: u32) -> Result<u32, (msgs::ControlErrorCode, String)> {
        match self.paused {
            true => Ok(count),
            false => Err((msgs::ControlErrorCode::Busy, "`step` needs a paused world (pause first)".into())),
        }
    }

    /// The steps of a `run_until` request: to the step nearest `sim_time`, which must be ahead of
    /// the world's and at most [`msgs::MAX_STEP_COUNT`] steps away.
    fn steps_until(&self, sim_time: f64) -> Result<u32, (msgs::ControlErrorCode, String)> {
        use msgs::ControlErrorCode as E;
        if !self.paused {
            return Err((E::Busy, "`run_until` needs a paused world (pause first)".into()));
        }
        let w = &self.scene.world;
        let target = (sim_time / w.settings().timestep).round();
        let now = w.steps() as f64;
        if target <= now {
            return Err((E::InThePast, format!("run_until {sim_time} s: the world is at {} s", w.time())));
        }
        let n = target - now;
        if n > f64::from(msgs::MAX_STEP_COUNT) {
            let msg = format!("run_until {sim_time} s is {n} steps ahead (at most {})", msgs::MAX_STEP_COUNT);
            return Err((E::InvalidRequest, msg));
        }
        Ok(n as u32)
    }

    /// One step of a lockstep request, its frames encoded (for the caller to publish); `false`
    /// when the request is done (its last step taken, or a step failed: the world is then paused
    /// at its last good state).
    pub fn lockstep_step(&mut self, job: &mut StepJob) -> bool {
        if job.remaining == 0 {
            return false;
        }
        let ok = self.step_once();
        self.encode_frames(pivotsim_link::wall_ns());
        if !ok {
            job.remaining = 0;
            return false;
        }
        job.remaining -= 1;
        let r = &mut job.report;
        r.count += 1;
        for s in self.scene.world.island_stats() {
            r.island_solves = r.island_solves.saturating_add(1);
            if s.status != crate::solver::SolveStatus::Converged {
                r.not_converged = r.not_converged.saturating_add(1);
            }
            if s.residual_rel.is_finite() {
                r.max_residual_rel = r.max_residual_rel.max(s.residual_rel);
            }
        }
        job.remaining > 0
    }

    /// The encoded reply to a finished lockstep request.
    pub fn finish_steps(&self, job: &StepJob) -> Vec<u8> {
        let status = msgs::ServerStatus { steps: Some(job.report), ..self.status() };
        encode_reply(&msgs::ControlReply::ok(job.id, status))
    }

    /// Decodes a control request and carries it out, except a `load_scene` or `reset`, whose
    /// [`LoadJob`] it returns for the caller to run (on any thread) and hand to
    /// [`Engine::finish_load`].
    pub fn begin_control(&mut self, bytes: &[u8]) -> ControlStep {
        let reply = match msgs::ControlRequest::decode(bytes) {
            Err(e) => msgs::ControlRequest::rejection(bytes, &e),
            Ok(req) => {
                let scene_ref = match &req.command {
                    msgs::ControlCommand::Reset => Some(self.scene_ref.clone()),
                    msgs::ControlCommand::LoadScene { scene } => Some(scene.clone()),
                    _ => None,
                };
                if let Some(scene_ref) = scene_ref.filter(|_| self.replay.is_none()) {
                    let overrides =
                        if scene_ref == self.start_scene { self.overrides.clone() } else { Vec::new() };
                    return ControlStep::Load(LoadJob::new(
                        req.id,
                        &scene_ref,
                        self.policy.clone(),
                        overrides,
                    ));
                }
                let world_changing = matches!(
                    req.command,
                    msgs::ControlCommand::Fault { .. }
                        | msgs::ControlCommand::SetVariant { .. }
                        | msgs::ControlCommand::Restore { .. }
                );
                if world_changing && self.replay.is_some() {
                    let msg = "a recording is being replayed (until its end or --branch)";
                    return ControlStep::Reply(encode_reply(&msgs::ControlReply::error(
                        req.id,
                        msgs::ControlErrorCode::Busy,
                        msg,
                    )));
                }
                let lockstep = match req.command {
                    msgs::ControlCommand::Step { count } => Some(self.steps_for(count)),
                    msgs::ControlCommand::RunUntil { sim_time } => Some(self.steps_until(sim_time)),
                    _ => None,
                };
                match lockstep {
                    Some(Ok(count)) => {
                        let report = msgs::StepReport::default();
                        return ControlStep::Steps(StepJob { id: req.id, remaining: count, report });
                    }
                    Some(Err((code, msg))) => msgs::ControlReply::error(req.id, code, msg),
                    None if matches!(
                        req.command,
                        msgs::ControlCommand::Fault { .. } | msgs::ControlCommand::SetVariant { .. }
                    ) =>
                    {
                        // Acts on the world: journaled (a refused fault is an event too).
                        self.journal.record(msgs::AppliedKind::Control, bytes);
                        match self.control(&req.command) {
                            Ok(()) => msgs::ControlReply::ok(req.id, self.status()),
                            Err((code, msg)) => msgs::ControlReply::error(req.id, code, msg),
                        }
                    }
                    None => match self.control(&req.command) {
                        Ok(()) => msgs::ControlReply::ok(req.id, self.status()),
                        Err((code, msg)) => msgs::ControlReply::error(req.id, code, msg),
                    },
                }
            }
        };
        ControlStep::Reply(encode_reply(&reply))
    }

    /// The encoded error reply to request `id` (`busy`: a load while another is under way).
    pub fn error_reply(id: u64, code: msgs::ControlErrorCode, why: &str) -> Vec<u8> {
        encode_reply(&msgs::ControlReply::error(id, code, why))
    }

    /// Installs a finished load (at a step boundary) and returns the encoded reply to its request:
    /// the new scene paused at time 0 with a new sequence, or the failure with the running scene
    /// kept.
    pub fn finish_load(&mut self, loaded: Loaded) -> Vec<u8> {
        let reply = match self.install(loaded.result, &loaded.scene_ref) {
            Ok(()) => msgs::ControlReply::ok(loaded.id, self.status()),
            Err((code, msg)) => msgs::ControlReply::error(loaded.id, code, msg),
        };
        encode_reply(&reply)
    }

    fn control(&mut self, cmd: &msgs::ControlCommand) -> Result<(), (msgs::ControlErrorCode, String)> {
        use msgs::ControlCommand as C;
        use msgs::ControlErrorCode as E;
        match cmd {
            C::Pause => self.paused = true,
            C::Resume => {
                self.paused = false;
                self.failure = None;
            }
            // Loads and lockstep requests go through `begin_control`'s jobs.
            C::Reset | C::LoadScene { .. } | C::Step { .. } | C::RunUntil { .. } => {
                return Err((E::Internal, "not a direct control request".into()));
            }
            C::Snapshot { path } => self.write_snapshot(path)?,
            C::Keyframe => self.journal.request_keyframe(msgs::KeyframeReason::Requested),
            C::Restore { path } => self.restore_snapshot(path)?,
            C::SetVariant { variant } => {
                let v = Variant::from(*variant);
                let mut s = *self.scene.world.settings();
                s.solver.variant = v;
                self.scene.world.set_settings(s).map_err(|e| (E::Internal, e.to_string()))?;
                info!("solver variant switched to {}", v.name());
            }
            C::Fault { fault, target, tension, to, ramp } => {
                let req = scene::FaultRequest {
                    kind: fault.name().to_string(),
                    target: target.clone(),
                    tension: *tension,
                    to: *to,
                    ramp: *ramp,
                };
                self.scene.request_fault(&req).map_err(|e| (E::FaultRejected, e.to_string()))?;
                info!("fault {} on `{target}` requested", fault.name());
            }
        }
        Ok(())
    }

    fn install(
        &mut self,
        result: Result<Scene, LoadError>,
        scene_ref: &str,
    ) -> Result<(), (msgs::ControlErrorCode, String)> {
        let mut sc = result.map_err(|e| (e.code(), e.to_string()))?;
        // The live variant and the server's budget carry over to the new scene.
        let variant = self.scene.world.settings().solver.variant;
        let mut s = *sc.world.settings();
        s.solver.variant = variant;
        s.solver.max_solve_us = self.max_solve_us.or(s.solver.max_solve_us);
        sc.world.set_settings(s).map_err(|e| (msgs::ControlErrorCode::Internal, e.to_string()))?;
        info!("scene `{}` loaded from {}", sc.name, sc.source);
        self.scene = sc;
        self.scene_ref = scene_ref.to_string();
        self.paused = true;
        self.scene_changed();
        self.journal.new_scene_state();
        // A new state gets a new sequence: the previous one's frames stay its own.
        self.sequence += 1;
        self.encode_frames(pivotsim_link::wall_ns());
        Ok(())
    }

    /// One tick of the loop at time `now`: the deadman, then a step unless paused, then the frames.
    /// Returns whether a step was taken.
    pub fn tick(&mut self, now: Instant) -> bool {
        if self.manual && !self.health.deadman_active {
            let silent = self.last_input.is_none_or(|t| now.saturating_duration_since(t) > self.deadman);
            if silent && !self.replaying {
                self.trip_deadman();
                info!("deadman: no input for {:?}, actuators at neutral", self.deadman);
            }
        }
        if self.paused {
            return false;
        }
        let stepped = self.step_once();
        self.encode_frames(pivotsim_link::wall_ns());
        stepped
    }

    fn step_once(&mut self) -> bool {
        match self.replay_before_step() {
            ReplayStep::Step => {}
            ReplayStep::Installed => return true,
            ReplayStep::Stop | ReplayStep::Branched => return false,
        }
        let t0 = Instant::now();
        let r = if self.manual { self.scene.step_manual() } else { self.scene.step() };
        self.step_wall_us = t0.elapsed().as_secs_f64() * 1e6;
        match r {
            Ok(()) => {
                self.sequence += 1;
                for s in self.scene.world.island_stats() {
                    self.degraded.count(s.status.into(), s.fallback);
                }
                let found = self.watchdog.check(&self.scene.world);
                self.unstable = found.is_some();
                if let Some(i) = found
                    && self.watchdog.count().is_power_of_two()
                {
                    warn!("{}: unstable ({} steps flagged): {i}", self.scene.name, self.watchdog.count());
                }
                true
            }
            Err(e) => {
                warn!("step failed, world paused at its last good state: {e}");
                self.failure = Some(e.to_string());
                self.paused = true;
                false
            }
        }
    }

    /// Encodes the pose and stats frames of the current state (wall clock `wall_ns`).
    pub fn encode_frames(&mut self, wall_ns: u64) {
        let w = &self.scene.world;
        match msgs::PoseFrameWriter::begin(&mut self.pose_buf, self.sequence, w.time(), wall_ns) {
            Ok(mut fw) => {
                for (i, b) in w.bodies().iter().enumerate() {
                    let (x, q, v, om) = (b.position(), b.orientation(), b.linvel(), b.angvel());
                    let flags = match b.kind() {
                        BodyKind::Dynamic => 0,
                        BodyKind::Kinematic => msgs::BODY_KINEMATIC,
                        BodyKind::Static => msgs::BODY_STATIC,
                    };
                    let pose = msgs::BodyPose {
                        id: i as u32,
                        flags,
                        position: [x.x, x.y, x.z],
                        orientation: [q.i, q.j, q.k, q.w],
                        linear_velocity: [v.x, v.y, v.z],
                        angular_velocity: [om.x, om.y, om.z],
                    };
                    if let Err(e) = fw.push(&pose) {
                        warn!("pose of body {i} not encodable: {e}");
                    }
                }
            }
            Err(e) => warn!("pose frame not encodable: {e}"),
        }
        let st = &mut self.stats;
        st.sequence = self.sequence;
        st.sim_time = w.time();
        st.step_wall_us = self.step_wall_us;
        st.overruns = self.overruns;
        st.inputs = self.health;
        st.unstable = self.unstable;
        st.unstable_steps = self.watchdog.count().min(u64::from(u16::MAX)) as u16;
        st.degraded = self.degraded;
        st.islands.clear();
        for s in w.island_stats() {
            st.islands.push(s.into());
        }
        st.totals = msgs::StepTotals::from_islands(&st.islands);
        if let Err(e) = st.encode(&mut self.stats_buf) {
            warn!("stats frame not encodable: {e}");
        }
        let sig = &self.scene.signals;
        super::wire::fill_signals(sig, &self.channel_names, self.sequence, w.time(), &mut self.signals);
        if let Err(e) = self.signals.encode(&mut self.signals_buf) {
            warn!("signals frame not encodable: {e}");
        }
        self.events_buf.clear();
        let fresh = self.events_sequence != Some(self.sequence);
        if fresh && !sig.events().is_empty() {
            self.events_sequence = Some(self.sequence);
            super::wire::fill_events(sig, self.sequence, w.time(), &mut self.events);
            if let Err(e) = self.events.encode(&mut self.events_buf) {
                warn!("events frame not encodable: {e}");
            }
            for e in &self.events.events {
                info!(
                    "event {} {} at {:.3} s: value {} (level {})",
                    e.kind.name(),
                    e.name.as_str(),
                    e.time,
                    e.value,
                    e.level
                );
            }
        }
        if !self.controller_events.is_empty() {
            // With this state's events, or in a frame of their own (a paused state's: its
            // sequence may then carry two events frames, told apart by their records).
            if self.events_buf.is_empty() {
                self.events.sequence = self.sequence;
                self.events.sim_time = w.time();
                self.events.events_total = self.scene.signals.events_total();
                self.events.events.clear();
            }
            let room = msgs::MAX_EVENTS - self.events.events.len().min(msgs::MAX_EVENTS);
            let n = self.controller_events.len().min(room);
            self.events.events.extend(self.controller_events.drain(..n));
            self.controller_events.clear();
            if let Err(e) = self.events.encode(&mut self.events_buf) {
                warn!("events frame not encodable: {e}");
            }
        }
        self.journal.encode(self.sequence, &self.scene, &self.watchdog, self.manual);
        self.replay_check();
    }
}

/// Sets the server-wide solve time budget on a scene's world (`None`: the scene's own).
fn apply_budget(scene: &mut Scene, max_solve_us: Option<f64>) -> Result<(), crate::dynamics::SettingsError> {
    if let Some(us) = max_solve_us {
        let mut s = *scene.world.settings();
        s.solver.max_solve_us = Some(us);
        scene.world.set_settings(s)?;
    }
    Ok(())
}

/// Encodes a control reply; one too long for the wire is replaced by a short `internal` error.
fn encode_reply(reply: &msgs::ControlReply) -> Vec<u8> {
    let mut buf = Vec::new();
    if let Err(e) = reply.encode(&mut buf) {
        let r = msgs::ControlReply::error(reply.id, msgs::ControlErrorCode::Internal, format!("reply: {e}"));
        buf.clear();
        let _ = r.encode(&mut buf);
    }
    buf
}
