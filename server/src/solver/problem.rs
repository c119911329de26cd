//! The boxed mixed linear complementarity problem (paper eq. 3) and its validation.
//!
//! Given a symmetric positive (semi)definite `A ∈ ℝ^{m×m}`, `b ∈ ℝ^m` and bounds `lo ≤ hi`, find `λ`
//! with `w = Aλ − b` such that for every row `i`
//!
//! ```text
//!   lo_i < λ_i < hi_i  and  w_i = 0      (free,  i ∈ F)
//!   λ_i = lo_i         and  w_i ≥ 0      (tight at the lower bound, i ∈ T_lo)
//!   λ_i = hi_i         and  w_i ≤ 0      (tight at the upper bound, i ∈ T_hi)
//! ```
//!
//! (paper eq. 3a/3b; `w = w₊ + w₋` with `0 ≤ w₊ ⊥ λ − lo ≥ 0` and `0 ≤ w₋ ⊥ hi − λ ≥ 0`).
//!
//! **Friction coupling.** A row `i` with `findex_i = j` is a friction row of the contact whose normal row
//! is `j`. Its stored `lo_i ≤ 0 ≤ hi_i` are *coefficients*: the true bounds are
//! `[lo_i · λ_j⁺, hi_i · λ_j⁺]` with `λ_j⁺ = max(λ_j, 0)` (a box approximation of the Coulomb cone,
//! `hi_i = μ`, `lo_i = −μ`; see `MLCP_FORMAT.md`). A solution is judged against the bounds at the
//! *final* normal impulse.
//!
//! **Residual.** The natural map `r(λ) = λ − clamp(λ − w, lo(λ), hi(λ))` is zero exactly at a
//! solution; we report `‖r‖∞` and `‖r‖∞ / max(‖λ‖∞, 1e-300)`.
//!
//! `A` is kept in compressed sparse rows with both triangles stored ([`SymCsr`]); dense input is
//! converted (exact zeros dropped), so every solver reads one representation.

use thiserror::Error;

/// Errors found while building or validating a problem. Each names the offending index.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MlcpError {
    /// A vector or matrix does not have the length the problem size requires.
    #[error("{what} has length {found}, expected {expected}")]
    DimensionMismatch {
        /// Which input.
        what: &'static str,
        /// The length required by the problem size.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A matrix entry is NaN or infinite.
    #[error("A[{row},{col}] is not finite ({value})")]
    NonFiniteMatrix {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The value found.
        value: f64,
    },
    /// A vector entry is NaN (or infinite where only finite values make sense).
    #[error("{vector}[{index}] is not allowed ({value})")]
    NonFiniteVector {
        /// Which vector (`b`, `lo`, `hi`, `lambda0`).
        vector: &'static str,
        /// Index of the entry.
        index: usize,
        /// The value found.
        value: f64,
    },
    /// `lo_i > hi_i`, or a bound that admits no value (`lo = +∞`, `hi = −∞`).
    #[error("row {index}: empty box lo = {lo} > hi = {hi}")]
    EmptyBox {
        /// Row index.
        index: usize,
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
    /// `findex_i` names a row outside `0..m` or the row itself.
    #[error("row {row}: findex {target} is out of range or names the row itself")]
    FindexOutOfRange {
        /// The friction row.
        row: usize,
        /// The index it names.
        target: i64,
    },
    /// `findex_i` names a row that is itself a friction row.
    #[error("row {row}: findex {target} names another friction row")]
    FindexToFrictionRow {
        /// The friction row.
        row: usize,
        /// The friction row it names.
        target: usize,
    },
    /// A friction row's coefficients must satisfy `−∞ < lo ≤ 0 ≤ hi < ∞`.
    #[error(
        "row {row}: friction coefficients must satisfy -inf < lo <= 0 <= hi < inf (lo = {lo}, hi = {hi})"
    )]
    FrictionCoefficients {
        /// The friction row.
        row: usize,
        /// Its stored lower coefficient.
        lo: f64,
        /// Its stored upper coefficient.
        hi: f64,
    },
    /// `A[i,j] ≠ A[j,i]` beyond rounding.
    #[error("A is not symmetric: A[{row},{col}] = {a_ij} but A[{col},{row}] = {a_ji}")]
    NotSymmetric {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// `A[row, col]`.
        a_ij: f64,
        /// `A[col, row]`.
        a_ji: f64,
    },
    /// A negative diagonal entry: `A` cannot be positive semidefinite.
    #[error("A[{index},{index}] = {value} < 0: A is not positive semidefinite")]
    NegativeDiagonal {
        /// Row index.
        index: usize,
        /// The diagonal value.
        value: f64,
    },
    /// An upper-triangle entry list ([`SymCsr::assign_from_upper`]) with an entry below the
    /// diagonal, out of `(row, col)` order, or repeated.
    #[error("A[{row},{col}]: upper-triangle entries must have row ≤ col, sorted, each once")]
    NotUpperSorted {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
    },
    /// An upper-triangle entry list without this diagonal entry.
    #[error("A[{index},{index}] is missing")]
    MissingDiagonal {
        /// The index.
        index: usize,
    },
    /// A sparse entry given twice.
    #[error("A[{row},{col}] is given more than once")]
    DuplicateEntry {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
    },
    /// A sparse entry outside `0..m`.
    #[error("A[{row},{col}] lies outside a {n}x{n} matrix")]
    EntryOutOfRange {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// Problem size.
        n: usize,
    },
}

/// Relative tolerance of the symmetry check, against `sqrt(|A_ii A_jj|)` and the entry itself.
pub const SYMMETRY_TOL: f64 = 1e-10;

/// Symmetric matrix in compressed sparse rows, both triangles stored, columns sorted in each row.
#[derive(Debug, Clone, Default)]
pub struct SymCsr {
    n: usize,
    row_ptr: Vec<usize>,
    col: Vec<usize>,
    val: Vec<f64>,
    /// Scratch of [`SymCsr::permuted_from`] (not part of the value).
    next: Vec<usize>,
    /// After [`SymCsr::permuted_from`]: the source position of every entry (not part of the value).
    src: Vec<usize>,
    /// Scratch of [`SymCsr::assign_from_triplets`] (not part of the value).
    sym: Vec<(usize, usize, f64)>,
}

impl PartialEq for SymCsr {
    fn eq(&self, other: &Self) -> bool {
        self.n == other.n && self.row_ptr == other.row_ptr && self.col == other.col && self.val == other.val
    }
}

impl SymCsr {
    /// Builds from a dense row-major `n × n` array. Exact zeros are not stored; `A[i,j]` and
    /// `A[j,i]` must agree within [`SYMMETRY_TOL`] and are then averaged.
    pub fn from_dense_row_major(n: usize, a: &[f64]) -> Result<Self, MlcpError> {
        if a.len() != n * n {
            return Err(MlcpError::DimensionMismatch { what: "A", expected: n * n, found: a.len() });
        }
        for (k, &v) in a.iter().enumerate() {
            if !v.is_finite() {
                return Err(MlcpError::NonFiniteMatrix { row: k / n, col: k % n, value: v });
            }
        }
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col = Vec::new();
        let mut val = Vec::new();
        row_ptr.push(0);
        for i in 0..n {
            for j in 0..n {
                let (aij, aji) = (a[i * n + j], a[j * n + i]);
                if i != j {
                    check_symmetric(i, j, aij, aji, a[i * n + i], a[j * n + j])?;
                }
                let v = 0.5 * (aij + aji);
                if v != 0.0 || i == j {
                    col.push(j);
                    val.push(v);
                }
            }
            row_ptr.push(col.len());
        }
        let m = SymCsr { n, row_ptr, col, val, ..Default::default() };
        m.check_diagonal()?;
        Ok(m)
    }

    /// Builds from `(row, col, value)` triplets that list every stored entry of *both* triangles
    /// (the sparse form of `MLCP_FORMAT.md`). A repeated `(i, j)` is an error.
    pub fn from_triplets(n: usize, triplets: &[(usize, usize, f64)]) -> Result<Self, MlcpError> {
        let mut t = triplets.to_vec();
        let mut m = SymCsr::default();
        m.assign_from_triplets(n, &mut t)?;
        Ok(m)
    }

    /// In-place [`SymCsr::from_triplets`]: sorts `triplets` in place and reuses `self`'s buffers,
    /// so that rebuilding a matrix of the same size every time step allocates nothing. Mirrors
    /// agree within [`SYMMETRY_TOL`] and are averaged; an entry whose mirror is missing (so it must
    /// be tiny) gets a stored mirror, so the pattern is always symmetric. On error `self` is left
    /// empty (`n = 0`), never half-built.
    pub fn assign_from_triplets(
        &mut self,
        n: usize,
        triplets: &mut [(usize, usize, f64)],
    ) -> Result<(), MlcpError> {
        let result = self.assign_inner(n, triplets);
        self.emptied_on_error(result)
    }

    /// Leaves the matrix empty (`n = 0`) when `result` is an error; passes `result` on.
    fn emptied_on_error(&mut self, result: Result<(), MlcpError>) -> Result<(), MlcpError> {
        if result.is_err() {
            self.n = 0;
            self.row_ptr.clear();
            self.row_ptr.push(0);
            self.col.clear();
            self.val.clear();
        }
        result
    }

    fn assign_inner(&mut self, n: usize, triplets: &mut [(usize, usize, f64)]) -> Result<(), MlcpError> {
        for &(i, j, v) in triplets.iter() {
            if i >= n || j >= n {
                return Err(MlcpError::EntryOutOfRange { row: i, col: j, n });
            }
            if !v.is_finite() {
                return Err(MlcpError::NonFiniteMatrix { row: i, col: j, value: v });
            }
        }
        triplets.sort_unstable_by_key(|&(i, j, _)| (i, j));
        for w in triplets.windows(2) {
            if (w[0].0, w[0].1) == (w[1].0, w[1].1) {
                return Err(MlcpError::DuplicateEntry { row: w[0].0, col: w[0].1 });
            }
        }
        let entries: &[(usize, usize, f64)] = triplets;
        let find = |i: usize, j: usize| -> Option<f64> {
            entries.binary_search_by_key(&(i, j), |&(a, b, _)| (a, b)).ok().map(|k| entries[k].2)
        };
        // Symmetric entry list: every entry (averaged with its mirror), missing mirrors, missing
        // diagonal entries; then one sort and a linear pass.
        let mut sym = std::mem::take(&mut self.sym);
        sym.clear();
        for &(i, j, aij) in entries {
            if i == j {
                sym.push((i, i, aij));
                continue;
            }
            let mirror = find(j, i);
            let aji = mirror.unwrap_or(0.0);
            check_symmetric(i, j, aij, aji, find(i, i).unwrap_or(0.0), find(j, j).unwrap_or(0.0))?;
            let v = 0.5 * (aij + aji);
            sym.push((i, j, v));
            if mirror.is_none() {
                sym.push((j, i, v));
            }
        }
        for i in 0..n {
            if find(i, i).is_none() {
                sym.push((i, i, 0.0));
            }
        }
        sym.sort_unstable_by_key(|&(i, j, _)| (i, j));
        self.n = n;
        self.row_ptr.clear();
        self.col.clear();
        self.val.clear();
        self.row_ptr.push(0);
        let mut k = 0;
        for i in 0..n {
            while k < sym.len() && sym[k].0 == i {
                self.col.push(sym[k].1);
                self.val.push(sym[k].2);
                k += 1;
            }
            self.row_ptr.push(self.col.len());
        }
        self.sym = sym;
        self.check_diagonal()
    }

    /// Refills the matrix (in place, reusing its buffers) from its upper triangle: entries
    /// `(i, j, a_ij)` with `i ≤ j`, sorted by `(i, j)`, each once, every diagonal entry present —
    /// what the dynamics assembler emits. The lower triangle is the mirror, so no symmetry check
    /// is needed, and one counting pass builds rows with sorted columns: row `j` receives its
    /// mirrored entries `(j, i)`, `i < j`, in increasing `i` before its own upper entries. On error
    /// the matrix is left empty.
    ///
    /// When `upper` has the structure of the matrix already held (the assembler's common case: the
    /// same rows on the same bodies as last step), only the values are written, each into the slot
    /// the full build would give it; the structure is checked entry by entry on the way (every slot
    /// of every row written once, in order), and anything else falls back to the full build. The
    /// result, errors included, is the full build's.
    pub fn assign_from_upper(&mut self, n: usize, upper: &[(usize, usize, f64)]) -> Result<(), MlcpError> {
        let result = match self.refill_upper_values(n, upper) {
            Some(result) => result,
            None => self.assign_upper_inner(n, upper),
        };
        self.emptied_on_error(result)
    }

    /// The values of `upper` into the structure held, if `upper` has exactly that structure
    /// (`None`, values possibly overwritten, otherwise). Errors as the full build reports them: the
    /// first non-finite entry in order, else the first negative diagonal entry.
    fn refill_upper_values(
        &mut self,
        n: usize,
        upper: &[(usize, usize, f64)],
    ) -> Option<Result<(), MlcpError>> {
        if n == 0 || n != self.n || self.row_ptr.len() != n + 1 || 2 * upper.len() != self.col.len() + n {
            return None;
        }
        self.next.clear();
        self.next.extend_from_slice(&self.row_ptr[..n]);
        let mut non_finite = None;
        let mut negative = None;
        for &(i, j, v) in upper {
            if i >= n || j >= n || j < i {
                return None;
            }
            let k = self.next[i];
            if k >= self.row_ptr[i + 1] || self.col[k] != j {
                return None;
            }
            self.val[k] = v;
            self.next[i] += 1;
            if j != i {
                let k = self.next[j];
                if k >= self.row_ptr[j + 1] || self.col[k] != i {
                    return None;
                }
                self.val[k] = v;
                self.next[j] += 1;
            } else if v < 0.0 && negative.is_none() {
                negative = Some(MlcpError::NegativeDiagonal { index: i, value: v });
            }
            if !v.is_finite() && non_finite.is_none() {
                non_finite = Some(MlcpError::NonFiniteMatrix { row: i, col: j, value: v });
            }
        }
        if (0..n).any(|i| self.next[i] != self.row_ptr[i + 1]) {
            return None;
        }
        Some(match non_finite.or(negative) {
            Some(e) => Err(e),
            None => Ok(()),
        })
    }

    fn assign_upper_inner(&mut self, n: usize, upper: &[(usize, usize, f64)]) -> Result<(), MlcpError> {
        self.row_ptr.clear();
        self.row_ptr.resize(n + 1, 0);
        // Validation and counts; rows must start with their diagonal entry.
        let mut prev: Option<(usize, usize)> = None;
        let mut next_row = 0;
        for &(i, j, v) in upper {
            if i >= n || j >= n {
                return Err(MlcpError::EntryOutOfRange { row: i, col: j, n });
            }
            if !v.is_finite() {
                return Err(MlcpError::NonFiniteMatrix { row: i, col: j, value: v });
            }
            if j < i || prev.is_some_and(|p| p >= (i, j)) {
                return Err(MlcpError::NotUpperSorted { row: i, col: j });
            }
            if prev.is_none_or(|p| p.0 != i) {
                if i != next_row || j != i {
                    return Err(MlcpError::MissingDiagonal { index: next_row });
                }
                next_row += 1;
            }
            prev = Some((i, j));
            self.row_ptr[i + 1] += 1;
            if j != i {
                self.row_ptr[j + 1] += 1;
            }
        }
        if next_row != n {
            return Err(MlcpError::MissingDiagonal { index: next_row });
        }
        for i in 0..n {
            self.row_ptr[i + 1] += self.row_ptr[i];
        }
        let nnz = self.row_ptr[n];
        // Sized, not cleared: the counts above give every slot exactly one write below (zeroing
        // both arrays first was 4 % of the crane's step).
        self.col.truncate(nnz);
        self.col.resize(nnz, 0);
        self.val.truncate(nnz);
        self.val.resize(nnz, 0.0);
        self.next.clear();
        self.next.extend_from_slice(&self.row_ptr[..n]);
        for &(i, j, v) in upper {
            let k = self.next[i];
            (self.col[k], self.val[k]) = (j, v);
            self.next[i] += 1;
            if j != i {
                let k = self.next[j];
                (self.col[k], self.val[k]) = (i, v);
                self.next[j] += 1;
            }
        }
        self.n = n;
        self.check_diagonal()
    }

    /// A diagonal matrix.
    pub fn diagonal(d: &[f64]) -> Result<Self, MlcpError> {
        let t: Vec<_> = d.iter().enumerate().map(|(i, &v)| (i, i, v)).collect();
        Self::from_triplets(d.len(), &t)
    }

    fn check_diagonal(&self) -> Result<(), MlcpError> {
        for i in 0..self.n {
            let d = self.get(i, i);
            if d < 0.0 {
                return Err(MlcpError::NegativeDiagonal { index: i, value: d });
            }
        }
        Ok(())
    }

    /// Matrix size.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Stored entries (both triangles, diagonal always stored).
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// Column indices and values of row `i`, columns ascending.
    #[inline]
    pub fn row(&self, i: usize) -> (&[usize], &[f64]) {
        let r = self.row_ptr[i]..self.row_ptr[i + 1];
        (&self.col[r.clone()], &self.val[r])
    }

    /// Row pointers (`n + 1` entries).
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// Column indices of all rows, concatenated.
    pub fn col_indices(&self) -> &[usize] {
        &self.col
    }

    /// Values of all rows, concatenated.
    pub fn values(&self) -> &[f64] {
        &self.val
    }

    /// Entry `(i, j)` (zero when not stored).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (c, v) = self.row(i);
        c.binary_search(&j).map(|k| v[k]).unwrap_or(0.0)
    }

    /// `y = A x`.
    #[inline]
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        debug_assert!(x.len() == self.n && y.len() == self.n);
        for i in 0..self.n {
            let (c, v) = self.row(i);
            // Four independent accumulators: the serial sum would be latency-bound.
            let mut acc = [0.0f64; 4];
            let mut cc = c.chunks_exact(4);
            let mut vc = v.chunks_exact(4);
            for (cj, vj) in (&mut cc).zip(&mut vc) {
                acc[0] += vj[0] * x[cj[0]];
                acc[1] += vj[1] * x[cj[1]];
                acc[2] += vj[2] * x[cj[2]];
                acc[3] += vj[3] * x[cj[3]];
            }
            let mut tail = 0.0;
            for (&j, &a) in cc.remainder().iter().zip(vc.remainder()) {
                tail += a * x[j];
            }
            y[i] = (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail;
        }
    }

    /// Dense column-major copy (`out.len() == n²`; symmetric, so row- and column-major agree).
    pub fn to_dense(&self, out: &mut [f64]) {
        assert_eq!(out.len(), self.n * self.n);
        out.fill(0.0);
        for i in 0..self.n {
            let (c, v) = self.row(i);
            for (&j, &a) in c.iter().zip(v) {
                out[j * self.n + i] = a;
            }
        }
    }

    /// Copies the diagonal into `out` (resized to `n`).
    pub fn diagonal_into(&self, out: &mut Vec<f64>) {
        out.clear();
        out.extend((0..self.n).map(|i| self.get(i, i)));
    }

    /// Overwrites the (always stored) diagonal with `d`.
    pub fn set_diagonal(&mut self, d: &[f64]) {
        for (i, &di) in d.iter().enumerate().take(self.n) {
            let r = self.row_ptr[i]..self.row_ptr[i + 1];
            if let Ok(k) = self.col[r.clone()].binary_search(&i) {
                self.val[r.start + k] = di;
            }
        }
    }

    /// Largest diagonal entry (1 for an empty matrix).
    pub fn max_diag(&self) -> f64 {
        (0..self.n).map(|i| self.get(i, i)).fold(0.0, f64::max).max(if self.n == 0 { 1.0 } else { 0.0 })
    }

    /// Rebuilds `self` as `P A Pᵀ` for the permutation `perm` (`perm[new] = old`, `inv[old] = new`),
    /// reusing its buffers: no allocation once they have grown to the size of `a`. O(nnz): new columns are visited in increasing order and each entry is appended to its
    /// new row, so rows come out sorted without a sort (symmetry: column `perm[j]` of `A` is row
    /// `perm[j]`).
    pub fn permuted_from(&mut self, a: &SymCsr, perm: &[usize], inv: &[usize]) {
        let mut next = std::mem::take(&mut self.next);
        let n = a.n;
        self.n = n;
        let nnz = a.col.len();
        reserve_touched(&mut self.row_ptr, n + 1, 0);
        reserve_touched(&mut next, n, 0);
        reserve_touched(&mut self.col, nnz, 0);
        reserve_touched(&mut self.val, nnz, 0.0);
        reserve_touched(&mut self.src, nnz, 0);
        self.row_ptr.clear();
        self.row_ptr.push(0);
        let mut acc = 0;
        for &old in perm.iter().take(n) {
            acc += a.row_ptr[old + 1] - a.row_ptr[old];
            self.row_ptr.push(acc);
        }
        self.col.clear();
        self.col.resize(acc, 0);
        self.val.clear();
        self.val.resize(acc, 0.0);
        self.src.clear();
        self.src.resize(acc, 0);
        next.clear();
        next.extend_from_slice(&self.row_ptr[..n]);
        for (j, &old_col) in perm.iter().enumerate().take(n) {
            let base = a.row_ptr[old_col];
            let (rows, vals) = a.row(old_col);
            for (q, (&k, &v)) in rows.iter().zip(vals).enumerate() {
                let r = inv[k];
                let slot = next[r];
                self.col[slot] = j;
                // New entry (inv[k], j) is A[k][old_col] = A[old_col][k] (symmetric), stored at
                // position `base + q` of row `old_col`.
                self.val[slot] = v;
                self.src[slot] = base + q;
                next[r] = slot + 1;
            }
        }
        self.next = next;
    }

    /// After `permuted_from(a, …)` with a matrix of the same pattern as `a`: refreshes only the
    /// values (a gather through the stored source positions; O(nnz), no index work).
    pub fn refresh_permuted_values(&mut self, a: &SymCsr) {
        debug_assert_eq!(self.src.len(), a.val.len());
        for (v, &k) in self.val.iter_mut().zip(&self.src) {
            *v = a.val[k];
        }
    }

    /// Whether `self` and `other` have the same sparsity pattern.
    pub fn same_pattern(&self, other: &SymCsr) -> bool {
        self.n == other.n && self.row_ptr == other.row_ptr && self.col == other.col
    }

    /// Copies the pattern (not the values) of `other` into `self`, reusing buffers.
    pub fn copy_pattern_from(&mut self, other: &SymCsr) {
        self.n = other.n;
        reserve_touched(&mut self.row_ptr, other.row_ptr.len(), 0);
        reserve_touched(&mut self.col, other.col.len(), 0);
        self.row_ptr.clone_from(&other.row_ptr);
        self.col.clone_from(&other.col);
        self.val.clear();
    }
}

/// Makes room in `v` for `n` elements with headroom, pre-faulted: when its capacity is short it
/// grows to `n + n / 2` and writes `x` into the whole spare capacity, so that the memory is
/// touched now and later growth up to that capacity costs neither a reallocation nor page faults.
///
/// Why: an island's buffers grow when it does (a contact onset adds rows, paper Fig. 7), and
/// fresh pages fault on their first write — measured ~3 µs per 4 KiB page on this project's
/// VMs: on the crane's hook touching the pipe (341 → 376 rows, 9.0k → 10.3k non-zeros) the
/// symbolic phase took 240–400 µs instead of ~80, and the whole solve 545–965 µs instead of
/// ~350. With this headroom the first solve of an island pays for its growth up to 1.5×.
pub(crate) fn reserve_touched<T: Copy>(v: &mut Vec<T>, n: usize, x: T) {
    if v.capacity() >= n {
        return;
    }
    let want = n + n / 2;
    v.reserve_exact(want - v.len());
    for e in v.spare_capacity_mut() {
        e.write(x);
    }
}

fn check_symmetric(i: usize, j: usize, aij: f64, aji: f64, aii: f64, ajj: f64) -> Result<(), MlcpError> {
    let scale = (aii.abs() * ajj.abs()).sqrt().max(aij.abs()).max(aji.abs());
    if (aij - aji).abs() > SYMMETRY_TOL * scale {
        return Err(MlcpError::NotSymmetric { row: i, col: j, a_ij: aij, a_ji: aji });
    }
    Ok(())
}

/// Which side of its box a variable sits on in an index set (paper eq. 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
#[repr(u8)]
pub enum IndexState {
    /// `i ∈ F`: strictly inside its bounds, `w_i = 0`.
    #[default]
    Free = 0,
    /// `i ∈ T_lo`: at its lower bound.
    Lower = 1,
    /// `i ∈ T_hi`: at its upper bound.
    Upper = 2,
}

impl IndexState {
    /// Tight (`Lower` or `Upper`).
    #[inline]
    pub fn is_tight(self) -> bool {
        self != IndexState::Free
    }
}

/// A validated boxed MLCP with optional friction coupling and warm start. `Default` is the empty
/// problem, to be filled with [`Mlcp::assign`].
#[derive(Debug, Clone, Default)]
pub struct Mlcp {
    a: SymCsr,
    b: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    findex: Vec<Option<usize>>,
    nub: usize,
    lambda0: Option<Vec<f64>>,
    index0: Option<Vec<IndexState>>,
    /// Buffers of a cleared warm start, kept for reuse (not part of the value).
    spare: (Vec<f64>, Vec<IndexState>),
}

impl PartialEq for Mlcp {
    fn eq(&self, o: &Self) -> bool {
        self.a == o.a
            && self.b == o.b
            && self.lo == o.lo
            && self.hi == o.hi
            && self.findex == o.findex
            && self.nub == o.nub
            && self.lambda0 == o.lambda0
            && self.index0 == o.index0
    }
}

impl Mlcp {
    /// Validates and builds a problem. `findex[i] = Some(j)` couples friction row `i` to normal row `j`.
    pub fn new(
        a: SymCsr,
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        findex: Vec<Option<usize>>,
    ) -> Result<Self, MlcpError> {
        let nub = validate_vectors(a.n(), &b, &lo, &hi, &findex)?;
        Ok(Mlcp { a, b, lo, hi, findex, nub, ..Default::default() })
    }

    /// Rebuilds `self` in place (reusing every buffer: no allocation once they have grown), with
    /// the same validation as [`SymCsr::from_triplets`] and [`Mlcp::new`]; `triplets` is sorted in
    /// place. The warm start is cleared. On error `self` is left as an empty problem, never
    /// half-built.
    pub fn assign(
        &mut self,
        n: usize,
        triplets: &mut [(usize, usize, f64)],
        b: &[f64],
        lo: &[f64],
        hi: &[f64],
        findex: &[Option<usize>],
    ) -> Result<(), MlcpError> {
        self.assign_with(n, |a| a.assign_from_triplets(n, triplets), b, lo, hi, findex)
    }

    /// [`Mlcp::assign`] with `A` given by its sorted upper triangle ([`SymCsr::assign_from_upper`]).
    pub fn assign_upper(
        &mut self,
        n: usize,
        upper: &[(usize, usize, f64)],
        b: &[f64],
        lo: &[f64],
        hi: &[f64],
        findex: &[Option<usize>],
    ) -> Result<(), MlcpError> {
        self.assign_with(n, |a| a.assign_from_upper(n, upper), b, lo, hi, findex)
    }

    fn assign_with(
        &mut self,
        n: usize,
        fill_a: impl FnOnce(&mut SymCsr) -> Result<(), MlcpError>,
        b: &[f64],
        lo: &[f64],
        hi: &[f64],
        findex: &[Option<usize>],
    ) -> Result<(), MlcpError> {
        self.clear_warm_start();
        let result = fill_a(&mut self.a).and_then(|()| validate_vectors(n, b, lo, hi, findex));
        match result {
            Ok(nub) => {
                self.nub = nub;
                fill_from(&mut self.b, b);
                fill_from(&mut self.lo, lo);
                fill_from(&mut self.hi, hi);
                fill_from(&mut self.findex, findex);
                Ok(())
            }
            Err(e) => {
                let mut empty: [(usize, usize, f64); 0] = [];
                self.a.assign_from_triplets(0, &mut empty).expect("the empty matrix is valid");
                self.b.clear();
                self.lo.clear();
                self.hi.clear();
                self.findex.clear();
                self.nub = 0;
                Err(e)
            }
        }
    }

    /// In-place warm start (reusing buffers): an initial `λ` and/or index set, validated like
    /// [`Mlcp::with_warm_start`]; on error the warm start is cleared.
    pub fn set_warm_start(
        &mut self,
        lambda0: Option<&[f64]>,
        index0: Option<&[IndexState]>,
    ) -> Result<(), MlcpError> {
        let n = self.n();
        let check = || -> Result<(), MlcpError> {
            if let Some(l) = lambda0 {
                if l.len() != n {
                    return Err(MlcpError::DimensionMismatch {
                        what: "lambda0",
                        expected: n,
                        found: l.len(),
                    });
                }
                if let Some((i, &v)) = l.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                    return Err(MlcpError::NonFiniteVector { vector: "lambda0", index: i, value: v });
                }
            }
            if let Some(s) = index0
                && s.len() != n
            {
                return Err(MlcpError::DimensionMismatch { what: "index0", expected: n, found: s.len() });
            }
            Ok(())
        };
        let checked = check();
        self.clear_warm_start();
        checked?;
        if let Some(l) = lambda0 {
            let mut v = std::mem::take(&mut self.spare.0);
            fill_from(&mut v, l);
            self.lambda0 = Some(v);
        }
        if let Some(s) = index0 {
            let mut v = std::mem::take(&mut self.spare.1);
            fill_from(&mut v, s);
            self.index0 = Some(v);
        }
        Ok(())
    }

    /// Drops the warm start, keeping its buffers for the next one.
    fn clear_warm_start(&mut self) {
        if let Some(v) = self.lambda0.take() {
            self.spare.0 = v;
        }
        if let Some(v) = self.index0.take() {
            self.spare.1 = v;
        }
    }

    /// A copy of the problem without its warm start: the same problem solved cold.
    pub fn without_warm_start(&self) -> Mlcp {
        let mut cold = self.clone();
        cold.clear_warm_start();
        cold
    }

    /// Adds a warm start: an initial `λ` and/or an initial index set. Validated like the rest.
    pub fn with_warm_start(
        mut self,
        lambda0: Option<Vec<f64>>,
        index0: Option<Vec<IndexState>>,
    ) -> Result<Self, MlcpError> {
        let n = self.n();
        if let Some(l) = &lambda0 {
            if l.len() != n {
                return Err(MlcpError::DimensionMismatch { what: "lambda0", expected: n, found: l.len() });
            }
            if let Some((i, &v)) = l.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(MlcpError::NonFiniteVector { vector: "lambda0", index: i, value: v });
            }
        }
        if let Some(s) = &index0
            && s.len() != n
        {
            return Err(MlcpError::DimensionMismatch { what: "index0", expected: n, found: s.len() });
        }
        self.lambda0 = lambda0;
        self.index0 = index0;
        Ok(self)
    }

    /// Problem size `m`.
    pub fn n(&self) -> usize {
        self.a.n()
    }
    /// Number of leading unbounded rows (informational; the solver looks at the bounds).
    pub fn nub(&self) -> usize {
        self.nub
    }
    /// The matrix.
    pub fn a(&self) -> &SymCsr {
        &self.a
    }
    /// Right-hand side.
    pub fn b(&self) -> &[f64] {
        &self.b
    }
    /// Stored lower bounds (coefficients `−μ` for friction rows).
    pub fn lo(&self) -> &[f64] {
        &self.lo
    }
    /// Stored upper bounds (coefficients `μ` for friction rows).
    pub fn hi(&self) -> &[f64] {
        &self.hi
    }
    /// Friction index.
    pub fn findex(&self) -> &[Option<usize>] {
        &self.findex
    }
    /// Warm-start `λ`, if any.
    pub fn lambda0(&self) -> Option<&[f64]> {
        self.lambda0.as_deref()
    }
    /// Warm-start index set, if any.
    pub fn index0(&self) -> Option<&[IndexState]> {
        self.index0.as_deref()
    }
    /// Whether any row is friction-coupled.
    pub fn has_friction(&self) -> bool {
        self.findex.iter().any(Option::is_some)
    }

    /// True bounds of row `i` at impulses `λ` (friction rows scale with `max(λ_j, 0)`).
    #[inline]
    pub fn bounds_at(&self, i: usize, lambda: &[f64]) -> (f64, f64) {
        effective_bounds(self.lo[i], self.hi[i], self.findex[i], lambda)
    }

    /// `w = Aλ − b`.
    pub fn residual_velocity(&self, lambda: &[f64], w: &mut [f64]) {
        self.a.mul_vec(lambda, w);
        for (wi, bi) in w.iter_mut().zip(&self.b) {
            *wi -= bi;
        }
    }

    /// Natural-map residual `(‖r‖∞, ‖r‖∞/‖λ‖∞)` of `λ` against the true (final-normal-impulse)
    /// bounds. `w` is scratch of length `m`.
    pub fn natural_residual(&self, lambda: &[f64], w: &mut [f64]) -> (f64, f64) {
        self.residual_velocity(lambda, w);
        natural_residual(lambda, w, &self.lo, &self.hi, &self.findex)
    }
}

/// Checks `b`, the bounds and the friction index of an `n`-row problem; returns `nub`.
fn validate_vectors(
    n: usize,
    b: &[f64],
    lo: &[f64],
    hi: &[f64],
    findex: &[Option<usize>],
) -> Result<usize, MlcpError> {
    for (what, len) in [("b", b.len()), ("lo", lo.len()), ("hi", hi.len()), ("findex", findex.len())] {
        if len != n {
            return Err(MlcpError::DimensionMismatch { what, expected: n, found: len });
        }
    }
    for (i, &v) in b.iter().enumerate() {
        if !v.is_finite() {
            return Err(MlcpError::NonFiniteVector { vector: "b", index: i, value: v });
        }
    }
    for i in 0..n {
        let (l, h) = (lo[i], hi[i]);
        if l.is_nan() {
            return Err(MlcpError::NonFiniteVector { vector: "lo", index: i, value: l });
        }
        if h.is_nan() {
            return Err(MlcpError::NonFiniteVector { vector: "hi", index: i, value: h });
        }
        if l > h || l == f64::INFINITY || h == f64::NEG_INFINITY {
            return Err(MlcpError::EmptyBox { index: i, lo: l, hi: h });
        }
    }
    for i in 0..n {
        if let Some(j) = findex[i] {
            if j >= n || j == i {
                return Err(MlcpError::FindexOutOfRange { row: i, target: j as i64 });
            }
            if findex[j].is_some() {
                return Err(MlcpError::FindexToFrictionRow { row: i, target: j });
            }
            if !(lo[i].is_finite() && hi[i].is_finite() && lo[i] <= 0.0 && hi[i] >= 0.0) {
                return Err(MlcpError::FrictionCoefficients { row: i, lo: lo[i], hi: hi[i] });
            }
        }
    }
    Ok((0..n).take_while(|&i| lo[i] == f64::NEG_INFINITY && hi[i] == f64::INFINITY).count())
}

/// `dst = src`, reusing `dst`'s capacity.
fn fill_from<T: Clone>(dst: &mut Vec<T>, src: &[T]) {
    dst.clear();
    dst.extend_from_slice(src);
}

/// Effective bounds of a row given the stored bounds, its friction index and the impulses.
#[inline]
pub fn effective_bounds(lo: f64, hi: f64, findex: Option<usize>, lambda: &[f64]) -> (f64, f64) {
    match findex {
        None => (lo, hi),
        Some(j) => {
            let ln = lambda[j].max(0.0);
            (lo * ln, hi * ln)
        }
    }
}

/// Natural-map residual of `(λ, w)` with bounds evaluated at `λ`: `(‖r‖∞, ‖r‖∞ / ‖λ‖∞)`.
pub fn natural_residual(
    lambda: &[f64],
    w: &[f64],
    lo: &[f64],
    hi: &[f64],
    findex: &[Option<usize>],
) -> (f64, f64) {
    let mut r: f64 = 0.0;
    let mut norm: f64 = 0.0;
    for i in 0..lambda.len() {
        let (l, h) = effective_bounds(lo[i], hi[i], findex[i], lambda);
        let ri = lambda[i] - (lambda[i] - w[i]).max(l).min(h);
        // NaN must never look small.
        r = if ri.is_nan() { f64::INFINITY } else { r.max(ri.abs()) };
        norm = norm.max(lambda[i].abs());
    }
    (r, r / norm.max(1e-300))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spd2() -> SymCsr {
        SymCsr::from_dense_row_major(2, &[2.0, 1.0, 1.0, 2.0]).unwrap()
    }

    /// The upper-triangle path equals the general triplet path on random sparse symmetric
    /// matrices, and refuses entries below the diagonal, out of order, repeated, or a missing
    /// diagonal, leaving the matrix empty.
    #[test]
    fn upper_triangle_assignment_equals_the_triplet_path() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for n in [1usize, 2, 5, 40, 120] {
            let mut upper = Vec::new();
            for i in 0..n {
                upper.push((i, i, rng.random_range(1.0..2.0)));
                for j in i + 1..n {
                    if rng.random_range(0.0..1.0) < 0.2 {
                        upper.push((i, j, rng.random_range(-0.1..0.1)));
                    }
                }
            }
            let mut full: Vec<_> = upper.iter().flat_map(|&(i, j, v)| [(i, j, v), (j, i, v)]).collect();
            full.dedup();
            let reference = SymCsr::from_triplets(n, &full).unwrap();
            let mut a = SymCsr::default();
            a.assign_from_upper(n, &upper).unwrap();
            assert_eq!(a, reference, "n = {n}");
        }
        let mut a = SymCsr::default();
        let bad: [&[(usize, usize, f64)]; 4] = [
            &[(0, 0, 1.0), (1, 0, 0.5), (1, 1, 1.0)],
            &[(0, 0, 1.0), (0, 1, 0.5), (0, 1, 0.5), (1, 1, 1.0)],
            &[(0, 1, 0.5), (0, 0, 1.0), (1, 1, 1.0)],
            &[(0, 0, 1.0), (0, 1, 0.5)],
        ];
        for (k, t) in bad.iter().enumerate() {
            let e = a.assign_from_upper(2, t).unwrap_err();
            assert!(
                matches!(e, MlcpError::NotUpperSorted { .. } | MlcpError::MissingDiagonal { .. }),
                "case {k}: {e}"
            );
            assert_eq!(a.n(), 0);
        }
    }

    /// Reassigning over a held matrix (the values-only refill when the structure is the same)
    /// gives what a fresh build gives, errors included, for the same structure with new values,
    /// for another structure, and for every malformed list.
    #[test]
    fn reassignment_over_a_held_matrix_equals_a_fresh_build() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let fresh = |n: usize, upper: &[(usize, usize, f64)]| {
            let mut a = SymCsr::default();
            let r = a.assign_from_upper(n, upper);
            (a, r)
        };
        for n in [1usize, 3, 30, 90] {
            let mut upper = Vec::new();
            for i in 0..n {
                upper.push((i, i, 0.0));
                for j in i + 1..n {
                    if rng.random_range(0.0..1.0) < 0.3 {
                        upper.push((i, j, 0.0));
                    }
                }
            }
            let mut held = SymCsr::default();
            for round in 0..4 {
                for e in &mut upper {
                    e.2 = if e.0 == e.1 { rng.random_range(1.0..2.0) } else { rng.random_range(-0.1..0.1) };
                }
                held.assign_from_upper(n, &upper).unwrap();
                assert_eq!(held, fresh(n, &upper).0, "n = {n}, round {round}");
            }
            // Non-finite and negative values over the held structure: the fresh build's error.
            for (at, v) in [(upper.len() / 2, f64::NAN), (0, -1.0), (upper.len() - 1, f64::INFINITY)] {
                let mut bad = upper.clone();
                bad[at].2 = v;
                let mut h = held.clone();
                let got = h.assign_from_upper(n, &bad);
                let want = fresh(n, &bad).1;
                if v < 0.0 && bad[at].0 != bad[at].1 {
                    assert!(got.is_ok() && want.is_ok());
                } else {
                    // Compared as text: a NaN in the error is not equal to itself.
                    assert_eq!(format!("{got:?}"), format!("{want:?}"), "n = {n}: {v} at {at}");
                    assert_eq!(h.n(), 0, "emptied on error");
                }
            }
            // Another structure (one off-diagonal entry fewer), then back.
            if let Some(drop) = upper.iter().position(|e| e.0 != e.1) {
                let mut other = upper.clone();
                other.remove(drop);
                held.assign_from_upper(n, &other).unwrap();
                assert_eq!(held, fresh(n, &other).0);
                held.assign_from_upper(n, &upper).unwrap();
                assert_eq!(held, fresh(n, &upper).0);
            }
        }
        // Malformed lists with the held matrix's entry count: the fresh build's errors.
        let ok: &[(usize, usize, f64)] = &[(0, 0, 1.0), (0, 1, 0.5), (1, 1, 1.0)];
        let bad: [&[(usize, usize, f64)]; 4] = [
            &[(0, 0, 1.0), (1, 0, 0.5), (1, 1, 1.0)],
            &[(0, 1, 0.5), (0, 0, 1.0), (1, 1, 1.0)],
            &[(0, 0, 1.0), (1, 1, 1.0), (0, 1, 0.5)],
            &[(0, 0, 1.0), (0, 1, 0.5), (0, 1, 0.5)],
        ];
        for (k, t) in bad.iter().enumerate() {
            let mut held = SymCsr::default();
            held.assign_from_upper(2, ok).unwrap();
            let got = held.assign_from_upper(2, t);
            assert!(got.is_err(), "case {k}");
            assert_eq!(got, fresh(2, t).1, "case {k}");
            assert_eq!(held.n(), 0, "case {k}");
        }
    }

    #[test]
    fn dense_and_triplets_agree() {
        let d = SymCsr::from_dense_row_major(3, &[4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0]).unwrap();
        let t = SymCsr::from_triplets(
            3,
            &[(0, 0, 4.0), (0, 1, 1.0), (1, 0, 1.0), (1, 1, 3.0), (1, 2, 0.5), (2, 1, 0.5), (2, 2, 2.0)],
        )
        .unwrap();
        assert_eq!(d, t);
        let mut y = [0.0; 3];
        d.mul_vec(&[1.0, 2.0, 3.0], &mut y);
        assert_eq!(y, [6.0, 8.5, 7.0]);
    }

    #[test]
    fn malformed_matrices_are_typed_errors() {
        assert!(matches!(
            SymCsr::from_dense_row_major(2, &[1.0, 2.0, 3.0]),
            Err(MlcpError::DimensionMismatch { .. })
        ));
        assert!(matches!(
            SymCsr::from_dense_row_major(2, &[1.0, f64::NAN, f64::NAN, 1.0]),
            Err(MlcpError::NonFiniteMatrix { row: 0, col: 1, .. })
        ));
        assert!(matches!(
            SymCsr::from_dense_row_major(2, &[1.0, 0.5, 0.4, 1.0]),
            Err(MlcpError::NotSymmetric { row: 0, col: 1, .. })
        ));
        assert!(matches!(
            SymCsr::from_triplets(2, &[(0, 0, 1.0), (0, 1, 0.3), (1, 1, 1.0)]),
            Err(MlcpError::NotSymmetric { row: 0, col: 1, .. })
        ));
        assert!(matches!(
            SymCsr::from_triplets(2, &[(0, 0, 1.0), (0, 0, 1.0)]),
            Err(MlcpError::DuplicateEntry { row: 0, col: 0 })
        ));
        assert!(matches!(
            SymCsr::from_triplets(2, &[(0, 2, 1.0)]),
            Err(MlcpError::EntryOutOfRange { row: 0, col: 2, n: 2 })
        ));
        assert!(matches!(
            SymCsr::from_dense_row_major(2, &[-1.0, 0.0, 0.0, 1.0]),
            Err(MlcpError::NegativeDiagonal { index: 0, .. })
        ));
    }

    #[test]
    fn malformed_problems_are_typed_errors() {
        let inf = f64::INFINITY;
        let mk =
            |b: Vec<f64>, lo: Vec<f64>, hi: Vec<f64>, f: Vec<Option<usize>>| Mlcp::new(spd2(), b, lo, hi, f);
        assert!(matches!(
            mk(vec![1.0], vec![0.0; 2], vec![inf; 2], vec![None; 2]),
            Err(MlcpError::DimensionMismatch { what: "b", .. })
        ));
        assert!(matches!(
            mk(vec![1.0, f64::INFINITY], vec![0.0; 2], vec![inf; 2], vec![None; 2]),
            Err(MlcpError::NonFiniteVector { vector: "b", index: 1, .. })
        ));
        assert!(matches!(
            mk(vec![1.0; 2], vec![0.0, 2.0], vec![inf, 1.0], vec![None; 2]),
            Err(MlcpError::EmptyBox { index: 1, .. })
        ));
        assert!(matches!(
            mk(vec![1.0; 2], vec![0.0, f64::NAN], vec![inf; 2], vec![None; 2]),
            Err(MlcpError::NonFiniteVector { vector: "lo", index: 1, .. })
        ));
        assert!(matches!(
            mk(vec![1.0; 2], vec![0.0, -1.0], vec![inf, 1.0], vec![None, Some(5)]),
            Err(MlcpError::FindexOutOfRange { row: 1, target: 5 })
        ));
        assert!(matches!(
            mk(vec![1.0; 2], vec![0.0, -1.0], vec![inf, 1.0], vec![None, Some(1)]),
            Err(MlcpError::FindexOutOfRange { row: 1, target: 1 })
        ));
        assert!(matches!(
            mk(vec![1.0; 2], vec![-1.0, -1.0], vec![1.0, 1.0], vec![Some(1), Some(0)]),
            Err(MlcpError::FindexToFrictionRow { row: 0, target: 1 })
        ));
        assert!(matches!(
            mk(vec![1.0; 2], vec![0.0, -inf], vec![inf, 1.0], vec![None, Some(0)]),
            Err(MlcpError::FrictionCoefficients { row: 1, .. })
        ));
        let ok = mk(vec![1.0; 2], vec![0.0, -1.0], vec![inf, 1.0], vec![None, Some(0)]).unwrap();
        assert!(matches!(
            ok.clone().with_warm_start(Some(vec![0.0, f64::NAN]), None),
            Err(MlcpError::NonFiniteVector { vector: "lambda0", index: 1, .. })
        ));
        assert!(matches!(
            ok.with_warm_start(None, Some(vec![IndexState::Free])),
            Err(MlcpError::DimensionMismatch { what: "index0", .. })
        ));
    }

    #[test]
    fn residual_uses_final_normal_impulse() {
        // Row 1 is friction on row 0 with mu = 0.5.
        let p =
            Mlcp::new(spd2(), vec![3.0, 3.0], vec![0.0, -0.5], vec![f64::INFINITY, 0.5], vec![None, Some(0)])
                .unwrap();
        let mut w = [0.0; 2];
        // lambda_n = 1, friction at mu*lambda_n = 0.5 with w_1 = 1 + 1 - 3 = -1 <= 0: tight at upper is fine.
        // w_0 = 2 + 0.5 - 3 = -0.5: normal row not satisfied.
        let (r, _) = p.natural_residual(&[1.0, 0.5], &mut w);
        assert!((r - 0.5).abs() < 1e-15);
        // Exact solution: with the friction row at mu*ln, 2 ln + 0.5 ln = 3 gives ln = 1.2, lt = 0.6,
        // and w1 = 1.2 + 1.2 - 3 = -0.6 <= 0, as a row tight at its upper bound requires.
        let (r, rel) = p.natural_residual(&[1.2, 0.6], &mut w);
        assert!(r < 1e-14 && rel < 1e-14, "{r}");
    }

    /// `reserve_touched` grows a short buffer to 1.5× what is asked, keeps its contents and leaves
    /// a buffer with room alone.
    #[test]
    fn reserve_touched_grows_with_headroom_and_keeps_contents() {
        let mut v = vec![1.0, 2.0];
        reserve_touched(&mut v, 10, 0.0);
        assert_eq!(v, [1.0, 2.0]);
        assert!(v.capacity() >= 15, "capacity {}", v.capacity());
        let (ptr, cap) = (v.as_ptr(), v.capacity());
        reserve_touched(&mut v, 15, 0.0);
        v.resize(15, 3.0);
        assert_eq!((v.as_ptr(), v.capacity()), (ptr, cap), "growth within the headroom moved the buffer");
        assert_eq!(&v[..3], [1.0, 2.0, 3.0]);
    }

    /// An island that grows by up to half (a contact onset adds rows and entries) is permuted and
    /// its pattern copied into the buffers the smaller one left, with the same result as into
    /// fresh ones.
    #[test]
    fn a_grown_pattern_reuses_the_buffers_of_a_smaller_one() {
        // Tridiagonal n = 8, then n = 10 with an extra coupling (more entries per row too).
        let band = |n: usize, extra: bool| {
            let mut t: Vec<(usize, usize, f64)> = (0..n).map(|i| (i, i, 4.0)).collect();
            for i in 1..n {
                t.extend([(i, i - 1, -1.0), (i - 1, i, -1.0)]);
            }
            if extra {
                t.extend([(0, n - 1, 0.5), (n - 1, 0, 0.5)]);
            }
            SymCsr::from_triplets(n, &t).unwrap()
        };
        let (small, big) = (band(8, false), band(10, true));
        assert!(big.nnz() <= small.nnz() * 3 / 2 && big.n() <= small.n() * 3 / 2);
        let rev = |n: usize| -> (Vec<usize>, Vec<usize>) { ((0..n).rev().collect(), (0..n).rev().collect()) };
        let mut p = SymCsr::default();
        let mut pattern = SymCsr::default();
        let (perm, inv) = rev(8);
        p.permuted_from(&small, &perm, &inv);
        pattern.copy_pattern_from(&small);
        let ptrs =
            |m: &SymCsr| [m.row_ptr.as_ptr() as usize, m.col.as_ptr() as usize, m.val.as_ptr() as usize];
        let (before, pattern_before) = (ptrs(&p), ptrs(&pattern));
        let (src_before, next_before) = (p.src.as_ptr(), p.next.as_ptr());
        let (perm, inv) = rev(10);
        p.permuted_from(&big, &perm, &inv);
        pattern.copy_pattern_from(&big);
        assert_eq!(ptrs(&p), before, "the permuted copy reallocated");
        assert_eq!((p.src.as_ptr(), p.next.as_ptr()), (src_before, next_before));
        assert_eq!(ptrs(&pattern)[..2], pattern_before[..2], "the pattern copy reallocated");
        let mut fresh = SymCsr::default();
        fresh.permuted_from(&big, &perm, &inv);
        assert_eq!(p, fresh);
        assert!(pattern.same_pattern(&big));
    }

    #[test]
    fn permutation_round_trip() {
        let a = SymCsr::from_dense_row_major(3, &[4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0]).unwrap();
        let perm = [2, 0, 1];
        let inv = [1, 2, 0];
        let mut p = SymCsr::default();
        p.permuted_from(&a, &perm, &inv);
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(p.get(i, j), a.get(perm[i], perm[j]));
            }
        }
        // Same pattern, new values: refreshing the values equals a fresh permutation.
        let b = SymCsr::from_dense_row_major(3, &[5.0, 2.0, 0.0, 2.0, 6.0, -1.0, 0.0, -1.0, 7.0]).unwrap();
        assert!(b.same_pattern(&a));
        p.refresh_permuted_values(&b);
        let mut fresh = SymCsr::default();
        fresh.permuted_from(&b, &perm, &inv);
        assert_eq!(p, fresh);
    }

    #[test]
    fn missing_mirrors_get_a_stored_mirror() {
        // (0, 1) is given, its mirror is not (tiny value: within the symmetry tolerance).
        let a = SymCsr::from_triplets(2, &[(0, 0, 1.0), (1, 1, 1.0), (0, 1, 1e-14)]).unwrap();
        assert_eq!(a.row(0).0, &[0, 1]);
        assert_eq!(a.row(1).0, &[0, 1]);
        assert_eq!(a.get(0, 1), a.get(1, 0));
        // A permutation of it is consistent.
        let mut p = SymCsr::default();
        p.permuted_from(&a, &[1, 0], &[1, 0]);
        assert_eq!(p.get(1, 0), a.get(0, 1));
    }

    #[test]
    fn assign_rebuilds_in_place_and_empties_on_error() {
        let mut t = vec![(1, 0, 0.5), (0, 0, 2.0), (0, 1, 0.5), (1, 1, 2.0)];
        let mut p = Mlcp::default();
        p.assign(2, &mut t, &[1.0, 1.0], &[0.0, 0.0], &[f64::INFINITY; 2], &[None, None]).unwrap();
        let fresh = Mlcp::new(
            SymCsr::from_dense_row_major(2, &[2.0, 0.5, 0.5, 2.0]).unwrap(),
            vec![1.0, 1.0],
            vec![0.0, 0.0],
            vec![f64::INFINITY; 2],
            vec![None, None],
        )
        .unwrap();
        assert_eq!(p, fresh);
        p.set_warm_start(Some(&[0.1, 0.2]), Some(&[IndexState::Free, IndexState::Lower])).unwrap();
        assert_eq!(p.lambda0(), Some(&[0.1, 0.2][..]));
        assert!(p.set_warm_start(Some(&[f64::NAN, 0.0]), None).is_err());
        assert_eq!(p.lambda0(), None);
        // Bad input: typed error, and the problem is empty rather than half-built.
        let mut bad = vec![(0, 0, 1.0), (1, 1, f64::NAN)];
        let e = p.assign(2, &mut bad, &[1.0, 1.0], &[0.0; 2], &[1.0; 2], &[None, None]).unwrap_err();
        assert!(matches!(e, MlcpError::NonFiniteMatrix { row: 1, col: 1, .. }));
        assert_eq!(p.n(), 0);
        assert!(p.b().is_empty());
    }
}
