//! Generated test problems: banded contact-like MLCPs of a given size and mass ratio, deterministic
//! in a seed. A test and benchmark utility (`bench-solver`, the solver's tests), not used by the
//! simulation itself.

use std::collections::BTreeMap;

use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{IndexState, Mlcp, SymCsr};

type V3 = [f64; 3];

fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot3(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: V3) -> V3 {
    let n = dot3(a, a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// One constraint row before assembly: its Jacobian blocks `(body, [linear, angular])`.
struct GenRow {
    blocks: Vec<(usize, [f64; 6])>,
    lo: f64,
    hi: f64,
    findex: Option<usize>,
}

/// Jacobian block of direction `d` at lever arm `r`: `[dᵀ, (r × d)ᵀ]` (i.e. `[I, −[r]×]` applied
/// to `d`), scaled by `sign`.
fn jac_block(d: V3, r: V3, sign: f64) -> [f64; 6] {
    let a = cross(r, d);
    [sign * d[0], sign * d[1], sign * d[2], sign * a[0], sign * a[1], sign * a[2]]
}

/// Time step `h` of the generated problems.
const H: f64 = 1.0 / 60.0;
/// Constraint compliance `c` of [`contact_like`] (adds `c/h²` to the diagonal).
const COMPLIANCE: f64 = 1e-8;
/// Gravity, m/s².
const G: f64 = 9.81;

/// The parameters of a generated island ([`contact_like_with`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IslandParams {
    /// About this many rows (4.5 per body: 3 joint rows per link, 3 contact rows on half the bodies).
    pub m_target: usize,
    /// Masses are log-uniform in `[1, mass_ratio]` kg.
    pub mass_ratio: f64,
    /// Constraint compliance `c` of every row (adds `c/h²` to the diagonal; smaller is stiffer).
    pub compliance: f64,
    /// Friction coefficient `μ` of every contact (friction rows `lo = −μ`, `hi = μ`).
    pub mu: f64,
}

/// A banded contact-like MLCP of about `m_target` rows, `c = 1e-8`, `μ = 1`: [`contact_like_with`].
pub fn contact_like(m_target: usize, seed: u64, mass_ratio: f64) -> Mlcp {
    contact_like_with(&IslandParams { m_target, mass_ratio, compliance: COMPLIANCE, mu: 1.0 }, seed)
}

/// A banded contact-like MLCP of about `m_target` rows: a serial chain of rigid bodies (6 DOF,
/// masses log-uniform in `[1, mass_ratio]`, diagonal inertia of random boxes) with ball joints
/// between neighbours (3 bilateral rows, blocks `[I, −[r]×]` with random lever arms) and frictional
/// ground contacts on a random half of the bodies (normal row `λ ≥ 0` and two friction rows with
/// `findex` → normal, bounds `±μ`). `A = J M⁻¹ Jᵀ + (c/h²) I` with `h = 1/60` (paper eq. 1–2),
/// assembled per body (rows couple only through a shared body); `b = −J (v + h M⁻¹ f_gravity)` with
/// small random velocities, so some contacts separate and some friction rows slide. The rows are
/// finally shuffled by a random symmetric permutation (Cuthill–McKee has work to do). Deterministic
/// in `seed`; the random draws do not depend on `compliance` or `μ`, so islands of one seed differ
/// only by those.
pub fn contact_like_with(params: &IslandParams, seed: u64) -> Mlcp {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // 3 joint rows per link and 3 contact rows on half of the bodies: about 4.5 rows per body.
    let nb = ((params.m_target as f64 + 3.0) / 4.5).round().max(2.0) as usize;
    let (minv, vel) = random_bodies(nb, params.mass_ratio, &mut rng);
    let mut rows: Vec<GenRow> = Vec::with_capacity(params.m_target + 8);
    push_ball_joints(nb, &mut rng, &mut rows);
    push_ground_contacts(nb, params.mu, &mut rng, &mut rows);
    let entries = assemble_a(&rows, &minv, params.compliance);
    let b = rhs(&rows, &vel);
    permuted_mlcp(&rows, &entries, &b, &mut rng)
}

/// The parameter ranges of the generated-island sweep (`tests/solver_sweep.rs`, `bench-solver
/// --sweep`): rows 50–1,000 and mass ratio 1e1–1e9 log-uniform, contact compliance 1e-12–1e-6
/// log-uniform, `μ` uniform in 0.3–1.
pub const SWEEP_ROWS: (usize, usize) = (50, 1_000);
/// Mass ratio range of the sweep (log-uniform).
pub const SWEEP_MASS_RATIO: (f64, f64) = (1e1, 1e9);
/// Compliance range of the sweep (log-uniform).
pub const SWEEP_COMPLIANCE: (f64, f64) = (1e-12, 1e-6);
/// Friction coefficient range of the sweep (uniform).
pub const SWEEP_MU: (f64, f64) = (0.3, 1.0);

/// The parameters of sweep island `seed`, drawn from the sweep's ranges by a generator of their
/// own (seeded with `seed` and a fixed tag, so that they do not correlate with the island's
/// bodies, which [`contact_like_with`] draws from `seed`).
pub fn sweep_params(seed: u64) -> IslandParams {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5357_4545_5000_0000);
    let log_uniform = |rng: &mut ChaCha8Rng, (lo, hi): (f64, f64)| rng.random_range(lo.ln()..hi.ln()).exp();
    let rows = log_uniform(&mut rng, (SWEEP_ROWS.0 as f64, SWEEP_ROWS.1 as f64)).round() as usize;
    IslandParams {
        m_target: rows.clamp(SWEEP_ROWS.0, SWEEP_ROWS.1),
        mass_ratio: log_uniform(&mut rng, SWEEP_MASS_RATIO),
        compliance: log_uniform(&mut rng, SWEEP_COMPLIANCE),
        mu: rng.random_range(SWEEP_MU.0..SWEEP_MU.1),
    }
}

/// Sweep island `seed`: its parameters ([`sweep_params`]) and its problem.
pub fn sweep_island(seed: u64) -> (IslandParams, Mlcp) {
    let params = sweep_params(seed);
    (params, contact_like_with(&params, seed))
}

/// The sweep's perturbed warm start from an answer `(λ, index set)` of island `seed`: every `λ_i`
/// scaled by `1 + 0.2 u` (`u` uniform in ±1) and a tenth of the rows released to free (a
/// simulation's warm start after a step that moved the island a little), deterministic in `seed`.
pub fn perturbed_warm_start(lambda: &[f64], index: &[IndexState], seed: u64) -> (Vec<f64>, Vec<IndexState>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5741_524D);
    let lam0 = lambda.iter().map(|&x| x * (1.0 + rng.random_range(-0.2..0.2))).collect();
    let index0 =
        index.iter().map(|&s| if rng.random_range(0.0..1.0) < 0.1 { IndexState::Free } else { s }).collect();
    (lam0, index0)
}

/// `nb` random bodies: the diagonal of each inverse mass matrix and each velocity (linear, angular).
fn random_bodies(nb: usize, mass_ratio: f64, rng: &mut ChaCha8Rng) -> (Vec<[f64; 6]>, Vec<[f64; 6]>) {
    let ln_ratio = mass_ratio.max(1.0).ln();
    let mut minv: Vec<[f64; 6]> = Vec::with_capacity(nb);
    let mut vel: Vec<[f64; 6]> = Vec::with_capacity(nb);
    for _ in 0..nb {
        let mass = if ln_ratio > 0.0 { rng.random_range(0.0..ln_ratio).exp() } else { 1.0 };
        let d: V3 = [rng.random_range(0.3..1.5), rng.random_range(0.3..1.5), rng.random_range(0.3..1.5)];
        let inertia = [
            mass * (d[1] * d[1] + d[2] * d[2]) / 12.0,
            mass * (d[0] * d[0] + d[2] * d[2]) / 12.0,
            mass * (d[0] * d[0] + d[1] * d[1]) / 12.0,
        ];
        let im = 1.0 / mass;
        minv.push([im, im, im, 1.0 / inertia[0], 1.0 / inertia[1], 1.0 / inertia[2]]);
        // Small velocities: tangential ±5 cm/s, vertical ±20 cm/s (g·h ≈ 16 cm/s, so some contacts
        // separate), angular ±0.1 rad/s. About 8 % of the rows end tight, as in the crane scene.
        let mut v = [0.0; 6];
        for (k, x) in v.iter_mut().enumerate() {
            let r = match k {
                0 | 1 => 0.05,
                2 => 0.2,
                _ => 0.1,
            };
            *x = rng.random_range(-r..r);
        }
        vel.push(v);
    }
    (minv, vel)
}

/// Three bilateral rows of a ball joint between each pair of neighbours, random lever arms.
fn push_ball_joints(nb: usize, rng: &mut ChaCha8Rng, rows: &mut Vec<GenRow>) {
    let axes: [V3; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for k in 0..nb - 1 {
        let ra: V3 = [rng.random_range(0.3..0.7), rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2)];
        let rb: V3 = [-rng.random_range(0.3..0.7), rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2)];
        for e in axes {
            rows.push(GenRow {
                blocks: vec![(k, jac_block(e, ra, 1.0)), (k + 1, jac_block(e, rb, -1.0))],
                lo: f64::NEG_INFINITY,
                hi: f64::INFINITY,
                findex: None,
            });
        }
    }
}

/// A frictional ground contact (normal row and two friction rows, bounds `±μ`) on a random half of
/// the bodies.
fn push_ground_contacts(nb: usize, mu: f64, rng: &mut ChaCha8Rng, rows: &mut Vec<GenRow>) {
    let mut which: Vec<usize> = (0..nb).collect();
    which.shuffle(rng);
    which.truncate(nb / 2);
    which.sort_unstable();
    for &k in &which {
        let n = normalize([rng.random_range(-0.15..0.15), rng.random_range(-0.15..0.15), 1.0]);
        let x: V3 = [1.0, 0.0, 0.0];
        let xn = dot3(x, n);
        let t1 = normalize([x[0] - xn * n[0], x[1] - xn * n[1], x[2] - xn * n[2]]);
        let t2 = cross(n, t1);
        let r: V3 = [rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5), -rng.random_range(0.2..0.6)];
        let normal = rows.len();
        rows.push(GenRow {
            blocks: vec![(k, jac_block(n, r, 1.0))],
            lo: 0.0,
            hi: f64::INFINITY,
            findex: None,
        });
        for t in [t1, t2] {
            rows.push(GenRow {
                blocks: vec![(k, jac_block(t, r, 1.0))],
                lo: -mu,
                hi: mu,
                findex: Some(normal),
            });
        }
    }
}

/// The entries of `A = J M⁻¹ Jᵀ + c/h² I`, assembled per body.
fn assemble_a(rows: &[GenRow], minv: &[[f64; 6]], compliance: f64) -> BTreeMap<(usize, usize), f64> {
    let mut per_body: Vec<Vec<(usize, [f64; 6])>> = vec![Vec::new(); minv.len()];
    for (i, row) in rows.iter().enumerate() {
        for &(b, j) in &row.blocks {
            per_body[b].push((i, j));
        }
    }
    let mut entries: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    for (b, list) in per_body.iter().enumerate() {
        let w = &minv[b];
        for &(i, ji) in list {
            for &(j, jj) in list {
                let v: f64 = (0..6).map(|d| ji[d] * w[d] * jj[d]).sum();
                *entries.entry((i, j)).or_insert(0.0) += v;
            }
        }
    }
    for i in 0..rows.len() {
        *entries.entry((i, i)).or_insert(0.0) += compliance / (H * H);
    }
    entries
}

/// `b = −J (v + h M⁻¹ f_gravity)`; `M⁻¹ f_gravity = (0, 0, −g, 0, 0, 0)` for every body.
fn rhs(rows: &[GenRow], vel: &[[f64; 6]]) -> Vec<f64> {
    rows.iter()
        .map(|row| {
            -row.blocks
                .iter()
                .map(|&(body, j)| {
                    let mut u = vel[body];
                    u[2] -= H * G;
                    (0..6).map(|d| j[d] * u[d]).sum::<f64>()
                })
                .sum::<f64>()
        })
        .collect()
}

/// The MLCP of `rows`, `A`'s `entries` and `b`, shuffled by a random symmetric permutation.
fn permuted_mlcp(
    rows: &[GenRow],
    entries: &BTreeMap<(usize, usize), f64>,
    b: &[f64],
    rng: &mut ChaCha8Rng,
) -> Mlcp {
    let m = rows.len();
    // Old row i becomes new_of[i].
    let mut new_of: Vec<usize> = (0..m).collect();
    new_of.shuffle(rng);
    let triplets: Vec<(usize, usize, f64)> =
        entries.iter().map(|(&(i, j), &v)| (new_of[i], new_of[j], v)).collect();
    let mut bp = vec![0.0; m];
    let mut lo = vec![0.0; m];
    let mut hi = vec![0.0; m];
    let mut findex = vec![None; m];
    for (i, row) in rows.iter().enumerate() {
        let k = new_of[i];
        bp[k] = b[i];
        lo[k] = row.lo;
        hi[k] = row.hi;
        findex[k] = row.findex.map(|j| new_of[j]);
    }
    let a = SymCsr::from_triplets(m, &triplets).expect("generated matrix is symmetric");
    Mlcp::new(a, bp, lo, hi, findex).expect("generated problem is valid")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::OrderingKind;
    use crate::solver::ordering::{self, OrderingWorkspace};
    use nalgebra::DMatrix;

    #[test]
    fn contact_like_is_a_valid_spd_problem_with_friction() {
        let p = contact_like(200, 7, 1_000.0);
        let n = p.n();
        assert!((190..=210).contains(&n), "size {n}");
        assert!(p.findex().iter().any(Option::is_some), "no friction rows");
        for (i, f) in p.findex().iter().enumerate() {
            if let Some(j) = *f {
                assert_eq!((p.lo()[i], p.hi()[i], p.lo()[j], p.hi()[j]), (-1.0, 1.0, 0.0, f64::INFINITY));
            }
        }
        let mut d = vec![0.0; n * n];
        p.a().to_dense(&mut d);
        for i in 0..n {
            for j in 0..n {
                assert_eq!(d[i * n + j], d[j * n + i]);
            }
        }
        let m = DMatrix::from_row_slice(n, n, &d);
        assert!(m.cholesky().is_some(), "A is not positive definite");
        // Sparse, and shuffled so that RCM reduces the bandwidth a lot.
        assert!(p.a().nnz() < n * n / 10);
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        ws.order(p.a(), OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
        assert!(ordering::bandwidth_permuted(p.a(), &inv) * 4 < ordering::bandwidth(p.a()));
        // Deterministic in the seed.
        assert_eq!(contact_like(200, 7, 1_000.0), p);
    }

    #[test]
    fn compliance_and_mu_change_only_the_diagonal_and_the_friction_boxes() {
        let base = IslandParams { m_target: 120, mass_ratio: 1e5, compliance: 1e-8, mu: 1.0 };
        let p = contact_like_with(&base, 11);
        let q = contact_like_with(&IslandParams { compliance: 1e-11, mu: 0.4, ..base }, 11);
        let n = p.n();
        assert_eq!((q.n(), q.b(), q.findex()), (n, p.b(), p.findex()));
        let shift = (1e-8 - 1e-11) / (H * H);
        for i in 0..n {
            for j in 0..n {
                let expect = if i == j { p.a().get(i, i) - shift } else { p.a().get(i, j) };
                assert!((q.a().get(i, j) - expect).abs() <= 1e-12 * (1.0 + expect.abs()), "A[{i}][{j}]");
            }
            match p.findex()[i] {
                Some(_) => assert_eq!((q.lo()[i], q.hi()[i]), (-0.4, 0.4)),
                None => assert_eq!((q.lo()[i], q.hi()[i]), (p.lo()[i], p.hi()[i])),
            }
        }
    }

    #[test]
    fn sweep_params_cover_the_ranges() {
        let ps: Vec<IslandParams> = (0..400).map(sweep_params).collect();
        let span = |f: &dyn Fn(&IslandParams) -> f64| {
            ps.iter().map(f).fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)))
        };
        let rows = span(&|p| p.m_target as f64);
        let ratio = span(&|p| p.mass_ratio);
        let c = span(&|p| p.compliance);
        let mu = span(&|p| p.mu);
        assert!(rows.0 < 60.0 && rows.1 > 900.0 && rows.0 >= 50.0 && rows.1 <= 1000.0, "{rows:?}");
        assert!(ratio.0 < 2e1 && ratio.1 > 5e8 && ratio.0 >= 1e1 && ratio.1 <= 1e9, "{ratio:?}");
        assert!(c.0 < 2e-12 && c.1 > 5e-7 && c.0 >= 1e-12 && c.1 <= 1e-6, "{c:?}");
        assert!(mu.0 < 0.35 && mu.1 > 0.95 && mu.0 >= 0.3 && mu.1 <= 1.0, "{mu:?}");
        assert_eq!(sweep_island(3).1, sweep_island(3).1);
    }
}
