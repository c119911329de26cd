//! Parsers of the numeric command-line values: a hostile value (NaN, ±inf, negative, out of range)
//! is a clear clap error naming the accepted range, never a panic further down.

/// A finite number `> 0` (real-time factor, tolerance).
pub fn positive_finite(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v > 0.0 { Ok(v) } else { Err(format!("{v} is not a finite number > 0")) }
}

/// A solver thread count, 1 ..= [`MAX_THREADS`](pivotsim_server::dynamics::MAX_THREADS).
pub fn threads(s: &str) -> Result<usize, String> {
    let max = pivotsim_server::dynamics::MAX_THREADS;
    let v: usize = s.parse().map_err(|e| format!("{e}"))?;
    if (1..=max).contains(&v) { Ok(v) } else { Err(format!("{v} is not a thread count in 1 ..= {max}")) }
}

/// The default solver thread count: the cores present (1 when unknown).
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get()).min(pivotsim_server::dynamics::MAX_THREADS)
}

/// A finite number `≥ 0` (seconds between keyframes; 0 turns the periodic ones off).
pub fn non_negative_finite(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v >= 0.0 { Ok(v) } else { Err(format!("{v} is not a finite number ≥ 0")) }
}

/// Longest simulated duration of `run` (s): about 11.6 days, 60 million steps at 60 Hz.
pub const MAX_RUN_SECONDS: f64 = 1.0e6;

/// Simulated seconds of `run`: a finite number `> 0` up to [`MAX_RUN_SECONDS`].
pub fn run_seconds(s: &str) -> Result<f64, String> {
    let v = positive_finite(s)?;
    if v <= MAX_RUN_SECONDS { Ok(v) } else { Err(format!("{v} s is more than {MAX_RUN_SECONDS} s")) }
}

/// Seconds between status lines: `0` turns them off; otherwise a finite number of seconds `> 0`
/// that a [`std::time::Duration`] can hold.
pub fn status_interval(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if v == 0.0 {
        return Ok(0.0);
    }
    if !(v.is_finite() && v > 0.0) {
        return Err(format!("{v} is not a number of seconds ≥ 0 (0: no status lines)"));
    }
    std::time::Duration::try_from_secs_f64(v).map_err(|e| format!("{v} s: {e}"))?;
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hostile_values_are_errors_and_ordinary_ones_pass() {
        for bad in ["nan", "NaN", "inf", "-inf", "-1", "0", "x", ""] {
            assert!(positive_finite(bad).is_err(), "{bad}");
            assert_eq!(non_negative_finite(bad).is_err(), bad != "0", "{bad}");
        }
        assert_eq!(positive_finite("1e-300"), Ok(1e-300));
        assert!(run_seconds("1e300").is_err());
        assert_eq!(run_seconds("20"), Ok(20.0));
        for bad in ["nan", "inf", "-1", "-0.5", "1e300", "x"] {
            assert!(status_interval(bad).is_err(), "{bad}");
        }
        assert_eq!(status_interval("0"), Ok(0.0));
        assert_eq!(status_interval("2.5"), Ok(2.5));
    }
}
