//! `pivotsim-ros2-bridge`: the pivotsim server on ROS 2 (see the crate documentation and
//! `bridge/README.md`).

use std::net::IpAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, ValueEnum};

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Stamp {
    /// Simulation time (as on /clock; run ROS nodes with use_sim_time:=true).
    Sim,
    /// The server's wall clock at the end of each step.
    Wall,
}

/// Bridge a pivotsim world to ROS 2: /tf, /tf_static, /pivotsim/pose_array, /pivotsim/markers,
/// /pivotsim/diagnostics, /clock, the signals (/pivotsim/signal_values, /pivotsim/signals/<sensor> wrenches,
/// /pivotsim/contact_markers) and events (/rosout) out, /joy in. No ROS installation needed.
#[derive(Debug, Parser)]
#[command(version, about)]
struct Cli {
    /// World name of the server.
    #[arg(long, default_value = pivotsim_msgs::DEFAULT_WORLD)]
    world: String,
    /// Zenoh endpoint of the server (repeatable).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    connect: Vec<String>,
    /// Zenoh configuration file (JSON5) instead of the loopback client defaults.
    #[arg(long)]
    zenoh_config: Option<PathBuf>,
    /// DDS domain id (default: $ROS_DOMAIN_ID, else 0).
    #[arg(long, allow_negative_numbers = true)]
    domain_id: Option<u16>,
    /// Use only this local interface address for DDS (repeatable; e.g. 127.0.0.1 keeps
    /// everything on this host). Default: every interface.
    #[arg(long = "dds-interface")]
    dds_interfaces: Vec<IpAddr>,
    /// Frame every body is placed in.
    #[arg(long, default_value = "world")]
    world_frame: String,
    /// Clock of the message stamps.
    #[arg(long, value_enum, default_value = "sim")]
    stamp: Stamp,
    /// Topic of the operator input (sensor_msgs/Joy).
    #[arg(long, default_value = pivotsim_ros2_bridge::topics::JOY)]
    joy_topic: String,
    /// ROS node name.
    #[arg(long, default_value = "pivotsim_bridge")]
    node_name: String,
    /// /pivotsim/diagnostics rate (Hz), 0.01 to 1000.
    #[arg(long, allow_negative_numbers = true, default_value_t = 10.0, value_parser = stats_rate)]
    stats_rate: f64,
    /// Joystick source id of the forwarded frames (default: random).
    #[arg(long, allow_negative_numbers = true)]
    source_id: Option<u32>,
    /// Length of the contact-force arrows on /pivotsim/contact_markers per newton (m/N), 1e-9 to
    /// 1000 (default 0.001: 1 m per kN).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.001, value_parser = force_scale)]
    force_scale: f64,
    /// Log the counters every this many seconds (0: never; else 0.001 to 86400).
    #[arg(long, allow_negative_numbers = true, default_value_t = 10.0, value_parser = log_interval)]
    log_interval: f64,
}

/// `--stats-rate`: a finite rate from 0.01 to 1000 Hz (a hostile value is a clear error).
fn stats_rate(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if (0.01..=1000.0).contains(&v) { Ok(v) } else { Err(format!("{v} Hz is not from 0.01 to 1000 Hz")) }
}

/// `--force-scale`: a finite scale from 1e-9 to 1000 m/N.
fn force_scale(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if (1e-9..=1000.0).contains(&v) { Ok(v) } else { Err(format!("{v} m/N is not from 1e-9 to 1000 m/N")) }
}

/// `--log-interval`: 0 (never) or a finite number of seconds up to a day.
fn log_interval(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if v == 0.0 || (0.001..=86_400.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} s is neither 0 (never) nor from 0.001 to 86400 s"))
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // RustDDS's UDP listener logs one ERROR of its own, "leave_multicast_group", when a socket
    // that never joined its multicast group (`--dds-interface 127.0.0.1`: no multicast interface)
    // closes at shutdown; it is its module's only error, so that module is silenced by default.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
            "info,zenoh=warn,rustdds=error,rustdds::network::udp_listener=off,ros2_client=warn".into()
        }))
        .with_writer(std::io::stderr)
        // Colours only on a terminal: a log file or a pipe gets plain text.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
    let domain_id = match cli.domain_id {
        Some(d) => d,
        None => match std::env::var("ROS_DOMAIN_ID").ok().filter(|s| !s.is_empty()) {
            None => 0,
            Some(s) => match s.parse() {
                Ok(d) => d,
                Err(_) => {
                    eprintln!("error: ROS_DOMAIN_ID={s:?} is not a domain id");
                    return ExitCode::FAILURE;
                }
            },
        },
    };
    let config = pivotsim_ros2_bridge::BridgeConfig {
        world: cli.world,
        connect: cli.connect,
        zenoh_config: cli.zenoh_config,
        domain_id,
        dds_interfaces: cli.dds_interfaces,
        world_frame: cli.world_frame,
        stamp: match cli.stamp {
            Stamp::Sim => pivotsim_ros2_bridge::StampSource::Sim,
            Stamp::Wall => pivotsim_ros2_bridge::StampSource::Wall,
        },
        joy_topic: cli.joy_topic,
        node_name: cli.node_name,
        stats_period: Duration::from_secs_f64(1.0 / cli.stats_rate),
        source_id: cli.source_id,
        log_interval: (cli.log_interval > 0.0).then(|| Duration::from_secs_f64(cli.log_interval)),
        force_scale: cli.force_scale,
        ..Default::default()
    };
    run(config)
}

#[cfg(feature = "ros2")]
fn run(config: pivotsim_ros2_bridge::BridgeConfig) -> ExitCode {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let shutdown = Arc::new(AtomicBool::new(false));
    let flag = shutdown.clone();
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)) {
        eprintln!("warning: no Ctrl-C handler: {e}");
    }
    match pivotsim_ros2_bridge::run(&config, shutdown) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(not(feature = "ros2"))]
fn run(_config: pivotsim_ros2_bridge::BridgeConfig) -> ExitCode {
    eprintln!("error: built without ROS 2 support (cargo feature `ros2` of pivotsim-ros2-bridge)");
    ExitCode::FAILURE
}
