//! Per-island statistics of one step, kept in a reusable list on the world for the server's stats
//! stream and the report (soft outcomes — step cap reached, inexact residual — are data here, not
//! errors).

use crate::solver::{SolveStatus, Variant};

/// Most shadow variants a world solves beside its own ([`World::set_shadow_variants`](super::World::set_shadow_variants)).
pub const MAX_SHADOWS: usize = 3;

/// The same island problem solved by another variant, its answer discarded (`shadow.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ShadowSolve {
    /// The variant (`None`: no shadow in this slot).
    pub variant: Option<Variant>,
    /// Solver wall time (µs).
    pub solve_us: f64,
    /// Pivot steps.
    pub pivot_steps: usize,
    /// How it ended.
    pub status: SolveStatus,
    /// `‖λ_shadow − λ‖∞ / ‖λ‖∞` against the island's own answer (∞ when not comparable).
    pub deviation: f64,
}

/// What one island's solve did in the last step.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct IslandStats {
    /// Island index in the step (see [`World::islands`](super::World::islands)).
    pub island: usize,
    /// Dynamic bodies in the island.
    pub bodies: usize,
    /// Rows `m` of the island's MLCP.
    pub rows: usize,
    /// Stored non-zeros of `A` (both triangles).
    pub nnz: usize,
    /// Solver variant.
    pub variant: Variant,
    /// How the solve ended.
    pub status: SolveStatus,
    /// Whether a fallback (projected Newton, Murty, semismooth Newton, interior point) ran ([`SolveStats::fallback`](crate::solver::SolveStats::fallback)).
    pub fallback: bool,
    /// Pivot steps (exact variants).
    pub pivot_steps: usize,
    /// Sweeps (PGS).
    pub iterations: usize,
    /// Tight rows in the solution.
    pub tight: usize,
    /// Natural-map residual `‖r‖∞`.
    pub residual: f64,
    /// `‖r‖∞ / ‖λ‖∞`.
    pub residual_rel: f64,
    /// Largest `|φ|` over the island's position rows at the start of the step.
    pub max_violation: f64,
    /// Row collection share and assembly of `A`, `b` (µs).
    pub assemble_us: f64,
    /// Solver wall time (µs).
    pub solve_us: f64,
    /// Solver thread CPU time (µs): the wall time less what other processes ran meanwhile.
    pub solve_cpu_us: f64,
    /// Position projection wall time, all iterations (µs; 0 when off).
    pub projection_us: f64,
    /// The shadow solves of this island, in the order of the world's shadow variants (empty
    /// slots have `variant: None`).
    pub shadow: [ShadowSolve; MAX_SHADOWS],
}
