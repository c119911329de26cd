//! The exact coupled Newton point of a settled index set: friction rows tight against a free
//! normal impulse follow it, which makes the linear system non-symmetric.
//!
//! **Two ways to solve it.** GMRES right-preconditioned with the factor of `A_FF` at hand: the
//! preconditioned operator is the identity plus a term of rank ≤ #coupled rows, so at most that
//! many iterations plus one, each a solve with the factor, a product with `A` and an
//! orthogonalisation. Or directly: one envelope LU (`envelope_lu.rs`, `factor_coupled`) of the
//! whole square system in which a free row is `A`'s row over the free and coupled columns, a
//! tight row the identity, and a coupled row `λ_i − μ^± λ_j = 0` — every entry in `A`'s pattern,
//! since a friction row and its normal touch the same two bodies, so the factors stay in `A`'s
//! envelope — then a solve and up to [`COUPLED_REFINE`] steps of iterative refinement. Without row
//! exchanges the LU can lose accuracy where a sliding contact makes its 2×2 block
//! `[[A_nn, A_nt], [−μ^±, 1]]` nearly singular (determinant `A_nn + μ^± A_nt`), though the whole
//! system is not: a direct point whose free-row residual misses `GMRES_ACCEPT` is discarded and
//! GMRES solves from the same start, and the rest of that solve uses GMRES. Which one runs is
//! [`SolverOptions::coupled_lu`](super::SolverOptions::coupled_lu): by default the cheaper by the
//! cost model in `coupled_direct` — GMRES at the iterations its recent points took, the LU at
//! twice the envelope Cholesky's multiply–adds, discounted by the recent share of rejected direct
//! points — and only with the envelope kernels, whose envelope of `A` it factors on (the dense
//! kernels of small islands keep GMRES).
//!
//! What the direct point gains and where it is rejected, measured: `docs/notes/solver.md`.

use std::time::Instant;

use super::super::problem::reserve_touched;
use super::super::{IndexState, Variant};
use super::solver::{FactorIn, Solver, resize, us};
use super::workspace::CoupledWork;

impl Solver {
    /// Exact semismooth-Newton point for the current index set when friction rows are tight
    /// against a *free* normal impulse: their value `λ_i = μ_i^± λ_j` moves with `λ_j`, so the
    /// system `(A_FF + A_FT E) λ_F = b_F − A_FT c_T` is not symmetric. Solved by GMRES, right
    /// preconditioned with the factor of `A_FF` already at hand (the preconditioned operator is the
    /// identity plus a term of rank ≤ #coupled rows, so few iterations), starting from the frozen
    /// point in `λ` — or by one envelope LU of the coupled system when that is predicted cheaper
    /// (module docs). Leaves the corrected `λ` and `w`. Returns `None` when nothing is coupled and
    /// `Some(false)` when GMRES did not reach `GMRES_ACCEPT` (the caller then keeps the frozen point).
    pub(super) fn coupled_newton(&mut self, which: FactorIn) -> Option<bool> {
        let m = self.ap.n();
        let coupled = (0..m).filter(|&i| self.coupled_row(i).is_some()).count();
        if coupled == 0 {
            return None;
        }
        let t0 = Instant::now();
        if self.coupled_direct(coupled) {
            self.stats.solve_us += us(t0);
            return Some(true);
        }
        let kry_before = self.stats.krylov_iterations;
        let restart = GMRES_RESTART.min(m);
        resize(&mut self.ws.krylov.v, (restart + 1) * m);
        resize(&mut self.ws.krylov.h, (restart + 1) * restart);
        resize(&mut self.ws.krylov.g, restart + 1);
        resize(&mut self.ws.krylov.cs, restart);
        resize(&mut self.ws.krylov.sn, restart);
        resize(&mut self.ws.krylov.z, m);
        // Coupled rows follow the current normal impulses.
        self.apply_coupling();
        self.compute_w();
        let mut beta0 = 0.0;
        for cycle in 0..GMRES_CYCLES {
            // r = −w_F (residual of the free rows), zero on T.
            for i in 0..m {
                self.ws.krylov.v[i] = if self.tight[i] { 0.0 } else { -self.w[i] };
            }
            let beta = dot(&self.ws.krylov.v[..m], &self.ws.krylov.v[..m]).sqrt();
            if cycle == 0 {
                beta0 = beta;
            }
            if beta == 0.0 || beta <= GMRES_TOL * beta0 {
                break;
            }
            self.ws.krylov.v[..m].iter_mut().for_each(|x| *x /= beta);
            self.ws.krylov.g.fill(0.0);
            self.ws.krylov.g[0] = beta;
            let k_used = self.gmres_arnoldi(which, restart, beta0);
            self.gmres_update(which, k_used, restart);
            self.apply_coupling();
            self.compute_w();
            if self.out_of_time {
                break;
            }
        }
        // What a GMRES point costs, in iterations, for the choice of the next (`coupled_direct`).
        let used = (self.stats.krylov_iterations - kry_before) as f64;
        self.cpl.gmres_iters += HISTORY_WEIGHT * (used - self.cpl.gmres_iters);
        // Accept only a converged Newton point: GMRES may stagnate when the coupling is strong.
        let beta = self.free_residual_norm();
        self.stats.solve_us += us(t0);
        Some(beta <= GMRES_ACCEPT * beta0.max(f64::MIN_POSITIVE))
    }

    /// One GMRES cycle's Arnoldi process from `v₀` (normalised, `g = β e₁` set): `z = P⁻¹ v_k`,
    /// `v_{k+1} = B z` orthogonalised (modified Gram–Schmidt), the Hessenberg column rotated
    /// (Givens) until the residual estimate `|g_{k+1}|` falls to `GMRES_TOL β₀`. Returns the
    /// number of Krylov vectors used.
    fn gmres_arnoldi(&mut self, which: FactorIn, restart: usize, beta0: f64) -> usize {
        let m = self.ap.n();
        let mut k_used = 0;
        for k in 0..restart {
            // A whole GMRES run is one pivot step, but up to 180 preconditioned products: it
            // answers to the solve's deadline at every one of them (a step budget of 0.5 ms was
            // overrun 7× on the winch by a single run before).
            if self.past_deadline() {
                break;
            }
            // z = P⁻¹ v_k, then v_{k+1} = B z.
            self.rhs.copy_from_slice(&self.ws.krylov.v[k * m..(k + 1) * m]);
            self.solve_with(which);
            self.ws.krylov.z.copy_from_slice(&self.rhs);
            self.apply_b();
            // Modified Gram–Schmidt.
            for q in 0..=k {
                let h = dot(&self.rhs, &self.ws.krylov.v[q * m..(q + 1) * m]);
                self.ws.krylov.h[q * restart + k] = h;
                for (x, &v) in self.rhs.iter_mut().zip(&self.ws.krylov.v[q * m..(q + 1) * m]) {
                    *x -= h * v;
                }
            }
            let hn = dot(&self.rhs, &self.rhs).sqrt();
            self.ws.krylov.h[(k + 1) * restart + k] = hn;
            if hn > 0.0 {
                for (dst, &x) in self.ws.krylov.v[(k + 1) * m..(k + 2) * m].iter_mut().zip(&self.rhs) {
                    *dst = x / hn;
                }
            }
            // Givens rotations on column k.
            for q in 0..k {
                let (a, b) = (self.ws.krylov.h[q * restart + k], self.ws.krylov.h[(q + 1) * restart + k]);
                self.ws.krylov.h[q * restart + k] = self.ws.krylov.cs[q] * a + self.ws.krylov.sn[q] * b;
                self.ws.krylov.h[(q + 1) * restart + k] =
                    -self.ws.krylov.sn[q] * a + self.ws.krylov.cs[q] * b;
            }
            let (a, b) = (self.ws.krylov.h[k * restart + k], self.ws.krylov.h[(k + 1) * restart + k]);
            let r = a.hypot(b);
            let (c, sn) = if r == 0.0 { (1.0, 0.0) } else { (a / r, b / r) };
            self.ws.krylov.cs[k] = c;
            self.ws.krylov.sn[k] = sn;
            self.ws.krylov.h[k * restart + k] = r;
            self.ws.krylov.h[(k + 1) * restart + k] = 0.0;
            self.ws.krylov.g[k + 1] = -sn * self.ws.krylov.g[k];
            self.ws.krylov.g[k] *= c;
            k_used = k + 1;
            self.stats.krylov_iterations += 1;
            if self.ws.krylov.g[k + 1].abs() <= GMRES_TOL * beta0 || hn == 0.0 {
                break;
            }
        }
        k_used
    }

    /// `y = H⁻¹ g` (upper triangular), `u = V y`, `λ_F += P⁻¹ u`.
    fn gmres_update(&mut self, which: FactorIn, k_used: usize, restart: usize) {
        let m = self.ap.n();
        for q in (0..k_used).rev() {
            let mut acc = self.ws.krylov.g[q];
            for p in q + 1..k_used {
                acc -= self.ws.krylov.h[q * restart + p] * self.ws.krylov.g[p];
            }
            self.ws.krylov.g[q] = acc / self.ws.krylov.h[q * restart + q];
        }
        self.rhs.fill(0.0);
        for q in 0..k_used {
            let y = self.ws.krylov.g[q];
            for (x, &v) in self.rhs.iter_mut().zip(&self.ws.krylov.v[q * m..(q + 1) * m]) {
                *x += y * v;
            }
        }
        self.solve_with(which);
        for i in 0..m {
            if !self.tight[i] {
                self.lam[i] += self.rhs[i];
            }
        }
    }

    /// The coupled Newton point by one envelope LU of the coupled matrix (`EnvelopeLu::factor_coupled`)
    /// when that is predicted cheaper than GMRES; `false` (nothing changed but the coupled rows
    /// following their normals) when GMRES should do it or the LU met a vanishing pivot.
    fn coupled_direct(&mut self, coupled: usize) -> bool {
        let m = self.ap.n();
        // The coupled matrix is factored on the envelope of `A` the envelope kernels keep; the
        // dense kernels (small islands) leave it to GMRES.
        if !matches!(
            self.kernel,
            Variant::Skyline | Variant::SkylineRefactor | Variant::Incremental | Variant::Auto
        ) {
            return false;
        }
        let direct = match self.opts.coupled_lu {
            Some(forced) => forced,
            // A rejected direct point in this solve: its coupled matrices stay hard for the LU.
            None if self.stats.coupled_lu_rejected > 0 => false,
            None => {
                // GMRES: the iterations its recent points took (at most `coupled + 1`: the
                // preconditioned operator is the identity plus a term of that rank), each a solve
                // with the factor at hand, a product with `A` and the orthogonalisation. The LU:
                // twice the multiply–adds of the envelope Cholesky and two solves, wasted when the
                // point is rejected (as often as recent attempts were), GMRES then running anyway.
                let env = &self.ws.factor.env;
                let iters = self.cpl.gmres_iters.min((coupled + 1) as f64).max(1.0);
                let per_iter = 2.0 * env.len() as f64 + self.ap.nnz() as f64 + m as f64 * iters;
                let gmres = iters * per_iter;
                let lu = 2.0 * env.cost_factor_from(0) + 4.0 * env.len() as f64;
                lu < (1.0 - self.cpl.lu_rejects) * gmres
            }
        };
        if !direct {
            return false;
        }
        self.apply_coupling();
        self.compute_w();
        let beta0 = self.free_residual_norm();
        if beta0 == 0.0 {
            return true;
        }
        self.cpl.rows.clear();
        self.cpl.vals.clear();
        for i in 0..m {
            let row = self.coupled_row(i);
            self.cpl.rows.push(row.map(|(j, _)| j));
            self.cpl.vals.push(row.map_or(0.0, |(_, coef)| -coef));
        }
        let t = Instant::now();
        let w = &mut self.cpl;
        let factored = w.lu.factor_coupled(&self.ws.factor.env, &self.ap, &self.tight, &w.rows, &w.vals);
        self.stats.factor_us += us(t);
        if factored.is_err() {
            self.reject_direct();
            return false;
        }
        self.cpl.start.clear();
        self.cpl.start.extend_from_slice(&self.lam);
        // Newton steps on the linear coupled system: one, and refinement while it pays.
        let mut beta = beta0;
        for _ in 0..1 + COUPLED_REFINE {
            for i in 0..m {
                self.rhs[i] = if self.tight[i] { 0.0 } else { -self.w[i] };
            }
            self.cpl.lu.solve(&self.ws.factor.env, &mut self.rhs);
            for i in 0..m {
                if !self.tight[i] || self.cpl.rows[i].is_some() {
                    self.lam[i] += self.rhs[i];
                }
            }
            self.apply_coupling();
            self.compute_w();
            let b = self.free_residual_norm();
            let stop = b <= GMRES_TOL * beta0 || b >= 0.5 * beta;
            beta = b;
            if stop {
                break;
            }
        }
        // Without row exchanges the LU can lose the point on an ill-conditioned coupled matrix
        // (pivots of mixed sign): then GMRES, preconditioned by the Cholesky factor, from the start.
        if beta > GMRES_ACCEPT * beta0 {
            self.lam.copy_from_slice(&self.cpl.start);
            self.compute_w();
            self.reject_direct();
            return false;
        }
        self.cpl.lu_rejects -= HISTORY_WEIGHT * self.cpl.lu_rejects;
        self.stats.coupled_lu += 1;
        true
    }

    /// A direct point given up: counted, and remembered by the cost model.
    fn reject_direct(&mut self) {
        self.stats.coupled_lu_rejected += 1;
        self.cpl.lu_rejects += HISTORY_WEIGHT * (1.0 - self.cpl.lu_rejects);
    }

    /// Tight friction row `i` against a free, positive normal impulse (a *coupled* row): that
    /// normal's index and the bound factor `μ^±` its value follows.
    fn coupled_row(&self, i: usize) -> Option<(usize, f64)> {
        match (self.tight[i], self.fip[i]) {
            (true, Some(j)) if !self.tight[j] && self.lam[j] > 0.0 => Some((j, self.friction_coef(i))),
            _ => None,
        }
    }

    /// The factor `μ^±` of the bound tight friction row `i` sits on.
    fn friction_coef(&self, i: usize) -> f64 {
        if self.state[i] == IndexState::Upper { self.hip[i] } else { self.lop[i] }
    }

    /// `‖w_F‖₂`, the residual of the free rows.
    fn free_residual_norm(&self) -> f64 {
        let mut beta = 0.0;
        for i in 0..self.ap.n() {
            if !self.tight[i] {
                beta += self.w[i] * self.w[i];
            }
        }
        beta.sqrt()
    }

    /// Tight friction rows against a free, positive normal impulse take `μ^± λ_j`.
    pub(super) fn apply_coupling(&mut self) {
        let m = self.ap.n();
        for i in 0..m {
            if let (true, Some(j)) = (self.tight[i], self.fip[i])
                && !self.tight[j]
            {
                self.lam[i] = self.friction_coef(i) * self.lam[j].max(0.0);
            }
        }
    }

    /// `rhs = (A z̃)_F` where `z̃ = kry_z` on F, `μ^± z_j` on coupled rows and 0 elsewhere on T.
    pub(super) fn apply_b(&mut self) {
        let m = self.ap.n();
        for i in 0..m {
            if self.tight[i] {
                self.ws.krylov.z[i] = 0.0;
            }
        }
        for i in 0..m {
            if let Some((j, coef)) = self.coupled_row(i) {
                self.ws.krylov.z[i] = coef * self.ws.krylov.z[j];
            }
        }
        self.ap.mul_vec(&self.ws.krylov.z, &mut self.rhs);
        for i in 0..m {
            if self.tight[i] {
                self.rhs[i] = 0.0;
            }
        }
    }
}

const GMRES_RESTART: usize = 60;
/// Refinement steps of a direct coupled Newton point (each one solve with its LU).
pub(super) const COUPLED_REFINE: usize = 2;
/// Weight of the newest point in the cost model's averages.
const HISTORY_WEIGHT: f64 = 0.2;
const GMRES_CYCLES: usize = 3;
const GMRES_TOL: f64 = 1e-8;
/// Largest relative free-row residual of an accepted coupled Newton point.
const GMRES_ACCEPT: f64 = 1e-6;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl CoupledWork {
    /// Room for the direct points of an `m`-row island with `len` envelope entries: sized when
    /// the envelope is (`factor.rs`, `prepare`), so that the first direct point of a run, which the
    /// cost model may choose many steps in, allocates nothing.
    pub(super) fn reserve(&mut self, m: usize, len: usize) {
        self.lu.reserve(len, m);
        reserve_touched(&mut self.rows, m, None);
        reserve_touched(&mut self.vals, m, 0.0);
        reserve_touched(&mut self.start, m, 0.0);
    }
}
