//! `send`: one operator command from the command line.
//!
//! ```text
//! send winch ACTUATOR SPEED                               drum speed (rad/s, + hauls in)
//! send actuator NAME VALUE [--mode velocity|position|effort]
//! send boom NAME=V [NAME=V …]                             targets in each actuator's mode
//! send joystick --axes a,b,c [--buttons BITS]
//! ```
//!
//! The sequence is the current time in ns (successive sends are fresh), the source id random per
//! run unless `--source-id`. The command is checked against the scene description when the server
//! answers the scene query (unknown actuator, winch command to a motor). The server's deadman
//! returns every actuator to neutral 250 ms after the last input: `--hold S` repeats the command
//! at `--rate` for S seconds. Afterwards the server's input counters (stats frames) say whether it
//! was accepted or rejected and why; a rejection exits with status 2.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::net::{InputSink, Stream, TransportKind, now_ns};
use crate::stop::{interrupted, secs};

/// `send` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Transport to send on.
    #[arg(long, value_enum, default_value = "zenoh", global = true)]
    pub transport: TransportKind,
    /// Keep sending the command (fresh sequence each time) for this many seconds.
    #[arg(long, value_name = "SECONDS", global = true)]
    pub hold: Option<f64>,
    /// Frames per second while holding.
    #[arg(long, default_value_t = 30.0, value_name = "HZ", global = true)]
    pub rate: f64,
    /// Source id (default: random).
    #[arg(long, value_name = "ID", global = true)]
    pub source_id: Option<u32>,
    /// Do not wait for the server's input counters.
    #[arg(long, global = true)]
    pub no_verify: bool,
    /// Send even when the scene description says the command is invalid.
    #[arg(long, global = true)]
    pub force: bool,
    #[command(subcommand)]
    pub what: What,
}

/// The command.
#[derive(Debug, Clone, clap::Subcommand)]
pub enum What {
    /// Winch drum speed (rad/s; positive hauls in).
    #[command(allow_negative_numbers = true)]
    Winch {
        /// Winch actuator name.
        actuator: String,
        /// Drum speed (rad/s).
        speed: f64,
    },
    /// One value for one actuator.
    #[command(allow_negative_numbers = true)]
    Actuator {
        /// Actuator name.
        name: String,
        /// Value in the mode's unit.
        value: f64,
        /// What the value means (default: the actuator's mode from the scene, else velocity).
        #[arg(long, value_parser = ["velocity", "position", "effort"])]
        mode: Option<String>,
    },
    /// Velocity targets for several actuators at once.
    Boom {
        /// NAME=VALUE pairs.
        #[arg(required = true, allow_hyphen_values = true, value_name = "NAME=VALUE")]
        targets: Vec<String>,
    },
    /// A joystick state.
    Joystick {
        /// Axis values in [-1, 1], comma-separated (axis 0 first).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_name = "A,B,…")]
        axes: Vec<f32>,
        /// Pressed buttons as a bit mask (decimal, 0x…, or 0b…).
        #[arg(long, default_value = "0", value_name = "BITS")]
        buttons: String,
        /// Buttons in use (default: up to the highest set bit).
        #[arg(long, value_name = "N")]
        button_count: Option<u8>,
    },
}

fn parse_bits(s: &str) -> Result<u64> {
    let s = s.trim().replace('_', "");
    let r = if let Some(h) = s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        u64::from_str_radix(h, 16)
    } else if let Some(b) = s.strip_prefix("0b").or_else(|| s.strip_prefix("0B")) {
        u64::from_str_radix(b, 2)
    } else {
        s.parse()
    };
    r.map_err(|e| anyhow!("buttons {s:?}: {e}"))
}

fn name(s: &str) -> Result<msgs::ActuatorName> {
    msgs::ActuatorName::new(s).map_err(|e| anyhow!("actuator name {s:?}: {e}"))
}

/// The input command (sequence and source filled by the caller per frame).
pub fn build(what: &What, scene: Option<&msgs::SceneDescription>) -> Result<msgs::InputCommand> {
    Ok(match what {
        What::Winch { actuator, speed } => msgs::InputCommand::Winch(msgs::WinchCommand {
            sequence: 0,
            source_id: 0,
            actuator: name(actuator)?,
            drum_speed: *speed,
        }),
        What::Actuator { name: n, value, mode } => {
            let mode = match mode {
                Some(m) => msgs::ActuatorMode::from_name(m).ok_or_else(|| anyhow!("mode {m:?}"))?,
                None => scene.and_then(|s| s.actuator(n)).map_or(msgs::ActuatorMode::Velocity, |a| a.mode),
            };
            msgs::InputCommand::Actuator(msgs::ActuatorCommand {
                sequence: 0,
                source_id: 0,
                mode,
                actuator: name(n)?,
                value: *value,
            })
        }
        What::Boom { targets } => {
            let targets = targets
                .iter()
                .map(|t| {
                    let (n, v) = t.split_once('=').ok_or_else(|| anyhow!("{t:?} is not NAME=VALUE"))?;
                    let value: f64 = v.trim().parse().with_context(|| format!("value of {n}"))?;
                    Ok(msgs::BoomTarget { actuator: name(n.trim())?, value })
                })
                .collect::<Result<Vec<_>>>()?;
            msgs::InputCommand::Boom(msgs::BoomCommand { sequence: 0, source_id: 0, targets })
        }
        What::Joystick { axes, buttons, button_count } => {
            let bits = parse_bits(buttons)?;
            let count = match button_count {
                Some(c) => *c,
                None => (64 - bits.leading_zeros()) as u8,
            };
            let j = msgs::Joystick::new(0, 0, axes, bits, count)
                .ok_or_else(|| anyhow!("{} axes (at most {})", axes.len(), msgs::MAX_AXES))?;
            msgs::InputCommand::Joystick(j)
        }
    })
}

/// Sets the sequence and source of an input.
pub fn stamp(cmd: &mut msgs::InputCommand, sequence: u64, source: u32) {
    match cmd {
        msgs::InputCommand::Joystick(j) => (j.sequence, j.source_id) = (sequence, source),
        msgs::InputCommand::Winch(w) => (w.sequence, w.source_id) = (sequence, source),
        msgs::InputCommand::Boom(b) => (b.sequence, b.source_id) = (sequence, source),
        msgs::InputCommand::Actuator(a) => (a.sequence, a.source_id) = (sequence, source),
    }
}

/// The topic an input goes on.
pub fn topic_of(cmd: &msgs::InputCommand) -> Topic {
    match cmd {
        msgs::InputCommand::Joystick(_) => Topic::Joystick,
        msgs::InputCommand::Winch(_) => Topic::Winch,
        msgs::InputCommand::Boom(_) => Topic::Boom,
        msgs::InputCommand::Actuator(_) => Topic::Actuator,
    }
}

/// Input counters of the server (from a stats frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Counters(pub msgs::InputHealth);

impl Counters {
    /// What changed from `before`: accepted, and rejected by reason.
    pub fn delta(&self, before: &Counters) -> (u64, Vec<(msgs::RejectReason, u64)>) {
        let acc = self.0.accepted.saturating_sub(before.0.accepted);
        let rej = msgs::RejectReason::ALL
            .iter()
            .filter_map(|r| {
                let d = self.0.rejected_for(*r).saturating_sub(before.0.rejected_for(*r));
                (d > 0).then_some((*r, d))
            })
            .collect();
        (acc, rej)
    }
}

/// The latest input counters in `stream`, waiting at most `wait` for a stats frame.
fn latest_counters(stream: &Stream, wait: Duration) -> Option<Counters> {
    let deadline = Instant::now() + wait;
    let mut latest = None;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let r = if latest.is_some() { stream.inbox.try_recv() } else { stream.inbox.recv_timeout(left) };
        match r {
            Some(r) => {
                if let Ok(s) = msgs::SolverStats::decode(&r.bytes) {
                    latest = Some(Counters(s.inputs));
                }
            }
            None if latest.is_some() || left.is_zero() => return latest,
            None => {}
        }
    }
}

/// Runs `send`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let timeout = common.timeout_or(5.0);
    let world = common.world()?;
    // Zenoh for the scene (and for the inputs on the zenoh transport).
    let (link, scene) = crate::util::input_link(common, args.transport, timeout)?;
    let mut cmd = build(&args.what, scene.as_ref())?;
    stamp(&mut cmd, 1, 1);
    cmd.validate().map_err(|e| anyhow!("invalid command: {e}"))?;
    check_against_scene(scene.as_ref(), &cmd, args.force)?;
    let stats = if args.no_verify {
        None
    } else {
        let s = Stream::open(
            &common.server()?,
            args.transport,
            &[Topic::Stats],
            256,
            Duration::from_micros(500),
            None,
        )?;
        Some(s)
    };
    let before = stats.as_ref().and_then(|s| latest_counters(s, Duration::from_millis(400)));
    let topic = topic_of(&cmd);
    let mut sink = InputSink::open(args.transport, &world, timeout)?;
    let source = args.source_id.unwrap_or_else(crate::util::random_u32);
    let hold = args.hold.map(secs).unwrap_or_default();
    let period = secs(1.0 / args.rate.clamp(1.0, 1000.0));
    let start = Instant::now();
    let mut sent = 0u64;
    let mut buf = Vec::new();
    let mut next = Instant::now();
    loop {
        stamp(&mut cmd, now_ns(), source);
        cmd.encode(&mut buf).map_err(|e| anyhow!("encode: {e}"))?;
        sink.send(link.as_ref(), topic, &buf, timeout)?;
        sent += 1;
        next += period;
        if start.elapsed() >= hold || interrupted() {
            break;
        }
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
    }
    let mut line = format!("sent {sent} {} frame(s) as source {source:#010x}", topic.suffix());
    let mut code = ExitCode::SUCCESS;
    match (&stats, before) {
        (Some(stats), Some(before)) => {
            let (verdict, rejected) = server_verdict(stats, &before, sent, timeout);
            line.push_str(&verdict);
            if rejected {
                code = ExitCode::from(2);
            }
        }
        (Some(_), None) => line.push_str("; no stats frames (server paused?): outcome unknown"),
        (None, _) => std::thread::sleep(Duration::from_millis(100)),
    }
    if matches!(sink, InputSink::Iox(_)) {
        // An iceoryx2 sample lives in this process's data segment: once the publisher is gone, a
        // subscriber that has not polled yet (a recorder, a bridge, polling at its own rate) loses
        // it. The server's verdict above says only that the server has it; linger for the others.
        std::thread::sleep(IOX_LINGER);
    }
    println!("{line}");
    Ok(code)
}

/// Checks `cmd` against the scene description when there is one: an invalid command is an error,
/// or with `force` a warning.
fn check_against_scene(
    scene: Option<&msgs::SceneDescription>,
    cmd: &msgs::InputCommand,
    force: bool,
) -> Result<()> {
    match scene {
        Some(s) => {
            if let Err(e) = s.check_input(cmd) {
                let names: Vec<&str> = s.actuators.iter().map(|a| a.name.as_str()).collect();
                let msg = format!("{e} (scene `{}` has actuators: {})", s.scene, names.join(", "));
                if !force {
                    bail!("{msg}; --force sends it anyway");
                }
                eprintln!("pivotsim-client: warning: {msg}");
            }
        }
        None => eprintln!("pivotsim-client: no scene description: the command is not checked"),
    }
    Ok(())
}

/// The server's verdict on the `sent` frames, from its input counters since `before` (waiting until
/// they account for every frame, at most `timeout` and 2 s): the text for the report line, and
/// whether the frames were rejected with none accepted.
fn server_verdict(stats: &Stream, before: &Counters, sent: u64, timeout: Duration) -> (String, bool) {
    let deadline = Instant::now() + timeout.min(Duration::from_secs(2));
    let mut last = (0, Vec::new());
    while Instant::now() < deadline && !interrupted() {
        if let Some(c) = latest_counters(stats, Duration::from_millis(100)) {
            last = c.delta(before);
            if last.0 + last.1.iter().map(|r| r.1).sum::<u64>() >= sent {
                break;
            }
        }
    }
    let (acc, rej) = last;
    let mut text = format!("; server: {acc} accepted");
    let mut rejected = false;
    if !rej.is_empty() {
        let r: Vec<String> = rej.iter().map(|(r, n)| format!("{n} {}", r.name())).collect();
        text.push_str(&format!(", rejected: {}", r.join(", ")));
        rejected = acc == 0;
    }
    (text, rejected)
}

/// How long `send` keeps its iceoryx2 publisher after the last frame, for subscribers other than
/// the server to take the samples (they poll every few milliseconds).
const IOX_LINGER: Duration = Duration::from_millis(200);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_parse_in_three_bases() {
        assert_eq!(parse_bits("5").unwrap(), 5);
        assert_eq!(parse_bits("0x10").unwrap(), 16);
        assert_eq!(parse_bits("0b101").unwrap(), 5);
        assert!(parse_bits("x").is_err());
    }

    #[test]
    fn commands_build_and_validate() {
        let c = build(&What::Boom { targets: vec!["slew=0.5".into(), "lift=-1".into()] }, None).unwrap();
        c.validate().unwrap();
        assert_eq!(topic_of(&c), Topic::Boom);
        let j = build(
            &What::Joystick { axes: vec![0.5, -1.0], buttons: "0b100".into(), button_count: None },
            None,
        )
        .unwrap();
        let msgs::InputCommand::Joystick(j) = j else { panic!() };
        assert_eq!(j.button_count, 3);
        assert!(j.button(2));
        assert_eq!(j.axes(), &[0.5, -1.0]);
        assert!(build(&What::Boom { targets: vec!["nope".into()] }, None).is_err());
    }
}
