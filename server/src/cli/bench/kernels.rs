//! Stages 1 and 2: the kernel crossover (copy + deletions from `L₀` against a refactor, envelope
//! and dense) and the paper's Fig. 4 grid on random dense SPD matrices.

use std::hint::black_box;
use std::time::Instant;

use nalgebra::DMatrix;
use pivotsim_server::solver::envelope::Envelope;
use pivotsim_server::solver::ordering::{self, OrderingWorkspace};
use pivotsim_server::solver::{OrderingKind, SymCsr, dense};
use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::plan::Plan;
use super::timing::{time_us, us};

/// Dense Cholesky factorizations until `budget_us` has passed (bounded by 100 000 rounds).
pub fn warm_up(budget_us: f64) {
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

/// One point of a tight-count sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepPoint {
    pub tight: usize,
    pub tight_pct: f64,
    /// Copy of `L₀` plus `tight` deletions (µs).
    pub downdate_us: f64,
    /// Refactor with the same tight set (µs).
    pub refactor_us: f64,
    /// `refactor_us / downdate_us`.
    pub speedup: f64,
}

/// Where `downdate / refactor` first reaches 1 along a sweep (interpolated on the given axis).
#[derive(Debug, Clone, Serialize)]
pub struct Crossover {
    /// Interpolated value, or the first/last point when the sweep does not bracket it.
    pub value: Option<f64>,
    /// "interpolated", "below-first-point" or "beyond-last-point".
    pub kind: &'static str,
}

pub fn crossover(points: &[SweepPoint], axis: impl Fn(&SweepPoint) -> f64) -> Crossover {
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

pub fn fmt_crossover(c: &Crossover, unit: &str, digits: usize) -> String {
    match (c.value, c.kind) {
        (None, _) => "—".into(),
        (Some(v), "below-first-point") => format!("< {v:.digits$}{unit}"),
        (Some(v), "beyond-last-point") => format!("> {v:.digits$}{unit}"),
        (Some(v), _) => format!("{v:.digits$}{unit}"),
    }
}

/// Envelope kernels on one matrix (RCM order).
#[derive(Debug, Clone, Serialize)]
pub struct EnvelopeKernel {
    pub matrix: String,
    pub m: usize,
    pub bandwidth_input: usize,
    pub bandwidth_rcm: usize,
    pub envelope_entries: usize,
    pub factor_us: f64,
    pub copy_us: f64,
    pub deletion_us_mean: f64,
    pub deletion_us_min: f64,
    pub deletion_us_max: f64,
    /// (index, µs) of the single deletions.
    pub deletions: Vec<(usize, f64)>,
    pub sweep: Vec<SweepPoint>,
    /// Tight count below which copy + deletions beat the masked refactor (measured sweep).
    pub crossover_tight: Crossover,
    /// Same from the single-kernel timings: `(factor − copy) / deletion`.
    pub crossover_model: f64,
}

pub fn envelope_kernel(name: &str, a: &SymCsr, plan: &Plan, seed: u64) -> EnvelopeKernel {
    let m = a.n();
    let mut b = EnvelopeBench::new(a, plan.kernel_target_us, plan.kernel_repeats);
    let factor_us = b.time_factor();
    let copy_us = b.time_copy();
    let deletions = b.time_single_deletions(copy_us);
    let dels: Vec<f64> = deletions.iter().map(|d| d.1).collect();
    let deletion_us_mean = dels.iter().sum::<f64>() / dels.len().max(1) as f64;
    let deletion_us_min = dels.iter().copied().fold(f64::INFINITY, f64::min);
    let deletion_us_max = dels.iter().copied().fold(0.0, f64::max);
    let sweep = b.sweep(plan.kernel_sets, plan.kernel_t_max, seed);
    let crossover_tight = crossover(&sweep, |p| p.tight as f64);
    EnvelopeKernel {
        matrix: name.to_string(),
        m,
        bandwidth_input: ordering::bandwidth(a),
        bandwidth_rcm: ordering::bandwidth(&b.ap),
        envelope_entries: b.env.len(),
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

/// The paper's Fig. 4 on an envelope (skyline) matrix: copy of `L₀` plus deletions against the
/// envelope refactor with the same tight rows, at each tight percentage of `fracs` (each averaged
/// over `sets` random tight sets; timings of `tu` µs samples, best of `reps`).
pub fn envelope_fig4(
    a: &SymCsr,
    fracs: &[f64],
    tu: f64,
    reps: usize,
    sets: usize,
    seed: u64,
) -> Vec<SweepPoint> {
    let m = a.n();
    let mut b = EnvelopeBench::new(a, tu, reps);
    let counts: Vec<usize> = fracs
        .iter()
        .map(|f| ((f * m as f64 / 100.0).round() as usize).clamp(1, m.saturating_sub(1).max(1)))
        .collect();
    b.sweep_counts(sets, &counts, seed)
}

/// One matrix in RCM order with its envelope, its factor `L₀` and the scratch the timed envelope
/// kernels work in.
struct EnvelopeBench {
    m: usize,
    ap: SymCsr,
    env: Envelope,
    maxd: f64,
    mask: Vec<bool>,
    l0: Vec<f64>,
    l: Vec<f64>,
    sigma: Vec<f64>,
    /// Target µs of a timing sample and the repeats of a timing.
    tu: f64,
    reps: usize,
}

impl EnvelopeBench {
    /// Orders `a` by RCM, builds its envelope and factors it once (nothing tight).
    fn new(a: &SymCsr, tu: f64, reps: usize) -> Self {
        let m = a.n();
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        ws.order(a, OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
        let mut ap = SymCsr::default();
        ap.permuted_from(a, &perm, &inv);
        let mut env = Envelope::new();
        env.build(&ap);
        let maxd = ap.max_diag();
        let mask = vec![false; m];
        let mut l0 = vec![0.0; env.len()];
        env.factor_from(&ap, &mask, &mut l0, 0, maxd);
        let l = l0.clone();
        let sigma = vec![0.0; m];
        EnvelopeBench { m, ap, env, maxd, mask, l0, l, sigma, tu, reps }
    }

    /// µs of one envelope factorization with the current mask.
    fn time_factor(&mut self) -> f64 {
        time_us(self.tu, self.reps, || {
            self.env.factor_from(&self.ap, &self.mask, &mut self.l, 0, self.maxd);
            black_box(&mut self.l);
        })
    }

    /// µs of one copy of `L₀`.
    fn time_copy(&mut self) -> f64 {
        time_us(self.tu, self.reps, || {
            self.l.copy_from_slice(&self.l0);
            black_box(&mut self.l);
        })
    }

    /// (index, µs) of single deletions from `L₀` at up to 8 indices spread over the matrix, the copy
    /// subtracted.
    fn time_single_deletions(&mut self, copy_us: f64) -> Vec<(usize, f64)> {
        let m = self.m;
        let k = 8.min(m);
        let mut deletions = Vec::with_capacity(k);
        for q in 0..k {
            let i = (2 * q + 1) * m / (2 * k);
            let t = time_us(self.tu, self.reps, || {
                self.l.copy_from_slice(&self.l0);
                self.env.delete(&mut self.l, i, &mut self.sigma);
                black_box(&mut self.l);
            });
            deletions.push((i, (t - copy_us).max(0.0)));
        }
        deletions
    }

    /// Copy + deletions against a masked refactor for every tight count up to `t_max`, each averaged
    /// over `sets` random nested tight sets drawn from `seed`.
    fn sweep(&mut self, sets: usize, t_max: usize, seed: u64) -> Vec<SweepPoint> {
        let counts: Vec<usize> = (1..=t_max.min(self.m.saturating_sub(1))).collect();
        self.sweep_counts(sets, &counts, seed)
    }

    /// [`Self::sweep`] at the given tight counts.
    fn sweep_counts(&mut self, sets: usize, counts: &[usize], seed: u64) -> Vec<SweepPoint> {
        let m = self.m;
        // Deletion cost depends on the position (the sweep runs to the end of the connected block),
        // so every tight count is averaged over several random nested tight sets.
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let orders: Vec<Vec<usize>> = (0..sets.max(1))
            .map(|_| {
                let mut o: Vec<usize> = (0..m).collect();
                o.shuffle(&mut rng);
                o
            })
            .collect();
        let mut sweep = Vec::new();
        for &t in counts {
            let (mut downdate_us, mut refactor_us) = (0.0, 0.0);
            for order in &orders {
                let mut set = order[..t].to_vec();
                set.sort_unstable();
                self.mask.fill(false);
                for &i in &set {
                    self.mask[i] = true;
                }
                downdate_us += time_us(self.tu, self.reps, || {
                    self.l.copy_from_slice(&self.l0);
                    for &i in &set {
                        self.env.delete(&mut self.l, i, &mut self.sigma);
                    }
                    black_box(&mut self.l);
                });
                refactor_us += self.time_factor();
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
        sweep
    }
}

/// Dense kernels on one matrix (input order).
#[derive(Debug, Clone, Serialize)]
pub struct DenseKernel {
    pub matrix: String,
    pub m: usize,
    /// Gather + dense Cholesky of the whole matrix (µs).
    pub factor_us: f64,
    pub copy_us: f64,
    pub deletion_us_mean: f64,
    pub sweep: Vec<SweepPoint>,
    pub crossover_pct: Crossover,
}

/// Column-major `m × m` random SPD matrix `(B Bᵀ + m I) / m`, `B` uniform in `[−1, 1]`.
pub fn random_spd(m: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let b = DMatrix::<f64>::from_fn(m, m, |_, _| rng.random_range(-1.0..1.0));
    let mut a = &b * b.transpose();
    for i in 0..m {
        a[(i, i)] += m as f64;
    }
    a /= m as f64;
    a.as_slice().to_vec()
}

/// Lower triangle of the compact `A_FF` (column-major `nf × nf`) gathered from the dense `a`.
pub fn gather_compact(a: &[f64], m: usize, free: &[usize], out: &mut [f64]) {
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
pub fn dense_sweep(
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

pub fn dense_kernel(name: &str, a: &[f64], m: usize, plan: &Plan, seed: u64) -> DenseKernel {
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
pub struct Fig4 {
    pub sizes: Vec<usize>,
    pub tight_pct: Vec<f64>,
    /// One sweep per size, in `sizes` order.
    pub sweeps: Vec<Vec<SweepPoint>>,
}
