//! `serve` (the default command): its options, the start message (where it listens, how to
//! connect, which scene and transports are up) and the final report.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Context;
use pivotsim_server::serve::config::ControllerLost;
use pivotsim_server::serve::{MAX_DEADMAN_MS, ServeConfig, Started, ZenohOptions};

use super::values;

/// The scene `serve` runs when none is given.
pub const DEFAULT_SCENE: &str = "forklift";

/// Options of `serve`.
#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// A built-in scene name (see `scenes`) or a scene file path.
    #[arg(long, default_value = DEFAULT_SCENE)]
    pub scene: String,
    /// World name: keys are `pivotsim/<world>/...`.
    #[arg(long, default_value = pivotsim_msgs::DEFAULT_WORLD)]
    pub world: String,
    /// Zenoh endpoints to listen on (repeatable).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to: routers or peers on other hosts (repeatable).
    #[arg(long)]
    pub connect: Vec<String>,
    /// A Zenoh configuration file (JSON5) for multi-host rigs and routers.
    #[arg(long)]
    pub zenoh_config: Option<PathBuf>,
    /// Turn Zenoh multicast scouting on (off by default: nothing leaves the given endpoints).
    #[arg(long)]
    pub multicast_scouting: bool,
    /// Do not start Zenoh.
    #[arg(long)]
    pub no_zenoh: bool,
    /// Do not start iceoryx2.
    #[arg(long)]
    pub no_iceoryx2: bool,
    /// Simulated seconds per wall second: a finite number > 0 whose step period `h / rtf` is at
    /// most a minute.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0, value_parser = values::positive_finite)]
    pub rtf: f64,
    /// Step as fast as possible instead of in real time.
    #[arg(long)]
    pub fast: bool,
    /// Deadman timeout in milliseconds, 1 to 3,600,000: actuators return to neutral after this
    /// long without an input.
    #[arg(long, allow_negative_numbers = true, default_value_t = 250, value_parser = clap::value_parser!(u64).range(1..=MAX_DEADMAN_MS))]
    pub deadman_ms: u64,
    /// Seconds between status lines (0: none; default 1 s on a terminal, none otherwise).
    #[arg(long, allow_negative_numbers = true, value_parser = values::status_interval)]
    pub status_interval: Option<f64>,
    /// Stop after this many steps.
    #[arg(long, allow_negative_numbers = true)]
    pub steps: Option<u64>,
    /// Start paused.
    #[arg(long)]
    pub paused: bool,
    /// Override a setting of the start scene (repeatable; again at each reset):
    /// `contact_compliance=1e-10`, `body.log.mass=800` (scenes/README.md, "Overriding settings").
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<pivotsim_server::scene::SceneOverride>,
    /// Time budget of the island solves of one step (µs), a finite number above 0, for every scene
    /// loaded. A solve that spends it returns its best safe iterate (status `budget`, counted in
    /// the stats), so no step overruns because of the solver (default: the scene's `max_solve_us`).
    #[arg(long, value_parser = values::positive_finite, allow_negative_numbers = true)]
    pub max_solve_us: Option<f64>,
    /// Solver threads: a step's islands solved concurrently, bit-identical to one thread, for
    /// every scene loaded (1 ..= 256; default: the cores present; 1: every island in turn on the
    /// stepping thread).
    #[arg(long, value_parser = values::threads)]
    pub threads: Option<usize>,
    /// A directory whose scene files `load_scene` may read (repeatable; default: none, so peers
    /// can load built-in scenes only). Paths outside it, links leading out of it, FIFOs, devices
    /// and directories are refused (`load_refused`).
    #[arg(long = "scene-dir", value_name = "DIR")]
    pub scene_dirs: Vec<PathBuf>,
    /// Largest scene file `load_scene` or `reset` reads, in bytes (at least 1).
    #[arg(long, default_value_t = pivotsim_server::serve::loader::DEFAULT_MAX_SCENE_BYTES, value_parser = clap::value_parser!(u64).range(1..))]
    pub max_scene_bytes: u64,
    /// The directory where the `snapshot` control request writes and `restore` reads (files named
    /// relative to it; no `..`, no absolute paths). Default: none, so both are refused.
    #[arg(long, value_name = "DIR")]
    pub snapshot_dir: Option<PathBuf>,
    /// Seconds of simulation time between keyframes on `pivotsim/<world>/keyframes` (snapshots a
    /// recording replays from; 0: only at the start, at each load, reset and restore, and on the
    /// control request `keyframe`).
    #[arg(long, value_name = "S", default_value_t = pivotsim_server::serve::journal::DEFAULT_KEYFRAME_EVERY, value_parser = values::non_negative_finite)]
    pub keyframes: f64,
    /// What the server does when the last lockstep controller (a Zenoh liveliness token on
    /// `pivotsim/<world>/controller/<id>`, or an iceoryx2 node of that name) disappears: `pause` (stay paused, the default) or
    /// `resume` (real time goes on). Either way an event `controller-lost` says so.
    #[arg(long, value_name = "WHAT", default_value = "pause", value_parser = ["pause", "resume"])]
    pub on_controller_lost: String,
}

impl ServeArgs {
    /// The library's configuration from the options.
    pub fn config(self) -> ServeConfig {
        let status_interval = match self.status_interval {
            Some(s) if s > 0.0 => Duration::try_from_secs_f64(s).ok(),
            Some(_) => None,
            None => std::io::stderr().is_terminal().then(|| Duration::from_secs(1)),
        };
        ServeConfig {
            scene: self.scene,
            world: self.world,
            realtime_factor: if self.fast { None } else { Some(self.rtf) },
            deadman: Duration::from_millis(self.deadman_ms),
            zenoh: (!self.no_zenoh).then_some(ZenohOptions {
                listen: self.listen,
                connect: self.connect,
                config_file: self.zenoh_config,
                multicast_scouting: self.multicast_scouting,
            }),
            iceoryx2: !self.no_iceoryx2,
            status_interval,
            max_steps: self.steps,
            start_paused: self.paused,
            overrides: self.set,
            max_solve_us: self.max_solve_us,
            threads: self.threads.unwrap_or_else(values::default_threads),
            scene_dirs: self.scene_dirs,
            max_scene_bytes: self.max_scene_bytes,
            snapshot_dir: self.snapshot_dir,
            keyframes: self.keyframes,
            on_controller_lost: match self.on_controller_lost.as_str() {
                "resume" => ControllerLost::Resume,
                _ => ControllerLost::Pause,
            },
            slow_load: None,
        }
    }
}

/// Runs `serve` until Ctrl-C (or `--steps`).
pub fn serve(args: ServeArgs) -> anyhow::Result<()> {
    super::init_tracing();
    let config = args.config();
    let shutdown = Arc::new(AtomicBool::new(false));
    let flag = shutdown.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;
    let report = pivotsim_server::serve::run_with(&config, shutdown, |s: &Started| {
        println!("{}", start_message(s));
    })?;
    println!(
        "{} steps, {:.2} s simulated in {:.2} s, {} overruns; inputs {} accepted, {} rejected, deadman trips {}",
        report.steps,
        report.sim_time,
        report.wall_s,
        report.overruns,
        report.inputs.accepted,
        report.inputs.rejected_total(),
        report.inputs.deadman_trips
    );
    Ok(())
}

/// The start message: the scene, the world, each transport that is up with where it listens,
/// and the commands that connect to it.
pub fn start_message(s: &Started) -> String {
    let mut m = format!(
        "pivotsim-server: scene `{}` ({} bodies, h = {:.4} s, {}) as world `{}`\n",
        s.scene, s.bodies, s.timestep, s.pace, s.world
    );
    if s.transports.is_empty() {
        m.push_str("  no transport is up (--no-zenoh --no-iceoryx2): nothing can connect\n");
    }
    for t in &s.transports {
        m.push_str(&format!("  {t}\n"));
    }
    let world =
        if s.world == pivotsim_msgs::DEFAULT_WORLD { String::new() } else { format!(" --world {}", s.world) };
    let connect = match s.zenoh_connect_hint.as_deref() {
        Some(ep) if ep != "tcp/127.0.0.1:7447" => format!(" --connect {ep}"),
        _ => String::new(),
    };
    if !s.transports.is_empty() {
        m.push_str("connect:\n");
        m.push_str(&format!("  cargo run --release -p pivotsim-client --{world}{connect} watch\n"));
        m.push_str(&format!("  cargo run --release -p pivotsim-client --{world}{connect} drive\n"));
        if s.zenoh_connect_hint.is_some() {
            m.push_str(&format!("  cargo run --release -p pivotsim-ros2-bridge --{world}{connect}   (ROS 2: /tf, markers, /joy)\n"));
        }
    }
    m.push_str("Ctrl-C stops the server.");
    m
}
