//! Timing helpers: wall-clock µs, medians of repeats, geometric means.

use std::time::Instant;

pub fn us(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e6
}

pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// Median time of one call of `f` in µs: one calibration call, then `repeats` samples of
/// `inner` calls each, `inner` chosen so that a sample lasts about `target_us` (at most 200 000).
pub fn time_us(target_us: f64, repeats: usize, mut f: impl FnMut()) -> f64 {
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

/// Geometric mean of the finite positive values (`None` when there are none).
pub fn geo_mean(v: &[f64]) -> Option<f64> {
    let v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite() && *x > 0.0).collect();
    if v.is_empty() { None } else { Some((v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp()) }
}
