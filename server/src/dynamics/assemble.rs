//! Island MLCP assembly (paper eq. 2) directly from the per-body Jacobian blocks, and the velocity
//! update `v⁺ = v_free + M⁻¹ Jᵀ λ`.
//!
//! For island rows `i, j` and a dynamic body `k` they both touch (a row has up to
//! [`MAX_ROW_BODIES`] blocks, `rows.rs`),
//!
//! ```text
//!   A_ij = Σ_k J_{i,k} M_k⁻¹ J_{j,k}ᵀ + δ_ij c_i / h²,     M_k⁻¹ = diag(m_k⁻¹ 𝟙₃, I_{w,k}⁻¹),
//!   b_i  = r_i − Σ_{k ∈ blocks(i)} J_{i,k} v_{free,k},
//! ```
//!
//! where `M_k` is the body's effective mass matrix — its inertia raised by the geometric stiffness
//! of its loaded joints, `Ĩ_k = I_k + α h² K̃_k` (`geometric_stiffness.rs`), which keeps `M_k` block
//! diagonal and `A` symmetric positive definite with the same pattern — and the sum in `b` runs
//! over every block of row `i`, including kinematic bodies (their scripted
//! velocity), and the sum in `A` only over dynamic ones (infinite mass contributes nothing).
//! `W_{i,k} = M_k⁻¹ J_{i,k}ᵀ` is formed once per row and block; `A` is built row by row by walking,
//! for each body of row `i`, the rows touching that body (a per-body list of (row, block) pairs),
//! accumulating into a dense scratch indexed by row with a stamp array (rows sharing several bodies,
//! e.g. the rows of one joint, meet once per shared body and are summed). Only `j ≥ i` is computed
//! and both `(i, j)` and `(j, i)` are emitted with the same value, so `A` is exactly symmetric. No
//! `6n × 6n` matrix is ever formed; the cost is `Σ_k (rows at k)²`.
//!
//! All buffers are reused across islands and steps, and the [`Mlcp`] is refilled in place
//! ([`Mlcp::assign`]): once the buffers have grown, the assembly allocates nothing.
//!
//! **The same structure as last time.** The structure of `A` depends only on which dynamic body
//! each block of each row is on. When that is what the assembler saw in its last assembly (the same
//! rows on the same bodies: most steps of a scene), the entries `(i, j)` are last time's: only the
//! values are computed, with the same additions in the same order (bit-identical), and the matrix
//! takes them into its held structure (`SymCsr::assign_from_upper`), without marking, sorting or
//! validating the structure again.

use nalgebra::{Matrix3, Vector3};

use super::island::Islands;
use super::rows::{ConstraintRow, Jac6, MAX_ROW_BODIES};
use crate::solver::{IndexState, Mlcp, MlcpError};

/// What the assembly needs of each body (world-indexed).
#[derive(Debug, Clone, Copy)]
pub(crate) struct BodyMotion {
    /// Whether the body is dynamic (finite mass).
    pub dynamic: bool,
    /// `1/m` (0 unless dynamic).
    pub inv_mass: f64,
    /// `I_w⁻¹` (0 unless dynamic).
    pub inv_inertia: Matrix3<f64>,
    /// Free velocity `v + h f / m` (scripted for kinematic, 0 for static).
    pub v: Vector3<f64>,
    /// Free angular velocity.
    pub w: Vector3<f64>,
}

impl Default for BodyMotion {
    fn default() -> Self {
        BodyMotion {
            dynamic: false,
            inv_mass: 0.0,
            inv_inertia: Matrix3::zeros(),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        }
    }
}

impl BodyMotion {
    #[inline]
    fn apply_inv_mass(&self, j: &Jac6) -> Jac6 {
        Jac6 { lin: j.lin * self.inv_mass, ang: self.inv_inertia * j.ang }
    }
}

/// Reusable buffers of the island assembly.
#[derive(Debug, Default)]
pub(crate) struct Assembler {
    /// `M⁻¹ Jᵀ` per row and block, and the rows at each body.
    terms: RowTerms,
    fill: Vec<usize>,
    acc: Vec<f64>,
    stamp: Vec<usize>,
    touched: Vec<usize>,
    triplets: Vec<(usize, usize, f64)>,
    /// Where each row's entries start in `triplets` (`m + 1` entries).
    row_start: Vec<usize>,
    /// Per island row, the island-local dynamic body of each block: what the structure of `A`
    /// depends on. `structure_prev` is that of the last assembly, whose `triplets` and `row_start`
    /// the values-only path reuses.
    structure: Vec<[Option<usize>; MAX_ROW_BODIES]>,
    structure_prev: Vec<[Option<usize>; MAX_ROW_BODIES]>,
    /// World row index → island row index (valid for the rows of the island being assembled).
    row_local: Vec<usize>,
    /// Right-hand side, bounds, friction index of the island (island row order).
    pub b: Vec<f64>,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    pub findex: Vec<Option<usize>>,
    /// Warm start, filled by the caller before [`Assembler::fill_mlcp`].
    pub lambda0: Vec<f64>,
    pub index0: Vec<IndexState>,
    /// Solution of the island (island row order).
    pub lambda: Vec<f64>,
}

/// `W = M⁻¹ Jᵀ` of the island's rows and the rows at each of its bodies: what the terms of `A`
/// are made of.
#[derive(Debug, Default)]
struct RowTerms {
    /// `M⁻¹ J_kᵀ` per island row and block (zero on a non-dynamic body).
    w: Vec<[Jac6; MAX_ROW_BODIES]>,
    /// Per island body: the (row, block) pairs touching it, CSR.
    body_rows_start: Vec<usize>,
    body_rows: Vec<(usize, usize)>,
}

impl RowTerms {
    /// Calls `f(j, J_{i,k} W_{j,k})` for every row `j ≥ i` sharing a dynamic body `k` with row
    /// `i` (`r`), body by body in the row's block order and row by row in island order: the terms
    /// of row `i` of the upper triangle, a pair of rows once per body they share. Both assembly
    /// paths add them in this order, so their sums are the same to the bit.
    #[inline]
    fn for_each(&self, isl: &IslandInput<'_>, i: usize, r: &ConstraintRow, mut f: impl FnMut(usize, f64)) {
        for s in 0..MAX_ROW_BODIES {
            let Some(b) = isl.dyn_local(r, s) else { continue };
            let j_i = &r.jac[s];
            for &(j, sj) in &self.body_rows[self.body_rows_start[b]..self.body_rows_start[b + 1]] {
                if j < i {
                    continue;
                }
                let w = &self.w[j][sj];
                f(j, j_i.lin.dot(&w.lin) + j_i.ang.dot(&w.ang));
            }
        }
    }
}

/// What the assembly stages read of the island being assembled and of the world.
struct IslandInput<'a> {
    /// World indices of the island's rows.
    island_rows: &'a [usize],
    /// Bodies in the island.
    nb: usize,
    /// Every row of the world.
    rows: &'a [ConstraintRow],
    islands: &'a Islands,
    motion: &'a [BodyMotion],
}

impl IslandInput<'_> {
    /// Island-local index of the dynamic body in block `s` of `r`, if any.
    #[inline]
    fn dyn_local(&self, r: &ConstraintRow, s: usize) -> Option<usize> {
        let in_island = |i: usize| self.islands.local_index(i).expect("body in an island");
        r.bodies[s].filter(|&i| self.motion[i].dynamic).map(in_island)
    }
}

impl Assembler {
    /// Assembles `A` (into the triplet buffer), `b`, bounds and findex for the island `k`.
    pub fn assemble(
        &mut self,
        k: usize,
        islands: &Islands,
        rows: &[ConstraintRow],
        motion: &[BodyMotion],
        h: f64,
    ) {
        let isl =
            IslandInput { island_rows: islands.rows(k), nb: islands.bodies(k).len(), rows, islands, motion };
        self.map_island_rows(isl.island_rows, rows.len());
        self.row_terms(&isl);
        self.index_rows_by_body(&isl);
        if self.structure == self.structure_prev && self.row_start.len() == self.structure.len() + 1 {
            self.upper_triangle_values(&isl, h);
        } else {
            self.upper_triangle(&isl, h);
            std::mem::swap(&mut self.structure, &mut self.structure_prev);
        }
    }

    /// Points `row_local` from the world index of each island row to its island index.
    fn map_island_rows(&mut self, island_rows: &[usize], world_rows: usize) {
        if self.row_local.len() < world_rows {
            self.row_local.resize(world_rows, usize::MAX);
        }
        for (i, &ri) in island_rows.iter().enumerate() {
            self.row_local[ri] = i;
        }
    }

    /// Per island row: the `M⁻¹ Jᵀ` blocks, `b`, bounds and findex; counts the rows at each island
    /// body into `body_rows_start` (shifted by one, not yet summed).
    fn row_terms(&mut self, isl: &IslandInput<'_>) {
        self.terms.w.clear();
        self.b.clear();
        self.lo.clear();
        self.hi.clear();
        self.findex.clear();
        self.terms.body_rows_start.clear();
        self.terms.body_rows_start.resize(isl.nb + 1, 0);
        self.structure.clear();
        for &ri in isl.island_rows {
            let r = &isl.rows[ri];
            self.structure.push(std::array::from_fn(|s| isl.dyn_local(r, s)));
            let mut w = [Jac6::default(); MAX_ROW_BODIES];
            let mut jv = 0.0;
            for (s, ws) in w.iter_mut().enumerate() {
                let Some(b) = r.bodies[s] else { continue };
                jv += r.jac[s].dot(&isl.motion[b].v, &isl.motion[b].w);
                if isl.motion[b].dynamic {
                    *ws = isl.motion[b].apply_inv_mass(&r.jac[s]);
                    self.terms.body_rows_start[isl.dyn_local(r, s).unwrap() + 1] += 1;
                }
            }
            self.terms.w.push(w);
            self.b.push(r.rhs - jv);
            self.lo.push(r.lo);
            self.hi.push(r.hi);
            self.findex.push(r.findex.map(|f| self.row_local[f]));
        }
    }

    /// The per-body (row, block) lists in CSR form, from the counts of [`Assembler::row_terms`].
    fn index_rows_by_body(&mut self, isl: &IslandInput<'_>) {
        for j in 0..isl.nb {
            self.terms.body_rows_start[j + 1] += self.terms.body_rows_start[j];
        }
        self.fill.clear();
        self.fill.extend_from_slice(&self.terms.body_rows_start[..isl.nb]);
        self.terms.body_rows.clear();
        self.terms.body_rows.resize(self.terms.body_rows_start[isl.nb], (0, 0));
        for (i, &ri) in isl.island_rows.iter().enumerate() {
            for s in 0..MAX_ROW_BODIES {
                if let Some(b) = isl.dyn_local(&isl.rows[ri], s) {
                    self.terms.body_rows[self.fill[b]] = (i, s);
                    self.fill[b] += 1;
                }
            }
        }
    }

    /// `A` into the triplet buffer, row by row: the upper triangle, rows in order, columns sorted.
    fn upper_triangle(&mut self, isl: &IslandInput<'_>, h: f64) {
        let m = isl.island_rows.len();
        self.acc.clear();
        self.acc.resize(m, 0.0);
        self.stamp.clear();
        self.stamp.resize(m, usize::MAX);
        self.triplets.clear();
        self.row_start.clear();
        let inv_h2 = 1.0 / (h * h);
        for (i, &ri) in isl.island_rows.iter().enumerate() {
            let r = &isl.rows[ri];
            self.row_start.push(self.triplets.len());
            self.touched.clear();
            let (stamp, acc, touched) = (&mut self.stamp, &mut self.acc, &mut self.touched);
            self.terms.for_each(isl, i, r, |j, v| {
                if stamp[j] != i {
                    stamp[j] = i;
                    acc[j] = 0.0;
                    touched.push(j);
                }
                acc[j] += v;
            });
            // Row i of the upper triangle, columns sorted: what `Mlcp::assign_upper` takes.
            self.touched.sort_unstable();
            for &j in &self.touched {
                let v = if j == i { self.acc[i] + r.compliance * inv_h2 } else { self.acc[j] };
                self.triplets.push((i, j, v));
            }
        }
        self.row_start.push(self.triplets.len());
    }

    /// [`Assembler::upper_triangle`] when the island's structure is that of the last assembly
    /// (the same rows on the same bodies, the common case from one step to the next): the entries
    /// of `triplets` are those of last time, so only their values are computed, in the same order
    /// of additions (every sum starts at 0 and adds the same terms in the same order: the values
    /// are the full path's to the bit), without marking, sorting or pushing.
    fn upper_triangle_values(&mut self, isl: &IslandInput<'_>, h: f64) {
        let m = isl.island_rows.len();
        self.acc.resize(m, 0.0);
        let inv_h2 = 1.0 / (h * h);
        for (i, &ri) in isl.island_rows.iter().enumerate() {
            let r = &isl.rows[ri];
            let entries = self.row_start[i]..self.row_start[i + 1];
            for &(_, j, _) in &self.triplets[entries.clone()] {
                self.acc[j] = 0.0;
            }
            let acc = &mut self.acc;
            self.terms.for_each(isl, i, r, |j, v| acc[j] += v);
            for e in &mut self.triplets[entries] {
                let j = e.1;
                e.2 = if j == i { self.acc[i] + r.compliance * inv_h2 } else { self.acc[j] };
            }
        }
    }

    /// Fills `problem` (in place, reusing its buffers) with the validated [`Mlcp`] of the last
    /// assembled island, with the warm start in `lambda0`/`index0` when `warm` is set.
    pub fn fill_mlcp(&mut self, problem: &mut Mlcp, warm: bool) -> Result<(), MlcpError> {
        let m = self.b.len();
        problem.assign_upper(m, &self.triplets, &self.b, &self.lo, &self.hi, &self.findex)?;
        if warm {
            problem.set_warm_start(Some(&self.lambda0), Some(&self.index0))?;
        }
        Ok(())
    }

    /// Adds `M⁻¹ Jᵀ λ` of the island rows (with `self.lambda`) to the velocities `v`, `w`
    /// (world-indexed).
    pub fn apply_impulses(
        &self,
        k: usize,
        islands: &Islands,
        rows: &[ConstraintRow],
        v: &mut [Vector3<f64>],
        w: &mut [Vector3<f64>],
    ) {
        for (i, &ri) in islands.rows(k).iter().enumerate() {
            let (r, l) = (&rows[ri], self.lambda[i]);
            for (s, wj) in self.terms.w[i].iter().enumerate() {
                // Non-dynamic blocks carry a zero `M⁻¹ Jᵀ`; skip them anyway (no write to a
                // kinematic body's velocity).
                if let Some(b) = r.bodies[s].filter(|_| *wj != Jac6::default()) {
                    v[b] += wj.lin * l;
                    w[b] += wj.ang * l;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::dynamics::ids::JointId;
    use crate::dynamics::joint::JointRow;
    use crate::dynamics::rows::{RowKey, RowKind};

    /// `A` and `b` from the per-body blocks equal the dense `J M⁻¹ Jᵀ + C/h²` and
    /// `r − J v_free` built from the full `m × 6n` Jacobian (independent reference).
    #[test]
    fn assembly_matches_dense_reference() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 5; // bodies 0..4 dynamic, body 4 kinematic
        let mut motion = vec![BodyMotion::default(); n];
        for (i, mo) in motion.iter_mut().enumerate() {
            let r = |rng: &mut ChaCha8Rng| rng.random_range(-1.0..1.0);
            mo.v = Vector3::new(r(&mut rng), r(&mut rng), r(&mut rng));
            mo.w = Vector3::new(r(&mut rng), r(&mut rng), r(&mut rng));
            if i < 4 {
                mo.dynamic = true;
                mo.inv_mass = rng.random_range(0.1..2.0);
                let b = DMatrix::from_fn(3, 3, |_, _| rng.random_range(-1.0..1.0));
                let spd = &b * b.transpose() + DMatrix::identity(3, 3);
                mo.inv_inertia = Matrix3::from_iterator(spd.iter().copied());
            }
        }
        // Two-body rows (joints) and rows on three and four bodies (couplings), sharing bodies.
        let sets: [&[Option<usize>]; 9] = [
            &[Some(0), Some(1)],
            &[Some(0), Some(1)],
            &[Some(1), Some(2)],
            &[Some(2), None],
            &[Some(4), Some(3)],
            &[Some(3), Some(2)],
            &[Some(0), None],
            &[Some(0), Some(1), Some(3)],
            &[Some(2), Some(4), Some(0), Some(3)],
        ];
        let mut rows = Vec::new();
        for (q, set) in sets.iter().enumerate() {
            let key = RowKey::Joint { joint: JointId(q as u32), row: JointRow::Locked(0) };
            let mut row = ConstraintRow::new(key, RowKind::Position);
            for &b in set.iter() {
                let r = |rng: &mut ChaCha8Rng| rng.random_range(-1.0..1.0);
                let j = Jac6::new(
                    Vector3::new(r(&mut rng), r(&mut rng), r(&mut rng)),
                    Vector3::new(r(&mut rng), r(&mut rng), r(&mut rng)),
                );
                assert!(row.add_block(b, j));
            }
            row.rhs = 0.1 * q as f64;
            row.compliance = 1e-3 * q as f64;
            rows.push(row);
        }
        let dynamic: Vec<bool> = motion.iter().map(|m| m.dynamic).collect();
        let mut isl = Islands::default();
        isl.build(&dynamic, &rows);
        assert_eq!(isl.len(), 1);
        let h = 0.1;
        let mut asm = Assembler::default();
        asm.assemble(0, &isl, &rows, &motion, h);
        let mut p = Mlcp::default();
        asm.fill_mlcp(&mut p, false).unwrap();
        // Dense reference.
        let m = rows.len();
        let mut j = DMatrix::zeros(m, 6 * n);
        let mut minv = DMatrix::zeros(6 * n, 6 * n);
        let mut vfree = nalgebra::DVector::zeros(6 * n);
        for (k, mo) in motion.iter().enumerate() {
            for c in 0..3 {
                vfree[6 * k + c] = mo.v[c];
                vfree[6 * k + 3 + c] = mo.w[c];
                if mo.dynamic {
                    minv[(6 * k + c, 6 * k + c)] = mo.inv_mass;
                    for d in 0..3 {
                        minv[(6 * k + 3 + c, 6 * k + 3 + d)] = mo.inv_inertia[(c, d)];
                    }
                }
            }
        }
        for (i, &ri) in isl.rows(0).iter().enumerate() {
            let r = &rows[ri];
            for (b, jb) in r.blocks() {
                for c in 0..3 {
                    j[(i, 6 * b + c)] += jb.lin[c];
                    j[(i, 6 * b + 3 + c)] += jb.ang[c];
                }
            }
        }
        let mut a_ref = &j * &minv * j.transpose();
        let mut b_ref = -(&j * &vfree);
        for (i, &ri) in isl.rows(0).iter().enumerate() {
            a_ref[(i, i)] += rows[ri].compliance / (h * h);
            b_ref[i] += rows[ri].rhs;
        }
        for i in 0..m {
            assert!((p.b()[i] - b_ref[i]).abs() < 1e-13);
            for k in 0..m {
                assert!((p.a().get(i, k) - a_ref[(i, k)]).abs() < 1e-12, "A[{i},{k}]");
            }
        }
        // The velocity update equals the dense M⁻¹ Jᵀ λ (kinematic body 4 untouched).
        asm.lambda = (0..m).map(|_| rng.random_range(-1.0..1.0)).collect();
        let dv_ref = &minv * j.transpose() * nalgebra::DVector::from_column_slice(&asm.lambda);
        let (mut v, mut w) = (vec![Vector3::zeros(); n], vec![Vector3::zeros(); n]);
        asm.apply_impulses(0, &isl, &rows, &mut v, &mut w);
        for k in 0..n {
            for c in 0..3 {
                assert!((v[k][c] - dv_ref[6 * k + c]).abs() < 1e-13, "v[{k}]");
                assert!((w[k][c] - dv_ref[6 * k + 3 + c]).abs() < 1e-13, "w[{k}]");
            }
        }
    }

    /// Rows on the given body sets with random Jacobians, right-hand sides and compliances.
    fn random_rows(rng: &mut ChaCha8Rng, sets: &[&[Option<usize>]]) -> Vec<ConstraintRow> {
        let r = |rng: &mut ChaCha8Rng| rng.random_range(-1.0..1.0);
        sets.iter()
            .enumerate()
            .map(|(q, set)| {
                let key = RowKey::Joint { joint: JointId(q as u32), row: JointRow::Locked(0) };
                let mut row = ConstraintRow::new(key, RowKind::Position);
                for &b in set.iter() {
                    let j =
                        Jac6::new(Vector3::new(r(rng), r(rng), r(rng)), Vector3::new(r(rng), r(rng), r(rng)));
                    assert!(row.add_block(b, j));
                }
                row.rhs = r(rng);
                row.compliance = 1e-3 * (q + 1) as f64;
                row
            })
            .collect()
    }

    /// An assembler that assembled this island's structure before (the values-only path) or
    /// another structure gives the problem a fresh assembler gives, to the bit.
    #[test]
    fn reassembly_equals_a_fresh_assembly_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let motion: Vec<BodyMotion> = (0..5)
            .map(|i| BodyMotion {
                dynamic: i < 4,
                inv_mass: if i < 4 { 0.5 + i as f64 } else { 0.0 },
                inv_inertia: if i < 4 { Matrix3::identity() * (1.0 + i as f64) } else { Matrix3::zeros() },
                v: Vector3::new(0.1 * i as f64, -0.2, 0.3),
                w: Vector3::new(0.0, 0.05 * i as f64, -0.1),
            })
            .collect();
        let dynamic: Vec<bool> = motion.iter().map(|m| m.dynamic).collect();
        let a: [&[Option<usize>]; 6] = [
            &[Some(0), Some(1)],
            &[Some(1), Some(2)],
            &[Some(2), None],
            &[Some(4), Some(3)],
            &[Some(3), Some(2)],
            &[Some(0), Some(1), Some(3)],
        ];
        let b: [&[Option<usize>]; 6] = [
            &[Some(0), Some(1)],
            &[Some(1), Some(3)],
            &[Some(2), None],
            &[Some(4), Some(3)],
            &[Some(3), Some(2)],
            &[Some(0), Some(2), Some(3)],
        ];
        let fresh = |rows: &[ConstraintRow]| {
            let mut isl = Islands::default();
            isl.build(&dynamic, rows);
            let mut asm = Assembler::default();
            asm.assemble(0, &isl, rows, &motion, 0.1);
            let mut p = Mlcp::default();
            asm.fill_mlcp(&mut p, false).unwrap();
            p
        };
        let mut held = Assembler::default();
        let mut p = Mlcp::default();
        for (round, sets) in [a, a, a, b, b, a].iter().enumerate() {
            let rows = random_rows(&mut rng, sets);
            let mut isl = Islands::default();
            isl.build(&dynamic, &rows);
            assert_eq!(isl.len(), 1);
            held.assemble(0, &isl, &rows, &motion, 0.1);
            held.fill_mlcp(&mut p, false).unwrap();
            assert_eq!(p, fresh(&rows), "round {round}");
        }
    }
}
