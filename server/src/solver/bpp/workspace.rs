//! The solver's scratch, grouped by the stage that owns it (as faer pairs each kernel with its
//! scratch): a solve sizes each part once and reuses it, so a warm solve allocates nothing. The
//! data types of the stages' state live here too (the pivoting loop's `Progress`, the interior
//! point and coupled-point scratch, `FactorIn`), their methods beside their stages, so that every
//! stage file imports this one and none imports another's.

use super::super::envelope::Envelope;
use super::super::envelope_lu::EnvelopeLu;
use super::super::ordering::OrderingWorkspace;
use super::super::{IndexState, OrderingKind, SymCsr};

/// The scratch of a [`Solver`](super::Solver), by stage.
#[derive(Debug, Default)]
pub(super) struct Workspace {
    /// The ordering and its pattern cache.
    pub(super) permuted: Permuted,
    /// The factor buffers.
    pub(super) factor: FactorWork,
    /// GMRES scratch.
    pub(super) krylov: Krylov,
    /// Proximal point iterations.
    pub(super) proximal: Proximal,
    /// Warm start and safe answers.
    pub(super) safe: SafeWarm,
    /// The interior point switch's way back.
    pub(super) saved: SavedPoint,
}

/// The ordering and what a sparsity pattern keeps across solves: the permutation, its inverse, the
/// pattern it was computed for, its metrics and the positions of the diagonal.
#[derive(Debug, Default)]
pub(super) struct Permuted {
    pub(super) ord_ws: OrderingWorkspace,
    pub(super) perm: Vec<usize>,
    pub(super) inv: Vec<usize>,
    pub(super) pattern: SymCsr,
    pub(super) pattern_ordering: Option<OrderingKind>,
    pub(super) pattern_reused: bool,
    pub(super) metrics: [usize; 4],
    /// Position of each row's diagonal in `ap`'s values (per pattern).
    pub(super) diag_at: Vec<usize>,
}

/// The factor buffers of the pivot steps (`factor.rs`): the envelope, `L₀`, the current factor, the
/// dense and compact kernels' buffers and the `auto` cost model's state.
#[derive(Debug, Default)]
pub(super) struct FactorWork {
    pub(super) env: Envelope,
    pub(super) l0: Vec<f64>,
    /// `l0` holds `chol(A)` of the current problem (`auto` factors it lazily).
    pub(super) l0_valid: bool,
    pub(super) l: Vec<f64>,
    pub(super) lref: Vec<f64>,
    pub(super) sigma: Vec<f64>,
    /// Prefix sums of the free columns' lengths (the `auto` cost model of deletions).
    pub(super) free_sums: Vec<f64>,
    /// Predicted cost of the refactors `auto` chose in this solve (its rent against `L₀`).
    pub(super) refactor_spent: f64,
    pub(super) dense_l0: Vec<f64>,
    pub(super) dense_l: Vec<f64>,
    pub(super) compact: Vec<f64>,
    pub(super) free_idx: Vec<usize>,
    pub(super) tmp_tight: Vec<bool>,
    pub(super) tight_l: Vec<bool>,
    pub(super) l_valid: bool,
    pub(super) last_factor: FactorIn,
}

/// GMRES scratch of the coupled Newton point (`coupled.rs`): the Arnoldi basis, the Hessenberg
/// matrix, its Givens rotations and the preconditioned solution.
#[derive(Debug, Default)]
pub(super) struct Krylov {
    pub(super) v: Vec<f64>,
    pub(super) h: Vec<f64>,
    pub(super) g: Vec<f64>,
    pub(super) cs: Vec<f64>,
    pub(super) sn: Vec<f64>,
    pub(super) z: Vec<f64>,
}

/// The proximal point iterations on `A + ρI` (`safeguard.rs`): the original diagonal and `b`, the
/// centre and the best iterate.
#[derive(Debug, Default)]
pub(super) struct Proximal {
    pub(super) diag0: Vec<f64>,
    pub(super) bp0: Vec<f64>,
    pub(super) center: Vec<f64>,
    pub(super) best: Vec<f64>,
    /// The frozen answer kept across the proximal outer iteration (`outer.rs`).
    pub(super) frozen0: Vec<f64>,
}

/// The warm start and the candidates and scratch of a safe answer (`safe.rs`).
#[derive(Debug, Default)]
pub(super) struct SafeWarm {
    /// The warm-start index set, permuted (all free without one).
    pub(super) state0: Vec<IndexState>,
    /// The warm-start `λ₀`, permuted (zero without one): a candidate for a capped solve's answer.
    pub(super) warm_lam: Vec<f64>,
    /// The last exact solution of the problem with frozen friction bounds, if any (`have_frozen`).
    pub(super) frozen: Vec<f64>,
    pub(super) have_frozen: bool,
    /// Every fixed box (rows without `findex`) contains 0 (`safe.rs`).
    pub(super) zero_feasible: bool,
    /// The candidate a polish started from (`safe.rs`).
    pub(super) polish_save: Vec<f64>,
    /// Scratch of `exact_bilateral` (`safe.rs`): the pivoting's tight set, the step `d` and `A d`.
    pub(super) bil_tight: Vec<bool>,
    pub(super) bil_d: Vec<f64>,
    pub(super) bil_ad: Vec<f64>,
    /// `1 / A_ii` of the permuted matrix, for the polish.
    pub(super) inv_diag: Vec<f64>,
}

/// The point the interior point switch comes back to (`ipm.rs`): the index set, `λ`, the frozen
/// bounds, the best residual and the pivoting loop's progress.
#[derive(Debug, Default)]
pub(super) struct SavedPoint {
    /// The index set and `λ` the interior point method started from or converged to (`ipm.rs`).
    pub(super) state: Vec<IndexState>,
    pub(super) lam: Vec<f64>,
    /// The frozen bounds, best residual and loop progress kept with `ipm_state`, `ipm_lam`.
    pub(super) lo: Vec<f64>,
    pub(super) hi: Vec<f64>,
    pub(super) best_res: f64,
    pub(super) progress: Progress,
}

/// Which buffer holds the factor of the current index set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) enum FactorIn {
    #[default]
    L0,
    L,
    Compact,
}

/// Progress of the block pivoting loop: the fewest infeasible variables since the last reset and
/// the steps without a decrease; the best outer residual and the outer updates without a 10 %
/// improvement of it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Progress {
    pub(super) best_ninf: usize,
    pub(super) no_progress: usize,
    pub(super) outer_best: f64,
    pub(super) outer_stall: usize,
    /// The safeguarded outer iteration and the Newton fallback both stalled: block pivots after
    /// the remaining outer updates.
    pub(super) block_pivots: bool,
}

impl Default for Progress {
    fn default() -> Self {
        Progress {
            best_ninf: usize::MAX,
            no_progress: 0,
            outer_best: f64::INFINITY,
            outer_stall: 0,
            block_pivots: false,
        }
    }
}

/// Outer residuals remembered by the non-monotone acceptance of coupled Newton points.
pub(super) const OUTER_MEMORY: usize = 4;

/// Scratch of the direct coupled Newton point, sized by the island and reused.
#[derive(Debug, Default)]
pub(super) struct CoupledWork {
    pub(super) lu: EnvelopeLu,
    /// Coupled tight rows: their normal impulse's index and `−μ^±`.
    pub(super) rows: Vec<Option<usize>>,
    pub(super) vals: Vec<f64>,
    /// `λ` before the direct point (restored when it is rejected).
    pub(super) start: Vec<f64>,
    /// Recent GMRES iterations per coupled point, and the recent share of rejected direct points
    /// (exponential averages over this solver's solves; the cost model's memory).
    pub(super) gmres_iters: f64,
    pub(super) lu_rejects: f64,
}

/// Scratch of the interior point method, sized by the island and reused.
#[derive(Debug, Default)]
pub(super) struct IpmWork {
    pub(super) kind: Vec<RowKind>,
    pub(super) env: Envelope,
    pub(super) lu: EnvelopeLu,
    pub(super) zl: Vec<f64>,
    pub(super) zu: Vec<f64>,
    pub(super) sl: Vec<f64>,
    pub(super) su: Vec<f64>,
    pub(super) d: Vec<f64>,
    pub(super) cv: Vec<f64>,
    pub(super) cpl: Vec<Option<usize>>,
    pub(super) dlam: Vec<f64>,
    pub(super) dsl: Vec<f64>,
    pub(super) dsu: Vec<f64>,
    pub(super) dzl: Vec<f64>,
    pub(super) dzu: Vec<f64>,
    pub(super) aff_l: Vec<f64>,
    pub(super) aff_u: Vec<f64>,
    pub(super) ratio: Vec<f64>,
    /// Smallest relative residual of this run's iterates.
    pub(super) best: f64,
    /// The start of this run, one of `IPM_STARTS`.
    pub(super) start: (usize, f64),
}

/// The bounds a row takes part in.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) enum RowKind {
    /// No finite bound.
    #[default]
    Free,
    /// `lo ≤ λ` and/or `λ ≤ hi` (plain rows).
    Box { lower: bool, upper: bool },
    /// `lo λ_n ≤ λ ≤ hi λ_n` for the normal row `n`.
    Friction(usize),
    /// `lo = hi`: held at that value.
    Fixed(f64),
}
