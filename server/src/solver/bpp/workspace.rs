//! The solver's scratch, grouped by the stage that owns it (as faer pairs each kernel with its
//! scratch): a solve sizes each part once and reuses it, so a warm solve allocates nothing.

use super::super::envelope::Envelope;
use super::super::ordering::OrderingWorkspace;
use super::super::{IndexState, OrderingKind, SymCsr};
use super::pivot::Progress;
use super::solver::FactorIn;

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
