//! The options of a [`Solver`](super::Solver): factor strategy, caps and tolerances, and the
//! switches of the safeguards, the outer friction loop and the capped answer (module docs of `bpp`).

use super::super::pgs::PgsOptions;
use super::super::{OrderingKind, Variant};

/// Options of a [`Solver`](super::Solver).
#[derive(Debug, Clone, Copy)]
pub struct SolverOptions {
    /// Factor strategy.
    pub variant: Variant,
    /// Reordering for the envelope variants (dense variants and PGS keep the input order).
    pub ordering: OrderingKind,
    /// Cap on pivot steps (paper: 35).
    pub max_steps: usize,
    /// Relative natural-map residual at which a solve is converged.
    pub tol_rel: f64,
    /// Time budget (µs): of one solve, or — set by the world — of all island solves of a step. A
    /// solve that spends it returns its best safe iterate with status `Budget` (`None`: no budget).
    pub max_solve_us: Option<f64>,
    /// Block pivots without a decrease of the infeasible count before the safeguard takes over
    /// (0: at the first that does not decrease it; measured in `docs/notes/solver.md`).
    pub murty_after: usize,
    /// Measure `‖L_deleted − chol(A_FF)‖_F` at every deletion step (costly; for Table 4).
    pub measure_deletion_error: bool,
    /// One step of iterative refinement on the final free system.
    pub refine: bool,
    /// Options of the `pgs` variant.
    pub pgs: PgsOptions,
    /// Safeguard when block pivoting stalls.
    pub fallback: Fallback,
    /// When the outer friction iteration stalls, finish with a semismooth Newton method on the
    /// natural map (exact coupled Newton points, backtracking line search).
    pub newton_fallback: bool,
    /// Switch to proximal point iterations when the factorization had to regularize pivots
    /// (semidefinite `A`).
    pub proximal: bool,
    /// Outer friction updates take the exact coupled Newton point of the settled index set (GMRES
    /// preconditioned by the factor) instead of the plain fixed-point update.
    pub coupled_update: bool,
    /// How the exact coupled Newton point is solved (`coupled.rs`): `Some(true)` by one envelope LU
    /// of the coupled matrix, `Some(false)` by GMRES preconditioned with the factor at hand, `None`
    /// (default) by whichever the cost model predicts cheaper. The LU needs an envelope kernel (the
    /// dense kernels of small islands always use GMRES), and a direct point whose residual the LU
    /// (no row exchanges) lost is redone by GMRES either way.
    pub coupled_lu: Option<bool>,
    /// A capped solve returns its last exact frozen-bounds solution when it has one, rather than
    /// the candidate of smallest residual (module docs, "Safe when capped").
    pub prefer_frozen: bool,
    /// A warm-started solve with friction first tries the semismooth Newton method on the true,
    /// moving friction bounds from its warm start (exact coupled points, `NEWTON_FIRST_BUDGET`
    /// steps, left early when it stalls), then the block pivoting from the warm start.
    pub newton_first: bool,
    /// After an outer update of the friction bounds, continue with the active-set safeguard from
    /// the last index set (tight rows at their moved bounds) instead of block pivots.
    pub safeguard_after_update: bool,
    /// Projected Gauss–Seidel sweeps that polish the safe answer of a solve that did not converge
    /// (`safe.rs`); 0 turns the polish off.
    pub polish_sweeps: usize,
    /// Only answers whose relative residual exceeds this are polished (measured: 1e-3).
    pub polish_above: f64,
    /// The answer of a solve that did not converge gets its bilateral rows (joints: unbounded, no
    /// friction index) solved exactly for its contact impulses, those scaled toward zero only as
    /// far as the merit needs (`safe.rs`).
    pub exact_bilateral: bool,
    /// Relative weights of the `auto` cost model: (deleted entry, copied entry, factor multiply–add);
    /// measured on this machine (m = 430, bandwidth 28): 3.0, 0.16 and 1.4 ns per unit.
    pub auto_weights: (f64, f64, f64),
    /// Pivot steps after which a solve that has not converged switches to the interior point
    /// method on the coupled problem (`ipm.rs`), once; `usize::MAX`: never.
    pub ipm_after: usize,
    /// The same switch for a cold solve with friction (no warm `λ`): after this many pivot steps
    /// (default 3: easy problems finish before it; measured in `docs/notes/solver.md`); `usize::MAX`: never.
    pub ipm_cold_after: usize,
    /// Halvings of the step tried along the projection arc `P(λ + t (λ̂ − λ))` when the full
    /// projected Newton step of the active-set safeguard fails its Armijo test (`safeguard.rs`);
    /// 0: only the full step, then the exact ratio-test step. Measured in `safeguard.rs`: the
    /// vehicle's geared, boxed rows want 4, redundant contact sets (forwarder) want 0.
    pub projected_arc: usize,
    /// When the outer friction loop stalls and the semismooth Newton fallback fails too, the
    /// proximal outer iteration on `A + ρ diag(A)` takes over (module docs of `bpp`, "Proximal
    /// outer iteration"; measured in `docs/notes/solver.md`).
    pub prox_outer: bool,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            variant: Variant::Skyline,
            ordering: OrderingKind::ReverseCuthillMcKee,
            max_steps: 35,
            tol_rel: 1e-10,
            max_solve_us: None,
            murty_after: 0,
            measure_deletion_error: false,
            refine: true,
            pgs: PgsOptions::default(),
            fallback: Fallback::ProjectedNewton,
            coupled_update: true,
            coupled_lu: None,
            proximal: true,
            newton_fallback: true,
            auto_weights: (2.15, 0.11, 1.0),
            prefer_frozen: true,
            newton_first: false,
            polish_sweeps: POLISH_SWEEPS,
            polish_above: 1e-3,
            exact_bilateral: true,
            safeguard_after_update: true,
            ipm_after: usize::MAX,
            ipm_cold_after: 3,
            projected_arc: 0,
            prox_outer: true,
        }
    }
}

/// What the block pivoting does when the number of infeasible variables stops decreasing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fallback {
    /// Murty's single pivot on the infeasible variable of largest index (Júdice–Pires): finite for
    /// SPD `A` and fixed bounds, but may need very many steps.
    Murty,
    /// Projected Newton with an Armijo search on the box QP: monotone, finite identification of
    /// the active set, each step a pivot step with the same factor reuse.
    #[default]
    ProjectedNewton,
}

/// Default [`SolverOptions::polish_sweeps`].
pub const POLISH_SWEEPS: usize = 20;
