//! `solve`: one MLCP file, its statistics as text or as one JSON object.
//!
//! The JSON object is the file name plus [`SolveStats`] as it serializes (one source of truth:
//! every field of the statistics, under its own name, and nothing written by hand here).

use std::path::{Path, PathBuf};

use anyhow::Context;
use pivotsim_server::solver::{Mlcp, OrderingKind, SolveStats, Solver, SolverOptions, Variant, io};
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
    /// Solve this many times in one process (1 to 10,000), each from the file's warm start (or
    /// cold, as the file says) with the same solver, and report the median and least total time;
    /// the statistics printed are the last solve's, which every repeat reproduces bit for bit.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub repeats: u32,
}

/// What `solve --json` prints: the file and every statistic of the solve.
#[derive(Debug, Serialize)]
pub struct SolveReport<'a> {
    /// The problem file as given.
    pub file: String,
    /// Solves timed (`--repeats`).
    pub repeats: usize,
    /// Median total time of the repeats (µs).
    pub median_us: f64,
    /// Least total time of the repeats (µs).
    pub min_us: f64,
    /// The solve's statistics, flattened into the same object.
    #[serde(flatten)]
    pub stats: &'a SolveStats,
}

/// The times of `repeats` solves of one problem by one solver, and the last solve's statistics
/// and answer.
#[derive(Debug, Clone)]
pub struct Repeated {
    /// Total time of each solve (µs), in the order run.
    pub times_us: Vec<f64>,
    /// The last solve's statistics.
    pub stats: SolveStats,
    /// The last solve's `λ` (problem row order).
    pub lambda: Vec<f64>,
}

impl Repeated {
    /// Median of the times (µs).
    pub fn median_us(&self) -> f64 {
        super::bench::median(&mut self.times_us.clone())
    }

    /// Least of the times (µs).
    pub fn min_us(&self) -> f64 {
        self.times_us.iter().copied().fold(f64::INFINITY, f64::min)
    }
}

/// Solves `p` `repeats` times (at least once) with one solver of options `opts`, each solve from
/// the problem's own warm start and with the cost model's memory of the earlier repeats forgotten
/// ([`Solver::forget_history`]). Every repeat must give the same `λ` bit for bit (the solver is
/// deterministic: no clock decides a step unless a time budget is set); a repeat that does not is an
/// error, since its time would not be the time of the same solve.
pub fn solve_repeated(p: &Mlcp, opts: SolverOptions, repeats: usize) -> anyhow::Result<Repeated> {
    let mut solver = Solver::new(opts);
    let mut lambda = vec![0.0; p.n()];
    let mut first: Option<Vec<f64>> = None;
    let mut times_us = Vec::with_capacity(repeats.max(1));
    for _ in 0..repeats.max(1) {
        lambda.fill(0.0);
        solver.forget_history();
        times_us.push(solver.solve(p, &mut lambda).total_us);
        match &first {
            None => first = Some(lambda.clone()),
            Some(f) => {
                if f.iter().zip(&lambda).any(|(a, b)| a.to_bits() != b.to_bits()) {
                    anyhow::bail!("a repeated solve gave another answer (the solve is not deterministic)");
                }
            }
        }
    }
    Ok(Repeated { times_us, stats: solver.stats().clone(), lambda })
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
    let r = solve_repeated(&p, opts, args.repeats as usize)?;
    if let Some(out) = &args.solution {
        write_solution(out, &r.lambda)?;
    }
    if args.json {
        let report = SolveReport {
            file: file.display().to_string(),
            repeats: r.times_us.len(),
            median_us: r.median_us(),
            min_us: r.min_us(),
            stats: &r.stats,
        };
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}", text(file, &r.stats));
        if r.times_us.len() > 1 {
            println!("{} solves: median {:.1} µs, min {:.1} µs", r.times_us.len(), r.median_us(), r.min_us());
        }
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
