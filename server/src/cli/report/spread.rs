//! The spread of a sample (min, max, mean, median), as the report's tables give it.

use serde::Serialize;

/// Min / max / mean / median of a sample (absent when it is empty).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Spread {
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub median: f64,
    /// Sample size.
    pub n: usize,
}

impl Spread {
    /// The spread of `x` (`None` when empty).
    pub fn of(mut x: Vec<f64>) -> Option<Spread> {
        if x.is_empty() {
            return None;
        }
        x.sort_by(f64::total_cmp);
        let n = x.len();
        let median = if n % 2 == 1 { x[n / 2] } else { 0.5 * (x[n / 2 - 1] + x[n / 2]) };
        Some(Spread { min: x[0], max: x[n - 1], mean: x.iter().sum::<f64>() / n as f64, median, n })
    }
}
