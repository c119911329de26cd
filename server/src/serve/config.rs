//! What the server runs and how ([`ServeConfig`], [`ZenohOptions`]), and why it could not start
//! ([`ServeError`]): plain data the CLI fills and tests build, checked once by [`super::run`].

use std::path::PathBuf;
use std::time::Duration;

use pivotsim_msgs as msgs;
use thiserror::Error;

/// Longest deadman timeout accepted (one hour), in ms; the shortest is 1 ms.
pub const MAX_DEADMAN_MS: u64 = 3_600_000;

/// Longest step period `h / rtf` accepted (a minute): a smaller real-time factor is refused.
pub const MAX_STEP_PERIOD: Duration = Duration::from_secs(60);

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
    /// Solver threads of every scene loaded (`World::set_threads`; 1: serial).
    pub threads: usize,
    /// Directories whose scene files `load_scene` may read (`--scene-dir`, repeatable; none by
    /// default: built-in scenes and the start scene only). `serve/loader.rs` states the rules.
    pub scene_dirs: Vec<PathBuf>,
    /// Largest scene file `load_scene` or `reset` reads (bytes; `--max-scene-bytes`).
    pub max_scene_bytes: u64,
    /// Test hook: every scene load waits this long before it reads (slow storage).
    pub slow_load: Option<Duration>,
    /// Where the `snapshot` control request writes and `restore` reads (`--snapshot-dir`; `None`:
    /// both are refused).
    pub snapshot_dir: Option<PathBuf>,
    /// Keyframes on `keyframes` every this many seconds of simulation time (`--keyframes`; 0:
    /// only at new scene states and on request).
    pub keyframes: f64,
    /// What the server does when the last lockstep controller disappears (`--on-controller-lost`).
    pub on_controller_lost: ControllerLost,
}

/// What the server does when a lockstep controller's liveliness token goes away (it crashed, was
/// killed, or lost its link).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ControllerLost {
    /// Stay paused: the world waits for a controller (the default: a rig's plant does not run on
    /// without the controller under test).
    #[default]
    Pause,
    /// Resume real time: the world goes on, driven by its script or operators.
    Resume,
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
            threads: 1,
            scene_dirs: Vec::new(),
            max_scene_bytes: super::loader::DEFAULT_MAX_SCENE_BYTES,
            slow_load: None,
            snapshot_dir: None,
            keyframes: super::journal::DEFAULT_KEYFRAME_EVERY,
            on_controller_lost: ControllerLost::Pause,
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

pub(crate) fn check_deadman(deadman: Duration) -> Result<(), ServeError> {
    if deadman.is_zero() || deadman > Duration::from_millis(MAX_DEADMAN_MS) {
        return Err(ServeError::Option(format!(
            "deadman timeout {deadman:?} must be from 1 ms to {MAX_DEADMAN_MS} ms (every input would trip a zero one)"
        )));
    }
    Ok(())
}
