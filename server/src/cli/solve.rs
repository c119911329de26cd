//! `solve`: one MLCP file, its statistics as text or as one JSON object.
//!
//! The JSON object is the file name plus [`SolveStats`] as it serializes (one source of truth:
//! every field of the statistics, under its own name, and nothing written by hand here).

use std::path::{Path, PathBuf};

use anyhow::Context;
use pivotsim_server::solver::{OrderingKind, SolveStats, Solver, SolverOptions, Variant, io};
use serde::Serialize;

use super::values;

/// Options of `solve`.
#[derive(Debug, clap::Args)]
pub struct SolveArgs {
    /// The problem file.
    pub file: PathBuf,
    /// Solver variant: full, downdate, skyline, skyline-refactor, incremental, auto, pgs.
    #[arg(long, default_value = "auto")]
    pub variant: Variant,
    /// Cap on pivot steps (PGS: sweeps), 1 to 1,000,000.
    #[arg(long, allow_negative_numbers = true, default_value_t = 35, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub max_steps: u32,
    /// Reordering for the envelope variants: natural, cm, rcm.
    #[arg(long, default_value = "rcm")]
    pub ordering: OrderingKind,
    /// Relative natural-map residual to reach (a finite number > 0).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1e-10, value_parser = values::positive_finite)]
    pub tol: f64,
    /// Write λ here (one number per line, 17 significant digits).
    #[arg(long)]
    pub solution: Option<PathBuf>,
    /// Also measure the deletion error against a refactor from scratch (slower).
    #[arg(long)]
    pub deletion_error: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What `solve --json` prints: the file and every statistic of the solve.
#[derive(Debug, Serialize)]
pub struct SolveReport<'a> {
    /// The problem file as given.
    pub file: String,
    /// The solve's statistics, flattened into the same object.
    #[serde(flatten)]
    pub stats: &'a SolveStats,
}

/// Runs `solve`.
pub fn solve(args: &SolveArgs) -> anyhow::Result<()> {
    let file = &args.file;
    let p = io::read_mlcp_file(file)?;
    let max_steps = args.max_steps as usize;
    let mut opts = SolverOptions {
        variant: args.variant,
        ordering: args.ordering,
        max_steps,
        tol_rel: args.tol,
        ..Default::default()
    };
    opts.pgs.max_iterations = max_steps;
    opts.pgs.tol_rel = args.tol;
    opts.measure_deletion_error = args.deletion_error;
    let mut solver = Solver::new(opts);
    let mut lambda = vec![0.0; p.n()];
    let st = solver.solve(&p, &mut lambda).clone();
    if let Some(out) = &args.solution {
        write_solution(out, &lambda)?;
    }
    if args.json {
        let report = SolveReport { file: file.display().to_string(), stats: &st };
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}", text(file, &st));
    }
    Ok(())
}

fn write_solution(out: &Path, lambda: &[f64]) -> anyhow::Result<()> {
    let f = std::fs::File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut f = std::io::BufWriter::new(f);
    io::write_solution(lambda, &mut f).with_context(|| format!("cannot write {}", out.display()))
}

fn text(file: &Path, st: &SolveStats) -> String {
    format!(
        "{}: n={} variant={} status={} pivot_steps={} tight={} residual={:.3e} (rel {:.3e}) time={:.1} µs \
         [order {:.1}, factor {:.1}, downdate {:.1}, solve {:.1}] bandwidth {}→{} envelope {}→{} regularized={}",
        file.display(),
        st.m,
        st.variant,
        st.status.name(),
        if st.variant == Variant::Pgs { st.iterations } else { st.pivot_steps },
        st.tight,
        st.residual,
        st.residual_rel,
        st.total_us,
        st.ordering_us,
        st.factor_us,
        st.downdate_us,
        st.solve_us,
        st.bandwidth_before,
        st.bandwidth_after,
        st.envelope_before,
        st.envelope_after,
        st.regularized
    )
}
