//! Stage 5: the regression corpus of real islands (`server/tests/data/corpus`, its README): per
//! scene set, how many of the hardest solves converge within the paper's 35 steps and within 100,
//! warm (the simulation's warm start) and cold, and the total `auto` time; then the per-solve time
//! of the small islands (`corpus/small`, ≤ 30 rows) with each exact variant.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use pivotsim_server::solver::{SolveStatus, Solver, SolverOptions, Variant, io};
use serde::Serialize;

use super::timing::time_us;
use super::txt_files;

/// One scene set of the corpus.
#[derive(Debug, Serialize)]
pub struct CorpusSet {
    /// Scene set (`forklift`, `winch-c1e-10`, …).
    pub set: String,
    /// Files.
    pub files: usize,
    /// Largest island (rows).
    pub max_rows: usize,
    /// Converged within 35 / 100 steps, warm start.
    pub warm: (usize, usize),
    /// Converged within 35 / 100 steps, cold.
    pub cold: (usize, usize),
    /// Total `auto` time of the warm solves at cap 100 (µs).
    pub warm_auto_us: f64,
    /// Total `auto` time of the cold solves at cap 100 (µs).
    pub cold_auto_us: f64,
}

/// Per-solve time of one small island.
#[derive(Debug, Serialize)]
pub struct SmallIsland {
    /// File stem.
    pub name: String,
    /// Rows.
    pub m: usize,
    /// Median µs per solve by variant (cold, cap 35).
    pub us: Vec<(String, f64)>,
}

/// The corpus stage's results.
#[derive(Debug, Default, Serialize)]
pub struct CorpusReport {
    /// Per scene set.
    pub sets: Vec<CorpusSet>,
    /// Small islands.
    pub small: Vec<SmallIsland>,
}

fn set_of(stem: &str) -> String {
    stem.split("-hard").next().unwrap_or(stem).to_string()
}

/// Runs the stage on `dir` (nothing when it holds no files).
pub fn run(dir: &Path, target_us: f64, repeats: usize, mut tick: impl FnMut(&str)) -> CorpusReport {
    let mut sets: BTreeMap<String, CorpusSet> = BTreeMap::new();
    let mut solver =
        Solver::new(SolverOptions { variant: Variant::Auto, max_steps: 100, ..Default::default() });
    for f in txt_files(dir) {
        let Ok(p) = io::read_mlcp_file(&f) else { continue };
        let stem = f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        tick(&stem);
        let set = set_of(&stem);
        let e = sets.entry(set.clone()).or_insert_with(|| CorpusSet {
            set,
            files: 0,
            max_rows: 0,
            warm: (0, 0),
            cold: (0, 0),
            warm_auto_us: 0.0,
            cold_auto_us: 0.0,
        });
        e.files += 1;
        e.max_rows = e.max_rows.max(p.n());
        for (is_warm, q) in [(true, p.clone()), (false, p.without_warm_start())] {
            let mut lambda = vec![0.0; q.n()];
            let st = solver.solve(&q, &mut lambda).clone();
            let ok = st.status == SolveStatus::Converged;
            let (counts, time) =
                if is_warm { (&mut e.warm, &mut e.warm_auto_us) } else { (&mut e.cold, &mut e.cold_auto_us) };
            counts.0 += (ok && st.pivot_steps <= 35) as usize;
            counts.1 += ok as usize;
            *time += st.total_us;
        }
    }
    let mut small = Vec::new();
    for f in txt_files(&dir.join("small")) {
        let Ok(p) = io::read_mlcp_file(&f) else { continue };
        let p = p.without_warm_start();
        let stem = f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        tick(&stem);
        let mut us = Vec::new();
        for v in [Variant::Full, Variant::Downdate, Variant::Skyline, Variant::Auto, Variant::Pgs] {
            let mut s = Solver::new(SolverOptions { variant: v, ..Default::default() });
            let mut lambda = vec![0.0; p.n()];
            us.push((
                v.name().to_string(),
                time_us(target_us, repeats, || {
                    s.solve(&p, &mut lambda);
                }),
            ));
        }
        small.push(SmallIsland { name: stem, m: p.n(), us });
    }
    CorpusReport { sets: sets.into_values().collect(), small }
}

/// The stage as markdown.
pub fn markdown(r: &CorpusReport) -> String {
    let mut md = String::new();
    if r.sets.is_empty() && r.small.is_empty() {
        return md;
    }
    let _ = writeln!(md, "\n## Regression corpus of real islands (`server/tests/data/corpus`)\n");
    let _ = writeln!(
        md,
        "`auto`, cap 100; converged within 35 / 100 steps, warm (the simulation's warm start) and cold.\n"
    );
    let _ = writeln!(
        md,
        "| set | files | max rows | warm ≤35 | warm ≤100 | cold ≤35 | cold ≤100 | auto warm total ms | auto cold total ms |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for s in &r.sets {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} |",
            s.set,
            s.files,
            s.max_rows,
            s.warm.0,
            s.warm.1,
            s.cold.0,
            s.cold.1,
            s.warm_auto_us / 1e3,
            s.cold_auto_us / 1e3
        );
    }
    if let Some(first) = r.small.first() {
        let _ = writeln!(md, "\nSmall islands (≤ 30 rows), median µs per cold solve:\n");
        let names: Vec<&str> = first.us.iter().map(|(n, _)| n.as_str()).collect();
        let _ = writeln!(md, "| island | rows | {} |", names.join(" | "));
        let _ = writeln!(md, "|---|---:|{}", "---:|".repeat(names.len()));
        for s in &r.small {
            let cells: Vec<String> = s.us.iter().map(|(_, t)| format!("{t:.2}")).collect();
            let _ = writeln!(md, "| {} | {} | {} |", s.name, s.m, cells.join(" | "));
        }
    }
    md
}
