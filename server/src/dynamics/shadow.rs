//! Shadow solves: every island problem of a step also handed to other solver variants, their
//! answers discarded — a paired measurement of speed and agreement on the very problems the world
//! solves (`run --shadow`, the report's paired speed-ups).
//!
//! Separate runs of two variants are timed minutes apart, and on a shared or virtual machine the
//! speed of the host drifts by ±30 % between them (the crane's `full`/`auto` ratio read 5.8× to
//! 10.1× over five pairs of runs of one binary). Here each variant solves the same problem — the
//! same `A`, `b`, bounds and warm start — within microseconds of the other, and the order
//! alternates every step (odd steps the shadows first), so drift and cache warmth fall on both
//! alike. The shadows keep their own solvers per island slot, so their ordering and pattern reuse
//! across steps match the world's own solver. With a step time budget (`max_solve_us`) the world's
//! solve goes first always: the shadows do not spend its budget and have none of their own.
//!
//! The *deviation* of a shadow is `‖λ_s − λ‖∞ / ‖λ‖∞` against the world's own answer: two exact
//! variants agree to the solver's tolerance on every island (checked in the tests), a
//! trajectory-level comparison of variants cannot say as much once a chaotic scene (a grasp) parts
//! them.
//!
//! Off by default: no shadow, no cost. On, it allocates a solver per variant and island slot as
//! the world's own solver list grows, and nothing per step after that.

use super::stats::{IslandStats, MAX_SHADOWS, ShadowSolve};
use crate::solver::{Mlcp, Solver, SolverOptions, Variant};

/// More shadow variants than [`MAX_SHADOWS`] were asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{0} shadow variants asked for, at most {MAX_SHADOWS}")]
pub struct TooManyShadows(pub usize);

/// One shadow variant: its solvers (one per island slot) and the answer of the last solve.
#[derive(Debug)]
struct Shadow {
    variant: Variant,
    solvers: Vec<Solver>,
    lambda: Vec<f64>,
    last: ShadowSolve,
}

/// The shadow variants of a world.
#[derive(Debug, Default)]
pub(crate) struct Shadows {
    shadows: Vec<Shadow>,
}

impl Shadows {
    /// Sets the variants (replacing any earlier ones and their solvers).
    pub fn set_variants(&mut self, variants: &[Variant]) -> Result<(), TooManyShadows> {
        if variants.len() > MAX_SHADOWS {
            return Err(TooManyShadows(variants.len()));
        }
        self.shadows = variants
            .iter()
            .map(|&variant| Shadow {
                variant,
                solvers: Vec::new(),
                lambda: Vec::new(),
                last: ShadowSolve::default(),
            })
            .collect();
        Ok(())
    }

    /// The variants, in order.
    pub fn variants(&self) -> impl Iterator<Item = Variant> + '_ {
        self.shadows.iter().map(|s| s.variant)
    }

    /// Whether there is any.
    pub fn is_empty(&self) -> bool {
        self.shadows.is_empty()
    }

    /// New solver options (the world's, each with its own variant).
    pub fn set_options(&mut self, opts: SolverOptions) {
        for sh in &mut self.shadows {
            for s in &mut sh.solvers {
                s.set_options(SolverOptions { variant: sh.variant, ..opts });
            }
        }
    }

    /// Solves `p` (island slot `slot`) with every shadow variant.
    pub fn solve(&mut self, p: &Mlcp, slot: usize, opts: SolverOptions) {
        for sh in &mut self.shadows {
            while sh.solvers.len() <= slot {
                sh.solvers.push(Solver::new(SolverOptions { variant: sh.variant, ..opts }));
            }
            sh.lambda.clear();
            sh.lambda.resize(p.n(), 0.0);
            let s = sh.solvers[slot].solve(p, &mut sh.lambda);
            sh.last = ShadowSolve {
                variant: Some(sh.variant),
                solve_us: s.total_us,
                pivot_steps: s.pivot_steps,
                status: s.status,
                deviation: 0.0,
            };
        }
    }

    /// Writes the last shadow solves into `st`, with their deviation from the world's answer
    /// `lambda`.
    pub fn record(&self, st: &mut IslandStats, lambda: &[f64]) {
        let scale = lambda.iter().fold(0.0f64, |a, &x| a.max(x.abs())).max(f64::MIN_POSITIVE);
        for (out, sh) in st.shadow.iter_mut().zip(&self.shadows) {
            let diff = sh.lambda.iter().zip(lambda).fold(0.0f64, |a, (&x, &y)| a.max((x - y).abs()));
            *out = ShadowSolve { deviation: diff / scale, ..sh.last };
            if sh.lambda.len() != lambda.len() || diff.is_nan() {
                out.deviation = f64::INFINITY;
            }
        }
    }
}
