//! `control`: one control request on the `control` queryable; prints the reply and exits non-zero
//! when the server refused or failed.

use std::process::ExitCode;

use anyhow::{Result, anyhow};
use pivotsim_msgs as msgs;

use crate::common::Common;

/// `control` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub op: Op,
    /// Print the reply as JSON.
    #[arg(long)]
    pub json: bool,
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
    request(common, args.op.command()?, args.json)
}

/// Sends one control request, prints the reply; exit code 2 when the server refused it.
pub fn request(common: &Common, command: msgs::ControlCommand, json: bool) -> Result<ExitCode> {
    // Ids below 2^53 (JavaScript clients read them exactly).
    let id = crate::net::now_ns() & ((1u64 << 53) - 1);
    let req = msgs::ControlRequest { id, command };
    req.validate().map_err(|e| anyhow!("invalid request: {e}"))?;
    let link = common.open_zenoh()?;
    let reply = link.control(&req, common.timeout_or(5.0))?;
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
