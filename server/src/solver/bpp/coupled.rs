//! The exact coupled Newton point of a settled index set: friction rows tight against a free
//! normal impulse follow it, which makes the linear system non-symmetric; GMRES right-preconditioned
//! with the factor of `A_FF` at hand solves it in few iterations.

use std::time::Instant;

use super::super::IndexState;
use super::{FactorIn, Solver, resize, us};

impl Solver {
    /// Exact semismooth-Newton point for the current index set when friction rows are tight
    /// against a *free* normal impulse: their value `λ_i = μ_i^± λ_j` moves with `λ_j`, so the
    /// system `(A_FF + A_FT E) λ_F = b_F − A_FT c_T` is not symmetric. Solved by GMRES, right
    /// preconditioned with the factor of `A_FF` already at hand (the preconditioned operator is the
    /// identity plus a term of rank ≤ #coupled rows, so few iterations), starting from the frozen
    /// point in `λ`. Leaves the corrected `λ` and `w`. Returns `None` when nothing is coupled and
    /// `Some(false)` when GMRES did not reach `GMRES_ACCEPT` (the caller then keeps the frozen point).
    pub(super) fn coupled_newton(&mut self, which: FactorIn) -> Option<bool> {
        let m = self.ap.n();
        let mut coupled = 0;
        for i in 0..m {
            if let (true, Some(j)) = (self.tight[i], self.fip[i])
                && !self.tight[j]
                && self.lam[j] > 0.0
            {
                coupled += 1;
            }
        }
        if coupled == 0 {
            return None;
        }
        let t0 = Instant::now();
        let restart = GMRES_RESTART.min(m);
        resize(&mut self.kry_v, (restart + 1) * m);
        resize(&mut self.kry_h, (restart + 1) * restart);
        resize(&mut self.kry_g, restart + 1);
        resize(&mut self.kry_cs, restart);
        resize(&mut self.kry_sn, restart);
        resize(&mut self.kry_z, m);
        // Coupled rows follow the current normal impulses.
        self.apply_coupling();
        self.compute_w();
        let mut beta0 = 0.0;
        for cycle in 0..GMRES_CYCLES {
            // r = −w_F (residual of the free rows), zero on T.
            for i in 0..m {
                self.kry_v[i] = if self.tight[i] { 0.0 } else { -self.w[i] };
            }
            let beta = dot(&self.kry_v[..m], &self.kry_v[..m]).sqrt();
            if cycle == 0 {
                beta0 = beta;
            }
            if beta == 0.0 || beta <= GMRES_TOL * beta0 {
                break;
            }
            self.kry_v[..m].iter_mut().for_each(|x| *x /= beta);
            self.kry_g.fill(0.0);
            self.kry_g[0] = beta;
            let k_used = self.gmres_arnoldi(which, restart, beta0);
            self.gmres_update(which, k_used, restart);
            self.apply_coupling();
            self.compute_w();
            if self.out_of_time {
                break;
            }
        }
        // Accept only a converged Newton point: GMRES may stagnate when the coupling is strong.
        let mut beta = 0.0;
        for i in 0..m {
            if !self.tight[i] {
                beta += self.w[i] * self.w[i];
            }
        }
        self.stats.solve_us += us(t0);
        Some(beta.sqrt() <= GMRES_ACCEPT * beta0.max(f64::MIN_POSITIVE))
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
            self.rhs.copy_from_slice(&self.kry_v[k * m..(k + 1) * m]);
            self.solve_with(which);
            self.kry_z.copy_from_slice(&self.rhs);
            self.apply_b();
            // Modified Gram–Schmidt.
            for q in 0..=k {
                let h = dot(&self.rhs, &self.kry_v[q * m..(q + 1) * m]);
                self.kry_h[q * restart + k] = h;
                for (x, &v) in self.rhs.iter_mut().zip(&self.kry_v[q * m..(q + 1) * m]) {
                    *x -= h * v;
                }
            }
            let hn = dot(&self.rhs, &self.rhs).sqrt();
            self.kry_h[(k + 1) * restart + k] = hn;
            if hn > 0.0 {
                for (dst, &x) in self.kry_v[(k + 1) * m..(k + 2) * m].iter_mut().zip(&self.rhs) {
                    *dst = x / hn;
                }
            }
            // Givens rotations on column k.
            for q in 0..k {
                let (a, b) = (self.kry_h[q * restart + k], self.kry_h[(q + 1) * restart + k]);
                self.kry_h[q * restart + k] = self.kry_cs[q] * a + self.kry_sn[q] * b;
                self.kry_h[(q + 1) * restart + k] = -self.kry_sn[q] * a + self.kry_cs[q] * b;
            }
            let (a, b) = (self.kry_h[k * restart + k], self.kry_h[(k + 1) * restart + k]);
            let r = a.hypot(b);
            let (c, sn) = if r == 0.0 { (1.0, 0.0) } else { (a / r, b / r) };
            self.kry_cs[k] = c;
            self.kry_sn[k] = sn;
            self.kry_h[k * restart + k] = r;
            self.kry_h[(k + 1) * restart + k] = 0.0;
            self.kry_g[k + 1] = -sn * self.kry_g[k];
            self.kry_g[k] *= c;
            k_used = k + 1;
            self.stats.krylov_iterations += 1;
            if self.kry_g[k + 1].abs() <= GMRES_TOL * beta0 || hn == 0.0 {
                break;
            }
        }
        k_used
    }

    /// `y = H⁻¹ g` (upper triangular), `u = V y`, `λ_F += P⁻¹ u`.
    fn gmres_update(&mut self, which: FactorIn, k_used: usize, restart: usize) {
        let m = self.ap.n();
        for q in (0..k_used).rev() {
            let mut acc = self.kry_g[q];
            for p in q + 1..k_used {
                acc -= self.kry_h[q * restart + p] * self.kry_g[p];
            }
            self.kry_g[q] = acc / self.kry_h[q * restart + q];
        }
        self.rhs.fill(0.0);
        for q in 0..k_used {
            let y = self.kry_g[q];
            for (x, &v) in self.rhs.iter_mut().zip(&self.kry_v[q * m..(q + 1) * m]) {
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

    /// Tight friction rows against a free, positive normal impulse take `μ^± λ_j`.
    pub(super) fn apply_coupling(&mut self) {
        let m = self.ap.n();
        for i in 0..m {
            if let (true, Some(j)) = (self.tight[i], self.fip[i])
                && !self.tight[j]
            {
                let coef = if self.state[i] == IndexState::Upper { self.hip[i] } else { self.lop[i] };
                self.lam[i] = coef * self.lam[j].max(0.0);
            }
        }
    }

    /// `rhs = (A z̃)_F` where `z̃ = kry_z` on F, `μ^± z_j` on coupled rows and 0 elsewhere on T.
    pub(super) fn apply_b(&mut self) {
        let m = self.ap.n();
        for i in 0..m {
            if self.tight[i] {
                self.kry_z[i] = 0.0;
            }
        }
        for i in 0..m {
            if let (true, Some(j)) = (self.tight[i], self.fip[i])
                && !self.tight[j]
                && self.lam[j] > 0.0
            {
                let coef = if self.state[i] == IndexState::Upper { self.hip[i] } else { self.lop[i] };
                self.kry_z[i] = coef * self.kry_z[j];
            }
        }
        self.ap.mul_vec(&self.kry_z, &mut self.rhs);
        for i in 0..m {
            if self.tight[i] {
                self.rhs[i] = 0.0;
            }
        }
    }
}

const GMRES_RESTART: usize = 60;
const GMRES_CYCLES: usize = 3;
const GMRES_TOL: f64 = 1e-8;
/// Largest relative free-row residual of an accepted coupled Newton point.
const GMRES_ACCEPT: f64 = 1e-6;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
