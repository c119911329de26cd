//! LU factorization without pivoting on the envelope of a symmetric pattern: the Newton matrix of
//! the interior point method (`bpp/ipm.rs`), `K = A + diag(d) + C`, where `C` holds at most one
//! entry per row, `C[i, c_i]` (a friction row's coupling to its normal impulse), and the matrix of
//! the exact coupled Newton point of an index set (`bpp/coupled.rs`, [`EnvelopeLu::factor_coupled`]):
//! `A`'s rows restricted to the free and coupled columns, identity rows for the tight ones, the
//! same kind of coupling entries. Either is structurally symmetric wherever `A[i, c_i] ≠ 0`, so
//! its `L` and `U` share `A`'s envelope (`envelope.rs`: no fill outside it, for the same reason as
//! Cholesky's).
//!
//! **Storage.** `L` (unit lower) by columns exactly as the Cholesky factor is stored; `U` (upper,
//! pivots on its diagonal) transposed into the same layout: `U[j, p]` sits where `L[p, j]` would.
//!
//! **Left-looking elimination**, column and row `j` together:
//! `U[j, j..] ← K[j, j..] − Σ_{k<j} L[j,k] U[k, j..]`, `L[j.., j] ← (K[j.., j] − Σ_{k<j} U[k,j]
//! L[j.., k]) / U[j,j]`, the sums over `k = g_j .. j−1` as contiguous axpys over column `k`'s rows
//! `j ..= s_k` (twice the work of the Cholesky of the same envelope).
//!
//! **No row exchanges** (they would leave the envelope): `K = S + C` with `S = A + diag(d)`
//! symmetric positive definite and `|C[i, c_i]| ≤ μ d_i`; pivots may turn negative (measured on
//! the corpus: requiring positive ones broke 20 of 30 runs) and are accepted unless they vanish
//! against their row's diagonal (`PIVOT_FLOOR`) or are not finite — then a typed error, and the
//! interior point method stops (no silent garbage).

use super::SymCsr;
use super::envelope::Envelope;
use super::problem::reserve_touched;

/// Smallest pivot, relative to the row's diagonal of `K`, that the elimination accepts.
const PIVOT_FLOOR: f64 = 1e-13;

/// An LU factor on an [`Envelope`]; buffers reused between factorizations.
#[derive(Debug, Clone, Default)]
pub struct EnvelopeLu {
    lo: Vec<f64>,
    up: Vec<f64>,
    /// `|K_jj|` before elimination (the pivots' scale), filled while `K` is scattered.
    scale: Vec<f64>,
}

/// Why a factorization failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LuError {
    /// A coupling entry falls outside the envelope of `A`.
    OutsideEnvelope { row: usize, col: usize },
    /// A pivot was not finite or vanished against its row's diagonal.
    Pivot { row: usize, value: f64 },
}

impl EnvelopeLu {
    /// Empty; sized by the first [`EnvelopeLu::factor`].
    pub fn new() -> Self {
        Self::default()
    }

    /// Factors `K = A + diag(d) + C`, `C[i, c] = cv[i]` for `cpl[i] = Some(c)`, on `env` (built
    /// from `a`). A coupling entry outside the envelope is an error (nothing is dropped silently).
    pub fn factor(
        &mut self,
        env: &Envelope,
        a: &SymCsr,
        d: &[f64],
        cpl: &[Option<usize>],
        cv: &[f64],
    ) -> Result<(), LuError> {
        self.clear(env);
        // Scatter K: row j's entries from the diagonal on give U's row j and L's column j.
        for j in 0..env.m() {
            let (cols, vals) = a.row(j);
            for (&p, &v) in cols.iter().zip(vals) {
                if p == j {
                    self.scale[j] = v;
                }
                if p >= j {
                    let at = env.index(p, j);
                    self.up[at] += v;
                    if p > j {
                        self.lo[at] += v;
                    }
                }
            }
            self.up[env.index(j, j)] += d[j];
            self.scale[j] = (self.scale[j] + d[j]).abs();
        }
        self.add_couplings(env, cpl, cv)?;
        self.eliminate(env)
    }

    /// Factors the matrix of the exact coupled Newton point of an index set (`bpp/coupled.rs`):
    /// a free row `i` (`!tight[i]`) is `A`'s row restricted to the free columns and to the tight
    /// columns `p` with `cpl[p] = Some(_)` (friction rows that follow their normal impulse); a tight
    /// row is the identity row, plus `cv[i]` in column `cpl[i]` for a coupled one
    /// (`λ_i + cv_i λ_n = …`). Every entry lies in `A`'s pattern or is a coupling, so the factors
    /// stay in `A`'s envelope; a coupling outside it is an error.
    pub fn factor_coupled(
        &mut self,
        env: &Envelope,
        a: &SymCsr,
        tight: &[bool],
        cpl: &[Option<usize>],
        cv: &[f64],
    ) -> Result<(), LuError> {
        self.clear(env);
        // Entry (r, c) of K from A's entry v: kept in a free row when column c is free or coupled.
        let keep = |r: usize, c: usize| !tight[r] && (!tight[c] || cpl[c].is_some());
        for j in 0..env.m() {
            let (cols, vals) = a.row(j);
            for (&p, &v) in cols.iter().zip(vals) {
                if p < j {
                    continue;
                }
                let at = env.index(p, j);
                if p == j {
                    let kjj = if tight[j] { 1.0 } else { v };
                    self.up[at] = kjj;
                    self.scale[j] = kjj.abs();
                    continue;
                }
                // U's row j holds K[j, p]; L's column j holds K[p, j].
                if keep(j, p) {
                    self.up[at] += v;
                }
                if keep(p, j) {
                    self.lo[at] += v;
                }
            }
        }
        self.add_couplings(env, cpl, cv)?;
        self.eliminate(env)
    }

    /// Room for a factor of `len` envelope entries and `m` rows, so that a later factorization of
    /// that size allocates nothing (grown with the headroom of `problem::reserve_touched`).
    pub fn reserve(&mut self, len: usize, m: usize) {
        reserve_touched(&mut self.lo, len, 0.0);
        reserve_touched(&mut self.up, len, 0.0);
        reserve_touched(&mut self.scale, m, 0.0);
    }

    /// Zeroed factor buffers and scales for `env`.
    fn clear(&mut self, env: &Envelope) {
        let len = env.len();
        self.lo.clear();
        self.lo.resize(len, 0.0);
        self.up.clear();
        self.up.resize(len, 0.0);
        self.scale.clear();
        self.scale.resize(env.m(), 0.0);
    }

    /// Adds `C[i, cpl[i]] = cv[i]` to the scattered `K`.
    fn add_couplings(&mut self, env: &Envelope, cpl: &[Option<usize>], cv: &[f64]) -> Result<(), LuError> {
        let s = env.skyline();
        for i in 0..env.m() {
            let Some(c) = cpl[i] else { continue };
            if cv[i] == 0.0 {
                continue;
            }
            let (p, j) = if c > i { (c, i) } else { (i, c) };
            if p > s[j] {
                return Err(LuError::OutsideEnvelope { row: i, col: c });
            }
            let at = env.index(p, j);
            if c > i {
                self.up[at] += cv[i];
            } else {
                self.lo[at] += cv[i];
            }
        }
        Ok(())
    }

    /// Left-looking elimination of the scattered `K` (module docs).
    fn eliminate(&mut self, env: &Envelope) -> Result<(), LuError> {
        let s = env.skyline();
        for j in 0..env.m() {
            let sj = s[j];
            let cj = env.index(j, j);
            for k in env.first_column_of_row(j)..j {
                let sk = s[k];
                if sk < j {
                    continue;
                }
                let at_jk = env.index(j, k);
                let (ljk, ukj) = (self.lo[at_jk], self.up[at_jk]);
                let n = sk - j + 1;
                if ljk != 0.0 {
                    let (left, right) = self.up.split_at_mut(cj);
                    for (x, &y) in right[..n].iter_mut().zip(&left[at_jk..at_jk + n]) {
                        *x -= ljk * y;
                    }
                }
                if ukj != 0.0 {
                    let (left, right) = self.lo.split_at_mut(cj);
                    // Row j of L's column j is the (unused) unit diagonal: start one below.
                    for (x, &y) in right[1..n].iter_mut().zip(&left[at_jk + 1..at_jk + n]) {
                        *x -= ukj * y;
                    }
                }
            }
            let piv = self.up[cj];
            if !(piv.is_finite() && piv.abs() > PIVOT_FLOOR * self.scale[j]) {
                return Err(LuError::Pivot { row: j, value: piv });
            }
            let inv = 1.0 / piv;
            for x in &mut self.lo[cj + 1..=cj + (sj - j)] {
                *x *= inv;
            }
            self.lo[cj] = 1.0;
        }
        Ok(())
    }

    /// Solves `K x = x` in place with the last factor.
    pub fn solve(&self, env: &Envelope, x: &mut [f64]) {
        let m = env.m();
        let s = env.skyline();
        for j in 0..m {
            let xj = x[j];
            if xj != 0.0 {
                let c = env.index(j, j);
                for (xp, &l) in x[j + 1..=s[j]].iter_mut().zip(&self.lo[c + 1..=c + (s[j] - j)]) {
                    *xp -= l * xj;
                }
            }
        }
        for j in (0..m).rev() {
            let c = env.index(j, j);
            let acc = x[j] - super::envelope::dot(&x[j + 1..=s[j]], &self.up[c + 1..=c + (s[j] - j)]);
            x[j] = acc / self.up[c];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// A random symmetric matrix of bandwidth `band − 1` with diagonal `diag ± ½` (row-major
    /// dense copy, CSR, envelope); off-diagonal entries in `±½`.
    fn banded(m: usize, band: usize, diag: f64, seed: u64) -> (Vec<f64>, SymCsr, Envelope) {
        let mut state = seed;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut dense = vec![0.0; m * m];
        for i in 0..m {
            for j in i..(i + band).min(m) {
                let v = if i == j { diag + rnd() } else { rnd() };
                dense[i * m + j] = v;
                dense[j * m + i] = v;
            }
        }
        let a = SymCsr::from_dense_row_major(m, &dense).unwrap();
        let mut env = Envelope::new();
        env.build(&a);
        (dense, a, env)
    }

    /// A random banded SPD matrix with a coupling entry per row inside the band: the envelope LU
    /// solve agrees with a dense LU of the same matrix.
    #[test]
    fn envelope_lu_matches_dense_lu() {
        let m = 40;
        let (dense, a, env) = banded(m, 4, 4.0, 12345);
        let d: Vec<f64> = (0..m).map(|i| 0.5 + (i % 3) as f64).collect();
        let cpl: Vec<Option<usize>> = (0..m)
            .map(|i| {
                if i % 3 == 1 {
                    Some(i - 1)
                } else if i % 3 == 2 {
                    Some(i - 2)
                } else {
                    None
                }
            })
            .collect();
        let cv: Vec<f64> = (0..m).map(|i| 0.7 * d[i] * if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let mut k = DMatrix::from_row_slice(m, m, &dense);
        for i in 0..m {
            k[(i, i)] += d[i];
            if let Some(c) = cpl[i] {
                k[(i, c)] += cv[i];
            }
        }
        let rhs: Vec<f64> = (0..m).map(|i| (i as f64).sin()).collect();
        let want = k.clone().lu().solve(&nalgebra::DVector::from_column_slice(&rhs)).unwrap();
        let mut lu = EnvelopeLu::new();
        lu.factor(&env, &a, &d, &cpl, &cv).unwrap();
        let mut x = rhs.clone();
        lu.solve(&env, &mut x);
        let err = (0..m).map(|i| (x[i] - want[i]).abs()).fold(0.0, f64::max);
        assert!(err < 1e-12, "envelope LU differs from dense LU by {err:e}");
        // A coupling outside the envelope is refused, not dropped.
        let mut far = cpl.clone();
        far[m - 1] = Some(0);
        assert_eq!(lu.factor(&env, &a, &d, &far, &cv), Err(LuError::OutsideEnvelope { row: m - 1, col: 0 }));
    }

    /// The coupled Newton matrix (`factor_coupled`): free rows of `A` over the free and coupled
    /// columns, identity rows for the tight ones, `cv` couplings on the coupled ones — built here
    /// densely from its definition and solved by nalgebra's LU with partial pivoting.
    #[test]
    fn coupled_factor_matches_a_dense_lu_of_its_definition() {
        let m = 36;
        let (dense, a, env) = banded(m, 5, 3.0, 777);
        // Rows 3k: "normals", free; 3k+1, 3k+2: "friction", tight; every other contact coupled.
        let mut tight = vec![false; m];
        let mut cpl = vec![None; m];
        let mut cv = vec![0.0; m];
        for k in 0..m / 3 {
            for t in [3 * k + 1, 3 * k + 2] {
                tight[t] = true;
                if k % 2 == 0 {
                    cpl[t] = Some(3 * k);
                    cv[t] = if t % 2 == 0 { 0.8 } else { -0.8 };
                }
            }
        }
        let mut k = DMatrix::zeros(m, m);
        for i in 0..m {
            if tight[i] {
                k[(i, i)] = 1.0;
                if let Some(c) = cpl[i] {
                    k[(i, c)] = cv[i];
                }
            } else {
                for p in 0..m {
                    if !tight[p] || cpl[p].is_some() {
                        k[(i, p)] = dense[i * m + p];
                    }
                }
            }
        }
        let rhs: Vec<f64> = (0..m).map(|i| if tight[i] { 0.0 } else { (1.0 + i as f64).cos() }).collect();
        let want = k.lu().solve(&nalgebra::DVector::from_column_slice(&rhs)).unwrap();
        let mut lu = EnvelopeLu::new();
        lu.factor_coupled(&env, &a, &tight, &cpl, &cv).unwrap();
        let mut x = rhs.clone();
        lu.solve(&env, &mut x);
        let err = (0..m).map(|i| (x[i] - want[i]).abs()).fold(0.0, f64::max);
        assert!(err < 1e-12, "coupled envelope LU differs from the dense LU by {err:e}");
        // The coupled rows follow their normal; the other tight rows stay at zero.
        for i in 0..m {
            match (tight[i], cpl[i]) {
                (true, Some(c)) => assert!((x[i] + cv[i] * x[c]).abs() < 1e-12),
                (true, None) => assert_eq!(x[i], 0.0),
                _ => {}
            }
        }
        // A coupling outside the envelope is refused.
        let mut far = cpl.clone();
        far[m - 1] = Some(0);
        let mut far_tight = tight.clone();
        far_tight[m - 1] = true;
        assert_eq!(
            lu.factor_coupled(&env, &a, &far_tight, &far, &vec![0.5; m]),
            Err(LuError::OutsideEnvelope { row: m - 1, col: 0 })
        );
    }
}
