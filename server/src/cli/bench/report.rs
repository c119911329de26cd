//! The headline summary and the report: `bench.md` (markdown) and the `bench.json` document.

use std::fmt::Write as _;

use pivotsim_server::solver::Variant;
use serde::Serialize;

use super::kernels::{DenseKernel, EnvelopeKernel, Fig4, fmt_crossover};
use super::plan::Plan;
use super::problems::{ProblemResult, RunRecord, VariantResult};
use super::timing::{geo_mean, median};

/// Headline numbers of a run (also in `bench.json` and printed at the end).
#[derive(Debug, Clone, Default, Serialize)]
pub struct Summary {
    /// Mode: quick, full or tiny.
    pub mode: String,
    /// Generated contact-like problems of the focus size (m ≈ 430) the ratios are taken over.
    pub focus_problems: Vec<String>,
    /// Geometric mean over the focus problems of `time(full) / time(auto)`, 35 steps.
    pub auto_vs_full: Option<f64>,
    /// Same for `skyline` (paper Table 3, crane: 3.6×).
    pub skyline_vs_full: Option<f64>,
    /// Same for `downdate` (paper Table 3, crane: 2.7×).
    pub downdate_vs_full: Option<f64>,
    /// Median over the focus problems of auto's µs per pivot step.
    pub auto_us_per_step: Option<f64>,
    /// Median over the focus problems of auto's ms per solve (35-step cap).
    pub auto_ms_per_solve: Option<f64>,
    /// Same four numbers on `scene-crane430` when it was loaded: (auto/full, skyline/full,
    /// µs per step auto, ms per solve auto).
    pub crane430: Option<(f64, f64, f64, f64)>,
    /// Problems (all sources) the `auto` variant converged on within 35 steps, and the total.
    pub converged_35: (usize, usize),
    /// Same within 1000 steps (skipped runs count as not converged).
    pub converged_1000: (usize, usize),
    /// Worst relative deletion error over every problem and deleting variant, with where.
    pub worst_deletion_error_rel: Option<(f64, String)>,
    /// Worst absolute deletion error (paper Table 4 unit), with where.
    pub worst_deletion_error_abs: Option<(f64, String)>,
    /// Worst relative and absolute deletion errors over the runs without regularized pivots
    /// (positive definite `A`, the setting of paper Table 4).
    pub worst_deletion_error_spd: Option<(f64, f64, String)>,
    /// Largest backward error `‖L Lᵀ − A_FF‖_F / ‖A_FF‖_F` of a deleted envelope factor, and where.
    pub worst_deletion_backward_error: Option<(f64, String)>,
    /// Envelope kernel crossover (tight count) on the generated contact-like matrix.
    pub envelope_crossover_tight: Option<f64>,
    /// Dense kernel crossover (% tight) on the random dense SPD matrix of the kernel size.
    pub dense_crossover_pct: Option<f64>,
    /// Wall time of the whole benchmark, s.
    pub elapsed_s: f64,
}

pub fn ratio_of(p: &ProblemResult, num: Variant, den: Variant) -> Option<f64> {
    Some(p.variant(num)?.short.time_us / p.variant(den)?.short.time_us)
}

pub fn summarize(
    plan: &Plan,
    problems: &[ProblemResult],
    env: &[EnvelopeKernel],
    dk: &[DenseKernel],
) -> Summary {
    let lo = plan.focus_m as f64 * 0.9;
    let hi = plan.focus_m as f64 * 1.1;
    let focus: Vec<&ProblemResult> = problems
        .iter()
        .filter(|p| p.group == "generated" && (p.m as f64) >= lo && (p.m as f64) <= hi)
        .collect();
    let ratios =
        |num: Variant| -> Vec<f64> { focus.iter().filter_map(|p| ratio_of(p, Variant::Full, num)).collect() };
    let mut per_step: Vec<f64> =
        focus.iter().filter_map(|p| p.variant(Variant::Auto)?.short.us_per_step).collect();
    let mut per_solve: Vec<f64> =
        focus.iter().filter_map(|p| Some(p.variant(Variant::Auto)?.short.time_us * 1e-3)).collect();
    let crane430 = problems.iter().find(|p| p.name.contains("crane430")).and_then(|p| {
        let auto = p.variant(Variant::Auto)?;
        Some((
            ratio_of(p, Variant::Full, Variant::Auto)?,
            ratio_of(p, Variant::Full, Variant::Skyline)?,
            auto.short.us_per_step?,
            auto.short.time_us * 1e-3,
        ))
    });
    let autos: Vec<&VariantResult> = problems.iter().filter_map(|p| p.variant(Variant::Auto)).collect();
    let c35 = autos.iter().filter(|r| r.short.converged()).count();
    let c1000 = autos.iter().filter(|r| r.long.as_ref().is_some_and(RunRecord::converged)).count();
    let mut worst_rel: Option<(f64, String)> = None;
    let mut worst_abs: Option<(f64, String)> = None;
    let mut worst_spd: Option<(f64, f64, String)> = None;
    let mut worst_back: Option<(f64, String)> = None;
    for p in problems {
        for r in &p.variants {
            if let Some(e) =
                r.deletion_backward_error.filter(|e| worst_back.as_ref().is_none_or(|w| *e > w.0))
            {
                worst_back = Some((e, format!("{} [{}]", p.name, r.variant)));
            }
            if let (Some(e), Some(a), 0) =
                (r.deletion_error, r.deletion_error_abs, r.deletion_run_regularized)
            {
                let (we, wa, wat) = worst_spd.take().unwrap_or((0.0, 0.0, String::new()));
                let wat = if e > we { format!("{} [{}]", p.name, r.variant) } else { wat };
                worst_spd = Some((we.max(e), wa.max(a), wat));
            }
            let at = format!("{} [{}]", p.name, r.variant);
            if let Some(e) = r.deletion_error.filter(|e| worst_rel.as_ref().is_none_or(|w| *e > w.0)) {
                worst_rel = Some((e, at.clone()));
            }
            if let Some(e) = r.deletion_error_abs.filter(|e| worst_abs.as_ref().is_none_or(|w| *e > w.0)) {
                worst_abs = Some((e, at));
            }
        }
    }
    Summary {
        mode: plan.mode.to_string(),
        focus_problems: focus.iter().map(|p| p.name.clone()).collect(),
        auto_vs_full: geo_mean(&ratios(Variant::Auto)),
        skyline_vs_full: geo_mean(&ratios(Variant::Skyline)),
        downdate_vs_full: geo_mean(&ratios(Variant::Downdate)),
        auto_us_per_step: (!per_step.is_empty()).then(|| median(&mut per_step)),
        auto_ms_per_solve: (!per_solve.is_empty()).then(|| median(&mut per_solve)),
        crane430,
        converged_35: (c35, autos.len()),
        converged_1000: (c1000, autos.len()),
        worst_deletion_error_rel: worst_rel,
        worst_deletion_error_abs: worst_abs,
        worst_deletion_error_spd: worst_spd,
        worst_deletion_backward_error: worst_back,
        envelope_crossover_tight: env.first().and_then(|e| e.crossover_tight.value),
        dense_crossover_pct: dk
            .iter()
            .find(|d| d.matrix.starts_with("random"))
            .and_then(|d| d.crossover_pct.value),
        elapsed_s: 0.0,
    }
}

pub fn opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}")).unwrap_or_else(|| "—".into())
}

pub fn summary_text(s: &Summary) -> String {
    let mut t = String::new();
    let pct = |(a, n): (usize, usize)| if n == 0 { 0.0 } else { 100.0 * a as f64 / n as f64 };
    let _ = writeln!(t, "Summary ({} mode, {:.1} s)", s.mode, s.elapsed_s);
    let _ = writeln!(t, "  contact-like m≈430 problems: {}", s.focus_problems.join(", "));
    let _ = writeln!(t, "    auto vs full speed-up (35 steps):      {}×", opt(s.auto_vs_full, 2));
    let _ = writeln!(t, "    skyline vs full speed-up (paper 3.6×): {}×", opt(s.skyline_vs_full, 2));
    let _ = writeln!(t, "    downdate vs full speed-up (paper 2.7×): {}×", opt(s.downdate_vs_full, 2));
    let _ = writeln!(
        t,
        "    auto: {} µs per pivot step, {} ms per solve (≤ 35 steps)",
        opt(s.auto_us_per_step, 1),
        opt(s.auto_ms_per_solve, 3)
    );
    if let Some((af, sf, ps, ms)) = s.crane430 {
        let _ = writeln!(
            t,
            "  scene-crane430: auto vs full {af:.2}×, skyline vs full {sf:.2}×, auto {ps:.1} µs/step, {ms:.3} ms/solve"
        );
    }
    let _ = writeln!(
        t,
        "  auto converged within 35 steps: {}/{} problems ({:.0} %); within 1000: {}/{} ({:.0} %)",
        s.converged_35.0,
        s.converged_35.1,
        pct(s.converged_35),
        s.converged_1000.0,
        s.converged_1000.1,
        pct(s.converged_1000)
    );
    match (&s.worst_deletion_error_rel, &s.worst_deletion_error_abs) {
        (Some((r, wr)), Some((a, wa))) => {
            let _ = writeln!(t, "  worst deletion error: relative {r:.2e} ({wr}), absolute {a:.2e} ({wa})");
        }
        _ => {
            let _ = writeln!(t, "  worst deletion error: — (not measured)");
        }
    }
    if let Some((b, at)) = &s.worst_deletion_backward_error {
        let _ = writeln!(t, "  worst deletion backward error ‖LLᵀ − A_FF‖/‖A_FF‖: {b:.2e} ({at})");
    }
    if let Some((r, a, at)) = &s.worst_deletion_error_spd {
        let _ = writeln!(
            t,
            "  worst deletion error without regularized pivots: relative {r:.2e} ({at}), absolute {a:.2e}"
        );
    }
    let _ = writeln!(
        t,
        "  kernel crossover: envelope {} tight, dense {} % tight",
        opt(s.envelope_crossover_tight, 1),
        opt(s.dense_crossover_pct, 1)
    );
    t
}

#[derive(Debug, Serialize)]
pub struct Report<'a> {
    pub mode: &'static str,
    pub cpu: String,
    pub build: &'static str,
    pub short_steps: usize,
    pub long_steps: usize,
    pub summary: &'a Summary,
    pub kernel_envelope: &'a [EnvelopeKernel],
    pub kernel_dense: &'a [DenseKernel],
    pub fig4: &'a Fig4,
    pub problems: &'a [ProblemResult],
    pub unreadable_files: &'a [(String, String)],
}

pub fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|x| x.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

pub fn build_kind() -> &'static str {
    if cfg!(debug_assertions) { "debug (timings not representative)" } else { "release" }
}

pub fn markdown(r: &Report<'_>) -> String {
    let mut md = String::new();
    write_header(&mut md, r);
    write_envelope_kernels(&mut md, r.kernel_envelope);
    write_dense_kernels(&mut md, r.kernel_dense);
    write_fig4(&mut md, r.fig4);
    write_variant_convergence(&mut md, r.problems);
    for p in r.problems {
        write_problem(&mut md, p);
    }
    write_unreadable_files(&mut md, r.unreadable_files);
    md
}

/// Title, machine line and the headline summary.
fn write_header(w: &mut String, r: &Report<'_>) {
    let _ = writeln!(w, "# pivotsim solver benchmark ({} mode)\n", r.mode);
    let _ = writeln!(
        w,
        "{} · {} build · single thread · median of repeats · step caps {} and {}\n",
        r.cpu, r.build, r.short_steps, r.long_steps
    );
    let _ = writeln!(w, "## Summary\n\n```text\n{}```\n", summary_text(r.summary));
}

/// Section 1, envelope half: the kernel table and each matrix's sweep.
fn write_envelope_kernels(w: &mut String, kernel_envelope: &[EnvelopeKernel]) {
    let _ = writeln!(w, "## 1. Kernel crossover\n");
    let _ = writeln!(
        w,
        "Envelope (RCM order): one factorization of `A`, one copy of `L₀`, single deletions at 8 indices \
         spread over the matrix (copy subtracted; a deletion sweeps to the end of its connected block, so \
         its cost falls with the index); crossover = tight count from which copy + deletions from `L₀` no \
         longer beat an envelope refactor of the masked matrix (sweep averaged over random nested tight \
         sets; model = (factor − copy) / mean deletion).\n"
    );
    let _ = writeln!(
        w,
        "| matrix | m | bandwidth in → RCM | envelope entries | factor µs | copy µs | deletion µs (min–max) | crossover (sweep) | crossover (model) |"
    );
    let _ = writeln!(w, "|---|---|---|---|---|---|---|---|---|");
    for e in kernel_envelope {
        let _ = writeln!(
            w,
            "| {} | {} | {} → {} | {} | {:.2} | {:.2} | {:.2} ({:.2}–{:.2}) | {} tight | {:.1} tight |",
            e.matrix,
            e.m,
            e.bandwidth_input,
            e.bandwidth_rcm,
            e.envelope_entries,
            e.factor_us,
            e.copy_us,
            e.deletion_us_mean,
            e.deletion_us_min,
            e.deletion_us_max,
            fmt_crossover(&e.crossover_tight, "", 1),
            e.crossover_model
        );
    }
    for e in kernel_envelope {
        let _ = writeln!(w, "\nSweep on {} (µs):\n", e.matrix);
        let _ = writeln!(w, "| tight | copy + deletions | masked refactor | speed-up |");
        let _ = writeln!(w, "|---|---|---|---|");
        for p in e.sweep.iter().filter(|p| p.tight <= 8 || p.tight % 4 == 0) {
            let _ = writeln!(
                w,
                "| {} | {:.2} | {:.2} | {:.2}× |",
                p.tight, p.downdate_us, p.refactor_us, p.speedup
            );
        }
    }
}

/// Section 1, dense half: the kernel table and each matrix's sweep.
fn write_dense_kernels(w: &mut String, kernel_dense: &[DenseKernel]) {
    let _ = writeln!(
        w,
        "\nDense (input order): gather + dense Cholesky of the whole matrix, copy of `L₀`, single deletions; \
         crossover in % tight from the sweep of (copy + deletions) against (gather + Cholesky of compact `A_FF`).\n"
    );
    let _ = writeln!(w, "| matrix | m | factor µs | copy µs | deletion µs (mean) | crossover |");
    let _ = writeln!(w, "|---|---|---|---|---|---|");
    for d in kernel_dense {
        let _ = writeln!(
            w,
            "| {} | {} | {:.1} | {:.1} | {:.2} | {} |",
            d.matrix,
            d.m,
            d.factor_us,
            d.copy_us,
            d.deletion_us_mean,
            fmt_crossover(&d.crossover_pct, " %", 1)
        );
    }
    for d in kernel_dense {
        let _ = writeln!(w, "\nDense sweep on {} (µs):\n", d.matrix);
        let _ = writeln!(w, "| tight % | tight | copy + deletions | gather + Cholesky | speed-up |");
        let _ = writeln!(w, "|---|---|---|---|---|");
        for p in &d.sweep {
            let _ = writeln!(
                w,
                "| {:.1} | {} | {:.1} | {:.1} | {:.2}× |",
                p.tight_pct, p.tight, p.downdate_us, p.refactor_us, p.speedup
            );
        }
    }
}

/// Section 2: the paper's Fig. 4 speed-up table, one row a size.
fn write_fig4(w: &mut String, fig4: &Fig4) {
    let _ =
        writeln!(w, "\n## 2. Paper Fig. 4: speed-up of copy + deletions over a dense refactor of `A_FF`\n");
    let _ = writeln!(
        w,
        "Random dense SPD `(B Bᵀ + m I)/m`; entries are `refactor / (copy + deletions)`; > 1 means the deletions win. Plot: `fig4_speedup.svg`.\n"
    );
    let _ = write!(w, "| m |");
    for f in &fig4.tight_pct {
        let _ = write!(w, " {f}% |");
    }
    let _ = writeln!(w);
    let _ = writeln!(w, "|---|{}", "---|".repeat(fig4.tight_pct.len()));
    for (m, sw) in fig4.sizes.iter().zip(&fig4.sweeps) {
        let _ = write!(w, "| {m} |");
        for p in sw {
            let _ = write!(w, " {:.2} |", p.speedup);
        }
        let _ = writeln!(w);
    }
}

/// Sections 3–4 opening: how the columns are measured and convergence per variant.
fn write_variant_convergence(w: &mut String, problems: &[ProblemResult]) {
    let _ = writeln!(w, "\n## 3–4. Solver variants per problem\n");
    let _ = writeln!(
        w,
        "Times are the solver's `total_us` (ordering included), median over repeats, step cap 35. \
         `converged@1000` reruns with 1000 steps (copied when already converged within 35; skipped when \
         its predicted time exceeds the mode's budget). Deletion error: `max ‖L_del − chol(A_FF)‖_F` \
         over the pivot steps, relative / absolute (paper Table 4), for the variants that delete. \
         `auto` choices: deletions from L₀ / from the previous factor / incremental refactor.\n"
    );
    let _ = writeln!(w, "Convergence per variant over all {} problems:\n", problems.len());
    let _ = writeln!(w, "| variant | converged@35 | converged@1000 | 1000-step runs skipped |");
    let _ = writeln!(w, "|---|---|---|---|");
    for v in Variant::ALL {
        let rs: Vec<&VariantResult> = problems.iter().filter_map(|p| p.variant(v)).collect();
        let c35 = rs.iter().filter(|x| x.short.converged()).count();
        let c1000 = rs.iter().filter(|x| x.long.as_ref().is_some_and(RunRecord::converged)).count();
        let sk = rs.iter().filter(|x| x.long_skipped.is_some()).count();
        let _ = writeln!(w, "| {v} | {c35}/{} | {c1000}/{} | {sk} |", rs.len(), rs.len());
    }
}

/// One problem's subsection: its shape line and a row per variant.
fn write_problem(w: &mut String, p: &ProblemResult) {
    let _ = writeln!(w, "\n### {} ({})\n", p.name, p.group);
    let origin = match (p.seed, p.mass_ratio) {
        (Some(s), Some(mr)) => format!(", seed {s}, mass ratio {mr}"),
        _ => String::new(),
    };
    let _ = writeln!(
        w,
        "m = {}, nnz = {}, rows: {} unbounded, {} friction, {} other; bandwidth {} → {} and envelope {} → {} (RCM){}\n",
        p.m,
        p.nnz,
        p.rows_unbounded,
        p.rows_friction,
        p.rows_other,
        p.bandwidth_before,
        p.bandwidth_after,
        p.envelope_before,
        p.envelope_after,
        origin
    );
    let _ = writeln!(
        w,
        "| variant | status@35 | steps | tight | time ms @35 | µs/step | residual_rel | converged@1000 | deletion error rel / abs / backward | auto choices |"
    );
    let _ = writeln!(w, "|---|---|---|---|---|---|---|---|---|---|");
    for r in &p.variants {
        write_variant_row(w, r);
    }
}

/// One variant's row of a problem table.
fn write_variant_row(w: &mut String, r: &VariantResult) {
    let s = &r.short;
    let long = match (&r.long, &r.long_skipped) {
        (Some(l), _) if l.converged() => format!("yes ({})", l.steps()),
        (Some(l), _) => format!("no ({}, r={:.1e})", l.stats.status.name(), l.stats.residual_rel),
        (None, Some(why)) => format!("skipped ({why})"),
        (None, None) => "—".into(),
    };
    let del = match (r.deletion_error, r.deletion_error_abs, &r.deletion_error_skipped) {
        (Some(a), Some(b), _) if r.deletion_run_regularized > 0 => {
            format!("{a:.1e} / {b:.1e} ({} regularized)", r.deletion_run_regularized)
        }
        (Some(a), Some(b), _) => match r.deletion_backward_error {
            Some(c) => format!("{a:.1e} / {b:.1e} / {c:.1e}"),
            None => format!("{a:.1e} / {b:.1e}"),
        },
        (_, _, Some(why)) => format!("skipped ({why})"),
        _ => "—".into(),
    };
    let choices = if r.variant == Variant::Auto {
        format!("{}/{}/{}", s.stats.auto_choices[0], s.stats.auto_choices[1], s.stats.auto_choices[2])
    } else {
        String::new()
    };
    let _ = writeln!(
        w,
        "| {} | {} | {} | {} | {:.3} | {} | {:.1e} | {} | {} | {} |",
        r.variant,
        s.stats.status.name(),
        s.steps(),
        s.stats.tight,
        s.time_us * 1e-3,
        opt(s.us_per_step, 1),
        s.stats.residual_rel,
        long,
        del,
        choices
    );
}

/// The closing list of input files that could not be read, when there are any.
fn write_unreadable_files(w: &mut String, unreadable_files: &[(String, String)]) {
    if !unreadable_files.is_empty() {
        let _ = writeln!(w, "\n### Files that could not be read\n");
        for (f, e) in unreadable_files {
            let _ = writeln!(w, "- `{f}`: {e}");
        }
    }
}
