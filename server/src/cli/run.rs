//! `run` (a scene headless, as fast as possible) and `scenes` (the built-in scenes).

use pivotsim_server::run::{RunOptions, run_scene, summary_text};
use pivotsim_server::scene::SceneOverride;

/// Runs `scene` (with its settings overridden) headless and prints the summary (text or one JSON
/// object).
pub fn run(scene: &str, overrides: &[SceneOverride], opts: &RunOptions, json: bool) -> anyhow::Result<()> {
    let mut sc = pivotsim_server::scene::load_with(scene, overrides)?;
    let summary = run_scene(&mut sc, opts)?;
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
