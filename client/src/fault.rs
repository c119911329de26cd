//! `fault`: an instructor station's fault injection — one `fault` control request (`break`,
//! `hose_burst`, `brake_fade`, `stick_valve`, `dropout`) on a named joint, actuator or sensor of the
//! running scene. The server checks the target and answers `fault_rejected` when the scene has no
//! such item (counted as a `fault-rejected` event); the fault itself shows on the `events` topic
//! (`pivotsim-client watch --signals`).

use std::process::ExitCode;

use anyhow::{Result, anyhow};
use pivotsim_msgs as msgs;

use crate::common::Common;

/// `fault` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The fault: break (a joint, a rope), hose_burst (an actuator goes limp), brake_fade (a
    /// brake's bound ramps down), stick_valve (an actuator freezes), dropout (a sensor goes dark).
    pub kind: String,
    /// The scene's joint (break), actuator (hose_burst, brake_fade, stick_valve) or sensor
    /// (dropout) name.
    pub target: String,
    /// break: part when the joint's force exceeds this (N); without it, at once.
    #[arg(long, value_name = "N")]
    pub tension: Option<f64>,
    /// brake_fade: the fraction of the bound left at the end (0 to 1; default 0).
    #[arg(long, value_name = "FRACTION")]
    pub to: Option<f64>,
    /// brake_fade: seconds of the ramp (default 0: at once).
    #[arg(long, value_name = "SECONDS")]
    pub ramp: Option<f64>,
    /// Print the reply as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `fault`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let fault = msgs::FaultKind::from_name(&args.kind).ok_or_else(|| {
        let names: Vec<_> = msgs::FaultKind::ALL.iter().map(|k| k.name()).collect();
        anyhow!("unknown fault {:?} (one of {})", args.kind, names.join(", "))
    })?;
    let command = msgs::ControlCommand::Fault {
        fault,
        target: args.target.clone(),
        tension: args.tension,
        to: args.to,
        ramp: args.ramp,
    };
    crate::control::request(common, command, args.json)
}
