//! Brute-force enumeration of index sets: a test reference for small problems (`m ≤ 10` in practice).
//!
//! **Test-only helper.** The cost grows like `3^m` dense `m × m` LU factorisations, so
//! [`enumerate_solutions`] refuses (panics on) problems with more than [`MAX_ROWS`] rows.
//!
//! # Method
//!
//! A solution of the boxed MLCP (paper eq. 3) is characterised by its index set: every row is either
//! free (`w_i = 0`), tight at its lower bound or tight at its upper bound (paper eq. 4). Once the index
//! set is fixed, the unknown `λ` solves a *square linear* system:
//!
//! ```text
//!   i ∈ F     :  (Aλ)_i          = b_i
//!   i ∈ T_lo  :  λ_i             = lo_i           (plain row)
//!                λ_i − lo_i · λ_j = 0              (friction row, findex_i = j)
//!   i ∈ T_hi  :  λ_i             = hi_i           (plain row)
//!                λ_i − hi_i · λ_j = 0              (friction row, findex_i = j)
//! ```
//!
//! A friction row's bound follows the normal impulse `λ_j` linearly, so fixing it to a bound keeps the
//! system linear. We try every assignment (rows with `lo_i = −∞` are never `Lower`, rows with
//! `hi_i = +∞` never `Upper`), solve each system with nalgebra's dense LU with partial pivoting, and
//! keep the candidates that are feasible and complementary, i.e. whose natural-map residual
//! `λ − clamp(λ − w, lo(λ), hi(λ))` vanishes. That test is applied in two parts, each in its own units
//! so that badly scaled problems are judged fairly:
//!
//! * feasibility, in impulse units: `lo_i(λ) − ε_λ ≤ λ_i ≤ hi_i(λ) + ε_λ` for every row;
//! * complementarity, in velocity units: `|w_i| ≤ ε_w` on free rows, `w_i ≥ −ε_w` on rows tight at the
//!   lower bound, `w_i ≤ ε_w` on rows tight at the upper bound;
//!
//! with `ε_λ = tol · max(‖λ‖∞, ‖b‖∞ / max|A|)` and `ε_w = tol · max(‖b‖∞, max|A| · ‖λ‖∞)`.
//!
//! **Degenerate friction boxes.** Where the normal row of a friction row may itself go negative
//! (`lo_j < 0`), the friction box collapses to `[0, 0]` for `λ_j ≤ 0`, which the linear relation above
//! does not express. Such friction rows get a fourth candidate `λ_i = 0`, accepted only when
//! `λ_j ≤ ε_λ`; it is reported as `Lower` when `w_i ≥ 0` and `Upper` otherwise.
//!
//! Singular systems (LU reports a zero pivot) are skipped, so for a singular `A` (positive
//! *semi*definite) the enumeration lists the solutions reachable through non-singular index sets only,
//! which may be several; for a positive definite `A` without friction the solution is unique and is
//! found exactly once. Candidates closer than `max(100 · tol, 1e-8) · scale` in `‖·‖∞` count as one
//! solution (the first index set found is reported).

use nalgebra::{DMatrix, DVector};

use super::{IndexState, Mlcp};

/// Largest problem [`enumerate_solutions`] accepts.
pub const MAX_ROWS: usize = 12;

/// One solution found by enumeration.
#[derive(Debug, Clone)]
pub struct Enumerated {
    /// The impulses.
    pub lambda: Vec<f64>,
    /// The index set whose linear system produced `lambda`.
    pub index: Vec<IndexState>,
    /// Absolute natural-map residual `‖λ − clamp(λ − w, lo(λ), hi(λ))‖∞` at `lambda`.
    pub residual: f64,
}

/// Candidate for one row (the private superset of [`IndexState`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Choice {
    Free,
    Lower,
    Upper,
    /// Friction row with a collapsed box: `λ_i = 0` (only offered when the normal row may go negative).
    ZeroBox,
}

/// Every solution of `p` reachable through a non-singular index set, each listed once.
///
/// `tol` is relative to the scale of the problem (see the module documentation); `1e-9` suits
/// well-conditioned test problems.
///
/// # Panics
///
/// If `p.n() > MAX_ROWS` (this is a test-only helper whose cost is exponential in `m`).
pub fn enumerate_solutions(p: &Mlcp, tol: f64) -> Vec<Enumerated> {
    let n = p.n();
    assert!(n <= MAX_ROWS, "enumerate_solutions is a test helper for m <= {MAX_ROWS}, got m = {n}");
    if n == 0 {
        return vec![Enumerated { lambda: Vec::new(), index: Vec::new(), residual: 0.0 }];
    }
    let (lo, hi, b, findex) = (p.lo(), p.hi(), p.b(), p.findex());

    let mut dense = vec![0.0; n * n];
    p.a().to_dense(&mut dense);
    let a_max = dense.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let b_max = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));

    // Candidate choices per row.
    let options: Vec<Vec<Choice>> = (0..n)
        .map(|i| {
            let mut o = vec![Choice::Free];
            if lo[i] > f64::NEG_INFINITY {
                o.push(Choice::Lower);
            }
            if hi[i] < f64::INFINITY {
                o.push(Choice::Upper);
            }
            if let Some(j) = findex[i]
                && lo[j] < 0.0
            {
                o.push(Choice::ZeroBox);
            }
            o
        })
        .collect();

    let mut digits = vec![0usize; n];
    let mut choice = vec![Choice::Free; n];
    let mut w = vec![0.0; n];
    let mut found: Vec<Enumerated> = Vec::new();
    loop {
        for i in 0..n {
            choice[i] = options[i][digits[i]];
        }
        if let Some(lambda) = solve_index_set(p, &dense, &choice) {
            let lam_max = lambda.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let lam_scale = lam_max.max(if a_max > 0.0 { b_max / a_max } else { 0.0 }).max(f64::MIN_POSITIVE);
            let w_scale = b_max.max(a_max * lam_max).max(f64::MIN_POSITIVE);
            p.residual_velocity(&lambda, &mut w);
            if accepts(p, &lambda, &w, &choice, tol * lam_scale, tol * w_scale) {
                let same = (100.0 * tol).max(1e-8) * lam_scale;
                let duplicate =
                    found.iter().any(|s| s.lambda.iter().zip(&lambda).all(|(x, y)| (x - y).abs() <= same));
                if !duplicate {
                    let index = choice
                        .iter()
                        .zip(&w)
                        .map(|(&c, &wi)| match c {
                            Choice::Free => IndexState::Free,
                            Choice::Lower => IndexState::Lower,
                            Choice::Upper => IndexState::Upper,
                            Choice::ZeroBox if wi >= 0.0 => IndexState::Lower,
                            Choice::ZeroBox => IndexState::Upper,
                        })
                        .collect();
                    let (residual, _) = p.natural_residual(&lambda, &mut w);
                    found.push(Enumerated { lambda, index, residual });
                }
            }
        }
        // Mixed-radix increment; row 0 varies fastest.
        let mut k = 0;
        loop {
            if k == n {
                return found;
            }
            digits[k] += 1;
            if digits[k] < options[k].len() {
                break;
            }
            digits[k] = 0;
            k += 1;
        }
    }
}

/// Solves the linear system of one index set; `None` when it is singular or the result not finite.
fn solve_index_set(p: &Mlcp, dense: &[f64], choice: &[Choice]) -> Option<Vec<f64>> {
    let n = p.n();
    let (lo, hi, b, findex) = (p.lo(), p.hi(), p.b(), p.findex());
    let mut m = DMatrix::<f64>::zeros(n, n);
    let mut rhs = DVector::<f64>::zeros(n);
    for i in 0..n {
        match (choice[i], findex[i]) {
            (Choice::Free, _) => {
                for c in 0..n {
                    // `dense` is column-major and symmetric: entry (i, c) sits at c * n + i.
                    m[(i, c)] = dense[c * n + i];
                }
                rhs[i] = b[i];
            }
            (Choice::Lower | Choice::Upper, Some(j)) => {
                let coeff = if choice[i] == Choice::Lower { lo[i] } else { hi[i] };
                m[(i, i)] = 1.0;
                m[(i, j)] = -coeff;
            }
            (Choice::Lower, None) => {
                m[(i, i)] = 1.0;
                rhs[i] = lo[i];
            }
            (Choice::Upper, None) => {
                m[(i, i)] = 1.0;
                rhs[i] = hi[i];
            }
            (Choice::ZeroBox, _) => {
                m[(i, i)] = 1.0;
            }
        }
    }
    let x = m.lu().solve(&rhs)?;
    if x.iter().all(|v| v.is_finite()) { Some(x.iter().copied().collect()) } else { None }
}

/// Feasibility (in impulse units) and complementarity (in velocity units) of a candidate.
fn accepts(p: &Mlcp, lambda: &[f64], w: &[f64], choice: &[Choice], eps_l: f64, eps_w: f64) -> bool {
    for i in 0..lambda.len() {
        let (l, h) = p.bounds_at(i, lambda);
        if !(lambda[i] >= l - eps_l && lambda[i] <= h + eps_l) {
            return false;
        }
        let ok = match choice[i] {
            Choice::Free => w[i].abs() <= eps_w,
            Choice::Lower => w[i] >= -eps_w,
            Choice::Upper => w[i] <= eps_w,
            Choice::ZeroBox => p.findex()[i].is_some_and(|j| lambda[j] <= eps_l),
        };
        if !ok {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::SymCsr;

    const INF: f64 = f64::INFINITY;

    fn problem(n: usize, a: &[f64], b: &[f64], lo: &[f64], hi: &[f64], f: &[Option<usize>]) -> Mlcp {
        Mlcp::new(
            SymCsr::from_dense_row_major(n, a).unwrap(),
            b.to_vec(),
            lo.to_vec(),
            hi.to_vec(),
            f.to_vec(),
        )
        .unwrap()
    }

    fn only(p: &Mlcp) -> Enumerated {
        let s = enumerate_solutions(p, 1e-9);
        assert_eq!(s.len(), 1, "expected exactly one solution, got {s:?}");
        s.into_iter().next().unwrap()
    }

    fn close(x: &[f64], y: &[f64]) -> bool {
        x.len() == y.len() && x.iter().zip(y).all(|(a, b)| (a - b).abs() <= 1e-12 * (1.0 + b.abs()))
    }

    #[test]
    fn one_by_one_free_lower_upper() {
        use IndexState::*;
        // 2 λ = 4 → λ = 2 inside [0, ∞): free.
        let s = only(&problem(1, &[2.0], &[4.0], &[0.0], &[INF], &[None]));
        assert!(close(&s.lambda, &[2.0]) && s.index == [Free], "{s:?}");
        // 2 λ = −4 would give λ = −2 < 0: λ = 0 at the lower bound, w = 0 + 4 = 4 ≥ 0.
        let s = only(&problem(1, &[2.0], &[-4.0], &[0.0], &[INF], &[None]));
        assert!(close(&s.lambda, &[0.0]) && s.index == [Lower], "{s:?}");
        // Box [0, 1]: λ = 1 at the upper bound, w = 2 − 4 = −2 ≤ 0.
        let s = only(&problem(1, &[2.0], &[4.0], &[0.0], &[1.0], &[None]));
        assert!(close(&s.lambda, &[1.0]) && s.index == [Upper], "{s:?}");
        assert_eq!(s.residual, 0.0);
        // Bilateral row: never tight.
        let s = only(&problem(1, &[2.0], &[-4.0], &[-INF], &[INF], &[None]));
        assert!(close(&s.lambda, &[-2.0]) && s.index == [Free], "{s:?}");
    }

    #[test]
    fn two_by_two_contact() {
        // A = [2 1; 1 2], b = (1, −2), λ ≥ 0.
        // All free: λ = A⁻¹ b = (4/3, −5/3), infeasible.
        // Row 1 at its lower bound 0: 2 λ0 = 1 → λ0 = 1/2 > 0, w1 = λ0 + 2·0 + 2 = 5/2 ≥ 0. Solution.
        let p = problem(2, &[2.0, 1.0, 1.0, 2.0], &[1.0, -2.0], &[0.0, 0.0], &[INF, INF], &[None, None]);
        let s = only(&p);
        assert!(close(&s.lambda, &[0.5, 0.0]), "{s:?}");
        assert_eq!(s.index, [IndexState::Free, IndexState::Lower]);
        assert!(s.residual < 1e-15);
    }

    #[test]
    fn two_by_two_box() {
        // A = [4 1; 1 3], b = (10, 1), λ ∈ [−1, 1]².
        // All free: λ0 = (3·10 − 1)/11 = 29/11 > 1, infeasible.
        // λ0 at its upper bound 1: 3 λ1 = 1 − 1 → λ1 = 0 (inside), w0 = 4 + 0 − 10 = −6 ≤ 0. Solution.
        let p = problem(2, &[4.0, 1.0, 1.0, 3.0], &[10.0, 1.0], &[-1.0, -1.0], &[1.0, 1.0], &[None, None]);
        let s = only(&p);
        assert!(close(&s.lambda, &[1.0, 0.0]), "{s:?}");
        assert_eq!(s.index, [IndexState::Upper, IndexState::Free]);
    }

    #[test]
    fn friction_follows_normal_impulse() {
        // Row 1 is friction on row 0 with μ = 0.5; A = [2 1; 1 2], b = (3, 3).
        // Both free: λ = (1, 1), but |λ1| = 1 > μ λ0 = 0.5. Infeasible.
        // λ0 = 0: friction box [0, 0] and w0 = λ1 − 3 < 0 for λ1 = 0. Infeasible.
        // λ1 = −μ λ0: 2 λ0 − 0.5 λ0 = 3 → λ0 = 2, w1 = 2 − 2 − 3 = −3 < 0 at a lower bound. Infeasible.
        // λ1 = +μ λ0: 2 λ0 + 0.5 λ0 = 3 → λ0 = 1.2, λ1 = 0.6, w1 = 1.2 + 1.2 − 3 = −0.6 ≤ 0. Solution.
        let p = problem(2, &[2.0, 1.0, 1.0, 2.0], &[3.0, 3.0], &[0.0, -0.5], &[INF, 0.5], &[None, Some(0)]);
        let s = only(&p);
        assert!(close(&s.lambda, &[1.2, 0.6]), "{s:?}");
        assert_eq!(s.index, [IndexState::Free, IndexState::Upper]);
        assert!(s.residual < 1e-14);
    }

    #[test]
    fn contact_with_two_friction_directions() {
        // A = diag(2, 1, 1), b = (2, 3, −0.1), μ = 0.5 on rows 1 and 2 (normal row 0).
        // λ0 = 1 (free); row 1 wants λ1 = 3 > μ λ0 = 0.5 → upper, w1 = 0.5 − 3 ≤ 0;
        // row 2 wants λ2 = −0.1 ∈ [−0.5, 0.5] → free.
        let p = problem(
            3,
            &[2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            &[2.0, 3.0, -0.1],
            &[0.0, -0.5, -0.5],
            &[INF, 0.5, 0.5],
            &[None, Some(0), Some(0)],
        );
        let s = only(&p);
        assert!(close(&s.lambda, &[1.0, 0.5, -0.1]), "{s:?}");
        assert_eq!(s.index, [IndexState::Free, IndexState::Upper, IndexState::Free]);
    }

    #[test]
    fn collapsed_friction_box_under_a_bilateral_normal() {
        // Row 0 bilateral with 1 · λ0 = −1 → λ0 = −1: the friction box of row 1 is [0, 0], so λ1 = 0
        // whatever w1 = −2 is. Only the extra "zero box" candidate finds it.
        let p = problem(2, &[1.0, 0.0, 0.0, 1.0], &[-1.0, 2.0], &[-INF, -0.5], &[INF, 0.5], &[None, Some(0)]);
        let s = only(&p);
        assert!(close(&s.lambda, &[-1.0, 0.0]), "{s:?}");
        assert_eq!(s.index, [IndexState::Free, IndexState::Upper]);
    }

    #[test]
    fn singular_matrix_lists_the_reachable_solutions() {
        // A = [1 1; 1 1] (PSD), b = (1, 1), λ ≥ 0: every λ ≥ 0 with λ0 + λ1 = 1 solves it. The
        // non-singular index sets reach the two vertices (1, 0) and (0, 1).
        let p = problem(2, &[1.0, 1.0, 1.0, 1.0], &[1.0, 1.0], &[0.0, 0.0], &[INF, INF], &[None, None]);
        let s = enumerate_solutions(&p, 1e-9);
        assert_eq!(s.len(), 2, "{s:?}");
        assert!(s.iter().any(|e| close(&e.lambda, &[1.0, 0.0])));
        assert!(s.iter().any(|e| close(&e.lambda, &[0.0, 1.0])));
    }

    #[test]
    fn empty_problem() {
        let p = Mlcp::new(SymCsr::diagonal(&[]).unwrap(), vec![], vec![], vec![], vec![]).unwrap();
        let s = enumerate_solutions(&p, 1e-9);
        assert_eq!(s.len(), 1);
        assert!(s[0].lambda.is_empty());
    }

    #[test]
    #[should_panic(expected = "test helper")]
    fn refuses_large_problems() {
        let n = MAX_ROWS + 1;
        let p = Mlcp::new(
            SymCsr::diagonal(&vec![1.0; n]).unwrap(),
            vec![0.0; n],
            vec![0.0; n],
            vec![INF; n],
            vec![None; n],
        )
        .unwrap();
        enumerate_solutions(&p, 1e-9);
    }
}
