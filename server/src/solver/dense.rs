//! Dense kernels: left-looking Cholesky, row/column deletion, triangular solves (paper Alg. 1, 2).
//!
//! Storage is column-major `n × n`; only the lower triangle is read or written.
//!
//! **Cholesky (left-looking).** For `j = 0..n`:
//! `L[j.., j] ← A[j.., j] − Σ_{k<j} L[j, k] · L[j.., k]`, then `L[j, j] ← √L[j, j]` and
//! `L[j+1.., j] ← L[j+1.., j] / L[j, j]`. A pivot `d ≤ ε·a_jj` (semidefinite `A`, paper §3 assumes
//! `C > 0` but redundant contacts break that) is replaced by `ε·a_jj` with `ε = 1e-9` (or `ε·max_diag` when
//! `a_jj = 0`) and counted: the factor is then that of `A + D` with a tiny diagonal `D ≥ 0`.
//!
//! **Row/column deletion (Davis–Hager 2005; paper §3.3.1).** Write
//! ```text
//!     ⎡L₁₁         ⎤              ⎡A₁₁  ·   A₁₃⎤
//! L = ⎢l₂₁ᵀ l₂₂    ⎥ ,  A = LLᵀ = ⎢ ·   a₂₂  · ⎥ .
//!     ⎣L₃₁  l₃₂ L₃₃⎦              ⎣A₃₁  ·   A₃₃⎦
//! ```
//! Removing row and column 2 leaves `A₃₃ = L₃₁L₃₁ᵀ + l₃₂l₃₂ᵀ + L₃₃L₃₃ᵀ`, so the new trailing factor
//! `L̃₃₃` satisfies `L̃₃₃L̃₃₃ᵀ = L₃₃L₃₃ᵀ + σσᵀ` with `σ = l₃₂ = L[i+1.., i]`: a rank-1 **update**
//! (all terms add, no cancellation — the reason the paper's copy-and-delete is stable, §4.3). `L₁₁`
//! and `L₃₁` do not change. The update runs column by column with Givens-like rotations:
//! `r = √(L_kk² + σ_k²)`, `c = r/L_kk`, `s = σ_k/L_kk`, `L_kk ← r`,
//! `L_pk ← (L_pk + s σ_p)/c`, `σ_p ← c σ_p − s L_pk` for `p > k`.
//!
//! We never resize `L`: a deleted index keeps its place as an identity row/column (`L_ii = 1`, the
//! rest of row and column `i` zero), so `L` stays the factor of `A_FF ⊕ I_TT` and the triangular
//! solves need no index juggling; a right-hand side that is zero on `T` yields zero there (Alg. 3's
//! CHOLSOLVE skips exactly these rows). Deleting in any order is valid: an identity column has
//! `σ_k = 0` and its rotation is the identity.

/// Regularization floor of a pivot relative to its diagonal entry.
pub const PIVOT_REL: f64 = 1e-9;

/// In-place dense left-looking Cholesky of the `n × n` column-major matrix in `l` (lower triangle).
/// Returns the number of regularized pivots.
pub fn cholesky_in_place(l: &mut [f64], n: usize, max_diag: f64) -> usize {
    assert!(l.len() >= n * n, "buffer too small");
    let mut regularized = 0;
    for j in 0..n {
        let (left, right) = l.split_at_mut(j * n);
        let colj = &mut right[j..n];
        let a_jj = colj[0];
        for k in 0..j {
            let colk = &left[k * n + j..k * n + n];
            let ljk = colk[0];
            if ljk != 0.0 {
                for (x, &y) in colj.iter_mut().zip(colk) {
                    *x -= ljk * y;
                }
            }
        }
        regularized += finish_column(colj, a_jj, max_diag);
    }
    regularized
}

/// Takes a column whose first entry is the pivot `d` after the left-looking update and whose rest
/// is `c = L[j+1.., j]` before scaling. Regularizes (returns 1) when `d ≤ ε·a_jj` or when
/// `d < max_p c_p² / max_diag` — the bound of Gill–Murray–Wright's modified Cholesky that keeps the
/// factor's entries bounded (for a positive definite `A` it always holds, since
/// `c_p² ≤ d · S_pp ≤ d · max_diag`); then `d ← max(ε·a_jj, max_p c_p² / max_diag)`.
/// Writes `√d` and scales the rest by `1/√d`.
#[inline]
pub(crate) fn finish_column(colj: &mut [f64], a_jj: f64, max_diag: f64) -> usize {
    let floor = if a_jj > 0.0 { PIVOT_REL * a_jj } else { PIVOT_REL * max_diag.max(f64::MIN_POSITIVE) };
    let mut d = colj[0];
    let mut reg = 0;
    if d.is_nan() || d <= floor {
        let theta2 = colj[1..].iter().fold(0.0f64, |a, &x| a.max(x * x));
        d = floor.max(theta2 / max_diag.max(f64::MIN_POSITIVE));
        reg = 1;
    } else {
        let theta2 = colj[1..].iter().fold(0.0f64, |a, &x| a.max(x * x));
        let bound = theta2 / max_diag.max(f64::MIN_POSITIVE);
        if d < bound * (1.0 - 1e-12) {
            d = bound;
            reg = 1;
        }
    }
    let r = d.sqrt();
    colj[0] = r;
    let inv = 1.0 / r;
    for x in &mut colj[1..] {
        *x *= inv;
    }
    reg
}

/// Deletes row and column `i` from the dense factor `l` (`n × n`, column-major) in place; afterwards
/// index `i` is an identity row/column. `sigma` is scratch of length `n`. Rows/columns already
/// deleted are identity and are left untouched by the rotations.
pub fn delete_in_place(l: &mut [f64], n: usize, i: usize, sigma: &mut [f64]) {
    let base = i * n;
    sigma[i + 1..n].copy_from_slice(&l[base + i + 1..base + n]);
    l[base + i + 1..base + n].fill(0.0);
    l[base + i] = 1.0;
    for k in 0..i {
        l[k * n + i] = 0.0;
    }
    for k in i + 1..n {
        let sk = sigma[k];
        if sk == 0.0 {
            continue;
        }
        let col = &mut l[k * n + k..k * n + n];
        let lkk = col[0];
        let r = (lkk * lkk + sk * sk).sqrt();
        let c = r / lkk;
        let s = sk / lkk;
        col[0] = r;
        let (cinv, sc) = (1.0 / c, s / c);
        for (x, w) in col[1..].iter_mut().zip(&mut sigma[k + 1..n]) {
            let nx = *x * cinv + sc * *w;
            *w = c * *w - s * nx;
            *x = nx;
        }
    }
}

/// Solves `L Lᵀ x = x` in place with the dense factor `l` (`n × n`, column-major).
pub fn solve_in_place(l: &[f64], n: usize, x: &mut [f64]) {
    for j in 0..n {
        let col = &l[j * n + j..j * n + n];
        let xj = x[j] / col[0];
        x[j] = xj;
        if xj != 0.0 {
            for (xp, &lp) in x[j + 1..n].iter_mut().zip(&col[1..]) {
                *xp -= lp * xj;
            }
        }
    }
    for j in (0..n).rev() {
        let col = &l[j * n + j..j * n + n];
        let mut s = x[j];
        for (&xp, &lp) in x[j + 1..n].iter().zip(&col[1..]) {
            s -= lp * xp;
        }
        x[j] = s / col[0];
    }
}

/// `‖L_a − L_b‖_F` over the lower triangles of two `n × n` factors.
pub fn frobenius_diff(a: &[f64], b: &[f64], n: usize) -> f64 {
    let mut s = 0.0;
    for j in 0..n {
        for p in j..n {
            let d = a[j * n + p] - b[j * n + p];
            s += d * d;
        }
    }
    s.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    pub(crate) fn random_spd(n: usize, rng: &mut ChaCha8Rng) -> DMatrix<f64> {
        use rand::RngExt;
        let b = DMatrix::<f64>::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
        &b * b.transpose() + DMatrix::<f64>::identity(n, n) * (n as f64 * 0.1)
    }

    fn lower_of(l: &[f64], n: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, n, |i, j| if i >= j { l[j * n + i] } else { 0.0 })
    }

    #[test]
    fn cholesky_matches_nalgebra() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for n in [1, 2, 5, 17, 64, 150] {
            let a = random_spd(n, &mut rng);
            let mut l = a.as_slice().to_vec();
            assert_eq!(cholesky_in_place(&mut l, n, a.diagonal().max()), 0);
            let reference = a.clone().cholesky().unwrap().l();
            let err = (lower_of(&l, n) - &reference).norm() / reference.norm();
            assert!(err < 1e-13, "n={n} err={err}");
        }
    }

    #[test]
    fn deletions_match_refactor_of_a_ff() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for n in [3, 10, 40, 120] {
            let a = random_spd(n, &mut rng);
            let mut l0 = a.as_slice().to_vec();
            assert_eq!(cholesky_in_place(&mut l0, n, a.diagonal().max()), 0);
            for frac in [0.05, 0.3, 0.6] {
                use rand::RngExt;
                let tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < frac).collect();
                let mut l = l0.clone();
                let mut sigma = vec![0.0; n];
                // Delete in a scrambled order: any order must give the same factor.
                let mut order: Vec<usize> = (0..n).filter(|&i| tight[i]).collect();
                order.reverse();
                for &i in &order {
                    delete_in_place(&mut l, n, i, &mut sigma);
                }
                // Reference: chol(A_FF) embedded with identity on T.
                let free: Vec<usize> = (0..n).filter(|&i| !tight[i]).collect();
                let aff = DMatrix::from_fn(free.len(), free.len(), |p, q| a[(free[p], free[q])]);
                let lff = aff.cholesky().unwrap().l();
                let mut reference = DMatrix::<f64>::identity(n, n);
                for (p, &fp) in free.iter().enumerate() {
                    for (q, &fq) in free.iter().enumerate() {
                        reference[(fp, fq)] = lff[(p, q)];
                    }
                }
                let err = (lower_of(&l, n) - &reference).norm() / reference.norm();
                assert!(err < 1e-12, "n={n} frac={frac} err={err}");
            }
        }
    }

    #[test]
    fn solve_matches_nalgebra() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 30;
        let a = random_spd(n, &mut rng);
        let mut l = a.as_slice().to_vec();
        assert_eq!(cholesky_in_place(&mut l, n, a.diagonal().max()), 0);
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = b.clone();
        solve_in_place(&l, n, &mut x);
        let ax = &a * nalgebra::DVector::from_column_slice(&x);
        for i in 0..n {
            assert!((ax[i] - b[i]).abs() < 1e-11);
        }
    }

    #[test]
    fn semidefinite_pivots_are_regularized_and_counted() {
        // Rank-1 matrix v vᵀ: one genuine pivot, the rest are (rounding) zeros.
        let v = [1.0, 2.0, 3.0];
        let mut l: Vec<f64> = (0..9).map(|k| v[k / 3] * v[k % 3]).collect();
        let reg = cholesky_in_place(&mut l, 3, 9.0);
        assert_eq!(reg, 2);
        assert!(l.iter().all(|x| x.is_finite()));
    }
}
