//! Generated test problems: banded contact-like MLCPs of a given size and mass ratio, deterministic
//! in a seed. A test and benchmark utility (`bench-solver`, the solver's tests), not used by the
//! simulation itself.

use std::collections::BTreeMap;

use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Mlcp, SymCsr};

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
/// Constraint compliance `c` of the generated problems (adds `c/h²` to the diagonal).
const COMPLIANCE: f64 = 1e-8;
/// Gravity, m/s².
const G: f64 = 9.81;

/// A banded contact-like MLCP of about `m_target` rows: a serial chain of rigid bodies (6 DOF,
/// masses log-uniform in `[1, mass_ratio]`, diagonal inertia of random boxes) with ball joints
/// between neighbours (3 bilateral rows, blocks `[I, −[r]×]` with random lever arms) and frictional
/// ground contacts on a random half of the bodies (normal row `λ ≥ 0` and two friction rows with
/// `findex` → normal, `μ = 1`). `A = J M⁻¹ Jᵀ + (c/h²) I` with `h = 1/60`, `c = 1e-8`, assembled per
/// body (rows couple only through a shared body); `b = −J (v + h M⁻¹ f_gravity)` with small random
/// velocities, so some contacts separate and some friction rows slide. The rows are finally
/// shuffled by a random symmetric permutation (Cuthill–McKee has work to do).
pub fn contact_like(m_target: usize, seed: u64, mass_ratio: f64) -> Mlcp {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // 3 joint rows per link and 3 contact rows on half of the bodies: about 4.5 rows per body.
    let nb = ((m_target as f64 + 3.0) / 4.5).round().max(2.0) as usize;
    let (minv, vel) = random_bodies(nb, mass_ratio, &mut rng);
    let mut rows: Vec<GenRow> = Vec::with_capacity(m_target + 8);
    push_ball_joints(nb, &mut rng, &mut rows);
    push_ground_contacts(nb, &mut rng, &mut rows);
    let entries = assemble_a(&rows, &minv);
    let b = rhs(&rows, &vel);
    permuted_mlcp(&rows, &entries, &b, &mut rng)
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

/// A frictional ground contact (normal row and two friction rows, `μ = 1`) on a random half of the
/// bodies.
fn push_ground_contacts(nb: usize, rng: &mut ChaCha8Rng, rows: &mut Vec<GenRow>) {
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
                lo: -1.0,
                hi: 1.0,
                findex: Some(normal),
            });
        }
    }
}

/// The entries of `A = J M⁻¹ Jᵀ + c/h² I`, assembled per body.
fn assemble_a(rows: &[GenRow], minv: &[[f64; 6]]) -> BTreeMap<(usize, usize), f64> {
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
        *entries.entry((i, i)).or_insert(0.0) += COMPLIANCE / (H * H);
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
}
