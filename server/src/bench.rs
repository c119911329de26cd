//! `pivotsim-server bench-solver`: the solver benchmark (paper §3.2, Fig. 4, Tables 3 and 4).
//!
//! Stages, every timing the median of repeats (single thread, meant for a release build):
//!
//! 1. **Kernel crossover.** On a banded contact-like matrix (RCM order) one envelope factorization,
//!    one copy of `L₀` and single deletions at indices spread over the matrix, then a sweep over the
//!    tight count `t`: copy + `t` deletions from `L₀` against an envelope refactor of the masked
//!    matrix with the same `t` tight. The crossover is the `t` below which deletions win. The same
//!    dense: compact gather + dense Cholesky against dense copy + deletions, crossover in % tight.
//! 2. **Fig. 4.** Random dense SPD matrices, speed-up of (copy + deletions from `L₀`) over a dense
//!    refactor of the compact `A_FF`, per size and tight fraction; plotted to `fig4_speedup.svg`.
//! 3. **Generated contact-like MLCPs** ([`contact_like`]) and 4. **every shared data file**: every
//!    variant with the paper's step cap (35) and with 1000 steps, plus a run that measures the
//!    deletion error (paper Table 4) for the variants that delete.
//! 5. `bench.md`, `bench.json`, `fig4_speedup.svg`, `solve_time.svg` in the output directory, the
//!    markdown and a summary on stdout.
//!
//! Every loop is bounded: repeats are capped, and a 1000-step run whose predicted time exceeds the
//! mode's budget is skipped (and reported as skipped); a run that converged within 35 steps is not
//! repeated with 1000 (the iterates are the same).

use std::fmt::Write as _;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use nalgebra::DMatrix;
use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::solver::envelope::Envelope;
use crate::solver::ordering::{self, OrderingWorkspace};
use crate::solver::{
    Mlcp, OrderingKind, SolveStats, SolveStatus, Solver, SolverOptions, SymCsr, Variant, dense, io,
};

/// Step cap of the paper (Table 1).
const SHORT_STEPS: usize = 35;
/// Generous step cap: does the pivoting converge at all?
const LONG_STEPS: usize = 1000;

/// What to run and where to write it.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// Output directory (created).
    pub out: PathBuf,
    /// Smaller sizes and fewer repeats (under a minute).
    pub quick: bool,
    /// Directory scanned for `*.txt` MLCP files instead of the shared data directories.
    pub data: Option<PathBuf>,
    /// Minimal sizes for the unit test (seconds in a test build); implies `quick`.
    pub tiny: bool,
}

impl BenchConfig {
    /// A configuration; `out` defaults to `bench-out/`.
    pub fn new(out: Option<PathBuf>, quick: bool, data: Option<PathBuf>) -> Self {
        BenchConfig { out: out.unwrap_or_else(|| PathBuf::from("bench-out")), quick, data, tiny: false }
    }
}

/// Sizes, repeats and budgets of one mode.
#[derive(Debug, Clone)]
struct Plan {
    mode: &'static str,
    /// Target duration of one timing sample of a kernel (µs); the kernel is looped to fill it.
    kernel_target_us: f64,
    kernel_repeats: usize,
    kernel_m: usize,
    kernel_t_max: usize,
    /// Random tight sets averaged per tight count in the envelope sweep.
    kernel_sets: usize,
    dense_repeats: usize,
    dense_fracs: Vec<f64>,
    fig4_m: Vec<usize>,
    fig4_fracs: Vec<f64>,
    fig4_target_us: f64,
    fig4_repeats: usize,
    /// Generated problems: (target size, seed, mass ratio).
    generated: Vec<(usize, u64, f64)>,
    /// Time budget for the repeats of one 35-step measurement (µs).
    solve_budget_us: f64,
    solve_max_repeats: usize,
    /// Largest predicted duration of a single 1000-step or deletion-error run (µs).
    long_budget_us: f64,
    /// Generated size whose problems the summary reports on.
    focus_m: usize,
    /// Busy work before the first timing (µs).
    warm_up_us: f64,
}

impl Plan {
    fn for_config(cfg: &BenchConfig) -> Self {
        if cfg.tiny {
            return Plan {
                mode: "tiny",
                kernel_target_us: 50.0,
                kernel_repeats: 3,
                kernel_m: 60,
                kernel_t_max: 8,
                kernel_sets: 1,
                dense_repeats: 1,
                dense_fracs: vec![5.0, 20.0],
                fig4_m: vec![20, 40],
                fig4_fracs: vec![5.0, 20.0, 50.0],
                fig4_target_us: 50.0,
                fig4_repeats: 1,
                generated: vec![(40, 1, 100.0)],
                solve_budget_us: 5_000.0,
                solve_max_repeats: 2,
                long_budget_us: 500_000.0,
                focus_m: 40,
                warm_up_us: 0.0,
            };
        }
        let fig4_fracs = vec![1.0, 5.0, 10.0, 15.0, 20.0, 30.0, 50.0];
        if cfg.quick {
            Plan {
                mode: "quick",
                kernel_target_us: 300.0,
                kernel_repeats: 5,
                kernel_m: 430,
                kernel_t_max: 40,
                kernel_sets: 3,
                dense_repeats: 3,
                dense_fracs: vec![1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0],
                fig4_m: vec![50, 100, 200],
                fig4_fracs,
                fig4_target_us: 2_000.0,
                fig4_repeats: 3,
                generated: vec![(100, 1, 6_300.0), (430, 5, 6_300.0), (430, 6, 400.0)],
                solve_budget_us: 100_000.0,
                solve_max_repeats: 9,
                long_budget_us: 1_000_000.0,
                focus_m: 430,
                warm_up_us: 300_000.0,
            }
        } else {
            Plan {
                mode: "full",
                kernel_target_us: 1_000.0,
                kernel_repeats: 9,
                kernel_m: 430,
                kernel_t_max: 64,
                kernel_sets: 5,
                dense_repeats: 5,
                dense_fracs: vec![
                    1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 40.0,
                ],
                fig4_m: vec![50, 100, 200, 400, 700, 1000],
                fig4_fracs,
                fig4_target_us: 5_000.0,
                fig4_repeats: 5,
                generated: vec![
                    (100, 1, 6_300.0),
                    (100, 2, 400.0),
                    (200, 3, 6_300.0),
                    (200, 4, 20_000.0),
                    (430, 5, 6_300.0),
                    (430, 6, 400.0),
                    (430, 7, 20_000.0),
                    (1000, 8, 6_300.0),
                ],
                solve_budget_us: 600_000.0,
                solve_max_repeats: 21,
                long_budget_us: 20_000_000.0,
                focus_m: 430,
                warm_up_us: 1_000_000.0,
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Generator
// ---------------------------------------------------------------------------------------------

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

/// A banded contact-like MLCP of about `m_target` rows: a serial chain of rigid bodies (6 DOF,
/// masses log-uniform in `[1, mass_ratio]`, diagonal inertia of random boxes) with ball joints
/// between neighbours (3 bilateral rows, blocks `[I, −[r]×]` with random lever arms) and frictional
/// ground contacts on a random half of the bodies (normal row `λ ≥ 0` and two friction rows with
/// `findex` → normal, `μ = 1`). `A = J M⁻¹ Jᵀ + (c/h²) I` with `h = 1/60`, `c = 1e-8`, assembled per
/// body (rows couple only through a shared body); `b = −J (v + h M⁻¹ f_gravity)` with small random
/// velocities, so some contacts separate and some friction rows slide. The rows are finally
/// shuffled by a random symmetric permutation (Cuthill–McKee has work to do).
pub fn contact_like(m_target: usize, seed: u64, mass_ratio: f64) -> Mlcp {
    const H: f64 = 1.0 / 60.0;
    const COMPLIANCE: f64 = 1e-8;
    const G: f64 = 9.81;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // 3 joint rows per link and 3 contact rows on half of the bodies: about 4.5 rows per body.
    let nb = ((m_target as f64 + 3.0) / 4.5).round().max(2.0) as usize;
    let ln_ratio = mass_ratio.max(1.0).ln();

    // Bodies: inverse mass matrix diagonal and velocity (linear, angular).
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

    let mut rows: Vec<GenRow> = Vec::with_capacity(m_target + 8);
    // Ball joints between neighbours.
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
    // Ground contacts on a random half of the bodies.
    let mut which: Vec<usize> = (0..nb).collect();
    which.shuffle(&mut rng);
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
    let m = rows.len();

    // A = J M⁻¹ Jᵀ + c/h² I, assembled per body.
    let mut per_body: Vec<Vec<(usize, [f64; 6])>> = vec![Vec::new(); nb];
    for (i, row) in rows.iter().enumerate() {
        for &(b, j) in &row.blocks {
            per_body[b].push((i, j));
        }
    }
    let mut entries: std::collections::BTreeMap<(usize, usize), f64> = std::collections::BTreeMap::new();
    for (b, list) in per_body.iter().enumerate() {
        let w = &minv[b];
        for &(i, ji) in list {
            for &(j, jj) in list {
                let v: f64 = (0..6).map(|d| ji[d] * w[d] * jj[d]).sum();
                *entries.entry((i, j)).or_insert(0.0) += v;
            }
        }
    }
    for i in 0..m {
        *entries.entry((i, i)).or_insert(0.0) += COMPLIANCE / (H * H);
    }
    // b = −J (v + h M⁻¹ f_gravity); M⁻¹ f_gravity = (0, 0, −g, 0, 0, 0) for every body.
    let b: Vec<f64> = rows
        .iter()
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
        .collect();

    // Random symmetric permutation: old row i becomes new_of[i].
    let mut new_of: Vec<usize> = (0..m).collect();
    new_of.shuffle(&mut rng);
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

// ---------------------------------------------------------------------------------------------
// Timing helpers
// ---------------------------------------------------------------------------------------------

fn us(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e6
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// Median time of one call of `f` in µs: one calibration call, then `repeats` samples of
/// `inner` calls each, `inner` chosen so that a sample lasts about `target_us` (at most 200 000).
fn time_us(target_us: f64, repeats: usize, mut f: impl FnMut()) -> f64 {
    let t = Instant::now();
    f();
    let first = us(t).max(0.02);
    let inner = ((target_us / first).ceil() as usize).clamp(1, 200_000);
    let mut samples = Vec::with_capacity(repeats.max(1));
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        for _ in 0..inner {
            f();
        }
        samples.push(us(t) / inner as f64);
    }
    median(&mut samples)
}

/// Dense Cholesky factorizations until `budget_us` has passed (bounded by 100 000 rounds).
fn warm_up(budget_us: f64) {
    let n = 120;
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let a = random_spd(n, &mut rng);
    let mut l = a.clone();
    let t = Instant::now();
    for _ in 0..100_000 {
        if us(t) >= budget_us {
            break;
        }
        l.copy_from_slice(&a);
        dense::cholesky_in_place(&mut l, n, 2.0);
        black_box(&mut l);
    }
}

fn geo_mean(v: &[f64]) -> Option<f64> {
    let v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite() && *x > 0.0).collect();
    if v.is_empty() { None } else { Some((v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp()) }
}

// ---------------------------------------------------------------------------------------------
// Kernel crossover and Fig. 4
// ---------------------------------------------------------------------------------------------

/// One point of a tight-count sweep.
#[derive(Debug, Clone, Serialize)]
struct SweepPoint {
    tight: usize,
    tight_pct: f64,
    /// Copy of `L₀` plus `tight` deletions (µs).
    downdate_us: f64,
    /// Refactor with the same tight set (µs).
    refactor_us: f64,
    /// `refactor_us / downdate_us`.
    speedup: f64,
}

/// Where `downdate / refactor` first reaches 1 along a sweep (interpolated on the given axis).
#[derive(Debug, Clone, Serialize)]
struct Crossover {
    /// Interpolated value, or the first/last point when the sweep does not bracket it.
    value: Option<f64>,
    /// "interpolated", "below-first-point" or "beyond-last-point".
    kind: &'static str,
}

fn crossover(points: &[SweepPoint], axis: impl Fn(&SweepPoint) -> f64) -> Crossover {
    let ratio = |p: &SweepPoint| p.downdate_us / p.refactor_us;
    match points.iter().position(|p| ratio(p) >= 1.0) {
        None => Crossover { value: points.last().map(&axis), kind: "beyond-last-point" },
        Some(0) => Crossover { value: Some(axis(&points[0])), kind: "below-first-point" },
        Some(k) => {
            let (p, q) = (&points[k - 1], &points[k]);
            let (rp, rq) = (ratio(p), ratio(q));
            let s = if rq > rp { (1.0 - rp) / (rq - rp) } else { 1.0 };
            Crossover { value: Some(axis(p) + s * (axis(q) - axis(p))), kind: "interpolated" }
        }
    }
}

fn fmt_crossover(c: &Crossover, unit: &str, digits: usize) -> String {
    match (c.value, c.kind) {
        (None, _) => "—".into(),
        (Some(v), "below-first-point") => format!("< {v:.digits$}{unit}"),
        (Some(v), "beyond-last-point") => format!("> {v:.digits$}{unit}"),
        (Some(v), _) => format!("{v:.digits$}{unit}"),
    }
}

/// Envelope kernels on one matrix (RCM order).
#[derive(Debug, Clone, Serialize)]
struct EnvelopeKernel {
    matrix: String,
    m: usize,
    bandwidth_input: usize,
    bandwidth_rcm: usize,
    envelope_entries: usize,
    factor_us: f64,
    copy_us: f64,
    deletion_us_mean: f64,
    deletion_us_min: f64,
    deletion_us_max: f64,
    /// (index, µs) of the single deletions.
    deletions: Vec<(usize, f64)>,
    sweep: Vec<SweepPoint>,
    /// Tight count below which copy + deletions beat the masked refactor (measured sweep).
    crossover_tight: Crossover,
    /// Same from the single-kernel timings: `(factor − copy) / deletion`.
    crossover_model: f64,
}

fn envelope_kernel(name: &str, a: &SymCsr, plan: &Plan, seed: u64) -> EnvelopeKernel {
    let m = a.n();
    let (tu, reps) = (plan.kernel_target_us, plan.kernel_repeats);
    let mut ws = OrderingWorkspace::new();
    let (mut perm, mut inv) = (Vec::new(), Vec::new());
    ws.order(a, OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
    let mut ap = SymCsr::default();
    ap.permuted_from(a, &perm, &inv);
    let mut env = Envelope::new();
    env.build(&ap);
    let maxd = ap.max_diag();
    let mut mask = vec![false; m];
    let mut l0 = vec![0.0; env.len()];
    env.factor_from(&ap, &mask, &mut l0, 0, maxd);
    let mut l = l0.clone();
    let mut sigma = vec![0.0; m];

    let factor_us = time_us(tu, reps, || {
        env.factor_from(&ap, &mask, &mut l, 0, maxd);
        black_box(&mut l);
    });
    let copy_us = time_us(tu, reps, || {
        l.copy_from_slice(&l0);
        black_box(&mut l);
    });
    let k = 8.min(m);
    let mut deletions = Vec::with_capacity(k);
    for q in 0..k {
        let i = (2 * q + 1) * m / (2 * k);
        let t = time_us(tu, reps, || {
            l.copy_from_slice(&l0);
            env.delete(&mut l, i, &mut sigma);
            black_box(&mut l);
        });
        deletions.push((i, (t - copy_us).max(0.0)));
    }
    let dels: Vec<f64> = deletions.iter().map(|d| d.1).collect();
    let deletion_us_mean = dels.iter().sum::<f64>() / dels.len().max(1) as f64;
    let deletion_us_min = dels.iter().copied().fold(f64::INFINITY, f64::min);
    let deletion_us_max = dels.iter().copied().fold(0.0, f64::max);

    // Deletion cost depends on the position (the sweep runs to the end of the connected block), so
    // every tight count is averaged over several random nested tight sets.
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let orders: Vec<Vec<usize>> = (0..plan.kernel_sets.max(1))
        .map(|_| {
            let mut o: Vec<usize> = (0..m).collect();
            o.shuffle(&mut rng);
            o
        })
        .collect();
    let mut sweep = Vec::new();
    for t in 1..=plan.kernel_t_max.min(m.saturating_sub(1)) {
        let (mut downdate_us, mut refactor_us) = (0.0, 0.0);
        for order in &orders {
            let mut set = order[..t].to_vec();
            set.sort_unstable();
            mask.fill(false);
            for &i in &set {
                mask[i] = true;
            }
            downdate_us += time_us(tu, reps, || {
                l.copy_from_slice(&l0);
                for &i in &set {
                    env.delete(&mut l, i, &mut sigma);
                }
                black_box(&mut l);
            });
            refactor_us += time_us(tu, reps, || {
                env.factor_from(&ap, &mask, &mut l, 0, maxd);
                black_box(&mut l);
            });
        }
        downdate_us /= orders.len() as f64;
        refactor_us /= orders.len() as f64;
        sweep.push(SweepPoint {
            tight: t,
            tight_pct: 100.0 * t as f64 / m as f64,
            downdate_us,
            refactor_us,
            speedup: refactor_us / downdate_us,
        });
    }
    let crossover_tight = crossover(&sweep, |p| p.tight as f64);
    EnvelopeKernel {
        matrix: name.to_string(),
        m,
        bandwidth_input: ordering::bandwidth(a),
        bandwidth_rcm: ordering::bandwidth(&ap),
        envelope_entries: env.len(),
        factor_us,
        copy_us,
        deletion_us_mean,
        deletion_us_min,
        deletion_us_max,
        deletions,
        sweep,
        crossover_tight,
        crossover_model: (factor_us - copy_us) / deletion_us_mean.max(1e-9),
    }
}

/// Dense kernels on one matrix (input order).
#[derive(Debug, Clone, Serialize)]
struct DenseKernel {
    matrix: String,
    m: usize,
    /// Gather + dense Cholesky of the whole matrix (µs).
    factor_us: f64,
    copy_us: f64,
    deletion_us_mean: f64,
    sweep: Vec<SweepPoint>,
    crossover_pct: Crossover,
}

/// Column-major `m × m` random SPD matrix `(B Bᵀ + m I) / m`, `B` uniform in `[−1, 1]`.
fn random_spd(m: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let b = DMatrix::<f64>::from_fn(m, m, |_, _| rng.random_range(-1.0..1.0));
    let mut a = &b * b.transpose();
    for i in 0..m {
        a[(i, i)] += m as f64;
    }
    a /= m as f64;
    a.as_slice().to_vec()
}

/// Lower triangle of the compact `A_FF` (column-major `nf × nf`) gathered from the dense `a`.
fn gather_compact(a: &[f64], m: usize, free: &[usize], out: &mut [f64]) {
    let nf = free.len();
    for (c, &fc) in free.iter().enumerate() {
        let col = &a[fc * m..fc * m + m];
        let dst = &mut out[c * nf..c * nf + nf];
        for r in c..nf {
            dst[r] = col[free[r]];
        }
    }
}

/// Sweep over tight fractions (%) of (copy + deletions from dense `L₀`) against (gather + dense
/// Cholesky of the compact `A_FF`). Tight sets are nested prefixes of one random permutation.
fn dense_sweep(
    a: &[f64],
    m: usize,
    fracs: &[f64],
    tu: f64,
    reps: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<SweepPoint> {
    let maxd = (0..m).map(|i| a[i * m + i]).fold(0.0, f64::max);
    let mut l0 = a.to_vec();
    dense::cholesky_in_place(&mut l0, m, maxd);
    let mut l = vec![0.0; m * m];
    let mut compact = vec![0.0; m * m];
    let mut sigma = vec![0.0; m];
    let mut order: Vec<usize> = (0..m).collect();
    order.shuffle(rng);
    let mut out = Vec::with_capacity(fracs.len());
    for &pct in fracs {
        let t = ((pct / 100.0 * m as f64).round() as usize).clamp(1, m.saturating_sub(1).max(1));
        let mut set = order[..t].to_vec();
        set.sort_unstable();
        let mut is_t = vec![false; m];
        for &i in &set {
            is_t[i] = true;
        }
        let free: Vec<usize> = (0..m).filter(|&i| !is_t[i]).collect();
        let nf = free.len();
        let downdate_us = time_us(tu, reps, || {
            l.copy_from_slice(&l0);
            for &i in &set {
                dense::delete_in_place(&mut l, m, i, &mut sigma);
            }
            black_box(&mut l);
        });
        let refactor_us = time_us(tu, reps, || {
            gather_compact(a, m, &free, &mut compact);
            dense::cholesky_in_place(&mut compact[..nf * nf], nf, maxd);
            black_box(&mut compact);
        });
        out.push(SweepPoint {
            tight: t,
            tight_pct: 100.0 * t as f64 / m as f64,
            downdate_us,
            refactor_us,
            speedup: refactor_us / downdate_us,
        });
    }
    out
}

fn dense_kernel(name: &str, a: &[f64], m: usize, plan: &Plan, seed: u64) -> DenseKernel {
    let (tu, reps) = (plan.kernel_target_us, plan.dense_repeats);
    let maxd = (0..m).map(|i| a[i * m + i]).fold(0.0, f64::max);
    let mut l0 = a.to_vec();
    dense::cholesky_in_place(&mut l0, m, maxd);
    let mut l = a.to_vec();
    let mut sigma = vec![0.0; m];
    let factor_us = time_us(tu, reps, || {
        l.copy_from_slice(a);
        dense::cholesky_in_place(&mut l, m, maxd);
        black_box(&mut l);
    });
    let copy_us = time_us(tu, reps, || {
        l.copy_from_slice(&l0);
        black_box(&mut l);
    });
    let k = 8.min(m);
    let mut dels = Vec::with_capacity(k);
    for q in 0..k {
        let i = (2 * q + 1) * m / (2 * k);
        let t = time_us(tu, reps, || {
            l.copy_from_slice(&l0);
            dense::delete_in_place(&mut l, m, i, &mut sigma);
            black_box(&mut l);
        });
        dels.push((t - copy_us).max(0.0));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sweep = dense_sweep(a, m, &plan.dense_fracs, tu, reps, &mut rng);
    let crossover_pct = crossover(&sweep, |p| p.tight_pct);
    DenseKernel {
        matrix: name.to_string(),
        m,
        factor_us,
        copy_us,
        deletion_us_mean: dels.iter().sum::<f64>() / dels.len().max(1) as f64,
        sweep,
        crossover_pct,
    }
}

/// Paper Fig. 4 grid.
#[derive(Debug, Clone, Serialize)]
struct Fig4 {
    sizes: Vec<usize>,
    tight_pct: Vec<f64>,
    /// One sweep per size, in `sizes` order.
    sweeps: Vec<Vec<SweepPoint>>,
}

// ---------------------------------------------------------------------------------------------
// Solver runs
// ---------------------------------------------------------------------------------------------

/// One solver configuration on one problem.
#[derive(Debug, Clone, Serialize)]
struct RunRecord {
    max_steps: usize,
    status: SolveStatus,
    pivot_steps: usize,
    iterations: usize,
    tight: usize,
    residual: f64,
    residual_rel: f64,
    /// Median `total_us` over the timed repeats.
    time_us: f64,
    /// Every timed repeat (the warm-up solve excluded when there is more than one run).
    time_us_samples: Vec<f64>,
    /// `time_us` per pivot step (PGS: per sweep).
    us_per_step: Option<f64>,
    ordering_us: f64,
    factor_us: f64,
    downdate_us: f64,
    solve_us: f64,
    deletions: usize,
    auto_choices: [usize; 3],
    regularized: usize,
    fallback: bool,
    murty_steps: usize,
    friction_updates: usize,
    /// Whether the repeats disagreed on the step count (should never happen).
    nondeterministic: bool,
    /// Copied from the 35-step run (which had converged) instead of run again.
    from_short: bool,
}

impl RunRecord {
    fn from_stats(st: &SolveStats, max_steps: usize, samples: Vec<f64>, nondeterministic: bool) -> Self {
        let mut s = samples.clone();
        let time_us = median(&mut s);
        let steps = if st.variant == Variant::Pgs { st.iterations } else { st.pivot_steps };
        RunRecord {
            max_steps,
            status: st.status,
            pivot_steps: st.pivot_steps,
            iterations: st.iterations,
            tight: st.tight,
            residual: st.residual,
            residual_rel: st.residual_rel,
            time_us,
            time_us_samples: samples,
            us_per_step: (steps > 0).then(|| time_us / steps as f64),
            ordering_us: st.ordering_us,
            factor_us: st.factor_us,
            downdate_us: st.downdate_us,
            solve_us: st.solve_us,
            deletions: st.deletions,
            auto_choices: st.auto_choices,
            regularized: st.regularized,
            fallback: st.fallback,
            murty_steps: st.murty_steps,
            friction_updates: st.friction_updates,
            nondeterministic,
            from_short: false,
        }
    }

    fn converged(&self) -> bool {
        self.status == SolveStatus::Converged
    }

    fn steps(&self) -> usize {
        self.pivot_steps.max(self.iterations)
    }
}

/// Every measurement of one variant on one problem.
#[derive(Debug, Clone, Serialize)]
struct VariantResult {
    variant: Variant,
    short: RunRecord,
    long: Option<RunRecord>,
    long_skipped: Option<String>,
    deletion_error: Option<f64>,
    deletion_error_abs: Option<f64>,
    deletion_backward_error: Option<f64>,
    deletion_error_skipped: Option<String>,
    /// Regularized pivots in the deletion-error run (a semidefinite `A`; the error is then large).
    deletion_run_regularized: usize,
}

/// One problem and its results.
#[derive(Debug, Clone, Serialize)]
struct ProblemResult {
    name: String,
    /// "generated", "scene" (shared/data/mlcp-scene), "siconos" (shared/data/mlcp) or "data".
    group: String,
    path: Option<String>,
    seed: Option<u64>,
    mass_ratio: Option<f64>,
    m: usize,
    nnz: usize,
    rows_unbounded: usize,
    rows_friction: usize,
    rows_other: usize,
    bandwidth_before: usize,
    bandwidth_after: usize,
    envelope_before: usize,
    envelope_after: usize,
    variants: Vec<VariantResult>,
}

impl ProblemResult {
    fn variant(&self, v: Variant) -> Option<&VariantResult> {
        self.variants.iter().find(|r| r.variant == v)
    }
}

fn options(variant: Variant, max_steps: usize) -> SolverOptions {
    let mut o = SolverOptions { variant, max_steps, ..Default::default() };
    o.pgs.max_iterations = max_steps;
    o.pgs.tol_rel = o.tol_rel;
    o
}

/// A warm-up solve, then `1..=max_repeats` timed solves within `budget_us` (one solve only when the
/// warm-up alone exceeds the budget, `single`).
fn timed_solve(p: &Mlcp, opts: SolverOptions, budget_us: f64, max_repeats: usize, single: bool) -> RunRecord {
    let mut solver = Solver::new(opts);
    let mut lambda = vec![0.0; p.n()];
    let first = solver.solve(p, &mut lambda).clone();
    let t1 = first.total_us.max(1.0);
    if single || t1 >= budget_us {
        return RunRecord::from_stats(&first, opts.max_steps, vec![first.total_us], false);
    }
    let reps = ((budget_us / t1).floor() as usize).clamp(1, max_repeats.max(1));
    let mut samples = Vec::with_capacity(reps);
    let mut nondet = false;
    let mut last = first.clone();
    for _ in 0..reps {
        lambda.fill(0.0);
        let st = solver.solve(p, &mut lambda);
        samples.push(st.total_us);
        nondet |= st.pivot_steps != first.pivot_steps || st.iterations != first.iterations;
        last = st.clone();
    }
    RunRecord::from_stats(&last, opts.max_steps, samples, nondet)
}

fn run_problem(
    name: String,
    group: &str,
    path: Option<&Path>,
    origin: Option<(u64, f64)>,
    p: &Mlcp,
    plan: &Plan,
    pb: &ProgressBar,
) -> ProblemResult {
    let a = p.a();
    let m = p.n();
    let mut ws = OrderingWorkspace::new();
    let (mut perm, mut inv) = (Vec::new(), Vec::new());
    ws.order(a, OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
    let rows_friction = p.findex().iter().filter(|f| f.is_some()).count();
    let rows_unbounded =
        (0..m).filter(|&i| p.lo()[i] == f64::NEG_INFINITY && p.hi()[i] == f64::INFINITY).count();
    let mut variants = Vec::with_capacity(Variant::ALL.len());
    for v in Variant::ALL {
        pb.set_message(format!("{name} [{v}]"));
        let short =
            timed_solve(p, options(v, SHORT_STEPS), plan.solve_budget_us, plan.solve_max_repeats, false);
        let (long, long_skipped) = if short.converged() {
            let mut l = short.clone();
            l.max_steps = LONG_STEPS;
            l.from_short = true;
            (Some(l), None)
        } else {
            let est = short.time_us * LONG_STEPS as f64 / short.steps().max(1) as f64;
            if est > plan.long_budget_us {
                (None, Some(format!("predicted {:.1} s", est * 1e-6)))
            } else {
                (Some(timed_solve(p, options(v, LONG_STEPS), 0.0, 1, true)), None)
            }
        };
        variants.push(VariantResult {
            variant: v,
            short,
            long,
            long_skipped,
            deletion_error: None,
            deletion_error_abs: None,
            deletion_backward_error: None,
            deletion_error_skipped: None,
            deletion_run_regularized: 0,
        });
        pb.inc(1);
    }
    // Deletion error (paper Table 4) for the variants that delete, outside the timings. The
    // measurement refactors at every deletion step: predict its cost from the refactoring variants.
    let time_of = |v: Variant, vs: &[VariantResult]| {
        vs.iter().find(|r| r.variant == v).map(|r| r.short.time_us).unwrap_or(0.0)
    };
    for v in [Variant::Downdate, Variant::Skyline, Variant::Auto] {
        let refactor = if v == Variant::Downdate { Variant::Full } else { Variant::SkylineRefactor };
        let est = time_of(v, &variants) + 2.0 * time_of(refactor, &variants);
        let Some(k) = variants.iter().position(|r| r.variant == v) else { continue };
        if est > plan.long_budget_us {
            variants[k].deletion_error_skipped = Some(format!("predicted {:.1} s", est * 1e-6));
            continue;
        }
        let mut opts = options(v, SHORT_STEPS);
        opts.measure_deletion_error = true;
        let mut solver = Solver::new(opts);
        let mut lambda = vec![0.0; m];
        let st = solver.solve(p, &mut lambda);
        variants[k].deletion_error = st.deletion_error;
        variants[k].deletion_error_abs = st.deletion_error_abs;
        variants[k].deletion_backward_error = st.deletion_backward_error;
        variants[k].deletion_run_regularized = st.regularized;
    }
    ProblemResult {
        name,
        group: group.to_string(),
        path: path.map(|p| p.display().to_string()),
        seed: origin.map(|g| g.0),
        mass_ratio: origin.map(|g| g.1),
        m,
        nnz: a.nnz(),
        rows_unbounded,
        rows_friction,
        rows_other: m - rows_unbounded - rows_friction,
        bandwidth_before: ordering::bandwidth(a),
        bandwidth_after: ordering::bandwidth_permuted(a, &inv),
        envelope_before: ordering::envelope(a),
        envelope_after: ordering::envelope_permuted(a, &inv),
        variants,
    }
}

// ---------------------------------------------------------------------------------------------
// Summary
// ---------------------------------------------------------------------------------------------

/// Headline numbers of a run (also in `bench.json` and printed at the end).
#[derive(Debug, Clone, Default, Serialize)]
pub struct Summary {
    /// Mode: quick, full or tiny.
    pub mode: String,
    /// Generated contact-like problems of the focus size (m ≈ 430) the ratios are taken over.
    pub focus_problems: Vec<String>,
    /// Geometric mean over the focus problems of `time(full) / time(auto)`, 35 steps.
    pub auto_vs_full: Option<f64>,
    /// Same for `skyline` (paper Table 3, crane: 3.6×).
    pub skyline_vs_full: Option<f64>,
    /// Same for `downdate` (paper Table 3, crane: 2.7×).
    pub downdate_vs_full: Option<f64>,
    /// Median over the focus problems of auto's µs per pivot step.
    pub auto_us_per_step: Option<f64>,
    /// Median over the focus problems of auto's ms per solve (35-step cap).
    pub auto_ms_per_solve: Option<f64>,
    /// Same four numbers on `scene-crane430` when it was loaded: (auto/full, skyline/full,
    /// µs per step auto, ms per solve auto).
    pub crane430: Option<(f64, f64, f64, f64)>,
    /// Problems (all sources) the `auto` variant converged on within 35 steps, and the total.
    pub converged_35: (usize, usize),
    /// Same within 1000 steps (skipped runs count as not converged).
    pub converged_1000: (usize, usize),
    /// Worst relative deletion error over every problem and deleting variant, with where.
    pub worst_deletion_error_rel: Option<(f64, String)>,
    /// Worst absolute deletion error (paper Table 4 unit), with where.
    pub worst_deletion_error_abs: Option<(f64, String)>,
    /// Worst relative and absolute deletion errors over the runs without regularized pivots
    /// (positive definite `A`, the setting of paper Table 4).
    pub worst_deletion_error_spd: Option<(f64, f64, String)>,
    /// Largest backward error `‖L Lᵀ − A_FF‖_F / ‖A_FF‖_F` of a deleted envelope factor, and where.
    pub worst_deletion_backward_error: Option<(f64, String)>,
    /// Envelope kernel crossover (tight count) on the generated contact-like matrix.
    pub envelope_crossover_tight: Option<f64>,
    /// Dense kernel crossover (% tight) on the random dense SPD matrix of the kernel size.
    pub dense_crossover_pct: Option<f64>,
    /// Wall time of the whole benchmark, s.
    pub elapsed_s: f64,
}

fn ratio_of(p: &ProblemResult, num: Variant, den: Variant) -> Option<f64> {
    Some(p.variant(num)?.short.time_us / p.variant(den)?.short.time_us)
}

fn summarize(plan: &Plan, problems: &[ProblemResult], env: &[EnvelopeKernel], dk: &[DenseKernel]) -> Summary {
    let lo = plan.focus_m as f64 * 0.9;
    let hi = plan.focus_m as f64 * 1.1;
    let focus: Vec<&ProblemResult> = problems
        .iter()
        .filter(|p| p.group == "generated" && (p.m as f64) >= lo && (p.m as f64) <= hi)
        .collect();
    let ratios =
        |num: Variant| -> Vec<f64> { focus.iter().filter_map(|p| ratio_of(p, Variant::Full, num)).collect() };
    let mut per_step: Vec<f64> =
        focus.iter().filter_map(|p| p.variant(Variant::Auto)?.short.us_per_step).collect();
    let mut per_solve: Vec<f64> =
        focus.iter().filter_map(|p| Some(p.variant(Variant::Auto)?.short.time_us * 1e-3)).collect();
    let crane430 = problems.iter().find(|p| p.name.contains("crane430")).and_then(|p| {
        let auto = p.variant(Variant::Auto)?;
        Some((
            ratio_of(p, Variant::Full, Variant::Auto)?,
            ratio_of(p, Variant::Full, Variant::Skyline)?,
            auto.short.us_per_step?,
            auto.short.time_us * 1e-3,
        ))
    });
    let autos: Vec<&VariantResult> = problems.iter().filter_map(|p| p.variant(Variant::Auto)).collect();
    let c35 = autos.iter().filter(|r| r.short.converged()).count();
    let c1000 = autos.iter().filter(|r| r.long.as_ref().is_some_and(RunRecord::converged)).count();
    let mut worst_rel: Option<(f64, String)> = None;
    let mut worst_abs: Option<(f64, String)> = None;
    let mut worst_spd: Option<(f64, f64, String)> = None;
    let mut worst_back: Option<(f64, String)> = None;
    for p in problems {
        for r in &p.variants {
            if let Some(e) =
                r.deletion_backward_error.filter(|e| worst_back.as_ref().is_none_or(|w| *e > w.0))
            {
                worst_back = Some((e, format!("{} [{}]", p.name, r.variant)));
            }
            if let (Some(e), Some(a), 0) =
                (r.deletion_error, r.deletion_error_abs, r.deletion_run_regularized)
            {
                let (we, wa, wat) = worst_spd.take().unwrap_or((0.0, 0.0, String::new()));
                let wat = if e > we { format!("{} [{}]", p.name, r.variant) } else { wat };
                worst_spd = Some((we.max(e), wa.max(a), wat));
            }
            let at = format!("{} [{}]", p.name, r.variant);
            if let Some(e) = r.deletion_error.filter(|e| worst_rel.as_ref().is_none_or(|w| *e > w.0)) {
                worst_rel = Some((e, at.clone()));
            }
            if let Some(e) = r.deletion_error_abs.filter(|e| worst_abs.as_ref().is_none_or(|w| *e > w.0)) {
                worst_abs = Some((e, at));
            }
        }
    }
    Summary {
        mode: plan.mode.to_string(),
        focus_problems: focus.iter().map(|p| p.name.clone()).collect(),
        auto_vs_full: geo_mean(&ratios(Variant::Auto)),
        skyline_vs_full: geo_mean(&ratios(Variant::Skyline)),
        downdate_vs_full: geo_mean(&ratios(Variant::Downdate)),
        auto_us_per_step: (!per_step.is_empty()).then(|| median(&mut per_step)),
        auto_ms_per_solve: (!per_solve.is_empty()).then(|| median(&mut per_solve)),
        crane430,
        converged_35: (c35, autos.len()),
        converged_1000: (c1000, autos.len()),
        worst_deletion_error_rel: worst_rel,
        worst_deletion_error_abs: worst_abs,
        worst_deletion_error_spd: worst_spd,
        worst_deletion_backward_error: worst_back,
        envelope_crossover_tight: env.first().and_then(|e| e.crossover_tight.value),
        dense_crossover_pct: dk
            .iter()
            .find(|d| d.matrix.starts_with("random"))
            .and_then(|d| d.crossover_pct.value),
        elapsed_s: 0.0,
    }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}")).unwrap_or_else(|| "—".into())
}

fn summary_text(s: &Summary) -> String {
    let mut t = String::new();
    let pct = |(a, n): (usize, usize)| if n == 0 { 0.0 } else { 100.0 * a as f64 / n as f64 };
    let _ = writeln!(t, "Summary ({} mode, {:.1} s)", s.mode, s.elapsed_s);
    let _ = writeln!(t, "  contact-like m≈430 problems: {}", s.focus_problems.join(", "));
    let _ = writeln!(t, "    auto vs full speed-up (35 steps):      {}×", opt(s.auto_vs_full, 2));
    let _ = writeln!(t, "    skyline vs full speed-up (paper 3.6×): {}×", opt(s.skyline_vs_full, 2));
    let _ = writeln!(t, "    downdate vs full speed-up (paper 2.7×): {}×", opt(s.downdate_vs_full, 2));
    let _ = writeln!(
        t,
        "    auto: {} µs per pivot step, {} ms per solve (≤ 35 steps)",
        opt(s.auto_us_per_step, 1),
        opt(s.auto_ms_per_solve, 3)
    );
    if let Some((af, sf, ps, ms)) = s.crane430 {
        let _ = writeln!(
            t,
            "  scene-crane430: auto vs full {af:.2}×, skyline vs full {sf:.2}×, auto {ps:.1} µs/step, {ms:.3} ms/solve"
        );
    }
    let _ = writeln!(
        t,
        "  auto converged within 35 steps: {}/{} problems ({:.0} %); within 1000: {}/{} ({:.0} %)",
        s.converged_35.0,
        s.converged_35.1,
        pct(s.converged_35),
        s.converged_1000.0,
        s.converged_1000.1,
        pct(s.converged_1000)
    );
    match (&s.worst_deletion_error_rel, &s.worst_deletion_error_abs) {
        (Some((r, wr)), Some((a, wa))) => {
            let _ = writeln!(t, "  worst deletion error: relative {r:.2e} ({wr}), absolute {a:.2e} ({wa})");
        }
        _ => {
            let _ = writeln!(t, "  worst deletion error: — (not measured)");
        }
    }
    if let Some((b, at)) = &s.worst_deletion_backward_error {
        let _ = writeln!(t, "  worst deletion backward error ‖LLᵀ − A_FF‖/‖A_FF‖: {b:.2e} ({at})");
    }
    if let Some((r, a, at)) = &s.worst_deletion_error_spd {
        let _ = writeln!(
            t,
            "  worst deletion error without regularized pivots: relative {r:.2e} ({at}), absolute {a:.2e}"
        );
    }
    let _ = writeln!(
        t,
        "  kernel crossover: envelope {} tight, dense {} % tight",
        opt(s.envelope_crossover_tight, 1),
        opt(s.dense_crossover_pct, 1)
    );
    t
}

// ---------------------------------------------------------------------------------------------
// Report: markdown, JSON, SVG
// ---------------------------------------------------------------------------------------------

#[derive(Debug, Serialize)]
struct Report<'a> {
    mode: &'static str,
    cpu: String,
    build: &'static str,
    short_steps: usize,
    long_steps: usize,
    summary: &'a Summary,
    kernel_envelope: &'a [EnvelopeKernel],
    kernel_dense: &'a [DenseKernel],
    fig4: &'a Fig4,
    problems: &'a [ProblemResult],
    unreadable_files: &'a [(String, String)],
}

fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|x| x.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

fn build_kind() -> &'static str {
    if cfg!(debug_assertions) { "debug (timings not representative)" } else { "release" }
}

fn markdown(r: &Report<'_>) -> String {
    let mut md = String::new();
    let w = &mut md;
    let _ = writeln!(w, "# pivotsim solver benchmark ({} mode)\n", r.mode);
    let _ = writeln!(
        w,
        "{} · {} build · single thread · median of repeats · step caps {} and {}\n",
        r.cpu, r.build, r.short_steps, r.long_steps
    );
    let _ = writeln!(w, "## Summary\n\n```text\n{}```\n", summary_text(r.summary));

    let _ = writeln!(w, "## 1. Kernel crossover\n");
    let _ = writeln!(
        w,
        "Envelope (RCM order): one factorization of `A`, one copy of `L₀`, single deletions at 8 indices \
         spread over the matrix (copy subtracted; a deletion sweeps to the end of its connected block, so \
         its cost falls with the index); crossover = tight count from which copy + deletions from `L₀` no \
         longer beat an envelope refactor of the masked matrix (sweep averaged over random nested tight \
         sets; model = (factor − copy) / mean deletion).\n"
    );
    let _ = writeln!(
        w,
        "| matrix | m | bandwidth in → RCM | envelope entries | factor µs | copy µs | deletion µs (min–max) | crossover (sweep) | crossover (model) |"
    );
    let _ = writeln!(w, "|---|---|---|---|---|---|---|---|---|");
    for e in r.kernel_envelope {
        let _ = writeln!(
            w,
            "| {} | {} | {} → {} | {} | {:.2} | {:.2} | {:.2} ({:.2}–{:.2}) | {} tight | {:.1} tight |",
            e.matrix,
            e.m,
            e.bandwidth_input,
            e.bandwidth_rcm,
            e.envelope_entries,
            e.factor_us,
            e.copy_us,
            e.deletion_us_mean,
            e.deletion_us_min,
            e.deletion_us_max,
            fmt_crossover(&e.crossover_tight, "", 1),
            e.crossover_model
        );
    }
    for e in r.kernel_envelope {
        let _ = writeln!(w, "\nSweep on {} (µs):\n", e.matrix);
        let _ = writeln!(w, "| tight | copy + deletions | masked refactor | speed-up |");
        let _ = writeln!(w, "|---|---|---|---|");
        for p in e.sweep.iter().filter(|p| p.tight <= 8 || p.tight % 4 == 0) {
            let _ = writeln!(
                w,
                "| {} | {:.2} | {:.2} | {:.2}× |",
                p.tight, p.downdate_us, p.refactor_us, p.speedup
            );
        }
    }
    let _ = writeln!(
        w,
        "\nDense (input order): gather + dense Cholesky of the whole matrix, copy of `L₀`, single deletions; \
         crossover in % tight from the sweep of (copy + deletions) against (gather + Cholesky of compact `A_FF`).\n"
    );
    let _ = writeln!(w, "| matrix | m | factor µs | copy µs | deletion µs (mean) | crossover |");
    let _ = writeln!(w, "|---|---|---|---|---|---|");
    for d in r.kernel_dense {
        let _ = writeln!(
            w,
            "| {} | {} | {:.1} | {:.1} | {:.2} | {} |",
            d.matrix,
            d.m,
            d.factor_us,
            d.copy_us,
            d.deletion_us_mean,
            fmt_crossover(&d.crossover_pct, " %", 1)
        );
    }
    for d in r.kernel_dense {
        let _ = writeln!(w, "\nDense sweep on {} (µs):\n", d.matrix);
        let _ = writeln!(w, "| tight % | tight | copy + deletions | gather + Cholesky | speed-up |");
        let _ = writeln!(w, "|---|---|---|---|---|");
        for p in &d.sweep {
            let _ = writeln!(
                w,
                "| {:.1} | {} | {:.1} | {:.1} | {:.2}× |",
                p.tight_pct, p.tight, p.downdate_us, p.refactor_us, p.speedup
            );
        }
    }

    let _ =
        writeln!(w, "\n## 2. Paper Fig. 4: speed-up of copy + deletions over a dense refactor of `A_FF`\n");
    let _ = writeln!(
        w,
        "Random dense SPD `(B Bᵀ + m I)/m`; entries are `refactor / (copy + deletions)`; > 1 means the deletions win. Plot: `fig4_speedup.svg`.\n"
    );
    let _ = write!(w, "| m |");
    for f in &r.fig4.tight_pct {
        let _ = write!(w, " {f}% |");
    }
    let _ = writeln!(w);
    let _ = writeln!(w, "|---|{}", "---|".repeat(r.fig4.tight_pct.len()));
    for (m, sw) in r.fig4.sizes.iter().zip(&r.fig4.sweeps) {
        let _ = write!(w, "| {m} |");
        for p in sw {
            let _ = write!(w, " {:.2} |", p.speedup);
        }
        let _ = writeln!(w);
    }

    let _ = writeln!(w, "\n## 3–4. Solver variants per problem\n");
    let _ = writeln!(
        w,
        "Times are the solver's `total_us` (ordering included), median over repeats, step cap 35. \
         `converged@1000` reruns with 1000 steps (copied when already converged within 35; skipped when \
         its predicted time exceeds the mode's budget). Deletion error: `max ‖L_del − chol(A_FF)‖_F` \
         over the pivot steps, relative / absolute (paper Table 4), for the variants that delete. \
         `auto` choices: deletions from L₀ / from the previous factor / incremental refactor.\n"
    );
    let _ = writeln!(w, "Convergence per variant over all {} problems:\n", r.problems.len());
    let _ = writeln!(w, "| variant | converged@35 | converged@1000 | 1000-step runs skipped |");
    let _ = writeln!(w, "|---|---|---|---|");
    for v in Variant::ALL {
        let rs: Vec<&VariantResult> = r.problems.iter().filter_map(|p| p.variant(v)).collect();
        let c35 = rs.iter().filter(|x| x.short.converged()).count();
        let c1000 = rs.iter().filter(|x| x.long.as_ref().is_some_and(RunRecord::converged)).count();
        let sk = rs.iter().filter(|x| x.long_skipped.is_some()).count();
        let _ = writeln!(w, "| {v} | {c35}/{} | {c1000}/{} | {sk} |", rs.len(), rs.len());
    }
    for p in r.problems {
        let _ = writeln!(w, "\n### {} ({})\n", p.name, p.group);
        let origin = match (p.seed, p.mass_ratio) {
            (Some(s), Some(mr)) => format!(", seed {s}, mass ratio {mr}"),
            _ => String::new(),
        };
        let _ = writeln!(
            w,
            "m = {}, nnz = {}, rows: {} unbounded, {} friction, {} other; bandwidth {} → {} and envelope {} → {} (RCM){}\n",
            p.m,
            p.nnz,
            p.rows_unbounded,
            p.rows_friction,
            p.rows_other,
            p.bandwidth_before,
            p.bandwidth_after,
            p.envelope_before,
            p.envelope_after,
            origin
        );
        let _ = writeln!(
            w,
            "| variant | status@35 | steps | tight | time ms @35 | µs/step | residual_rel | converged@1000 | deletion error rel / abs / backward | auto choices |"
        );
        let _ = writeln!(w, "|---|---|---|---|---|---|---|---|---|---|");
        for r in &p.variants {
            let s = &r.short;
            let long = match (&r.long, &r.long_skipped) {
                (Some(l), _) if l.converged() => format!("yes ({})", l.steps()),
                (Some(l), _) => format!("no ({}, r={:.1e})", l.status.name(), l.residual_rel),
                (None, Some(why)) => format!("skipped ({why})"),
                (None, None) => "—".into(),
            };
            let del = match (r.deletion_error, r.deletion_error_abs, &r.deletion_error_skipped) {
                (Some(a), Some(b), _) if r.deletion_run_regularized > 0 => {
                    format!("{a:.1e} / {b:.1e} ({} regularized)", r.deletion_run_regularized)
                }
                (Some(a), Some(b), _) => match r.deletion_backward_error {
                    Some(c) => format!("{a:.1e} / {b:.1e} / {c:.1e}"),
                    None => format!("{a:.1e} / {b:.1e}"),
                },
                (_, _, Some(why)) => format!("skipped ({why})"),
                _ => "—".into(),
            };
            let choices = if r.variant == Variant::Auto {
                format!("{}/{}/{}", s.auto_choices[0], s.auto_choices[1], s.auto_choices[2])
            } else {
                String::new()
            };
            let _ = writeln!(
                w,
                "| {} | {} | {} | {} | {:.3} | {} | {:.1e} | {} | {} | {} |",
                r.variant,
                s.status.name(),
                s.steps(),
                s.tight,
                s.time_us * 1e-3,
                opt(s.us_per_step, 1),
                s.residual_rel,
                long,
                del,
                choices
            );
        }
    }
    if !r.unreadable_files.is_empty() {
        let _ = writeln!(w, "\n### Files that could not be read\n");
        for (f, e) in r.unreadable_files {
            let _ = writeln!(w, "- `{f}`: {e}");
        }
    }
    md
}

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plot: {e}")
}

fn plot_fig4(path: &Path, fig: &Fig4) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let xmax = fig.sizes.iter().copied().max().unwrap_or(1) as f64 * 1.05;
    let ymax =
        fig.sweeps.iter().flatten().map(|p| p.speedup).filter(|x| x.is_finite()).fold(1.0f64, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption("Speed-up of copy + deletions over refactor of A_FF (cf. paper Fig. 4)", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..xmax, 0.0..ymax)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("size m of A")
        .y_desc("speed-up (refactor / downdate)")
        .draw()
        .map_err(plot_err)?;
    chart
        .draw_series(LineSeries::new([(0.0, 1.0), (xmax, 1.0)], BLACK.mix(0.5).stroke_width(1)))
        .map_err(plot_err)?;
    for (k, &pct) in fig.tight_pct.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let pts: Vec<(f64, f64)> = fig
            .sizes
            .iter()
            .zip(&fig.sweeps)
            .filter_map(|(&m, sw)| sw.get(k).map(|p| (m as f64, p.speedup)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(plot_err)?
            .label(format!("{pct}% tight"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        chart
            .draw_series(PointSeries::of_element(pts, 4, color.filled(), &|c, s, st| Circle::new(c, s, st)))
            .map_err(plot_err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    root.present().map_err(plot_err)?;
    Ok(())
}

fn plot_solve_times(path: &Path, problems: &[&ProblemResult]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (1100, 620)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let times: Vec<f64> = problems
        .iter()
        .flat_map(|p| p.variants.iter().map(|v| v.short.time_us * 1e-3))
        .filter(|x| *x > 0.0)
        .collect();
    let ymin = times.iter().copied().fold(f64::INFINITY, f64::min).min(1.0) / 2.0;
    let ymax = times.iter().copied().fold(0.0, f64::max).max(ymin * 10.0) * 30.0;
    let n = problems.len().max(1) as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption("Solve time per variant (35-step cap, median)", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..n, (ymin..ymax).log_scale())
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_x_axis()
        .y_desc("time per solve, ms (log)")
        .draw()
        .map_err(plot_err)?;
    let nv = Variant::ALL.len() as f64;
    for (k, v) in Variant::ALL.into_iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let bars: Vec<Rectangle<(f64, f64)>> = problems
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                let t = p.variant(v)?.short.time_us * 1e-3;
                let x0 = i as f64 + 0.1 + 0.8 * k as f64 / nv;
                Some(Rectangle::new([(x0, ymin), (x0 + 0.8 / nv, t.max(ymin))], color.filled()))
            })
            .collect();
        chart
            .draw_series(bars)
            .map_err(plot_err)?
            .label(v.name())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    for (i, p) in problems.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(i as f64 + 0.5, ymin));
        let style = ("sans-serif", 13).into_font().into_text_style(&root).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Top,
            ),
        );
        root.draw(&Text::new(p.name.clone(), (px, py + 8), style.clone())).map_err(plot_err)?;
        root.draw(&Text::new(format!("m = {}", p.m), (px, py + 24), style)).map_err(plot_err)?;
    }
    root.present().map_err(plot_err)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Driver
// ---------------------------------------------------------------------------------------------

/// The data directories scanned by default: `shared/data/mlcp` and `shared/data/mlcp-scene`.
fn default_data_dirs() -> Vec<(PathBuf, &'static str)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    vec![(root.join("mlcp"), "siconos"), (root.join("mlcp-scene"), "scene")]
}

fn txt_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(rd) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    v.sort();
    v
}

/// Runs the benchmark of `cfg`, writes the report files and prints the markdown and the summary.
pub fn run(cfg: &BenchConfig) -> anyhow::Result<Summary> {
    let t_start = Instant::now();
    let plan = Plan::for_config(cfg);
    std::fs::create_dir_all(&cfg.out).with_context(|| format!("cannot create {}", cfg.out.display()))?;
    if cfg!(debug_assertions) && !cfg.tiny {
        eprintln!("warning: debug build; build with --release for meaningful timings");
    }

    // Inputs first, so that the progress bar knows its length.
    let dirs: Vec<(PathBuf, &'static str)> = match &cfg.data {
        Some(d) => vec![(d.clone(), "data")],
        None => default_data_dirs(),
    };
    let mut files: Vec<(String, &'static str, PathBuf, Mlcp)> = Vec::new();
    let mut unreadable: Vec<(String, String)> = Vec::new();
    for (dir, group) in &dirs {
        let list = txt_files(dir);
        if list.is_empty() {
            eprintln!("note: no *.txt problems in {}", dir.display());
        }
        for f in list {
            match io::read_mlcp_file(&f) {
                Ok(p) => {
                    let name = f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                    files.push((name, group, f, p));
                }
                Err(e) => unreadable.push((f.display().to_string(), e.to_string())),
            }
        }
    }
    let generated: Vec<(String, u64, f64, Mlcp)> = plan
        .generated
        .iter()
        .map(|&(m, seed, mr)| {
            let p = contact_like(m, seed, mr);
            (format!("contact-like-{}-s{seed}", p.n()), seed, mr, p)
        })
        .collect();
    let crane = files.iter().find(|f| f.0.contains("crane430"));
    let n_env_kernels = 1 + usize::from(crane.is_some());
    let total =
        (n_env_kernels + 2 + plan.fig4_m.len() + (generated.len() + files.len()) * Variant::ALL.len()) as u64;
    let target = if cfg.tiny { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
    let pb = ProgressBar::with_draw_target(Some(total), target);
    pb.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let say = |s: String| {
        if !cfg.tiny {
            pb.suspend(|| eprintln!("{s}"));
        }
    };
    say(format!(
        "bench-solver: {} mode, {} generated + {} file problems, {} variants, output {}",
        plan.mode,
        generated.len(),
        files.len(),
        Variant::ALL.len(),
        cfg.out.display()
    ));

    // 1. Kernels, after a short warm-up that brings the core to its steady clock.
    say("[1/4] kernel crossover".into());
    let kernel_problem = contact_like(plan.kernel_m, 430, 6_300.0);
    warm_up(plan.warm_up_us);
    let mut env_kernels = Vec::new();
    let kname = format!("contact-like-{} (generated)", kernel_problem.n());
    pb.set_message(format!("envelope kernels on {kname}"));
    env_kernels.push(envelope_kernel(&kname, kernel_problem.a(), &plan, 11));
    pb.inc(1);
    if let Some((name, _, _, p)) = crane {
        pb.set_message(format!("envelope kernels on {name}"));
        env_kernels.push(envelope_kernel(name, p.a(), &plan, 11));
        pb.inc(1);
    }
    let mut dense_kernels = Vec::new();
    let km = kernel_problem.n();
    let mut kd = vec![0.0; km * km];
    kernel_problem.a().to_dense(&mut kd);
    pb.set_message("dense kernels (contact-like)");
    dense_kernels.push(dense_kernel(&format!("contact-like-{km} (input order)"), &kd, km, &plan, 12));
    pb.inc(1);
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let rd = random_spd(km, &mut rng);
    pb.set_message("dense kernels (random SPD)");
    dense_kernels.push(dense_kernel(&format!("random SPD {km}"), &rd, km, &plan, 13));
    pb.inc(1);

    // 2. Fig. 4.
    say("[2/4] paper Fig. 4 grid".into());
    let mut fig4 =
        Fig4 { sizes: plan.fig4_m.clone(), tight_pct: plan.fig4_fracs.clone(), sweeps: Vec::new() };
    for &m in &plan.fig4_m {
        pb.set_message(format!("Fig. 4, m = {m}"));
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + m as u64);
        let a = random_spd(m, &mut rng);
        let reps = if m >= 700 { plan.fig4_repeats.min(3) } else { plan.fig4_repeats };
        fig4.sweeps.push(dense_sweep(&a, m, &plan.fig4_fracs, plan.fig4_target_us, reps, &mut rng));
        pb.inc(1);
    }

    // 3. Generated problems, 4. files.
    say("[3/4] generated contact-like problems".into());
    let mut problems = Vec::new();
    for (name, seed, mr, p) in &generated {
        problems.push(run_problem(name.clone(), "generated", None, Some((*seed, *mr)), p, &plan, &pb));
    }
    say(format!("[4/4] {} data files", files.len()));
    for (name, group, path, p) in &files {
        problems.push(run_problem(name.clone(), group, Some(path), None, p, &plan, &pb));
    }
    pb.finish_and_clear();

    let mut summary = summarize(&plan, &problems, &env_kernels, &dense_kernels);
    summary.elapsed_s = t_start.elapsed().as_secs_f64();
    let report = Report {
        mode: plan.mode,
        cpu: cpu_name(),
        build: build_kind(),
        short_steps: SHORT_STEPS,
        long_steps: LONG_STEPS,
        summary: &summary,
        kernel_envelope: &env_kernels,
        kernel_dense: &dense_kernels,
        fig4: &fig4,
        problems: &problems,
        unreadable_files: &unreadable,
    };
    let md = markdown(&report);
    let out = &cfg.out;
    std::fs::write(out.join("bench.md"), &md).with_context(|| format!("cannot write {}", out.display()))?;
    let json = serde_json::to_string_pretty(&report)?;
    std::fs::write(out.join("bench.json"), json)
        .with_context(|| format!("cannot write {}", out.display()))?;
    plot_fig4(&out.join("fig4_speedup.svg"), &fig4)?;
    let lo = plan.focus_m as f64 * 0.9;
    let hi = plan.focus_m as f64 * 1.1;
    let mut chart_problems: Vec<&ProblemResult> = problems
        .iter()
        .filter(|p| p.group == "generated" && (p.m as f64) >= lo && (p.m as f64) <= hi || p.group == "scene")
        .collect();
    if cfg.data.is_some() {
        chart_problems.extend(problems.iter().filter(|p| p.group == "data" && p.m >= 150).take(10));
    }
    if chart_problems.is_empty() {
        chart_problems = problems.iter().take(6).collect();
    }
    plot_solve_times(&out.join("solve_time.svg"), &chart_problems)?;

    println!("{md}");
    println!("{}", summary_text(&summary));
    println!("report: {}", out.join("bench.md").display());
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn tiny_run_writes_the_report() {
        let dir = std::env::temp_dir().join(format!(
            "pivotsim-bench-test-{}-{}",
            std::process::id(),
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos()
        ));
        let data = dir.join("data");
        std::fs::create_dir_all(&data).unwrap();
        let p = contact_like(30, 3, 50.0);
        let mut f = std::fs::File::create(data.join("tiny.txt")).unwrap();
        io::write_mlcp(&p, &mut f).unwrap();
        drop(f);
        let out = dir.join("out");
        let cfg = BenchConfig { out: out.clone(), quick: true, data: Some(data), tiny: true };
        let s = run(&cfg).unwrap();
        assert_eq!(s.mode, "tiny");
        assert_eq!(s.converged_35.1, 2);
        for f in ["bench.md", "bench.json", "fig4_speedup.svg", "solve_time.svg"] {
            assert!(out.join(f).is_file(), "{f} missing");
        }
        let md = std::fs::read_to_string(out.join("bench.md")).unwrap();
        assert!(md.contains("### tiny (data)"));
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("bench.json")).unwrap()).unwrap();
        assert_eq!(json["problems"].as_array().unwrap().len(), 2);
        std::fs::remove_dir_all(&dir).ok();
    }
}
