//! `replay FILE.mcap`: a recorded session reproduced bit for bit (`serve/replay.rs`), published
//! like a live server (in real time, `--fast`, or `--paused` for a lockstep controller), or
//! checked without transports (`--check`); `--from T` starts at the keyframe at or before `T` and
//! goes through the recorded inputs to `T`; `--branch T` hands control to live inputs at `T`.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, bail};
use pivotsim_msgs as msgs;
use pivotsim_server::serve::replay::{Recording, replay_headless};
use pivotsim_server::serve::{Started, run_engine};

use super::serve::{ServeArgs, start_message};
use super::values;

/// Options of `replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The recording (`pivotsim-client record`; it needs the journal channels of a server that
    /// publishes them).
    pub file: PathBuf,
    /// Start at this simulation time (s): the keyframe at or before it, then the recorded steps to
    /// it (default: the first keyframe).
    #[arg(long, value_name = "T", value_parser = values::non_negative_finite)]
    pub from: Option<f64>,
    /// Hand control to live inputs at this time (s): the recording drives until then.
    #[arg(long, value_name = "T", value_parser = values::non_negative_finite)]
    pub branch: Option<f64>,
    /// Check the recording against the replay without serving it (as fast as possible); exit
    /// code 1 at a divergence.
    #[arg(long)]
    pub check: bool,
    /// Stop the check at this time (s).
    #[arg(long, value_name = "T", value_parser = values::non_negative_finite, requires = "check")]
    pub until: Option<f64>,
    /// How to serve it: the options of `serve` (`--scene` and `--set` do not apply: the recording
    /// carries its scene; `--paused` waits for `step`/`run_until` requests: lockstep).
    #[command(flatten)]
    pub serve: ServeArgs,
}

/// Runs `replay`.
pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    super::init_tracing();
    if !args.serve.set.is_empty() {
        bail!("--set does not apply to a replay: the recording carries its scene");
    }
    let rec = Arc::new(Recording::read(&args.file)?);
    eprintln!(
        "pivotsim-server: {}: {} pose frames, {} steps with applied inputs, {} keyframes ({} malformed frames skipped)",
        args.file.display(),
        rec.poses.len(),
        rec.applied.len(),
        rec.keyframes.len(),
        rec.malformed
    );
    let world = msgs::WorldName::new(args.serve.world.clone()).context("--world")?;
    // To `--from` without publishing (through the recorded inputs), or the whole check.
    let until = if args.check { args.until } else { args.from };
    let engine = replay_headless(rec.clone(), args.from, until, args.branch, world)?;
    let p = engine.replay_progress().clone();
    if args.check {
        println!(
            "replayed to {:.4} s (sequence {}): {} pose frames equal, {} keyframes equal, {} states not in the recording",
            engine.scene().world.time(),
            engine.sequence(),
            p.poses_compared,
            p.keyframes_compared,
            p.poses_missing
        );
        if let Some(d) = &p.divergence {
            bail!("the replay {d}");
        }
        return Ok(());
    }
    if let Some(d) = &p.divergence {
        bail!("the replay {d} before --from");
    }
    let paused = args.serve.paused;
    let config = args.serve.config();
    let mut engine = engine;
    engine.set_keyframe_every(config.keyframes);
    engine.set_paused(paused);
    let shutdown = Arc::new(AtomicBool::new(false));
    let flag = shutdown.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;
    let report = run_engine(&config, engine, shutdown, |s: &Started| println!("{}", start_message(s)))?;
    let p = &report.replay;
    println!(
        "{} steps, {:.2} s simulated; replay: {} pose frames equal, {} keyframes equal{}{}",
        report.steps,
        report.sim_time,
        p.poses_compared,
        p.keyframes_compared,
        if p.branched { ", branched to live inputs" } else { "" },
        if p.finished { ", recording finished" } else { "" },
    );
    if let Some(d) = &p.divergence {
        bail!("the replay {d}");
    }
    Ok(())
}
