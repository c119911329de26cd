//! What a solve reports: status and statistics (soft outcomes are data, not errors).

use super::variant::{OrderingKind, Variant};

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolveStatus {
    /// The index set settled and the natural-map residual met the tolerance.
    #[default]
    Converged,
    /// The index set settled but the residual stayed above the tolerance (regularized pivots of a
    /// semidefinite `A`, or conditioning beyond double precision).
    Inexact,
    /// The step cap was reached; `λ` is the best feasible iterate (see the solver's docs).
    MaxSteps,
    /// The time budget (`max_solve_us`) was spent first; `λ` is the best feasible iterate.
    Budget,
    /// The problem had no rows (or the output slice had the wrong length).
    Empty,
    /// A non-finite value appeared (numerically singular beyond regularization); `λ` is the best
    /// finite iterate seen.
    NonFinite,
}

impl SolveStatus {
    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            SolveStatus::Converged => "converged",
            SolveStatus::MaxSteps => "max-steps",
            SolveStatus::Budget => "budget",
            SolveStatus::Empty => "empty",
            SolveStatus::Inexact => "inexact",
            SolveStatus::NonFinite => "non-finite",
        }
    }
}

/// Statistics of one solve. Buffers are reused from solve to solve (no allocation once sized).
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SolveStats {
    /// Variant used.
    pub variant: Variant,
    /// Ordering used (natural for the dense variants).
    pub ordering: OrderingKind,
    /// How the solve ended.
    pub status: SolveStatus,
    /// Problem size `m`.
    pub m: usize,
    /// Stored non-zeros of `A` (both triangles).
    pub nnz: usize,
    /// Bandwidth of `A` in input order.
    pub bandwidth_before: usize,
    /// Bandwidth after reordering.
    pub bandwidth_after: usize,
    /// Envelope (profile) of `A` below the diagonal, input order: `Σ_i (i − first_nz(i))`.
    pub envelope_before: usize,
    /// Same after reordering.
    pub envelope_after: usize,
    /// The ordering and envelope of the previous solve were reused (same sparsity pattern).
    pub pattern_reused: bool,
    /// Stored entries of the factor (envelope storage incl. diagonal, or `m(m+1)/2` dense).
    pub factor_entries: usize,
    /// Pivot steps (linear solves with a new index set) taken.
    pub pivot_steps: usize,
    /// PGS sweeps (PGS only).
    pub iterations: usize,
    /// Tight count at each pivot step (length `pivot_steps`).
    pub tight_per_step: Vec<u32>,
    /// Tight count of the returned solution.
    pub tight: usize,
    /// Whether a fallback (Murty, projected Newton, semismooth Newton, the interior point method) ran.
    pub fallback: bool,
    /// The returned iterate had positive merit (it would have added energy) and was scaled
    /// towards zero (`safe.rs`); only ever on a solve that did not converge.
    pub energy_scaled: bool,
    /// A solve that did not converge returned its (safe) warm start: it had a smaller residual than
    /// the best iterate.
    pub returned_warm_start: bool,
    /// A solve that did not converge returned the last exact solution with frozen friction bounds
    /// (an ODE-style answer: complementary, with friction boxes from an intermediate normal).
    pub returned_frozen: bool,
    /// Projected Gauss–Seidel sweeps that polished the answer of a solve that did not converge
    /// (0: none, or the polish did not lower the residual and was dropped).
    pub polish_sweeps: usize,
    /// A solve that did not converge had its bilateral rows solved exactly for its contact impulses
    /// (`SolverOptions::exact_bilateral`); the contact impulses were scaled by this factor (1: not).
    pub bilateral_scale: Option<f64>,
    /// Murty single-pivot steps taken.
    pub murty_steps: usize,
    /// Steps of the semismooth Newton fallback (stalled outer friction iteration).
    pub newton_steps: usize,
    /// Proximal point iterations (semidefinite `A`).
    pub proximal_iterations: usize,
    /// Steps of the active-set safeguard taken (each a pivot step).
    pub projected_newton_steps: usize,
    /// Of those, steps that took the projected Newton point (many bounds changed at once).
    pub projected_steps: usize,
    /// Outer friction-bound updates.
    pub friction_updates: usize,
    /// Outer updates that took the exact coupled Newton point (`bpp/coupled.rs`).
    pub coupled_steps: usize,
    /// Outer updates where the coupled Newton point was damped or rejected by the residual test.
    pub outer_damped: usize,
    /// GMRES iterations of the coupled Newton points (outer updates and semismooth Newton steps).
    pub krylov_iterations: usize,
    /// Coupled Newton points solved by one envelope LU of the coupled matrix instead of GMRES.
    pub coupled_lu: usize,
    /// Direct coupled points given up (a vanishing pivot, or the residual the LU lost): then GMRES.
    pub coupled_lu_rejected: usize,
    /// Interior point runs (`bpp/ipm.rs`) in this solve (0 or 1).
    pub ipm_runs: usize,
    /// Interior point iterations (each also counted in `pivot_steps`).
    pub ipm_iterations: usize,
    /// Friction couplings the interior point method's Newton matrix could not hold (outside the
    /// envelope of `A`): its directions were inexact there.
    pub ipm_dropped: usize,
    /// Pivots of the factorization that were non-positive or tiny and were regularized.
    pub regularized: usize,
    /// Row deletions applied (downdate variants).
    pub deletions: usize,
    /// How `auto` chose, per strategy: [deletions from L₀, deletions from previous, incremental].
    pub auto_choices: [usize; 3],
    /// `L₀ = chol(A)` was factored (`skyline` always; `auto` only when it first deletes from it or
    /// solves with no tight row).
    pub l0_factored: bool,
    /// Natural-map residual `‖r‖∞` against the true bounds.
    pub residual: f64,
    /// `‖r‖∞ / ‖λ‖∞`.
    pub residual_rel: f64,
    /// Deletion error `max ‖L_deleted − chol(A_FF)‖_F / ‖chol(A_FF)‖_F` over the pivot steps,
    /// when requested (paper Table 4).
    pub deletion_error: Option<f64>,
    /// Same, absolute Frobenius norm (the paper's Table 4 unit).
    pub deletion_error_abs: Option<f64>,
    /// Backward error `max ‖L Lᵀ − A_FF‖_F / ‖A_FF‖_F` of the deleted factors (envelope variants),
    /// when requested: the stability of the deletions, independent of the conditioning.
    pub deletion_backward_error: Option<f64>,
    /// Time spent ordering, µs.
    pub ordering_us: f64,
    /// Time spent factoring (initial factor and refactors), µs.
    pub factor_us: f64,
    /// Time spent copying and deleting rows/columns, µs.
    pub downdate_us: f64,
    /// Time spent in triangular solves and residual updates, µs.
    pub solve_us: f64,
    /// Wall time of the whole solve, µs.
    pub total_us: f64,
    /// CPU time of the solving thread over the whole solve, µs: the wall time less what the
    /// operating system gave to other processes meanwhile (a virtual machine's steal time is not
    /// left out: the guest counts it as running); 0 where the clock is unavailable.
    pub cpu_us: f64,
}

impl SolveStats {
    pub(crate) fn reset(&mut self, variant: Variant, ordering: OrderingKind, m: usize, nnz: usize) {
        let mut per_step = std::mem::take(&mut self.tight_per_step);
        per_step.clear();
        *self = SolveStats { variant, ordering, m, nnz, tight_per_step: per_step, ..Default::default() };
    }
}
