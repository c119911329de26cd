//! `pivotsim-server bench-solver`: the solver benchmark (paper §3.2, Fig. 4, Tables 3 and 4).
//!
//! Stages, every timing the median of repeats (single thread, meant for a release build):
//!
//! 1. **Kernel crossover.** On a banded contact-like matrix (RCM order) one envelope factorization,
//!    one copy of `L₀` and single deletions at indices spread over the matrix, then a sweep over the
//!    tight count `t`: copy + `t` deletions from `L₀` against an envelope refactor of the masked
//!    matrix with the same `t` tight. The crossover is the `t` below which deletions win. The same
//!    dense: compact gather + dense Cholesky against dense copy + deletions, crossover in % tight.
//! 2. **Fig. 4.** Random dense SPD matrices, speed-up of (copy + deletions from `L₀`) over a dense
//!    refactor of the compact `A_FF`, per size and tight fraction; plotted to `fig4_speedup.svg`.
//! 3. **Generated contact-like MLCPs** (`solver::generate::contact_like`) and 4. **every data
//!    file** (the repository's test problems, or `--data DIR`): every
//!    variant with the paper's step cap (35) and with 1000 steps, plus a run that measures the
//!    deletion error (paper Table 4) for the variants that delete.
//! 5. **The regression corpus** of real islands (`server/tests/data/corpus`, not with `--data`):
//!    convergence within 35 and 100 steps, warm and cold, total `auto` time per scene set, and the
//!    per-solve time of its small islands (≤ 30 rows) with each variant (`corpus.rs`).
//! 6. `bench.md`, `bench.json`, `corpus.json`, `fig4_speedup.svg`, `solve_time.svg` in the output
//!    directory, the markdown and a summary on stdout.
//!
//! Every loop is bounded: repeats are capped, and a 1000-step run whose predicted time exceeds the
//! mode's budget is skipped (and reported as skipped); a run that converged within 35 steps is not
//! repeated with 1000 (the iterates are the same).

//!
//! | file | what |
//! |---|---|
//! | `plan.rs` | sizes, repeats and budgets of the tiny, quick and full modes |
//! | `timing.rs` | medians of timed repeats |
//! | `kernels.rs` | stage 1 (kernel crossover) and stage 2 (Fig. 4) |
//! | `problems.rs` | stages 3 and 4: every variant on one problem |
//! | `corpus.rs` | stage 5: the corpus of real islands |
//! | `report.rs` | the summary, `bench.md` and the `bench.json` document |
//! | `plots.rs` | the SVG plots |
//! | `sweep.rs` | `--sweep N`, alone: the generated-island sweep at scale (`sweep.json`) |
//! | `hard.rs` | `--hard`, alone: the hardest warm solves of the shipped scenes beside ODE's column (`hard.md`) |

mod corpus;
pub mod hard;
mod kernels;
mod plan;
mod plots;
mod problems;
mod report;
pub mod sweep;
mod timing;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use pivotsim_server::solver::generate::contact_like;
use pivotsim_server::solver::{Mlcp, Variant, io};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use kernels::{DenseKernel, EnvelopeKernel, Fig4, dense_kernel, envelope_kernel};
pub use kernels::{SweepPoint, dense_sweep, envelope_fig4, random_spd, warm_up};
use plan::{LONG_STEPS, Plan, SHORT_STEPS};
use plots::{plot_fig4, plot_solve_times};
use problems::{ProblemResult, run_problem};
use report::{Report, Summary, markdown, summarize, summary_text};
pub use report::{build_kind, cpu_name};
pub use timing::median;

/// What to run and where to write it.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// Output directory (created).
    pub out: PathBuf,
    /// Smaller sizes and fewer repeats (under a minute).
    pub quick: bool,
    /// Directory scanned for `*.txt` MLCP files instead of the repository's test problems.
    pub data: Option<PathBuf>,
    /// Minimal sizes for the unit test (seconds in a test build); implies `quick`.
    pub tiny: bool,
}

impl BenchConfig {
    /// A configuration; `out` defaults to `bench-out/`.
    pub fn new(out: Option<PathBuf>, quick: bool, data: Option<PathBuf>) -> Self {
        BenchConfig { out: out.unwrap_or_else(|| PathBuf::from("bench-out")), quick, data, tiny: false }
    }
}

/// The data directories scanned by default, relative to the repository root (the directory
/// `cargo run` is usually started from) or to `server/`: the Siconos problems and the scene-shaped
/// islands of `server/tests/data/` (nothing outside the repository; `--data DIR` for others).
fn default_data_dirs() -> Vec<(PathBuf, &'static str)> {
    let root = data_root();
    vec![(root.join("siconos"), "siconos"), (root.join("scene-shaped"), "scene")]
}

/// `server/tests/data`, seen from the repository root or from `server/`.
fn data_root() -> PathBuf {
    ["server/tests/data", "tests/data"]
        .into_iter()
        .map(PathBuf::from)
        .find(|p| p.join("siconos").is_dir())
        .unwrap_or_else(|| PathBuf::from("server/tests/data"))
}

fn txt_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(rd) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    v.sort();
    v
}

/// A data file read as a problem: name, group, path and the MLCP.
type FileProblem = (String, &'static str, PathBuf, Mlcp);

/// A generated problem: name, seed, mass ratio and the MLCP.
type GeneratedProblem = (String, u64, f64, Mlcp);

/// Runs the benchmark of `cfg`, writes the report files and prints the markdown and the summary.
pub fn run(cfg: &BenchConfig) -> anyhow::Result<Summary> {
    let t_start = Instant::now();
    let plan = Plan::for_config(cfg);
    std::fs::create_dir_all(&cfg.out).with_context(|| format!("cannot create {}", cfg.out.display()))?;
    if cfg!(debug_assertions) && !cfg.tiny {
        eprintln!("warning: debug build; build with --release for meaningful timings");
    }

    // Inputs first, so that the progress bar knows its length.
    let (files, unreadable) = read_data_files(cfg);
    let generated = generate_problems(&plan);
    let crane = files.iter().find(|f| f.0.contains("crane430"));
    let n_env_kernels = 1 + usize::from(crane.is_some());
    let total =
        (n_env_kernels + 2 + plan.fig4_m.len() + (generated.len() + files.len()) * Variant::ALL.len()) as u64;
    let pb = progress_bar(cfg.tiny, total);
    let say = |s: String| {
        if !cfg.tiny {
            pb.suspend(|| eprintln!("{s}"));
        }
    };
    say(format!(
        "bench-solver: {} mode, {} generated + {} file problems, {} variants, output {}",
        plan.mode,
        generated.len(),
        files.len(),
        Variant::ALL.len(),
        cfg.out.display()
    ));

    say("[1/4] kernel crossover".into());
    let (env_kernels, dense_kernels) = run_kernels(&plan, crane, &pb);
    say("[2/4] paper Fig. 4 grid".into());
    let fig4 = run_fig4(&plan, &pb);

    // 3. Generated problems, 4. files.
    say("[3/4] generated contact-like problems".into());
    let mut problems = Vec::new();
    for (name, seed, mr, p) in &generated {
        problems.push(run_problem(name.clone(), "generated", None, Some((*seed, *mr)), p, &plan, &pb));
    }
    say(format!("[4/4] {} data files", files.len()));
    for (name, group, path, p) in &files {
        problems.push(run_problem(name.clone(), group, Some(path), None, p, &plan, &pb));
    }
    let corpus_dir = data_root().join("corpus");
    let corpus = if cfg.data.is_none() && !cfg.tiny {
        say(format!("[5/5] corpus {}", corpus_dir.display()));
        corpus::run(&corpus_dir, plan.kernel_target_us, plan.kernel_repeats, |n| {
            pb.set_message(n.to_string())
        })
    } else {
        corpus::CorpusReport::default()
    };
    pb.finish_and_clear();

    let mut summary = summarize(&plan, &problems, &env_kernels, &dense_kernels);
    summary.elapsed_s = t_start.elapsed().as_secs_f64();
    let report = Report {
        mode: plan.mode,
        cpu: cpu_name(),
        build: build_kind(),
        short_steps: SHORT_STEPS,
        long_steps: LONG_STEPS,
        summary: &summary,
        kernel_envelope: &env_kernels,
        kernel_dense: &dense_kernels,
        fig4: &fig4,
        problems: &problems,
        unreadable_files: &unreadable,
    };
    let md = write_report(cfg, &plan, &report, &corpus)?;
    println!("{md}");
    println!("{}", summary_text(&summary));
    println!("report: {}", cfg.out.join("bench.md").display());
    Ok(summary)
}

/// Reads every `*.txt` problem of the data directories; the files that fail to parse are listed
/// with their error.
fn read_data_files(cfg: &BenchConfig) -> (Vec<FileProblem>, Vec<(String, String)>) {
    let dirs: Vec<(PathBuf, &'static str)> = match &cfg.data {
        Some(d) => vec![(d.clone(), "data")],
        None => default_data_dirs(),
    };
    let mut files: Vec<FileProblem> = Vec::new();
    let mut unreadable: Vec<(String, String)> = Vec::new();
    for (dir, group) in &dirs {
        let list = txt_files(dir);
        if list.is_empty() {
            eprintln!("note: no *.txt problems in {}", dir.display());
        }
        for f in list {
            match io::read_mlcp_file(&f) {
                Ok(p) => {
                    let name = f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                    files.push((name, group, f, p));
                }
                Err(e) => unreadable.push((f.display().to_string(), e.to_string())),
            }
        }
    }
    (files, unreadable)
}

/// The plan's generated contact-like problems, named by size and seed.
fn generate_problems(plan: &Plan) -> Vec<GeneratedProblem> {
    plan.generated
        .iter()
        .map(|&(m, seed, mr)| {
            let p = contact_like(m, seed, mr);
            (format!("contact-like-{}-s{seed}", p.n()), seed, mr, p)
        })
        .collect()
}

/// A progress bar of `total` ticks on stderr (hidden in a tiny run).
fn progress_bar(tiny: bool, total: u64) -> ProgressBar {
    let target = if tiny { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
    let pb = ProgressBar::with_draw_target(Some(total), target);
    pb.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb
}

/// Stage 1: envelope kernels on the generated matrix (and on `scene-crane430` when loaded), then
/// dense kernels on it and on a random SPD matrix, after a short warm-up that brings the core to its
/// steady clock.
fn run_kernels(
    plan: &Plan,
    crane: Option<&FileProblem>,
    pb: &ProgressBar,
) -> (Vec<EnvelopeKernel>, Vec<DenseKernel>) {
    let kernel_problem = contact_like(plan.kernel_m, 430, 6_300.0);
    warm_up(plan.warm_up_us);
    let mut env_kernels = Vec::new();
    let kname = format!("contact-like-{} (generated)", kernel_problem.n());
    pb.set_message(format!("envelope kernels on {kname}"));
    env_kernels.push(envelope_kernel(&kname, kernel_problem.a(), plan, 11));
    pb.inc(1);
    if let Some((name, _, _, p)) = crane {
        pb.set_message(format!("envelope kernels on {name}"));
        env_kernels.push(envelope_kernel(name, p.a(), plan, 11));
        pb.inc(1);
    }
    let mut dense_kernels = Vec::new();
    let km = kernel_problem.n();
    let mut kd = vec![0.0; km * km];
    kernel_problem.a().to_dense(&mut kd);
    pb.set_message("dense kernels (contact-like)");
    dense_kernels.push(dense_kernel(&format!("contact-like-{km} (input order)"), &kd, km, plan, 12));
    pb.inc(1);
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let rd = random_spd(km, &mut rng);
    pb.set_message("dense kernels (random SPD)");
    dense_kernels.push(dense_kernel(&format!("random SPD {km}"), &rd, km, plan, 13));
    pb.inc(1);
    (env_kernels, dense_kernels)
}

/// Stage 2: the paper's Fig. 4 grid, one dense sweep a size.
fn run_fig4(plan: &Plan, pb: &ProgressBar) -> Fig4 {
    let mut fig4 =
        Fig4 { sizes: plan.fig4_m.clone(), tight_pct: plan.fig4_fracs.clone(), sweeps: Vec::new() };
    for &m in &plan.fig4_m {
        pb.set_message(format!("Fig. 4, m = {m}"));
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + m as u64);
        let a = random_spd(m, &mut rng);
        let reps = if m >= 700 { plan.fig4_repeats.min(3) } else { plan.fig4_repeats };
        fig4.sweeps.push(dense_sweep(&a, m, &plan.fig4_fracs, plan.fig4_target_us, reps, &mut rng));
        pb.inc(1);
    }
    fig4
}

/// Writes `bench.md`, `bench.json`, `corpus.json` and the two plots to the output directory;
/// returns the markdown.
fn write_report(
    cfg: &BenchConfig,
    plan: &Plan,
    report: &Report<'_>,
    corpus: &corpus::CorpusReport,
) -> anyhow::Result<String> {
    let md = markdown(report) + &corpus::markdown(corpus);
    let out = &cfg.out;
    std::fs::write(out.join("bench.md"), &md).with_context(|| format!("cannot write {}", out.display()))?;
    let json = serde_json::to_string_pretty(report)?;
    std::fs::write(out.join("bench.json"), json)
        .with_context(|| format!("cannot write {}", out.display()))?;
    std::fs::write(out.join("corpus.json"), serde_json::to_string_pretty(corpus)?)
        .with_context(|| format!("cannot write {}", out.display()))?;
    plot_fig4(&out.join("fig4_speedup.svg"), report.fig4)?;
    let charted = chart_problems(plan, report.problems, cfg.data.is_some());
    plot_solve_times(&out.join("solve_time.svg"), &charted)?;
    Ok(md)
}

/// The problems of the solve-time chart: the focus-size generated ones and the scene-shaped ones,
/// up to ten larger ones of `--data`, or else the first six.
fn chart_problems<'p>(plan: &Plan, problems: &'p [ProblemResult], data: bool) -> Vec<&'p ProblemResult> {
    let lo = plan.focus_m as f64 * 0.9;
    let hi = plan.focus_m as f64 * 1.1;
    let mut chart_problems: Vec<&ProblemResult> = problems
        .iter()
        .filter(|p| p.group == "generated" && (p.m as f64) >= lo && (p.m as f64) <= hi || p.group == "scene")
        .collect();
    if data {
        chart_problems.extend(problems.iter().filter(|p| p.group == "data" && p.m >= 150).take(10));
    }
    if chart_problems.is_empty() {
        chart_problems = problems.iter().take(6).collect();
    }
    chart_problems
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiny_run_writes_the_report() {
        let dir = std::env::temp_dir().join(format!(
            "pivotsim-bench-test-{}-{}",
            std::process::id(),
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos()
        ));
        let data = dir.join("data");
        std::fs::create_dir_all(&data).unwrap();
        let p = contact_like(30, 3, 50.0);
        let mut f = std::fs::File::create(data.join("tiny.txt")).unwrap();
        io::write_mlcp(&p, &mut f).unwrap();
        drop(f);
        let out = dir.join("out");
        let cfg = BenchConfig { out: out.clone(), quick: true, data: Some(data), tiny: true };
        let s = run(&cfg).unwrap();
        assert_eq!(s.mode, "tiny");
        assert_eq!(s.converged_35.1, 2);
        for f in ["bench.md", "bench.json", "fig4_speedup.svg", "solve_time.svg"] {
            assert!(out.join(f).is_file(), "{f} missing");
        }
        let md = std::fs::read_to_string(out.join("bench.md")).unwrap();
        assert!(md.contains("### tiny (data)"));
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
        assert_eq!(json["problems"].as_array().unwrap().len(), 2);
        std::fs::remove_dir_all(&dir).ok();
    }
}
