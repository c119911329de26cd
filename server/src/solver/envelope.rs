//! Envelope (skyline) Cholesky: storage of the envelope only, factorization from any row,
//! row/column deletion restricted to the skyline, and the triangular solves (paper §3.4, Alg. 3).
//!
//! **Structure.** Let `f_i = min{ j : A_ij ≠ 0 }` (row `i`'s first entry). Cholesky creates fill
//! only inside the row envelope `{(i, j) : f_i ≤ j ≤ i}`. We store the factor by columns: column `j`
//! holds rows `j ..= s_j` contiguously, with the *skyline*
//! `s_j = max{ i : f_i ≤ j }` (paper Fig. 6: the last non-zero row of column `j`). `s` is
//! non-decreasing, so the stored region is also contiguous by rows: row `i` spans columns
//! `g_i ..= i` with `g_i = min{ k : s_k ≥ i } = min_{p ≥ i} f_p`. Storage is `Σ_j (s_j − j + 1)`
//! entries instead of the paper's full `m × m` (its stated future work, §4.3).
//!
//! **Closure under deletion.** Deleting index `i` runs the rank-1 update of `dense.rs` with
//! `σ = L[i+1 ..= s_i, i]`. After processing column `k`, `σ` is non-zero at most up to
//! `max(s_i, …, s_k) = s_k ≤ s_{k+1}`, so the rotation at column `k+1` never writes outside
//! column `k+1`'s stored rows: the envelope of `L₀` holds every `L_FF` (the paper's remark that the
//! bandwidth never grows, §3.4). The sweep stops at the first `k > s_{k−1}` past `i` (a break of the
//! envelope, i.e. the end of a connected block) or at `m`.
//!
//! **Masked factorization.** `factor_from(c)` factors `M = A_FF ⊕ I_TT` (tight rows and columns
//! replaced by identity) in place, left-looking:
//! `L[j.., j] ← M[j.., j] − Σ_{k = g_j}^{j−1} L_jk L[j.., k]`, pivot, scale. Rows `0 .. c` of `L`
//! depend only on the leading block `M[0..c, 0..c]`; when the index set changes first at `c`, those
//! rows are kept and only rows `≥ c` are recomputed: columns `g_c .. c` below row `c`, then the
//! trailing columns. `c = 0` is a full refactor (`skyline-refactor`), `c > 0` is `incremental`.
//! Adjacent free columns `j, j + 1` are factored together (register blocking of the left-looking
//! update): each source column `k < j` is read once for both, two sources at a time, so a pass
//! over the rows does four multiply–adds per two loads and two stores of the targets instead of
//! one per load and store; then column `j + 1` takes its update from column `j`. Every entry
//! still takes its updates in the order of `k`, with the same zero multipliers skipped: the
//! factor is the column-by-column one to the bit (unit test), so no trajectory changes (its speed,
//! measured, in `docs/notes/solver.md`).
//!
//! **Solves (Alg. 3 CHOLSOLVE).** Forward `L y = r` as column axpys over `j+1 ..= s_j`, backward
//! `Lᵀ x = y` as dot products over the same ranges. Identity rows of tight indices pass a zero
//! right-hand side through unchanged, which is the paper's "skip tight indices".
//!
//! **Cost model** (for the `auto` variant). In stored-entry units: a deletion at `i` sweeps
//! `Σ_{k=i+1}^{reach(i)−1} (s_k − k)` entries (in `auto`, each column at least a fixed amount: its
//! rotation's square root and divisions, `bpp/factor.rs`); a refactor from `c` costs
//! `Σ_{j ≥ c} Σ_{k=g_j}^{j−1} (s_k − j + 1)` multiply–adds; a copy of the columns from `c` on
//! costs their storage. Prefix sums make each prediction O(1).

use super::SymCsr;
use super::dense::finish_column;

/// The envelope structure of a (reordered) symmetric matrix, plus cost-model prefix sums.
#[derive(Debug, Clone, Default)]
pub struct Envelope {
    m: usize,
    s: Vec<usize>,
    g: Vec<usize>,
    colptr: Vec<usize>,
    next_break: Vec<usize>,
    /// `Σ_{j<k} (s_j − j)`: sub-diagonal entries of columns before `k`.
    sub_cum: Vec<f64>,
    /// `Σ_{j<k}` left-looking multiply–adds of column `j`.
    fac_cum: Vec<f64>,
    /// Scratch of [`Envelope::solve`]: reciprocals of the diagonal.
    dinv: Vec<f64>,
}

impl Envelope {
    /// An empty structure; [`Envelope::build`] sizes it.
    pub fn new() -> Self {
        Self::default()
    }

    /// Computes the skyline of `a` (already in the order to be factored). Reuses buffers.
    pub fn build(&mut self, a: &SymCsr) {
        let m = a.n();
        self.m = m;
        // f_i: first column of row i (the diagonal is always stored, so f_i ≤ i).
        self.g.clear();
        self.g.extend((0..m).map(|i| a.row(i).0.first().copied().unwrap_or(i).min(i)));
        // s_j = max{ i : f_i ≤ j }: scatter each row to its first column, then prefix max.
        self.s.clear();
        self.s.extend(0..m);
        for i in 0..m {
            let f = self.g[i];
            if self.s[f] < i {
                self.s[f] = i;
            }
        }
        for j in 1..m {
            if self.s[j] < self.s[j - 1] {
                self.s[j] = self.s[j - 1];
            }
        }
        // g_i = min_{p ≥ i} f_p (suffix minimum).
        for i in (0..m.saturating_sub(1)).rev() {
            if self.g[i + 1] < self.g[i] {
                self.g[i] = self.g[i + 1];
            }
        }
        self.colptr.clear();
        self.colptr.push(0);
        let mut acc = 0;
        for j in 0..m {
            acc += self.s[j] - j + 1;
            self.colptr.push(acc);
        }
        // Breaks: k with s_{k-1} = k - 1 (no column before k reaches row k).
        self.next_break.clear();
        self.next_break.resize(m, m);
        let mut nb = m;
        for k in (0..m).rev() {
            self.next_break[k] = nb;
            if k > 0 && self.s[k - 1] == k - 1 {
                nb = k;
            }
        }
        // Cost prefix sums.
        self.sub_cum.clear();
        self.fac_cum.clear();
        self.sub_cum.push(0.0);
        self.fac_cum.push(0.0);
        for j in 0..m {
            self.sub_cum.push(self.sub_cum[j] + (self.s[j] - j) as f64);
        }
        // Per column j: Σ_{k=g_j}^{j-1} (s_k − j + 1). Computed with a running window over k.
        let mut window_sum = 0.0; // Σ_{k=g_j}^{j-1} s_k
        let mut lo = 0;
        for j in 0..m {
            let gj = self.g[j];
            while lo < gj {
                window_sum -= self.s[lo] as f64;
                lo += 1;
            }
            let cnt = (j - gj) as f64;
            let cost = window_sum - cnt * (j as f64 - 1.0) + (self.s[j] - j + 1) as f64;
            self.fac_cum.push(self.fac_cum[j] + cost.max(0.0));
            window_sum += self.s[j] as f64;
        }
    }

    /// Problem size.
    pub fn m(&self) -> usize {
        self.m
    }

    /// Stored entries (diagonal included).
    pub fn len(&self) -> usize {
        self.colptr.last().copied().unwrap_or(0)
    }

    /// Whether nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Largest `s_j − j`: the bandwidth of the stored envelope.
    pub fn bandwidth(&self) -> usize {
        (0..self.m).map(|j| self.s[j] - j).max().unwrap_or(0)
    }

    /// Skyline: last stored row of each column.
    pub fn skyline(&self) -> &[usize] {
        &self.s
    }

    /// Offset of entry `(p, j)` (`j ≤ p ≤ s_j`) in the value array.
    #[inline]
    pub fn index(&self, p: usize, j: usize) -> usize {
        debug_assert!(j <= p && p <= self.s[j]);
        self.colptr[j] + (p - j)
    }

    /// Entry `(p, j)` of a factor stored on this envelope (zero outside it).
    pub fn get(&self, l: &[f64], p: usize, j: usize) -> f64 {
        if j <= p && p <= self.s[j] { l[self.index(p, j)] } else { 0.0 }
    }

    /// Factors the masked matrix `A_FF ⊕ I_TT` into `l`, recomputing only rows `≥ c`
    /// (`c = 0`: full factorization). Rows `< c` of `l` must hold the factor of the same leading
    /// block. `tight[i]` marks `i ∈ T`. Returns the number of regularized pivots.
    pub fn factor_from(&self, a: &SymCsr, tight: &[bool], l: &mut [f64], c: usize, max_diag: f64) -> usize {
        let m = self.m;
        assert!(l.len() >= self.len() && tight.len() >= m && a.n() == m);
        if c >= m {
            return 0;
        }
        let mut regularized = 0;
        let mut j = self.g[c].min(c);
        while j < m {
            if j >= c && j + 1 < m && !tight[j] && !tight[j + 1] && self.s[j] > j {
                regularized += self.factor_pair(a, tight, l, j, max_diag);
                j += 2;
            } else {
                regularized += self.factor_column(a, tight, l, c, j, max_diag);
                j += 1;
            }
        }
        regularized
    }

    /// Column `j` of [`Envelope::factor_from`] alone: the left-looking update from every free
    /// column before it, then the pivot (or, for `j < c`, only its rows `≥ c`, scaled by the
    /// kept pivot).
    #[inline]
    fn factor_column(
        &self,
        a: &SymCsr,
        tight: &[bool],
        l: &mut [f64],
        c: usize,
        j: usize,
        max_diag: f64,
    ) -> usize {
        let r0 = j.max(c);
        let sj = self.s[j];
        if sj < r0 {
            return 0;
        }
        let col = self.colptr[j];
        let (left, right) = l.split_at_mut(col);
        let diag = right[0];
        let seg = &mut right[r0 - j..=sj - j];
        seg.fill(0.0);
        if tight[j] {
            if j >= c {
                seg[0] = 1.0;
            }
            return 0;
        }
        let a_jj = scatter_row(a, tight, j, r0, seg);
        for k in self.g[j]..j {
            if tight[k] {
                continue;
            }
            let sk = self.s[k];
            if sk < r0 {
                continue;
            }
            let ck = self.colptr[k];
            let ljk = left[ck + (j - k)];
            if ljk == 0.0 {
                continue;
            }
            let src = &left[ck + (r0 - k)..=ck + (sk - k)];
            for (x, &y) in seg[..src.len()].iter_mut().zip(src) {
                *x -= ljk * y;
            }
        }
        if j >= c {
            finish_column(seg, a_jj, max_diag)
        } else {
            let inv = 1.0 / diag;
            for x in seg.iter_mut() {
                *x *= inv;
            }
            0
        }
    }

    /// Free columns `j` and `j + 1` (`j ≥ c`, `s_j > j`) together: each source column `k < j` is
    /// read once for both targets, and two sources at a time (`update_2x2`); then column `j + 1`'s
    /// update from column `j`. Every entry still takes its updates in the order of `k`, with the
    /// same zero multipliers skipped, so the factor is the same to the bit as column by column.
    fn factor_pair(&self, a: &SymCsr, tight: &[bool], l: &mut [f64], j: usize, max_diag: f64) -> usize {
        let j1 = j + 1;
        let (sj, sj1) = (self.s[j], self.s[j1]);
        let (left, right) = l.split_at_mut(self.colptr[j]);
        let (cj, rest) = right.split_at_mut(sj - j + 1);
        let cj1 = &mut rest[..sj1 - j1 + 1];
        cj.fill(0.0);
        cj1.fill(0.0);
        let a_jj = scatter_row(a, tight, j, j, cj);
        let a_j1 = scatter_row(a, tight, j1, j1, cj1);
        // A source column with both multipliers non-zero waits for a second one: two sources
        // times two targets per pass over the rows.
        let mut held: Option<(f64, f64, usize, usize)> = None;
        for k in self.g[j]..j {
            if tight[k] {
                continue;
            }
            let sk = self.s[k];
            let ck = self.colptr[k];
            let x = left[ck + (j - k)];
            let y = if sk > j { left[ck + (j1 - k)] } else { 0.0 };
            // Column k's rows j + 1 ..= s_k.
            let at = ck + (j1 - k);
            let n = sk - j;
            if x != 0.0 && y != 0.0 {
                match held.take() {
                    None => held = Some((x, y, at, n)),
                    Some((x0, y0, at0, n0)) => {
                        cj[0] -= x0 * x0;
                        cj[0] -= x * x;
                        update_2x2(&mut cj[1..], cj1, left, (x0, y0, at0, n0), (x, y, at, n));
                    }
                }
                continue;
            }
            if let Some((x0, y0, at0, n0)) = held.take() {
                cj[0] -= x0 * x0;
                update_1x2(&mut cj[1..=n0], &mut cj1[..n0], x0, y0, &left[at0..at0 + n0]);
            }
            let src = &left[at..at + n];
            if x != 0.0 {
                cj[0] -= x * x;
                axpy(&mut cj[1..=n], x, src);
            } else if y != 0.0 {
                axpy(&mut cj1[..n], y, src);
            }
        }
        if let Some((x0, y0, at0, n0)) = held {
            cj[0] -= x0 * x0;
            update_1x2(&mut cj[1..=n0], &mut cj1[..n0], x0, y0, &left[at0..at0 + n0]);
        }
        let mut reg = finish_column(cj, a_jj, max_diag);
        let y = cj[1];
        if y != 0.0 {
            let n = sj - j;
            let tj1 = &mut cj1[..n];
            let src = &cj[1..=n];
            for r in 0..n {
                tj1[r] -= y * src[r];
            }
        }
        reg += finish_column(cj1, a_j1, max_diag);
        reg
    }

    /// Deletes row and column `i` from the factor `l` in place (it becomes an identity row and
    /// column). `sigma` is scratch of length `m` that must be zero on entry and is zero on exit.
    /// Returns the number of stored entries the sweep touched.
    pub fn delete(&self, l: &mut [f64], i: usize, sigma: &mut [f64]) -> usize {
        self.delete_before(l, i, sigma, self.m)
    }

    /// [`Self::delete`] that updates only the columns before `end`: when every index from `end`
    /// on is deleted too (tight), their values do not matter — each becomes an identity row and
    /// column at its own deletion — so the sweep stops there (a trailing tight block costs no
    /// rank-1 updates at all). The factor's free columns are the same as with [`Self::delete`].
    pub fn delete_before(&self, l: &mut [f64], i: usize, sigma: &mut [f64], end: usize) -> usize {
        self.sweep(l, i, sigma, end, |_| false)
    }

    /// [`Self::delete_before`] that also skips the columns of the indices still to be deleted
    /// (`pending[k]`, `k > i`). Why that is exact: with `F` the free and `T` the tight indices,
    /// `A_FF = L̃ L̃ᵀ + Σ_{t∈T} x_t x_tᵀ`, where `L̃` is `L₀` restricted to rows and columns `F`
    /// (lower triangular) and `x_t` is column `t` of `L₀` restricted to rows `F`. So `chol(A_FF)` is
    /// `L̃` after one rank-1 update per tight `t`, in any order, each rotating only through the
    /// columns of `F`: a pending column is never rotated, and stays the `x_t` its own deletion
    /// needs; what the rotations leave in a pending row is overwritten when that row is deleted
    /// (rows do not mix under column rotations). Deleting every tight index this way, each
    /// sequential deletion's rotations through the columns of later tight indices are saved.
    /// Columns already deleted (identity, zero rows) may be marked or not: their rotation is the
    /// identity.
    pub fn delete_pending(
        &self,
        l: &mut [f64],
        i: usize,
        sigma: &mut [f64],
        end: usize,
        pending: &[bool],
    ) -> usize {
        self.sweep(l, i, sigma, end, |k| pending[k])
    }

    /// The deletion sweep of row and column `i`, rotating through the columns after `i` except
    /// those `skip` names (their entry of the swept vector is dropped).
    #[inline]
    fn sweep(
        &self,
        l: &mut [f64],
        i: usize,
        sigma: &mut [f64],
        end: usize,
        skip: impl Fn(usize) -> bool,
    ) -> usize {
        let m = self.m.min(end.max(i + 1));
        let si = self.s[i];
        let ci = self.colptr[i];
        sigma[i + 1..=si].copy_from_slice(&l[ci + 1..=ci + (si - i)]);
        l[ci + 1..=ci + (si - i)].fill(0.0);
        l[ci] = 1.0;
        for k in self.g[i]..i {
            l[self.colptr[k] + (i - k)] = 0.0;
        }
        let mut hi = si;
        let mut touched = 0;
        let mut k = i + 1;
        while k <= hi && k < m {
            let sk_val = sigma[k];
            sigma[k] = 0.0;
            if sk_val != 0.0 && !skip(k) {
                let s_k = self.s[k];
                let ck = self.colptr[k];
                let col = &mut l[ck..=ck + (s_k - k)];
                let lkk = col[0];
                let r = (lkk * lkk + sk_val * sk_val).sqrt();
                let c = r / lkk;
                let s = sk_val / lkk;
                col[0] = r;
                let (cinv, sc) = (1.0 / c, s / c);
                for (x, w) in col[1..].iter_mut().zip(&mut sigma[k + 1..=s_k]) {
                    let nx = *x * cinv + sc * *w;
                    *w = c * *w - s * nx;
                    *x = nx;
                }
                touched += s_k - k;
                if s_k > hi {
                    hi = s_k;
                }
            }
            k += 1;
        }
        // Columns from `end` on were not swept: clear what the sweep would have consumed there.
        if k <= hi && k < self.m {
            sigma[k..=hi.min(self.m - 1)].fill(0.0);
        }
        touched
    }

    /// Solves `L Lᵀ x = x` in place. The reciprocals of the diagonal are formed first, all at
    /// once (independent divisions pipeline), so that the two sweeps multiply instead of sitting on
    /// a division per column; the back sweep's dot products use four accumulators.
    pub fn solve(&mut self, l: &[f64], x: &mut [f64]) {
        let m = self.m;
        self.dinv.clear();
        self.dinv.extend(self.colptr[..m].iter().map(|&c| 1.0 / l[c]));
        for j in 0..m {
            let c = self.colptr[j];
            let xj = x[j] * self.dinv[j];
            x[j] = xj;
            if xj != 0.0 {
                let sj = self.s[j];
                for (xp, &lp) in x[j + 1..=sj].iter_mut().zip(&l[c + 1..=c + (sj - j)]) {
                    *xp -= lp * xj;
                }
            }
        }
        for j in (0..m).rev() {
            let c = self.colptr[j];
            let sj = self.s[j];
            let acc = x[j] - dot(&x[j + 1..=sj], &l[c + 1..=c + (sj - j)]);
            x[j] = acc * self.dinv[j];
        }
    }

    /// First stored column of row `i` (`g_i`): deleting `i` writes no column before it.
    #[inline]
    pub fn first_column_of_row(&self, i: usize) -> usize {
        if i >= self.m { self.m } else { self.g[i] }
    }

    /// Copies the columns `c..m` of `src` into `dst` (columns before `c` are assumed equal).
    pub fn copy_from_column(&self, src: &[f64], dst: &mut [f64], c: usize) {
        let start = self.colptr[c.min(self.m)];
        let end = self.len();
        dst[start..end].copy_from_slice(&src[start..end]);
    }

    /// First stored offset of column `c` (the copy of columns `c..` starts here).
    pub fn column_offset(&self, c: usize) -> usize {
        self.colptr[c.min(self.m)]
    }

    /// Predicted sweep length (stored entries) of deleting index `i`.
    #[inline]
    pub fn cost_delete(&self, i: usize) -> f64 {
        self.cost_delete_before(i, self.m)
    }

    /// Predicted sweep length of [`Self::delete_before`]`(i, end)`.
    #[inline]
    pub fn cost_delete_before(&self, i: usize, end: usize) -> f64 {
        let reach = self.next_break[i].min(end.max(i + 1)).min(self.m);
        self.sub_cum[reach] - self.sub_cum[(i + 1).min(reach)]
    }

    /// Prefix sums of the stored entries below the diagonal of the columns not marked in
    /// `pending`, each column counted as at least `per_column` (`out[k]`: columns `< k`), for
    /// [`Self::cost_delete_pending`]. Reuses `out`.
    pub fn free_column_sums(&self, pending: &[bool], per_column: f64, out: &mut Vec<f64>) {
        out.clear();
        out.push(0.0);
        for j in 0..self.m {
            let below = if pending[j] { 0.0 } else { ((self.s[j] - j) as f64).max(per_column) };
            out.push(out[j] + below);
        }
    }

    /// Predicted sweep length of [`Self::delete_pending`]`(i, end)`, given the sums
    /// [`Self::free_column_sums`] of the same `pending`.
    #[inline]
    pub fn cost_delete_pending(&self, i: usize, end: usize, free_sums: &[f64]) -> f64 {
        let reach = self.next_break[i].min(end.max(i + 1)).min(self.m);
        free_sums[reach] - free_sums[(i + 1).min(reach)]
    }

    /// Predicted multiply–adds of `factor_from(c)`.
    #[inline]
    pub fn cost_factor_from(&self, c: usize) -> f64 {
        let c = c.min(self.m);
        self.fac_cum[self.m] - self.fac_cum[c]
    }

    /// Stored entries copied by `copy_from_column(c)`.
    #[inline]
    pub fn cost_copy_from(&self, c: usize) -> f64 {
        (self.len() - self.column_offset(c)) as f64
    }

    /// `‖L_a − L_b‖_F` over the envelope.
    pub fn frobenius_diff(&self, a: &[f64], b: &[f64]) -> f64 {
        let n = self.len();
        a[..n].iter().zip(&b[..n]).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
    }

    /// Backward error `‖L Lᵀ − M‖_F / ‖M‖_F` (lower triangles) of a factor `l` of the masked
    /// matrix `M = A_FF ⊕ I_TT`. Unlike the distance between two factors (which grows with the
    /// condition number of `M` for *any* pair of stable factorizations), this measures the
    /// stability of the process that produced `l`.
    pub fn backward_error(&self, a: &SymCsr, tight: &[bool], l: &[f64]) -> f64 {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for j in 0..self.m {
            for p in j..=self.s[j] {
                // (L Lᵀ)_pj = Σ_k L_pk L_jk over k ∈ [g_p, j] (g is monotone: g_p ≥ g_j).
                let mut acc = 0.0;
                for k in self.g[p]..=j {
                    acc += l[self.colptr[k] + (p - k)] * l[self.colptr[k] + (j - k)];
                }
                let mpj = if tight[p] || tight[j] { if p == j { 1.0 } else { 0.0 } } else { a.get(p, j) };
                num += (acc - mpj) * (acc - mpj);
                den += mpj * mpj;
            }
        }
        (num / den.max(f64::MIN_POSITIVE)).sqrt()
    }

    /// `‖L‖_F` over the envelope.
    pub fn frobenius(&self, a: &[f64]) -> f64 {
        a[..self.len()].iter().map(|x| x * x).sum::<f64>().sqrt()
    }
}

/// `x ← x − a·y` over `x`'s length.
#[inline(always)]
fn axpy(x: &mut [f64], a: f64, y: &[f64]) {
    let n = x.len();
    let y = &y[..n];
    for r in 0..n {
        x[r] -= a * y[r];
    }
}

/// One source column `v` into two targets: `t ← t − x·v`, `u ← u − y·v` (`t`, `u`, `v` of one
/// length).
#[inline(always)]
fn update_1x2(t: &mut [f64], u: &mut [f64], x: f64, y: f64, v: &[f64]) {
    let n = v.len();
    let (t, u) = (&mut t[..n], &mut u[..n]);
    for r in 0..n {
        let w = v[r];
        t[r] -= x * w;
        u[r] -= y * w;
    }
}

/// Two source columns `(x, y, offset, length)` in the order of `k` (the first no longer) into
/// two targets `t` (multipliers `x`) and `u` (`y`): each entry takes the first source's update,
/// then the second's, as one at a time would.
#[inline(always)]
fn update_2x2(
    t: &mut [f64],
    u: &mut [f64],
    l: &[f64],
    (x0, y0, at0, n0): (f64, f64, usize, usize),
    (x1, y1, at1, n1): (f64, f64, usize, usize),
) {
    debug_assert!(n0 <= n1);
    let v0 = &l[at0..at0 + n0];
    let v1 = &l[at1..at1 + n0];
    {
        let (t, u) = (&mut t[..n0], &mut u[..n0]);
        for r in 0..n0 {
            let (a, b) = (v0[r], v1[r]);
            t[r] = (t[r] - x0 * a) - x1 * b;
            u[r] = (u[r] - y0 * a) - y1 * b;
        }
    }
    update_1x2(&mut t[n0..n1], &mut u[n0..n1], x1, y1, &l[at1 + n0..at1 + n1]);
}

/// Row `j` of `a` (its entries in columns `≥ r0`, free ones) into `seg` (row `r0` first); returns
/// `a_jj`.
#[inline]
fn scatter_row(a: &SymCsr, tight: &[bool], j: usize, r0: usize, seg: &mut [f64]) -> f64 {
    let (cols, vals) = a.row(j);
    let mut a_jj = 0.0;
    // From the last column back to the first below `min(j, r0) = j`: the upper half of the row
    // is never read (it was 21 % of the factor's instructions on the crane).
    for (&p, &v) in cols.iter().zip(vals).rev() {
        if p < j {
            break;
        }
        if p == j {
            a_jj = v;
        }
        if p >= r0 && !tight[p] {
            seg[p - r0] = v;
        }
    }
    a_jj
}

/// Dot product with four independent accumulators (the serial sum is latency-bound).
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 4];
    let mut ca = a.chunks_exact(4);
    let mut cb = b.chunks_exact(4);
    for (x, y) in (&mut ca).zip(&mut cb) {
        acc[0] += x[0] * y[0];
        acc[1] += x[1] * y[1];
        acc[2] += x[2] * y[2];
        acc[3] += x[3] * y[3];
    }
    let mut tail = 0.0;
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        tail += x * y;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::dense;
    use nalgebra::DMatrix;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random SPD matrix with a variable band: row i couples to a few columns in [i − bw, i).
    fn random_banded(n: usize, bw: usize, density: f64, rng: &mut ChaCha8Rng) -> (SymCsr, DMatrix<f64>) {
        let mut d = DMatrix::<f64>::zeros(n, n);
        for i in 0..n {
            for j in i.saturating_sub(bw)..i {
                if rng.random_range(0.0..1.0) < density {
                    let v = rng.random_range(-1.0..1.0);
                    d[(i, j)] = v;
                    d[(j, i)] = v;
                }
            }
        }
        for i in 0..n {
            let row: f64 = (0..n).filter(|&j| j != i).map(|j| d[(i, j)].abs()).sum();
            d[(i, i)] = row + rng.random_range(0.1..2.0);
        }
        let rm: Vec<f64> = d.transpose().as_slice().to_vec();
        (SymCsr::from_dense_row_major(n, &rm).unwrap(), d)
    }

    fn dense_of(env: &Envelope, l: &[f64]) -> DMatrix<f64> {
        DMatrix::from_fn(env.m(), env.m(), |p, j| env.get(l, p, j))
    }

    fn masked_reference(a: &DMatrix<f64>, tight: &[bool]) -> DMatrix<f64> {
        let n = a.nrows();
        let free: Vec<usize> = (0..n).filter(|&i| !tight[i]).collect();
        let aff = DMatrix::from_fn(free.len(), free.len(), |p, q| a[(free[p], free[q])]);
        let lff = aff.cholesky().unwrap().l();
        let mut r = DMatrix::<f64>::identity(n, n);
        for (p, &fp) in free.iter().enumerate() {
            for (q, &fq) in free.iter().enumerate() {
                r[(fp, fq)] = lff[(p, q)];
            }
        }
        r
    }

    #[test]
    fn skyline_is_monotone_and_holds_the_factor() {
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        for (n, bw) in [(1, 0), (5, 2), (50, 4), (200, 12)] {
            let (a, d) = random_banded(n, bw, 0.5, &mut rng);
            let mut env = Envelope::new();
            env.build(&a);
            let s = env.skyline();
            assert!(s.windows(2).all(|w| w[0] <= w[1]));
            assert!((0..n).all(|j| s[j] >= j && s[j] < n));
            let mut l = vec![0.0; env.len()];
            assert_eq!(env.factor_from(&a, &vec![false; n], &mut l, 0, a.max_diag()), 0);
            let reference = d.clone().cholesky().unwrap().l();
            // Every non-zero of the true factor lies inside the envelope, and values agree.
            let err = (dense_of(&env, &l) - &reference).norm() / reference.norm();
            assert!(err < 1e-13, "n={n} err={err}");
            assert!(env.len() <= n * (n + 1) / 2);
        }
    }

    #[test]
    fn envelope_matches_dense_cholesky() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (a, d) = random_banded(120, 9, 0.7, &mut rng);
        let mut env = Envelope::new();
        env.build(&a);
        let mut l = vec![0.0; env.len()];
        env.factor_from(&a, &[false; 120], &mut l, 0, a.max_diag());
        let mut ld = d.as_slice().to_vec();
        dense::cholesky_in_place(&mut ld, 120, a.max_diag());
        for j in 0..120 {
            for p in j..120 {
                assert!((env.get(&l, p, j) - ld[j * 120 + p]).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn deletions_on_the_skyline_match_refactor_of_a_ff() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        for (n, bw) in [(10, 3), (60, 6), (250, 15)] {
            let (a, d) = random_banded(n, bw, 0.6, &mut rng);
            let mut env = Envelope::new();
            env.build(&a);
            let mut l0 = vec![0.0; env.len()];
            env.factor_from(&a, &vec![false; n], &mut l0, 0, a.max_diag());
            for frac in [0.02, 0.1, 0.3, 0.7] {
                let tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < frac).collect();
                let mut l = l0.clone();
                let mut sigma = vec![0.0; n];
                for i in (0..n).filter(|&i| tight[i]) {
                    env.delete(&mut l, i, &mut sigma);
                    assert!(sigma.iter().all(|&x| x == 0.0));
                }
                let reference = masked_reference(&d, &tight);
                let err = (dense_of(&env, &l) - &reference).norm() / reference.norm();
                assert!(err < 1e-12, "n={n} frac={frac} err={err}");
                // Refactor of the masked matrix gives the same factor.
                let mut lr = vec![0.0; env.len()];
                env.factor_from(&a, &tight, &mut lr, 0, a.max_diag());
                let err = (dense_of(&env, &lr) - &reference).norm() / reference.norm();
                assert!(err < 1e-13, "refactor n={n} frac={frac} err={err}");
            }
        }
    }

    /// `delete_before(end)` with `end` one past the last free index (a trailing tight block, and
    /// tight indices scattered before it) gives the factor of `A_FF ⊕ I` like a refactor.
    #[test]
    fn deletions_stop_at_the_last_free_index() {
        let mut rng = ChaCha8Rng::seed_from_u64(14);
        for (n, bw) in [(12, 3), (90, 8), (200, 20)] {
            let (a, d) = random_banded(n, bw, 0.6, &mut rng);
            let mut env = Envelope::new();
            env.build(&a);
            let mut l0 = vec![0.0; env.len()];
            env.factor_from(&a, &vec![false; n], &mut l0, 0, a.max_diag());
            for (frac, tail) in [(0.1, n / 3), (0.3, n / 10), (0.0, n / 2), (0.5, 1)] {
                let mut tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < frac).collect();
                tight[n - tail - 1] = false;
                tight[n - tail..].fill(true);
                let end = n - tail;
                let mut l = l0.clone();
                let mut sigma = vec![0.0; n];
                let (mut swept, mut swept_all) = (0, 0);
                for i in (0..n).filter(|&i| tight[i]) {
                    swept += env.delete_before(&mut l, i, &mut sigma, end);
                    assert!(sigma.iter().all(|&x| x == 0.0), "n={n}: sigma left dirty");
                }
                let mut la = l0.clone();
                for i in (0..n).filter(|&i| tight[i]) {
                    swept_all += env.delete(&mut la, i, &mut sigma);
                }
                let reference = masked_reference(&d, &tight);
                let err = (dense_of(&env, &l) - &reference).norm() / reference.norm();
                assert!(err < 1e-12, "n={n} frac={frac} tail={tail} err={err}");
                // The last column has nothing below its diagonal: a tail of one saves nothing.
                assert!(
                    swept < swept_all || (tail == 1 && swept == swept_all),
                    "n={n} tail={tail}: swept {swept}, full sweeps {swept_all}"
                );
            }
        }
    }

    /// Deleting every tight index with the pending ones' columns skipped gives the same factor as
    /// the sequential deletions and the refactor, with fewer stored entries swept.
    #[test]
    fn deletions_that_skip_pending_columns_match_refactor() {
        let mut rng = ChaCha8Rng::seed_from_u64(15);
        for (n, bw) in [(12, 3), (90, 8), (220, 25)] {
            let (a, d) = random_banded(n, bw, 0.6, &mut rng);
            let mut env = Envelope::new();
            env.build(&a);
            let mut l0 = vec![0.0; env.len()];
            env.factor_from(&a, &vec![false; n], &mut l0, 0, a.max_diag());
            for frac in [0.05, 0.3, 0.6] {
                let tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < frac).collect();
                let end = tight.iter().rposition(|&t| !t).map_or(0, |f| f + 1);
                let mut sigma = vec![0.0; n];
                let (mut l, mut ls) = (l0.clone(), l0.clone());
                let (mut swept, mut swept_seq) = (0, 0);
                for i in (0..n).filter(|&i| tight[i]) {
                    swept += env.delete_pending(&mut l, i, &mut sigma, end, &tight);
                    assert!(sigma.iter().all(|&x| x == 0.0), "n={n}: sigma left dirty");
                    swept_seq += env.delete_before(&mut ls, i, &mut sigma, end);
                }
                let reference = masked_reference(&d, &tight);
                let err = (dense_of(&env, &l) - &reference).norm() / reference.norm();
                assert!(err < 1e-12, "n={n} frac={frac} err={err}");
                // The cost model bounds what the sweeps touched.
                let mut sums = Vec::new();
                env.free_column_sums(&tight, 0.0, &mut sums);
                let predicted: f64 =
                    (0..n).filter(|&i| tight[i]).map(|i| env.cost_delete_pending(i, end, &sums)).sum();
                assert!(
                    swept as f64 <= predicted + 1e-9,
                    "n={n} frac={frac}: swept {swept} > predicted {predicted}"
                );
                assert!(swept <= swept_seq, "n={n} frac={frac}: swept {swept}, sequential {swept_seq}");
                if n >= 90 && frac >= 0.3 {
                    assert!(swept < swept_seq, "n={n} frac={frac}: swept {swept}, sequential {swept_seq}");
                }
            }
        }
    }

    #[test]
    fn deletion_order_does_not_matter_and_later_deletions_extend_earlier_ones() {
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let n = 80;
        let (a, d) = random_banded(n, 7, 0.8, &mut rng);
        let mut env = Envelope::new();
        env.build(&a);
        let mut l = vec![0.0; env.len()];
        env.factor_from(&a, &[false; 80], &mut l, 0, a.max_diag());
        let mut sigma = vec![0.0; n];
        let mut tight = vec![false; n];
        for &i in &[70, 3, 41, 40, 79, 0] {
            env.delete(&mut l, i, &mut sigma);
            tight[i] = true;
            let reference = masked_reference(&d, &tight);
            let err = (dense_of(&env, &l) - &reference).norm() / reference.norm();
            assert!(err < 1e-12, "after deleting {i}: err={err}");
        }
    }

    /// The left-looking factor one column at a time, one source column at a time (what
    /// `factor_from` computed before it paired columns), from `c` on.
    fn factor_column_by_column(env: &Envelope, a: &SymCsr, tight: &[bool], l: &mut [f64], c: usize) {
        let m = env.m();
        let (s, max_diag) = (env.skyline(), a.max_diag());
        for j in env.first_column_of_row(c).min(c)..m {
            let r0 = j.max(c);
            if s[j] < r0 {
                continue;
            }
            let mut seg = vec![0.0; s[j] - r0 + 1];
            if tight[j] {
                if j >= c {
                    seg[0] = 1.0;
                }
            } else {
                for p in r0..=s[j] {
                    if !tight[p] {
                        seg[p - r0] = a.get(p, j);
                    }
                }
                for k in env.first_column_of_row(j)..j {
                    let ljk = l[env.index(j, k)];
                    if tight[k] || s[k] < r0 || ljk == 0.0 {
                        continue;
                    }
                    for p in r0..=s[k] {
                        seg[p - r0] -= ljk * l[env.index(p, k)];
                    }
                }
                if j >= c {
                    finish_column(&mut seg, a.get(j, j), max_diag);
                } else {
                    let inv = 1.0 / l[env.index(j, j)];
                    seg.iter_mut().for_each(|x| *x *= inv);
                }
            }
            for p in r0..=s[j] {
                l[env.index(p, j)] = seg[p - r0];
            }
        }
    }

    #[test]
    fn paired_columns_give_the_column_by_column_factor_to_the_bit() {
        // `factor_from` factors adjacent free columns in pairs, two sources at a time; each entry
        // must still take the same updates in the same order (same zero multipliers skipped).
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        for (n, bw, density) in [(7, 3, 1.0), (60, 8, 0.5), (150, 12, 0.9), (200, 30, 0.3)] {
            let (a, _) = random_banded(n, bw, density, &mut rng);
            let mut env = Envelope::new();
            env.build(&a);
            let mut tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < 0.2).collect();
            let (mut l, mut r) = (vec![0.0; env.len()], vec![0.0; env.len()]);
            env.factor_from(&a, &tight, &mut l, 0, a.max_diag());
            factor_column_by_column(&env, &a, &tight, &mut r, 0);
            assert!(l.iter().zip(&r).all(|(x, y)| x.to_bits() == y.to_bits()), "n={n} c=0");
            for _ in 0..10 {
                let c = rng.random_range(0..n);
                for _ in 0..3 {
                    let i = rng.random_range(c..n);
                    tight[i] = !tight[i];
                }
                env.factor_from(&a, &tight, &mut l, c, a.max_diag());
                factor_column_by_column(&env, &a, &tight, &mut r, c);
                assert!(l.iter().zip(&r).all(|(x, y)| x.to_bits() == y.to_bits()), "n={n} c={c}");
            }
        }
    }

    #[test]
    fn incremental_refactor_matches_full_refactor() {
        let mut rng = ChaCha8Rng::seed_from_u64(14);
        let n = 150;
        let (a, d) = random_banded(n, 10, 0.6, &mut rng);
        let mut env = Envelope::new();
        env.build(&a);
        let mut l = vec![0.0; env.len()];
        let mut tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < 0.2).collect();
        env.factor_from(&a, &tight, &mut l, 0, a.max_diag());
        for _ in 0..20 {
            // Flip a few indices, all at or after c.
            let c = rng.random_range(0..n);
            for _ in 0..3 {
                let i = rng.random_range(c..n);
                tight[i] = !tight[i];
            }
            let c_eff = (0..n).find(|&i| i >= c).unwrap();
            env.factor_from(&a, &tight, &mut l, c_eff, a.max_diag());
            let reference = masked_reference(&d, &tight);
            let err = (dense_of(&env, &l) - &reference).norm() / reference.norm();
            assert!(err < 1e-12, "c={c} err={err}");
        }
    }

    #[test]
    fn solve_with_tight_rows_matches_reduced_system() {
        let mut rng = ChaCha8Rng::seed_from_u64(15);
        let n = 90;
        let (a, d) = random_banded(n, 8, 0.7, &mut rng);
        let mut env = Envelope::new();
        env.build(&a);
        let tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < 0.25).collect();
        let mut l = vec![0.0; env.len()];
        env.factor_from(&a, &tight, &mut l, 0, a.max_diag());
        let rhs: Vec<f64> = (0..n).map(|i| if tight[i] { 0.0 } else { (i as f64 * 0.37).cos() }).collect();
        let mut x = rhs.clone();
        env.solve(&l, &mut x);
        for i in 0..n {
            if tight[i] {
                assert_eq!(x[i], 0.0);
            } else {
                let ax: f64 = (0..n).filter(|&j| !tight[j]).map(|j| d[(i, j)] * x[j]).sum();
                assert!((ax - rhs[i]).abs() < 1e-12, "row {i}");
            }
        }
    }

    #[test]
    fn cost_model_counts_what_the_sweep_touches() {
        let mut rng = ChaCha8Rng::seed_from_u64(16);
        let n = 200;
        let (a, _) = random_banded(n, 12, 1.0, &mut rng);
        let mut env = Envelope::new();
        env.build(&a);
        let mut l = vec![0.0; env.len()];
        env.factor_from(&a, &[false; 200], &mut l, 0, a.max_diag());
        let mut sigma = vec![0.0; n];
        for i in [0, 50, 150, 199] {
            let mut lc = l.clone();
            let touched = env.delete(&mut lc, i, &mut sigma) as f64;
            let predicted = env.cost_delete(i);
            assert!(touched <= predicted + 1e-9, "i={i} touched={touched} predicted={predicted}");
            assert!(touched >= 0.8 * predicted - 20.0, "i={i} touched={touched} predicted={predicted}");
        }
        assert!(env.cost_factor_from(0) > env.cost_factor_from(100));
        assert_eq!(env.cost_factor_from(n), 0.0);
    }

    #[test]
    fn backward_error_of_deletions_is_at_rounding_level() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let n = 150;
        let (a, _) = random_banded(n, 10, 0.7, &mut rng);
        let mut env = Envelope::new();
        env.build(&a);
        let mut l = vec![0.0; env.len()];
        env.factor_from(&a, &vec![false; n], &mut l, 0, a.max_diag());
        let none = vec![false; n];
        assert!(env.backward_error(&a, &none, &l) < 1e-15);
        let tight: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < 0.2).collect();
        let mut sigma = vec![0.0; n];
        for i in (0..n).filter(|&i| tight[i]) {
            env.delete(&mut l, i, &mut sigma);
        }
        let e = env.backward_error(&a, &tight, &l);
        assert!(e < 1e-14, "{e}");
        // And it detects a wrong factor.
        l[0] *= 1.001;
        assert!(env.backward_error(&a, &tight, &l) > 1e-6);
    }
}
