//! `pivotsim-client`: the operator console and probes of the pivotsim server.
//!
//! | command | what it does | transports |
//! |---|---|---|
//! | `watch` | live table of solver stats and body poses (`--signals`: sensor channels, contact states, events) | zenoh, iceoryx2 |
//! | `drive` | keyboard or gamepad → joystick frames at 30–60 Hz | zenoh, iceoryx2 |
//! | `send` | one winch, actuator, boom or joystick command | zenoh, iceoryx2 |
//! | `scene` | the scene description (summary or JSON) | zenoh |
//! | `control` | pause, resume, step, run until, snapshot, restore, reset, solver variant, load scene | zenoh, iceoryx2 |
//! | `fault` | inject a fault (rope break, hose burst, brake fade, sticking valve, sensor dropout) | zenoh |
//! | `record` | poses, stats and inputs into an MCAP file Foxglove opens | zenoh, iceoryx2 |
//! | `foxglove` | the world live in Foxglove (WebSocket on 127.0.0.1:8765): shapes, transforms, stats | zenoh, iceoryx2 |
//! | `ping` | pose latency publish → receive, percentiles and histogram | zenoh, iceoryx2 |
//! | `lockstep` | a controller in the loop: step, read the pose, send the next input; round trips per second | zenoh, iceoryx2 |
//!
//! Everything stays on loopback unless told otherwise: Zenoh connects to `tcp/127.0.0.1:7447` as a
//! peer that listens on nothing, with multicast scouting off; iceoryx2 is same-host by nature.
//! Every loop is bounded by a count and/or a time, and Ctrl-C stops every command cleanly.
//! Malformed frames are counted and skipped.

mod common;
mod control;
mod control_link;
mod drive;
mod fault;
mod fox;
mod foxglove_live;
mod keymap;
mod lockstep;
mod net;
mod ping;
mod record;
mod scene;
mod send;
mod signals;
mod stop;
mod tojson;
mod util;
mod watch;

use clap::{Parser, Subcommand};

use common::Common;

/// Operator console and probes for the pivotsim server.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(flatten)]
    common: Common,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Live table of solver stats and body poses.
    Watch(watch::Args),
    /// Drive the scene's actuators from the keyboard or a gamepad (joystick frames).
    Drive(drive::Args),
    /// Send one command (winch, actuator, boom, joystick).
    Send(send::Args),
    /// Print the scene description.
    Scene(scene::Args),
    /// Pause, resume, step, run until a time, snapshot, restore, reset, switch the solver variant
    /// or load a scene.
    Control(control::Args),
    /// Inject a fault (instructor station): break, hose_burst, brake_fade, stick_valve, dropout.
    Fault(fault::Args),
    /// Record poses, stats and inputs into an MCAP file (Foxglove opens it).
    Record(record::Args),
    /// Pose latency, server publish → client receive.
    Ping(ping::Args),
    /// A controller in the loop (lockstep): step, read that step's pose, send the next input;
    /// reports round trips per second.
    Lockstep(lockstep::Args),
    /// Serve the world live to Foxglove (WebSocket protocol, ws://127.0.0.1:8765 by default).
    Foxglove(foxglove_live::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // iceoryx2 logs warnings such as "no config file" on stderr: errors only (IOX2_LOG_LEVEL overrides).
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    stop::install_handler();
    let r = match &cli.command {
        Command::Watch(a) => watch::run(&cli.common, a),
        Command::Drive(a) => drive::run(&cli.common, a),
        Command::Send(a) => send::run(&cli.common, a),
        Command::Scene(a) => scene::run(&cli.common, a),
        Command::Control(a) => control::run(&cli.common, a),
        Command::Fault(a) => fault::run(&cli.common, a),
        Command::Record(a) => record::run(&cli.common, a),
        Command::Ping(a) => ping::run(&cli.common, a),
        Command::Lockstep(a) => lockstep::run(&cli.common, a),
        Command::Foxglove(a) => foxglove_live::run(&cli.common, a),
    };
    match r {
        Ok(code) => code,
        Err(e) => {
            eprintln!("pivotsim-client: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
