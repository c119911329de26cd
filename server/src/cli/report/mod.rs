//! `pivotsim-server report`: the speed/accuracy report — what a user reads to choose between speed
//! and accuracy. Every number comes from this one command on the machine it runs on.
//!
//! Stages (fixed scenes and settings, so a rerun measures the same work; timings are wall clock of
//! a single thread):
//!
//! 1. **Scenes × variants** (`scenes.rs`): every built-in paper scene with every exact variant,
//!    per-step solve time (the sum over islands, as the paper's Table 3 and Fig. 7), tight count and
//!    pivot steps; the `auto` run dumps its islands every few steps (with their warm starts).
//! 2. **Islands** (`islands.rs`): on the dumped islands of each scene, the condition number of `A`
//!    (dense symmetric eigenvalues) for Table 2, the deletion error `‖L_deleted − chol(A_FF)‖_F` with
//!    and without the skyline for Table 4, the sparsity of the largest island before and after
//!    reverse Cuthill–McKee (Fig. 5/6), and **the trade**: residual against wall time of projected
//!    Gauss–Seidel (1…1000 sweeps, warm and cold) and of block pivoting (cap 1…35).
//! 3. **Warm start** (the paper's future work): each scene with `warm_start = false` against the run
//!    of stage 1.
//! 4. **Extremes** (`extremes.rs`): the winch over compliance 1e-4…1e-12 and the crane over the mass
//!    ratio of its load 1e2…1e9, with `auto` and with PGS: stable or not, drift, residual.
//! 5. **Fig. 4** (`fig4.rs`): deletion against refactor over matrix size and tight fraction, dense
//!    and on the envelope.
//! 6. **Equal time** (`equal_time.rs`): each scene with PGS given `auto`'s solve time per step —
//!    joint error, penetration, where the payload ends.
//! 7. **rapier** (`rapier.rs`, built with the `rapier` feature): rapier and pivotsim on three rigs
//!    built from one description — a heavy load on a light chain, a stack of alternating masses, a
//!    vehicle body on a hinged arm — over the mass ratio 1e1…1e9: joint drift, penetration, energy,
//!    time per step, and where each engine breaks.
//! 8. **Faults** (`faults.rs`): the fault matrix — every shipped scene × every fault it accepts, at
//!    two moments — as shipped, with projection, and with its load ×10 and ×100: stable cells, the
//!    worst joint error and energy excess.
//! 9. `README.md` (tables, links to the figures), `report.json` (every number), `steps.csv` (the
//!    per-step series) and the SVG figures in the output directory.
//!
//! | file | what |
//! |---|---|
//! | `plan.rs` | what the full, quick and tiny modes run |
//! | `scenes.rs` | stages 1 and 3 |
//! | `islands.rs` | stage 2 |
//! | `extremes.rs` | stage 4 |
//! | `fig4.rs` | stage 5 |
//! | `equal_time.rs` | stage 6 |
//! | `tight_last.rs` | stage 2: the paper's tight-rows-last ordering against RCM on the warm islands |
//! | `rapier.rs` | stage 7: the comparison with rapier (feature `rapier`) |
//! | `faults.rs` | stage 8: the fault matrix |
//! | `markdown.rs` | `README.md` |
//! | `plots.rs` | the figures |
//! | `spread.rs` | min / max / mean / median of a sample |

mod equal_time;
mod extremes;
mod faults;
mod fig4;
mod islands;
mod markdown;
mod plan;
mod plots;
mod rapier;
mod scenes;
mod spread;
mod tight_last;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;

pub use plan::Plan;

/// What to run and where to write it.
#[derive(Debug, Clone)]
pub struct ReportConfig {
    /// Output directory (created).
    pub out: PathBuf,
    /// Shorter runs and fewer points (a few minutes).
    pub quick: bool,
    /// Minimal sizes for the unit test (seconds); implies `quick`.
    pub tiny: bool,
}

/// The machine and the moment the report was made on.
#[derive(Debug, Clone, Serialize)]
pub struct Machine {
    /// CPU model (`/proc/cpuinfo`).
    pub cpu: String,
    /// Logical cores available.
    pub cores: usize,
    /// 1-minute load average at the start (`/proc/loadavg`).
    pub load_at_start: Option<f64>,
    /// `release` or `debug`.
    pub build: String,
    /// UTC time of the start (seconds since the Unix epoch).
    pub started_unix_s: u64,
    /// Mode: full, quick or tiny.
    pub mode: String,
    /// Wall time of the whole report (s).
    pub wall_s: f64,
}

/// Everything the report measured (`report.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Where and how it was measured.
    pub machine: Machine,
    /// Stage 1 and 3, per scene.
    pub scenes: Vec<scenes::SceneResult>,
    /// Stage 2, per scene.
    pub islands: Vec<islands::IslandsResult>,
    /// Stage 4.
    pub extremes: extremes::Extremes,
    /// Stage 5.
    pub fig4: fig4::Fig4,
    /// Stage 6, per scene.
    pub equal_time: Vec<equal_time::EqualTime>,
    /// Stage 7 (`None`: built without the `rapier` feature).
    pub rapier: Option<rapier::RapierComparison>,
    /// Stage 8.
    pub faults: faults::Faults,
    /// The figures written (file names in the output directory).
    pub figures: Vec<String>,
}

/// Runs the report into `cfg.out`.
pub fn run(cfg: &ReportConfig) -> anyhow::Result<Report> {
    let t0 = Instant::now();
    let plan = Plan::for_config(cfg);
    std::fs::create_dir_all(&cfg.out).with_context(|| format!("cannot create {}", cfg.out.display()))?;
    let machine = machine(&plan);
    let pb = progress_bar(cfg.tiny, plan.units());
    // The dumped islands are scratch (tens of MB for the full run): a temporary directory.
    let dumps = std::env::temp_dir().join(format!("pivotsim-report-islands-{}", std::process::id()));
    let scenes = scenes::run(&plan, &dumps, &pb)?;
    let islands = islands::run(&plan, &cfg.out, &scenes, &pb)?;
    let _ = std::fs::remove_dir_all(&dumps);
    let extremes = extremes::run(&plan, &pb)?;
    let fig4 = fig4::run(&plan, &pb);
    let equal_time = equal_time::run(&plan, &pb)?;
    #[cfg(feature = "rapier")]
    let rapier = Some(rapier::run(&plan, &pb)?);
    #[cfg(not(feature = "rapier"))]
    let rapier = None;
    let faults = faults::run(&plan, &pb)?;
    pb.finish_and_clear();
    let mut report =
        Report { machine, scenes, islands, extremes, fig4, equal_time, rapier, faults, figures: Vec::new() };
    report.figures = plots::write_all(&cfg.out, &report)?;
    report.machine.wall_s = t0.elapsed().as_secs_f64();
    write_outputs(&cfg.out, &report)?;
    eprintln!("report: {} ({:.0} s)", cfg.out.join("README.md").display(), report.machine.wall_s);
    Ok(report)
}

fn write_outputs(out: &Path, r: &Report) -> anyhow::Result<()> {
    let write = |name: &str, text: String| {
        std::fs::write(out.join(name), text).with_context(|| format!("cannot write {name}"))
    };
    write("README.md", markdown::readme(r))?;
    write("report.json", serde_json::to_string_pretty(r)?)?;
    let mut w = csv::Writer::from_path(out.join("steps.csv")).context("cannot write steps.csv")?;
    w.write_record(["scene", "variant", "step", "solve_us", "tight", "rows", "pivot_steps"])?;
    for s in &r.scenes {
        for v in &s.variants {
            for (k, p) in v.steps.iter().enumerate() {
                w.write_record([
                    s.scene.as_str(),
                    v.variant.as_str(),
                    &(k + 1).to_string(),
                    &format!("{:.3}", p.solve_us),
                    &p.tight.to_string(),
                    &p.rows.to_string(),
                    &p.pivot_steps.to_string(),
                ])?;
            }
        }
    }
    w.flush()?;
    Ok(())
}

fn machine(plan: &Plan) -> Machine {
    let load_at_start = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|x| x.parse().ok()));
    Machine {
        cpu: super::bench::cpu_name(),
        cores: std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        load_at_start,
        build: super::bench::build_kind().to_string(),
        started_unix_s: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0),
        mode: plan.mode.to_string(),
        wall_s: 0.0,
    }
}

fn progress_bar(tiny: bool, total: u64) -> ProgressBar {
    let pb = ProgressBar::new(total);
    if tiny {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    pb.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiny_run_writes_the_report() {
        let dir = std::env::temp_dir().join(format!("pivotsim-report-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let cfg = ReportConfig { out: dir.clone(), quick: true, tiny: true };
        let r = run(&cfg).expect("report");
        // The files appear and parse; the numbers are the report's business, not this test's.
        let md = std::fs::read_to_string(dir.join("README.md")).expect("README.md");
        for heading in [
            "Table 2",
            "Table 3",
            "Table 4",
            "Fig. 4",
            "trade",
            "equal time",
            "Warm start",
            "Extremes",
            "## rapier",
            "## Faults",
        ] {
            assert!(md.contains(heading), "README.md lacks {heading}");
        }
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).expect("json"))
                .expect("parse");
        assert!(json["scenes"].as_array().is_some_and(|s| !s.is_empty()));
        assert!(json["equal_time"].as_array().is_some_and(|s| !s.is_empty()));
        assert!(json["fig4"]["dense"].as_array().is_some_and(|s| !s.is_empty()));
        // Tiny mode runs the pendulum's fault cells: every one of them is in the JSON and the table.
        let cells = json["faults"]["cells"].as_array().expect("fault cells");
        assert!(!cells.is_empty() && cells.iter().all(|c| c["scene"] == "pendulum"));
        assert_eq!(json["faults"]["rows"][0]["cells"].as_u64(), Some(cells.len() as u64));
        // The comparison is there exactly when it is built in.
        assert_eq!(json["rapier"]["points"].as_array().is_some_and(|p| !p.is_empty()), rapier::BUILT);
        assert_eq!(md.to_lowercase().contains("where each engine breaks"), rapier::BUILT);
        let mut rd = csv::Reader::from_path(dir.join("steps.csv")).expect("csv");
        assert!(rd.records().count() > 0);
        assert!(!r.figures.is_empty());
        for f in &r.figures {
            let svg = std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
            assert!(svg.starts_with("<svg") || svg.contains("<svg"), "{f} is not an SVG");
            assert!(md.contains(f.as_str()), "README.md does not link {f}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
