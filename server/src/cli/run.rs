//! `run` (a scene headless, as fast as possible) and `scenes` (the built-in scenes).

use std::path::PathBuf;

use anyhow::Context;
use pivotsim_server::run::{RunOptions, run_scene, summary_text};
use pivotsim_server::scene::SceneOverride;
use pivotsim_server::snapshot::Snapshot;

/// Where a run starts.
pub enum Start {
    /// A scene's start (built-in name or path).
    Scene(String),
    /// A snapshot file.
    Snapshot(PathBuf),
}

/// Runs a scene (with its settings overridden) or a snapshot headless and prints the summary
/// (text or one JSON object).
pub fn run(
    start: Start,
    overrides: &[SceneOverride],
    mut opts: RunOptions,
    threads: usize,
    json: bool,
) -> anyhow::Result<()> {
    let mut sc = match start {
        Start::Scene(scene) => pivotsim_server::scene::load_with(&scene, overrides)?,
        Start::Snapshot(file) => {
            let snap = Snapshot::read(&file)?;
            let sc = snap.to_scene().with_context(|| format!("{}", file.display()))?;
            if opts.duration.is_none() {
                let left = sc.duration - sc.world.time();
                anyhow::ensure!(
                    left > 0.5 * sc.world.settings().timestep,
                    "the snapshot is at {:.3} s, past the scene's {} s: give --duration",
                    sc.world.time(),
                    sc.duration
                );
                opts.duration = Some(left);
            }
            opts.watchdog = snap.watchdog;
            sc
        }
    };
    sc.world.set_threads(threads)?;
    let summary = run_scene(&mut sc, &opts)?;
    if json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!("{}", summary_text(&summary));
    }
    if !summary.finite {
        anyhow::bail!("the run stopped: {}", summary.error.as_deref().unwrap_or("non-finite state"));
    }
    Ok(())
}

/// Prints the built-in scenes, one a line.
pub fn scenes() {
    for b in pivotsim_server::scene::BUILTIN {
        println!("{:<16} {}", b.name, b.summary);
    }
}
