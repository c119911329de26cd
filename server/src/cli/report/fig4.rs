//! Stage 5, the paper's Fig. 4: how much faster deleting the tight rows from a copy of `L₀` is than
//! refactoring `A_FF`, against the matrix size, one curve per tight percentage — on random dense
//! SPD matrices (the paper's experiment: dense deletions against a dense Cholesky of the compact
//! `A_FF`) and on banded contact-like matrices (the generator's crane-shaped islands, reverse
//! Cuthill–McKee order: envelope deletions against the envelope refactor of `A_FF ⊕ I`, our
//! `skyline` against `skyline-refactor`). Timings are the fastest of a few samples, as
//! `bench-solver` takes them (its kernels, on the report's own grid).

use indicatif::ProgressBar;
use pivotsim_server::solver::generate::contact_like;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::Plan;
use crate::cli::bench::{SweepPoint, dense_sweep, envelope_fig4, random_spd};

/// One matrix of the grid.
#[derive(Debug, Clone, Serialize)]
pub struct Fig4Size {
    /// Rows.
    pub m: usize,
    /// One point per tight percentage of the plan.
    pub points: Vec<SweepPoint>,
}

/// Both grids.
#[derive(Debug, Clone, Serialize)]
pub struct Fig4 {
    /// Tight percentages of each sweep.
    pub tight_pct: Vec<f64>,
    /// Random dense SPD matrices.
    pub dense: Vec<Fig4Size>,
    /// Banded contact-like matrices on the envelope.
    pub envelope: Vec<Fig4Size>,
}

/// Runs both grids.
pub fn run(plan: &Plan, pb: &ProgressBar) -> Fig4 {
    let (tu, reps) = (plan.fig4_target_us, plan.repeats);
    let mut out = Fig4 { tight_pct: plan.fig4_fracs.clone(), dense: Vec::new(), envelope: Vec::new() };
    for &m in &plan.fig4_sizes {
        pb.set_message(format!("Fig. 4: dense, m = {m}"));
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + m as u64);
        let a = random_spd(m, &mut rng);
        out.dense.push(Fig4Size { m, points: dense_sweep(&a, m, &plan.fig4_fracs, tu, reps, &mut rng) });
        pb.set_message(format!("Fig. 4: envelope, m = {m}"));
        let p = contact_like(m, 430, 6_300.0);
        let points = envelope_fig4(p.a(), &plan.fig4_fracs, tu, reps, 3, 11);
        out.envelope.push(Fig4Size { m: p.n(), points });
        pb.inc(1);
    }
    out
}
