//! Shared by the solver's regression and sweep tests: the natural-map residual of `MLCP_FORMAT.md`
//! recomputed here from `A`'s stored rows, `b`, the bounds and the friction index, without the
//! solver's own statistics or its `natural_residual`:
//!
//! `w = Aλ − b`, `r = max_i |λ_i − clamp(λ_i − w_i, lo_i(λ), hi_i(λ))|` (paper eq. 3), where a
//! friction row `i` with `findex_i = j` has the bounds `[−μ λ_j⁺, μ λ_j⁺]` (`μ = hi_i`) at the
//! final `λ_j`; relative to `‖λ‖∞`.

#![allow(dead_code)]

use pivotsim_server::solver::Mlcp;

/// `(absolute, relative)` natural-map residual of `lambda` for `p`, in the ∞-norm, each product
/// `A_i λ` summed in compensated (Neumaier) arithmetic so that the check does not share the
/// solver's rounding. A non-finite `λ` or residual counts as infinite.
pub fn natural_map_residual(p: &Mlcp, lambda: &[f64]) -> (f64, f64) {
    let n = p.n();
    assert_eq!(lambda.len(), n, "λ has {} entries for {n} rows", lambda.len());
    let (ptr, cols, vals) = (p.a().row_ptr(), p.a().col_indices(), p.a().values());
    let mut r: f64 = 0.0;
    let mut norm: f64 = 0.0;
    for i in 0..n {
        let (mut s, mut c) = (-p.b()[i], 0.0);
        for k in ptr[i]..ptr[i + 1] {
            let x = vals[k] * lambda[cols[k]];
            let t = s + x;
            c += if s.abs() >= x.abs() { (s - t) + x } else { (x - t) + s };
            s = t;
        }
        let w = s + c;
        let (lo, hi) = match p.findex()[i] {
            Some(j) => {
                // A negative normal is its own row's violation; its friction box is then empty.
                let mu = p.hi()[i];
                let ln = lambda[j].max(0.0);
                (-mu * ln, mu * ln)
            }
            None => (p.lo()[i], p.hi()[i]),
        };
        let ri = (lambda[i] - (lambda[i] - w).max(lo).min(hi)).abs();
        if !ri.is_finite() {
            return (f64::INFINITY, f64::INFINITY);
        }
        r = r.max(ri);
        norm = norm.max(lambda[i].abs());
    }
    (r, r / norm.max(1e-300))
}
