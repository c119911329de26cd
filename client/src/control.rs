//! `control`: one control request on the world's `control` queryable (Zenoh) or request-response
//! service (`--transport iceoryx2`, same host); prints the reply — after a lockstep request
//! (`step`, `run-until`) also the steps taken and how their island solves ended — and exits
//! non-zero when the server refused or failed.

use std::process::ExitCode;

use anyhow::{Result, anyhow};
use pivotsim_msgs as msgs;

use crate::common::Common;
use crate::control_link::ControlLink;
use crate::net::TransportKind;

/// `control` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub op: Op,
    /// Print the reply as JSON.
    #[arg(long)]
    pub json: bool,
    /// Transport of the request: the Zenoh queryable, or the iceoryx2 request-response service
    /// (same host).
    #[arg(long, value_enum, default_value = "zenoh")]
    pub transport: TransportKind,
}

/// The request.
#[derive(Debug, Clone, clap::Subcommand)]
pub enum Op {
    /// Stop stepping.
    Pause,
    /// Step in real time again.
    Resume,
    /// Advance a paused world by N steps (1 ..= 3600).
    Step {
        /// Steps.
        count: u32,
    },
    /// Advance a paused world to the step nearest a simulation time (s), publishing every step.
    #[command(allow_negative_numbers = true)]
    RunUntil {
        /// Simulation time (s).
        sim_time: f64,
    },
    /// Write the world's complete state to a file in the server's snapshot directory
    /// (`serve --snapshot-dir`).
    Snapshot {
        /// File name relative to the server's snapshot directory.
        path: String,
    },
    /// Put back the state of a snapshot file of the running scene (paused, new sequence).
    Restore {
        /// File name relative to the server's snapshot directory.
        path: String,
    },
    /// Publish a keyframe (a snapshot on `keyframes`) of the current state with the next frames,
    /// for a recorder that starts mid-session.
    Keyframe,
    /// Restart the current scene, paused at time 0.
    Reset,
    /// Switch the solver variant (full, downdate, skyline, skyline-refactor, incremental, auto, pgs).
    Variant {
        /// Variant name.
        name: String,
    },
    /// Load a scene, paused at time 0: a built-in name, or a file in one of the server's scene
    /// directories (`serve --scene-dir`; anything else is refused as `load_refused`).
    Load {
        /// Scene name or path.
        scene: String,
    },
}

impl Op {
    /// The wire command.
    pub fn command(&self) -> Result<msgs::ControlCommand> {
        Ok(match self {
            Op::Pause => msgs::ControlCommand::Pause,
            Op::Resume => msgs::ControlCommand::Resume,
            Op::Step { count } => msgs::ControlCommand::Step { count: *count },
            Op::RunUntil { sim_time } => msgs::ControlCommand::RunUntil { sim_time: *sim_time },
            Op::Snapshot { path } => msgs::ControlCommand::Snapshot { path: path.clone() },
            Op::Restore { path } => msgs::ControlCommand::Restore { path: path.clone() },
            Op::Keyframe => msgs::ControlCommand::Keyframe,
            Op::Reset => msgs::ControlCommand::Reset,
            Op::Variant { name } => msgs::ControlCommand::SetVariant {
                variant: msgs::SolverVariant::from_name(name).ok_or_else(|| {
                    anyhow!("unknown solver variant {name:?} (one of {})", msgs::SOLVER_VARIANTS.join(", "))
                })?,
            },
            Op::Load { scene } => msgs::ControlCommand::LoadScene { scene: scene.clone() },
        })
    }
}

/// Runs `control`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    request_on(common, args.transport, args.op.command()?, args.json)
}

/// Sends one control request over Zenoh, prints the reply; exit code 2 when the server refused it.
pub fn request(common: &Common, command: msgs::ControlCommand, json: bool) -> Result<ExitCode> {
    request_on(common, TransportKind::Zenoh, command, json)
}

/// A fresh request id: below 2^53 (JavaScript clients read them exactly), never 0.
pub fn fresh_id() -> u64 {
    (crate::net::now_ns() & ((1u64 << 53) - 1)).max(1)
}

/// [`request`] over `transport`.
pub fn request_on(
    common: &Common,
    transport: TransportKind,
    command: msgs::ControlCommand,
    json: bool,
) -> Result<ExitCode> {
    let id = fresh_id();
    let req = msgs::ControlRequest { id, command };
    req.validate().map_err(|e| anyhow!("invalid request: {e}"))?;
    let mut link = ControlLink::open(common, transport)?;
    let reply = link.request(&req, common.timeout_or(5.0))?;
    if json {
        println!("{}", serde_json::to_string(&reply)?);
    }
    if reply.id != id {
        eprintln!("pivotsim-client: warning: reply id {} for request {id}", reply.id);
    }
    match reply.outcome {
        msgs::ControlOutcome::Ok(s) => {
            if !json {
                println!(
                    "ok: scene {}  {}  sequence {}  sim time {:.4} s  variant {}",
                    s.scene,
                    if s.paused { "paused" } else { "running" },
                    s.sequence,
                    s.sim_time,
                    s.variant.name()
                );
                if let Some(r) = s.steps {
                    println!("{}", steps_line(&r));
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        msgs::ControlOutcome::Error(f) => {
            let code = serde_json::to_value(f.code).ok().and_then(|v| v.as_str().map(String::from));
            eprintln!("error ({}): {}", code.as_deref().unwrap_or("?"), f.message);
            Ok(ExitCode::from(2))
        }
    }
}

/// One line on a lockstep request's steps.
pub fn steps_line(r: &msgs::StepReport) -> String {
    format!(
        "steps: {} taken  island solves {}  not converged {}  max residual {:.3e}",
        r.count, r.island_solves, r.not_converged, r.max_residual_rel
    )
}
