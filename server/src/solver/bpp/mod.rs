//! Block principal pivoting (Júdice–Pires 1994; paper §3.1–3.3, eq. 4–6, Alg. 1 and 2) with the
//! factor strategies of [`Variant`], a monotone safeguard, friction coupling, an interior point
//! switch and a proximal mode for semidefinite `A`. What was measured and what was tried and
//! dropped is in `docs/notes/solver.md`.
//!
//! **One pivot step.** For the index set `(F, T_lo, T_hi)` set `λ_T` to its bounds and solve
//! `A_FF λ_F = b_F − A_FT λ_T` (eq. 6), then `w = Aλ − b` (eq. 5). A variable is *infeasible* when
//! `i ∈ F` and `λ_i ∉ [lo_i, hi_i]`, `i ∈ T_lo` and `w_i < 0`, or `i ∈ T_hi` and `w_i > 0`; the block
//! pivot moves every infeasible variable to the set eq. 4 names. A block pivot is exactly a full
//! semismooth Newton step on the natural map `r(λ) = λ − clamp(λ − w, lo, hi)`. The sign of `w_i`
//! on a tight row is trusted beyond a per-row rounding scale `1e-13 (|b_i| + ‖A_i‖₁ ‖λ‖∞)`.
//!
//! **Safeguard.** When the number of infeasible variables has not decreased for `murty_after`
//! steps (default 0: at the first block pivot that does not lower it), either Murty's rule pivots
//! only the infeasible variable of largest index (Júdice–Pires: finite for SPD `A` and fixed
//! bounds, [`Fallback::Murty`]), or — the default, [`Fallback::ProjectedNewton`] — a primal
//! feasible active-set method on the strictly convex box QP `min ½λᵀAλ − bᵀλ` whose optimality
//! system the boxed LCP is (`safeguard.rs`): projected Newton steps while they decrease the
//! objective clearly, else exact ratio-test steps to the first blocking bound; every step a pivot
//! step with the same factor reuse, finite, ending on an exact pivot step.
//!
//! **Friction coupling** (the outer loop). Friction bounds `±μ λ_n` move with the normal impulses;
//! pivoting with bounds that change at every step cycles. The bounds are frozen at the current
//! normal impulses and that boxed LCP solved exactly; then, with the settled index set, the exact
//! coupled Newton point in which tight friction rows follow their free normal impulse is taken
//! (`coupled.rs`), globalized by backtracking on the true natural-map residual against a
//! non-monotone reference, the bounds updated from it, and the solve continues from the same
//! index set — with the active-set safeguard ([`SolverOptions::safeguard_after_update`]), its tight
//! rows at their moved bounds. This is Newton's method on the outer fixed point
//! `λ_n ↦ λ_n(bounds(λ_n))`; when it stalls (no 10 % gain of the best residual in 4 updates) the
//! semismooth Newton method on the whole natural map takes over from the best iterate for a budget
//! of steps, after which the outer iteration resumes with block pivots. Every iterate is judged by
//! the natural-map residual against the bounds at its own normal impulses. The outer loop has no
//! proof of convergence, and it can cycle (`docs/notes/solver.md`, "Generated-island sweep"):
//! when the Newton fallback fails too, the proximal outer iteration below takes over
//! ([`SolverOptions::prox_outer`]).
//!
//! **Proximal outer iteration** (`outer.rs`). The friction-coupled problem is a quasi-variational
//! inequality: find `λ ∈ K(λ)` with `r(λ) = λ − P_{K(λ)}(λ − (Aλ − b)) = 0`, where `K(λ)` is the
//! box whose friction rows are `[−μ λ_n⁺, μ λ_n⁺]`. With `D = diag A > 0`, a centre `c` and
//! `ρ > 0`, one proximal step solves the same problem for `A_ρ = A + ρD`, `b_ρ = b + ρDc` — by the
//! pivoting and its outer friction loop above — and moves the centre to its answer.
//! - *Fixed points.* At `λ = c` the two problems coincide (`w_ρ = w`). An exact inner answer `λ`
//!   has the true residual `‖r(λ)‖∞ ≤ ρ ‖D(λ − c)‖∞` (the natural map is 1-Lipschitz in `w`, and
//!   `w = w_ρ − ρD(λ − c)`).
//! - *Large `ρ` makes the inner problem well posed and its outer loop a contraction.* Let
//!   `q = maxᵢ Σ_{j≠i} |Aᵢⱼ| / ((1 + ρ) Aᵢᵢ)`, below 1 once `ρ > maxᵢ Σ_{j≠i} |Aᵢⱼ| / Aᵢᵢ − 1`
//!   (`A_ρ` strictly diagonally dominant). A solution of the boxed LCP with bounds `(l, h)` is a
//!   fixed point of `λ ↦ mid(l, h, ((1 + ρ)D)⁻¹(b_ρ − (A − D)λ))`, a contraction with factor `q`
//!   in `‖·‖∞`; two solutions for bounds `(l, h)` and `(l', h')` therefore satisfy
//!   `‖λ − λ'‖∞ ≤ max(‖(l, h) − (l', h')‖∞, q ‖λ − λ'‖∞)`, i.e. `‖λ − λ'‖∞ ≤ ‖(l, h) − (l', h')‖∞`.
//!   Friction bounds frozen at normals `ν` and `ν'` differ by at most `μ_max ‖ν − ν'‖∞`, so the
//!   outer fixed-point map `ν ↦ λ_n(bounds(ν))` of the inner problem is a contraction with factor
//!   `μ_max` when `μ_max < 1` (non-expansive at `μ = 1`): the inner problem has exactly one
//!   solution and the plain outer iteration converges to it linearly. As `ρ → 0` the guarantee
//!   fades, and that is where the unregularized outer loop can cycle.
//! - *The schedule.* `ρ` starts at 1 (`PROX_RHO0`, relative to `D`). A step whose inner solve
//!   converges (within `PROX_INNER_STEPS` pivot steps; an inner outer loop that stalls fails at
//!   once) moves `c` and multiplies `ρ` by 0.3, so that the iteration turns into the
//!   unregularized one, with exact coupled Newton points, as soon as the inner problems stay
//!   solvable; a step that fails keeps `c` and multiplies `ρ` by 4, back towards the contractive
//!   range. The best true
//!   iterate is kept. The proximal iteration itself has no proof of convergence (the problem is
//!   not monotone): that it converges where the outer loop cycled is measured
//!   (`docs/notes/solver.md`, "Generated-island sweep"), not proven.
//!
//! **Interior point switch** (`ipm.rs`, [`SolverOptions::ipm_cold_after`],
//! [`SolverOptions::ipm_after`]): a solve that has not converged after a few pivot steps runs
//! Mehrotra's predictor–corrector on the friction-coupled problem itself, then crosses over to the
//! exact solution of the index set it identifies. A run that fails hands the pivoting back its
//! whole point (λ, index set, frozen bounds, loop progress): the switch costs its own iterations
//! and does not change the pivoting's path. On by default for cold solves with friction.
//!
//! **Semismooth Newton first** ([`SolverOptions::newton_first`], off by default): a warm-started
//! solve with friction first takes up to `NEWTON_FIRST_BUDGET` semismooth Newton steps on the true,
//! moving bounds, leaving early when `‖r‖²` does not halve in `NEWTON_PATIENCE` steps, then block
//! pivots from its warm start.
//!
//! **Safe when capped.** A solve stopped by the step cap or the time budget
//! ([`Solver::set_deadline`], [`SolverOptions::max_solve_us`]) returns its last exact solution with
//! frozen friction bounds when it has one ([`SolverOptions::prefer_frozen`]), else the better of its
//! best iterate and its warm start, each made safe (`safe.rs`: projected onto the feasible set and,
//! when the merit `f = ½λᵀAλ − bᵀλ` is positive, scaled towards zero to `f ≤ 0`), polished by
//! [`SolverOptions::polish_sweeps`] projected Gauss–Seidel sweeps when its residual exceeds
//! [`SolverOptions::polish_above`], and its bilateral rows solved exactly for its contact impulses
//! ([`SolverOptions::exact_bilateral`]).
//!
//! **Semidefinite `A`.** When the factorization has to regularize pivots, the solve switches to
//! proximal point iterations on `A + ρI` (`safeguard.rs`), judged against the original problem.
//!
//! **Factor strategies** (`factor.rs`). `full`: gather and factor the compact `A_FF` each step.
//! `downdate`: dense `L₀ = chol(A)` once, per step copy + deletions (`dense.rs`). `skyline`: reorder
//! (CM/RCM), envelope `L₀`, per step copy of the columns from `g_{min T}` on + deletions on the
//! skyline (`envelope.rs`), each sweep stopping at the last free index and skipping the columns of
//! the tight indices still to be deleted (`chol(A_FF)` is `L₀`'s free block after one rank-1 update
//! per tight column, each rotating through free columns only); when the tight set only grew since
//! the last pivot step, just the new tight indices are deleted from the factor at hand (deletions
//! commute). `skyline-refactor`: envelope factor of `A_FF ⊕ I` per step. `incremental`: keep the
//! last factor and refactor from the first index whose state changed. `auto`: per step the
//! cheapest predicted of deletions from `L₀`, deletions from the last factor (when `T` only grew)
//! and the incremental refactor, from the skyline cost model; `L₀` is factored only when first
//! chosen, its cost counted only as far as this solve's refactors have not yet paid it (ski
//! rental: never worse than twice the better choice in hindsight), and each rotated column of a
//! deletion counts at least `ROTATION_MIN_ENTRIES` entries.
//!
//! | file | stage |
//! |---|---|
//! | `options.rs` | [`SolverOptions`], [`Fallback`] |
//! | `solver.rs` | the [`Solver`] and its buffers; one solve from the permuted problem to the reported answer |
//! | `pivot.rs` | the pivoting loop: pivot steps, the judgement of each iterate, block pivots, Newton first |
//! | `outer.rs` | the outer friction loop: coupled Newton point, bound updates, Newton fallback, proximal outer iteration |
//! | `factor.rs` | the factor strategies of [`Variant`] and the `auto` cost model |
//! | `safeguard.rs` | the active-set and proximal safeguards, semismooth Newton |
//! | `coupled.rs` | the exact coupled Newton point (GMRES or envelope LU) |
//! | `ipm.rs` | the interior point switch and its crossover |
//! | `safe.rs` | safe, polished answers of capped solves |
//! | `workspace.rs` | the scratch, by stage: permuted, factor, Krylov, proximal, safe/warm, saved point |

mod coupled;
mod factor;
mod ipm;
mod options;
mod outer;
mod pivot;
mod safe;
mod safeguard;
mod solver;
mod workspace;

pub use options::{Fallback, POLISH_SWEEPS, SolverOptions};
pub use solver::Solver;

#[cfg(doc)]
use super::Variant;
