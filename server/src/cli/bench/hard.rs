//! `bench-solver --hard`: the hardest warm solves of the shipped scenes, timed per variant beside
//! ODE's column of issue 31 (part 2).
//!
//! For each scene of [`SCENES`], a headless run as shipped dumps its [`FILES`] hardest island solves
//! with their warm starts (`run --scene S --dump-hard 7`) into `OUT/hard/S/` — or, with `--data
//! DIR`, the files already in `DIR/S/` are read (the same files for an A/B between builds: a
//! dump follows the trajectory, which the solver under test decides). Each file is solved
//! `repeats` times per variant in one process with default options and the paper's cap of 35
//! (`solve --repeats`, each repeat from the file's warm start); the per-file median is summed
//! over the scene's files. Writes `hard.md`, `hard.json` and `hard.svg`.
//!
//! The ODE column is not measured here: it is the table (ODE 0.16 `dSolveLCP`, Dantzig, on
//! the same kind of files without their warm section, median of 3 solves in one process, total
//! over the 7 files), measured by the author on the same machine type.

use std::path::{Path, PathBuf};

use anyhow::Context;
use pivotsim_server::run::{RunOptions, run_scene};
use pivotsim_server::scene;
use pivotsim_server::solver::{Mlcp, SolveStatus, SolverOptions, Variant, io};
use serde::Serialize;

use super::super::solve::solve_repeated;
use super::plots::plot_err;
use super::txt_files;

/// The shipped scenes of the table and ODE's total time over their 7 files (ms) and worst
/// relative residual, as the issue gives them.
pub const SCENES: [(&str, f64, f64); 6] = [
    ("crane", 27.2, 6e-17),
    ("winch", 32.6, 2e-3),
    ("offshore", 24.6, 2e-3),
    ("forklift", 7.3, 2e-1),
    ("vehicle", 7.9, 3e-3),
    ("forwarder", 4.0, 1e-1),
];

/// Hard solves dumped per scene.
pub const FILES: usize = 7;

/// The variants timed: `auto` first, then the exact ones it chooses among and the others.
pub const VARIANTS: [Variant; 6] = [
    Variant::Auto,
    Variant::Skyline,
    Variant::SkylineRefactor,
    Variant::Incremental,
    Variant::Full,
    Variant::Downdate,
];

/// One variant on one scene's files.
#[derive(Debug, Clone, Serialize)]
pub struct VariantTotal {
    /// Variant name.
    pub variant: &'static str,
    /// Sum over the files of each file's median time (ms).
    pub total_ms: f64,
    /// Sum over the files of each file's least time (ms).
    pub total_min_ms: f64,
    /// Per file: median time (µs).
    pub file_us: Vec<f64>,
    /// Files that stopped at the cap.
    pub capped: usize,
    /// Pivot steps over the files.
    pub steps: usize,
    /// Largest relative residual.
    pub worst_residual_rel: f64,
}

/// One scene.
#[derive(Debug, Clone, Serialize)]
pub struct SceneHard {
    /// Scene name.
    pub scene: &'static str,
    /// The files (names), in the order of `file_us`.
    pub files: Vec<String>,
    /// Rows of each file.
    pub rows: Vec<usize>,
    /// One entry per variant of [`VARIANTS`].
    pub variants: Vec<VariantTotal>,
    /// ODE's total (ms) and worst residual, as the issue gives them (not measured here).
    pub ode_ms: f64,
    /// ODE's worst relative residual (the issue's).
    pub ode_worst_residual_rel: f64,
}

impl SceneHard {
    /// The variant's entry.
    pub fn variant(&self, v: Variant) -> Option<&VariantTotal> {
        self.variants.iter().find(|t| t.variant == v.name())
    }

    /// The fastest of skyline, skyline-refactor and incremental (the strategies `auto` picks
    /// among), by total.
    pub fn best_envelope(&self) -> Option<&VariantTotal> {
        [Variant::Skyline, Variant::SkylineRefactor, Variant::Incremental]
            .into_iter()
            .filter_map(|v| self.variant(v))
            .min_by(|a, b| a.total_ms.total_cmp(&b.total_ms))
    }
}

/// Runs the stage: dumps (or reads from `data`) and times; writes the report into `out`.
pub fn run(out: &Path, data: Option<&Path>, repeats: usize) -> anyhow::Result<Vec<SceneHard>> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut scenes = Vec::new();
    for &(name, ode_ms, ode_res) in &SCENES {
        let dir = match data {
            Some(d) => d.join(name),
            None => dump(out, name)?,
        };
        let files = txt_files(&dir);
        if files.is_empty() {
            anyhow::bail!("no *.txt problems in {}", dir.display());
        }
        let problems = files
            .iter()
            .map(|f| io::read_mlcp_file(f).with_context(|| format!("cannot read {}", f.display())))
            .collect::<anyhow::Result<Vec<Mlcp>>>()?;
        eprintln!("hard: {name}, {} files", files.len());
        let variants = VARIANTS
            .iter()
            .map(|&v| time_variant(&problems, v, repeats))
            .collect::<anyhow::Result<Vec<_>>>()?;
        scenes.push(SceneHard {
            scene: name,
            files: files.iter().map(|f| file_name(f)).collect(),
            rows: problems.iter().map(Mlcp::n).collect(),
            variants,
            ode_ms,
            ode_worst_residual_rel: ode_res,
        });
    }
    let md = markdown(&scenes, repeats);
    std::fs::write(out.join("hard.md"), &md).with_context(|| format!("cannot write {}", out.display()))?;
    std::fs::write(out.join("hard.json"), serde_json::to_string_pretty(&scenes)?)
        .with_context(|| format!("cannot write {}", out.display()))?;
    plot(&out.join("hard.svg"), &scenes)?;
    println!("{md}");
    println!("report: {}", out.join("hard.md").display());
    Ok(scenes)
}

/// Runs scene `name` as shipped and dumps its hardest solves into `OUT/hard/name` (emptied
/// first); returns that directory.
fn dump(out: &Path, name: &str) -> anyhow::Result<PathBuf> {
    let dir = out.join("hard").join(name);
    for f in txt_files(&dir) {
        std::fs::remove_file(&f).with_context(|| format!("cannot remove {}", f.display()))?;
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut sc = scene::load_with(name, &[])?;
    let opts = RunOptions {
        dump_mlcp: Some(dir.clone()),
        dump_hard: FILES,
        progress: false,
        ..RunOptions::default()
    };
    run_scene(&mut sc, &opts)?;
    Ok(dir)
}

/// Every problem solved by `v` (default options, cap 35), `repeats` times each.
fn time_variant(problems: &[Mlcp], v: Variant, repeats: usize) -> anyhow::Result<VariantTotal> {
    let opts = SolverOptions { variant: v, ..SolverOptions::default() };
    let mut t = VariantTotal {
        variant: v.name(),
        total_ms: 0.0,
        total_min_ms: 0.0,
        file_us: Vec::new(),
        capped: 0,
        steps: 0,
        worst_residual_rel: 0.0,
    };
    for p in problems {
        let r = solve_repeated(p, opts, repeats)?;
        let med = r.median_us();
        t.total_ms += med * 1e-3;
        t.total_min_ms += r.min_us() * 1e-3;
        t.file_us.push(med);
        t.capped += usize::from(r.stats.status != SolveStatus::Converged);
        t.steps += r.stats.pivot_steps;
        // The residual recomputed from the problem, not the solver's own figure.
        let mut w = vec![0.0; p.n()];
        let (_, rel) = p.natural_residual(&r.lambda, &mut w);
        t.worst_residual_rel = t.worst_residual_rel.max(rel);
    }
    Ok(t)
}

fn file_name(f: &Path) -> String {
    f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

/// The table: per scene the total of each variant, the best envelope strategy and ODE's column.
pub fn markdown(scenes: &[SceneHard], repeats: usize) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "## Hardest warm solves of the shipped scenes ({FILES} per scene, cap 35, total of per-file medians of {repeats})\n\n"
    ));
    s.push_str("| scene | rows | ");
    for v in VARIANTS {
        s.push_str(&format!("`{}` (ms) | ", v.name()));
    }
    s.push_str("auto / best of skyline, skyline-refactor, incremental | ODE 0.16 dSolveLCP, measured by the issue's author (ms) | auto / ODE | capped (auto) | worst residual (auto) | ODE's worst residual (issue) |\n");
    s.push_str(&"|---".repeat(VARIANTS.len() + 8));
    s.push_str("|\n");
    for sc in scenes {
        let rows = format!(
            "{}–{}",
            sc.rows.iter().min().copied().unwrap_or(0),
            sc.rows.iter().max().copied().unwrap_or(0)
        );
        s.push_str(&format!("| {} | {rows} | ", sc.scene));
        for v in &sc.variants {
            s.push_str(&format!("{:.2} | ", v.total_ms));
        }
        let auto = sc.variant(Variant::Auto);
        let best = sc.best_envelope();
        let ratio = match (auto, best) {
            (Some(a), Some(b)) => format!("{:.2} ({})", a.total_ms / b.total_ms, b.variant),
            _ => "—".into(),
        };
        let (auto_ms, capped, worst) =
            auto.map_or((f64::NAN, 0, f64::NAN), |a| (a.total_ms, a.capped, a.worst_residual_rel));
        s.push_str(&format!(
            "{ratio} | {:.1} | {:.2} | {capped} | {worst:.1e} | {:.0e} |\n",
            sc.ode_ms,
            auto_ms / sc.ode_ms,
            sc.ode_worst_residual_rel
        ));
    }
    s
}

/// Bars per scene: `auto`, the best envelope strategy and ODE's (issue) total, log scale.
fn plot(path: &Path, scenes: &[SceneHard]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let bars = |sc: &SceneHard| -> [(String, f64); 3] {
        [
            ("auto".into(), sc.variant(Variant::Auto).map_or(f64::NAN, |v| v.total_ms)),
            (
                "best of skyline, skyline-refactor, incremental".into(),
                sc.best_envelope().map_or(f64::NAN, |v| v.total_ms),
            ),
            ("ODE 0.16 dSolveLCP (issue's figure, not measured here)".into(), sc.ode_ms),
        ]
    };
    let all: Vec<f64> =
        scenes.iter().flat_map(|sc| bars(sc).map(|b| b.1)).filter(|x| x.is_finite() && *x > 0.0).collect();
    let ymin = all.iter().copied().fold(f64::INFINITY, f64::min).min(1.0) / 2.0;
    let ymax = all.iter().copied().fold(0.0, f64::max).max(ymin * 10.0) * 4.0;
    let n = scenes.len().max(1) as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption("Hardest warm solves per scene: total time (cap 35)", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..n, (ymin..ymax).log_scale())
        .map_err(plot_err)?;
    chart.configure_mesh().disable_x_mesh().disable_x_axis().y_desc("ms (log)").draw().map_err(plot_err)?;
    for k in 0..3 {
        let color = Palette99::pick(k).to_rgba();
        let label = scenes.first().map(|sc| bars(sc)[k].0.clone()).unwrap_or_default();
        let rects: Vec<Rectangle<(f64, f64)>> = scenes
            .iter()
            .enumerate()
            .map(|(i, sc)| {
                let x0 = i as f64 + 0.1 + 0.8 * k as f64 / 3.0;
                Rectangle::new([(x0, ymin), (x0 + 0.8 / 3.0, bars(sc)[k].1.max(ymin))], color.filled())
            })
            .collect();
        chart
            .draw_series(rects)
            .map_err(plot_err)?
            .label(label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    for (i, sc) in scenes.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(i as f64 + 0.5, ymin));
        let style = ("sans-serif", 14).into_font().into_text_style(&root).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Top,
            ),
        );
        root.draw(&Text::new(sc.scene.to_string(), (px, py + 8), style)).map_err(plot_err)?;
    }
    root.present().map_err(plot_err)?;
    Ok(())
}
