//! Projected Gauss–Seidel (PGS): the iterative baseline that the pivoting solver is traded against.
//!
//! One sweep visits the rows in order and relaxes each against the current values of all others:
//!
//! ```text
//!   for i in 0..m:
//!       λ_i ← clamp( λ_i + ω · (b_i − (Aλ)_i) / A_ii ,  lo_i(λ), hi_i(λ) )
//! ```
//!
//! `(Aλ)_i` is read from row `i` of the CSR matrix with the newest `λ` (rows already visited in this
//! sweep use their updated values: Gauss–Seidel, not Jacobi). The bounds are the true ones at the
//! current iterate: a friction row `i` with `findex_i = j` is clamped to
//! `[lo_i · max(λ_j, 0), hi_i · max(λ_j, 0)]` with the current `λ_j`, the same coupling the pivoting
//! solver honours (see [`effective_bounds`]). `ω` is the relaxation factor
//! (`ω = 1` is plain PGS, `ω > 1` over-relaxation).
//!
//! The iteration stops once the relative natural-map residual `‖λ − clamp(λ − w, lo(λ), hi(λ))‖∞ / ‖λ‖∞`
//! (with `w = Aλ − b`, measured against the bounds at the *final* normal impulses) falls to
//! `tol_rel`, or after `max_iterations` sweeps. Each sweep costs one pass over the stored entries of
//! `A`; each residual check costs another, hence [`PgsOptions::check_every`].
//!
//! PGS converges for symmetric positive definite `A` without friction coupling, but its rate degrades
//! with the condition number of `A`: long chains with large mass ratios stall far from the solution
//! within a real-time iteration budget (see the tests), which is the weakness the pivoting solver
//! removes.
//!
//! Rows whose diagonal `A_ii` is zero or tiny (`≤ 1e-300`) cannot be relaxed and are left untouched
//! (counted in [`PgsInfo::zero_diagonals`]).

use super::{Mlcp, SymCsr, effective_bounds};

/// Diagonals at or below this value are treated as zero.
const TINY_DIAGONAL: f64 = 1e-300;

/// Options of [`pgs_solve`].
#[derive(Debug, Clone, Copy)]
pub struct PgsOptions {
    /// Upper bound on the number of sweeps (default 100).
    pub max_iterations: usize,
    /// Stop when the relative natural-map residual is at or below this (default `1e-9`).
    pub tol_rel: f64,
    /// Relaxation factor `ω` (default 1: plain Gauss–Seidel).
    pub omega: f64,
    /// Check the residual every this many sweeps (default 1; 0 is read as 1). The residual is always
    /// evaluated after the last sweep.
    pub check_every: usize,
}

impl Default for PgsOptions {
    fn default() -> Self {
        PgsOptions { max_iterations: 100, tol_rel: 1e-9, omega: 1.0, check_every: 1 }
    }
}

/// What [`pgs_solve`] did.
#[derive(Debug, Clone, Copy, Default)]
pub struct PgsInfo {
    /// Sweeps performed.
    pub iterations: usize,
    /// Whether the relative residual reached `tol_rel`.
    pub converged: bool,
    /// Absolute natural-map residual `‖r‖∞` at the returned `λ` (`inf` if a non-finite value appeared).
    pub residual: f64,
    /// `‖r‖∞ / ‖λ‖∞` at the returned `λ` (`inf` if a non-finite value appeared).
    pub residual_rel: f64,
    /// Rows skipped because their diagonal is zero or tiny.
    pub zero_diagonals: usize,
}

/// Workspace reused between solves (no allocation after the first solve of a given size).
#[derive(Debug, Default)]
pub struct PgsWorkspace {
    /// `w = Aλ − b` for the residual checks.
    w: Vec<f64>,
    /// `1 / A_ii`, or 0 for a skipped row.
    inv_diag: Vec<f64>,
}

/// Runs projected Gauss–Seidel on `p`.
///
/// `lambda` holds the initial guess (warm start; zeros for a cold start) and receives the result. Stops
/// when the natural-map relative residual (against the true friction bounds, see
/// [`Mlcp::natural_residual`]) is at or below `opts.tol_rel`, or after `opts.max_iterations` sweeps
/// (with `max_iterations == 0` it only evaluates the residual of the guess).
///
/// Never panics and never writes a non-finite value into `lambda`: if the initial guess is not finite,
/// `lambda` has the wrong length, or an update overflows (e.g. a divergent `ω`), it stops and reports
/// `residual = residual_rel = inf`, leaving the last finite iterate in `lambda`.
pub fn pgs_solve(p: &Mlcp, lambda: &mut [f64], ws: &mut PgsWorkspace, opts: &PgsOptions) -> PgsInfo {
    let n = p.n();
    let mut info = PgsInfo::default();
    if lambda.len() != n || lambda.iter().any(|v| !v.is_finite()) {
        info.residual = f64::INFINITY;
        info.residual_rel = f64::INFINITY;
        return info;
    }
    let a = p.a();
    let b = p.b();

    ws.w.resize(n, 0.0);
    info.zero_diagonals = inverse_diagonal(a, &mut ws.inv_diag);

    let check_every = opts.check_every.max(1);
    let omega = opts.omega;
    let mut last_checked = None;
    let mut blew_up = false;
    while info.iterations < opts.max_iterations {
        if !pgs_sweep(a, b, p.lo(), p.hi(), p.findex(), &ws.inv_diag, omega, lambda) {
            blew_up = true;
            break;
        }
        info.iterations += 1;
        if info.iterations % check_every == 0 || info.iterations == opts.max_iterations {
            let (r, rel) = p.natural_residual(lambda, &mut ws.w);
            last_checked = Some(info.iterations);
            info.residual = r;
            info.residual_rel = rel;
            // `rel` alone may overflow legitimately (λ = 0 with a large residual); `r` may not.
            if !r.is_finite() {
                blew_up = true;
                break;
            }
            if rel <= opts.tol_rel {
                info.converged = true;
                break;
            }
        }
    }
    if blew_up {
        info.converged = false;
        info.residual = f64::INFINITY;
        info.residual_rel = f64::INFINITY;
    } else if last_checked != Some(info.iterations) {
        // `max_iterations == 0`: report the residual of the guess.
        let (r, rel) = p.natural_residual(lambda, &mut ws.w);
        info.residual = r;
        info.residual_rel = rel;
        info.converged = rel <= opts.tol_rel;
    }
    info
}

/// One projected Gauss–Seidel sweep (module docs) over the rows of `a` in order, with the bounds
/// at the current `λ`; rows with `inv_diag[i] == 0` are skipped. Returns `false` and stops at the
/// first non-finite update, leaving the last finite values in `lambda`. Shared by [`pgs_solve`] and
/// the pivoting solver's polish of a capped iterate.
#[allow(clippy::too_many_arguments)]
pub(crate) fn pgs_sweep(
    a: &SymCsr,
    b: &[f64],
    lo: &[f64],
    hi: &[f64],
    findex: &[Option<usize>],
    inv_diag: &[f64],
    omega: f64,
    lambda: &mut [f64],
) -> bool {
    for i in 0..lambda.len() {
        let inv = inv_diag[i];
        if inv == 0.0 {
            continue;
        }
        let (cols, vals) = a.row(i);
        let mut ai_lambda = 0.0;
        for (&j, &v) in cols.iter().zip(vals) {
            ai_lambda += v * lambda[j];
        }
        let (l, h) = effective_bounds(lo[i], hi[i], findex[i], lambda);
        let next = (lambda[i] + omega * (b[i] - ai_lambda) * inv).max(l).min(h);
        if !next.is_finite() {
            return false;
        }
        lambda[i] = next;
    }
    true
}

/// `1 / A_ii`, or 0 for a diagonal at or below `TINY_DIAGONAL`, into `out`; returns the number of
/// zero diagonals.
pub(crate) fn inverse_diagonal(a: &SymCsr, out: &mut Vec<f64>) -> usize {
    out.clear();
    let mut zeros = 0;
    for i in 0..a.n() {
        let d = a.get(i, i);
        if d > TINY_DIAGONAL {
            out.push(1.0 / d);
        } else {
            out.push(0.0);
            zeros += 1;
        }
    }
    zeros
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::SymCsr;
    use crate::solver::reference::enumerate_solutions;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const INF: f64 = f64::INFINITY;

    /// Random boxed problem with a strictly diagonally dominant (hence SPD) `A`, or `B Bᵀ + n I`.
    fn random_problem(rng: &mut ChaCha8Rng, n: usize, gram: bool) -> Mlcp {
        let mut a = vec![0.0; n * n];
        if gram {
            let bm: Vec<f64> = (0..n * n).map(|_| rng.random_range(-1.0..1.0)).collect();
            for i in 0..n {
                for j in 0..n {
                    a[i * n + j] = (0..n).map(|k| bm[i * n + k] * bm[j * n + k]).sum::<f64>();
                }
                a[i * n + i] += n as f64;
            }
            // Exact symmetry.
            for i in 0..n {
                for j in 0..i {
                    a[i * n + j] = a[j * n + i];
                }
            }
        } else {
            for i in 0..n {
                for j in 0..i {
                    if rng.random_bool(0.4) {
                        let v = rng.random_range(-1.0..1.0);
                        a[i * n + j] = v;
                        a[j * n + i] = v;
                    }
                }
            }
            for i in 0..n {
                let off: f64 = (0..n).filter(|&j| j != i).map(|j| a[i * n + j].abs()).sum();
                a[i * n + i] = off + rng.random_range(0.5..2.0);
            }
        }
        let b: Vec<f64> = (0..n).map(|_| rng.random_range(-3.0..3.0)).collect();
        let mut lo = vec![0.0; n];
        let mut hi = vec![INF; n];
        for i in 0..n {
            match rng.random_range(0..3) {
                0 => {
                    lo[i] = -INF;
                    hi[i] = INF;
                }
                1 => {}
                _ => {
                    let c = rng.random_range(0.1..1.0);
                    lo[i] = -c;
                    hi[i] = c * rng.random_range(0.5..2.0);
                }
            }
        }
        Mlcp::new(SymCsr::from_dense_row_major(n, &a).unwrap(), b, lo, hi, vec![None; n]).unwrap()
    }

    fn max_diff(x: &[f64], y: &[f64]) -> f64 {
        x.iter().zip(y).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)
    }

    fn tight() -> PgsOptions {
        PgsOptions { max_iterations: 5000, tol_rel: 1e-13, ..PgsOptions::default() }
    }

    #[test]
    fn matches_enumeration_on_small_random_problems() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x9e5);
        let mut ws = PgsWorkspace::default();
        for trial in 0..40 {
            let n = 5 + trial % 4;
            let p = random_problem(&mut rng, n, trial % 2 == 1);
            let sols = enumerate_solutions(&p, 1e-9);
            assert_eq!(sols.len(), 1, "trial {trial}: SPD without friction has one solution");
            let mut lambda = vec![0.0; n];
            let info = pgs_solve(&p, &mut lambda, &mut ws, &tight());
            assert!(info.converged, "trial {trial}: {info:?}");
            assert_eq!(info.zero_diagonals, 0);
            let d = max_diff(&lambda, &sols[0].lambda);
            assert!(d <= 1e-8, "trial {trial}: |λ_pgs − λ_enum| = {d}");
        }
    }

    #[test]
    fn converges_on_larger_random_problems() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let mut ws = PgsWorkspace::default();
        for trial in 0..24 {
            let n = 9 + 41 * trial / 23; // 9 ..= 50
            let p = random_problem(&mut rng, n, trial % 2 == 0);
            let mut lambda = vec![0.0; n];
            let opts = PgsOptions { max_iterations: 2000, ..PgsOptions::default() };
            let info = pgs_solve(&p, &mut lambda, &mut ws, &opts);
            assert!(info.converged, "trial {trial} (n = {n}): {info:?}");
            assert!(info.residual_rel <= 1e-9 && info.residual.is_finite());
            // The reported residual is the true one at the returned λ.
            let mut w = vec![0.0; n];
            let (r, rel) = p.natural_residual(&lambda, &mut w);
            assert_eq!((r, rel), (info.residual, info.residual_rel));
        }
    }

    #[test]
    fn warm_start_from_the_solution_takes_one_sweep() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut ws = PgsWorkspace::default();
        for trial in 0..10 {
            let n = 6 + trial % 3;
            let p = random_problem(&mut rng, n, trial % 2 == 0);
            let sols = enumerate_solutions(&p, 1e-9);
            assert_eq!(sols.len(), 1);
            let mut lambda = sols[0].lambda.clone();
            let info = pgs_solve(&p, &mut lambda, &mut ws, &PgsOptions::default());
            assert!(info.converged, "trial {trial}: {info:?}");
            assert_eq!(info.iterations, 1, "trial {trial}");
            assert!(max_diff(&lambda, &sols[0].lambda) <= 1e-12);
        }
    }

    #[test]
    fn friction_coupling_converges_to_an_enumerated_solution() {
        let mut rng = ChaCha8Rng::seed_from_u64(2024);
        let mut ws = PgsWorkspace::default();
        for trial in 0..30 {
            // `contacts` contacts of one normal row followed by two friction rows.
            let contacts = 1 + trial % 3;
            let n = 3 * contacts;
            let mut a = vec![0.0_f64; n * n];
            for i in 0..n {
                for j in 0..i {
                    if rng.random_bool(0.5) {
                        let v = rng.random_range(-0.5..0.5);
                        a[i * n + j] = v;
                        a[j * n + i] = v;
                    }
                }
            }
            for i in 0..n {
                let off: f64 = (0..n).filter(|&j| j != i).map(|j| a[i * n + j].abs()).sum();
                a[i * n + i] = 2.0 * off + rng.random_range(1.0..2.0);
            }
            let mut b = vec![0.0; n];
            let mut lo = vec![0.0; n];
            let mut hi = vec![INF; n];
            let mut findex = vec![None; n];
            for c in 0..contacts {
                let k = 3 * c;
                b[k] = rng.random_range(0.5..3.0); // pushing into the contact
                let mu = rng.random_range(0.2..0.8);
                for f in k + 1..k + 3 {
                    b[f] = rng.random_range(-3.0..3.0);
                    lo[f] = -mu;
                    hi[f] = mu;
                    findex[f] = Some(k);
                }
            }
            let p = Mlcp::new(SymCsr::from_dense_row_major(n, &a).unwrap(), b, lo, hi, findex).unwrap();
            let sols = enumerate_solutions(&p, 1e-9);
            assert!(!sols.is_empty(), "trial {trial}");
            let mut lambda = vec![0.0; n];
            let info = pgs_solve(&p, &mut lambda, &mut ws, &tight());
            assert!(info.converged, "trial {trial}: {info:?}");
            let d = sols.iter().map(|s| max_diff(&lambda, &s.lambda)).fold(INF, f64::min);
            assert!(d <= 1e-8, "trial {trial}: distance to the nearest enumerated solution {d}");
        }
    }

    /// A hanging chain of `links` light bodies (mass 1) holding a heavy body (mass `heavy`) at its end,
    /// one bilateral joint per body along the vertical, after one step of gravity.
    fn hanging_chain(links: usize, heavy: f64) -> Mlcp {
        let n = links + 1; // joints: ground–body 0, then body k−1 – body k
        let mass: Vec<f64> = (0..n).map(|k| if k == n - 1 { heavy } else { 1.0 }).collect();
        // J: row 0 = e_0, row k = e_k − e_{k−1}; A = J M⁻¹ Jᵀ is tridiagonal.
        let mut a = vec![0.0; n * n];
        for k in 0..n {
            a[k * n + k] = 1.0 / mass[k] + if k > 0 { 1.0 / mass[k - 1] } else { 0.0 };
            if k > 0 {
                a[k * n + k - 1] = -1.0 / mass[k - 1];
                a[(k - 1) * n + k] = -1.0 / mass[k - 1];
            }
        }
        // Free velocities v = −g h for every body: J v = (−g h, 0, …), b = −J v.
        let gh = 9.81 / 60.0;
        let mut b = vec![0.0; n];
        b[0] = gh;
        Mlcp::new(SymCsr::from_dense_row_major(n, &a).unwrap(), b, vec![-INF; n], vec![INF; n], vec![None; n])
            .unwrap()
    }

    #[test]
    fn stalls_on_an_ill_conditioned_chain() {
        let p = hanging_chain(9, 1e6);
        // The problem itself is well posed: the exact impulses all carry the weight below each joint.
        let exact = enumerate_solutions(&p, 1e-9);
        assert_eq!(exact.len(), 1);
        let gh = 9.81 / 60.0;
        for (k, &l) in exact[0].lambda.iter().enumerate() {
            let below = (9 - k) as f64 + 1e6;
            assert!((l - below * gh).abs() <= 1e-6 * below * gh, "joint {k}: {l}");
        }
        // PGS within the usual budget gets nowhere near it.
        let mut lambda = vec![0.0; p.n()];
        let opts = PgsOptions::default();
        let info = pgs_solve(&p, &mut lambda, &mut PgsWorkspace::default(), &opts);
        assert!(!info.converged, "{info:?}");
        assert_eq!(info.iterations, opts.max_iterations);
        assert!(info.residual_rel > 1e3 * opts.tol_rel, "{info:?}");
        assert!(max_diff(&lambda, &exact[0].lambda) > 0.5 * 1e6 * gh);
    }

    #[test]
    fn zero_diagonal_rows_are_skipped() {
        // Row 1 has a zero diagonal (and no coupling): it is left alone, the others are solved.
        let a = SymCsr::diagonal(&[2.0, 0.0, 4.0]).unwrap();
        let p = Mlcp::new(a, vec![2.0, 1.0, 8.0], vec![0.0; 3], vec![INF; 3], vec![None; 3]).unwrap();
        let mut lambda = vec![0.0, 0.5, 0.0];
        let info = pgs_solve(&p, &mut lambda, &mut PgsWorkspace::default(), &PgsOptions::default());
        assert_eq!(info.zero_diagonals, 1);
        assert_eq!(lambda, [1.0, 0.5, 2.0]);
        // w1 = −1 < 0 with λ1 = 0.5 inside its box: not a solution, and the residual says so.
        assert!(!info.converged && info.residual.is_finite() && info.residual > 0.0);
    }

    #[test]
    fn non_finite_input_and_divergence_are_reported_not_returned() {
        let a = SymCsr::from_dense_row_major(2, &[2.0, 1.9, 1.9, 2.0]).unwrap();
        let p = Mlcp::new(a, vec![1.0, -1.0], vec![-INF; 2], vec![INF; 2], vec![None; 2]).unwrap();
        let mut ws = PgsWorkspace::default();

        let mut lambda = vec![f64::NAN, 0.0];
        let info = pgs_solve(&p, &mut lambda, &mut ws, &PgsOptions::default());
        assert!(!info.converged && info.residual == INF && info.residual_rel == INF);

        let mut short = vec![0.0];
        let info = pgs_solve(&p, &mut short, &mut ws, &PgsOptions::default());
        assert!(!info.converged && info.residual == INF);

        // ω = 3 diverges: it must stop at overflow with finite λ and an infinite residual.
        let mut lambda = vec![0.0; 2];
        let opts = PgsOptions { omega: 3.0, max_iterations: 100_000, ..PgsOptions::default() };
        let info = pgs_solve(&p, &mut lambda, &mut ws, &opts);
        assert!(!info.converged && info.residual == INF && info.residual_rel == INF, "{info:?}");
        assert!(lambda.iter().all(|v| v.is_finite()));
        assert!(info.iterations < opts.max_iterations);
    }

    #[test]
    fn zero_iterations_and_check_interval() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let p = random_problem(&mut rng, 12, false);
        let mut ws = PgsWorkspace::default();
        let mut lambda = vec![0.0; 12];
        let info =
            pgs_solve(&p, &mut lambda, &mut ws, &PgsOptions { max_iterations: 0, ..Default::default() });
        assert_eq!(info.iterations, 0);
        assert!(lambda.iter().all(|&v| v == 0.0) && info.residual.is_finite());

        // Checking every 7 sweeps stops on a multiple of 7 (or at the budget) and agrees with the
        // every-sweep run to within the tolerance.
        let mut every = vec![0.0; 12];
        let i1 =
            pgs_solve(&p, &mut every, &mut ws, &PgsOptions { max_iterations: 1000, ..Default::default() });
        let mut sparse_checks = vec![0.0; 12];
        let opts = PgsOptions { max_iterations: 1000, check_every: 7, ..Default::default() };
        let i7 = pgs_solve(&p, &mut sparse_checks, &mut ws, &opts);
        assert!(i1.converged && i7.converged);
        assert_eq!(i7.iterations % 7, 0);
        assert!(i7.iterations >= i1.iterations && i7.iterations < i1.iterations + 7);
    }

    #[test]
    fn workspace_does_not_reallocate_for_the_same_size() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let p = random_problem(&mut rng, 20, false);
        let mut ws = PgsWorkspace::default();
        let mut lambda = vec![0.0; 20];
        pgs_solve(&p, &mut lambda, &mut ws, &PgsOptions::default());
        let (pw, pd) = (ws.w.as_ptr(), ws.inv_diag.as_ptr());
        lambda.fill(0.0);
        pgs_solve(&p, &mut lambda, &mut ws, &PgsOptions::default());
        assert_eq!((pw, pd), (ws.w.as_ptr(), ws.inv_diag.as_ptr()));
    }
}
