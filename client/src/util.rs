//! Small shared pieces: a random source id, percentiles and histograms, frame counters, the
//! best-effort scene lookup for body names.

use std::collections::hash_map::RandomState;
use std::hash::{BuildHasher, Hasher};
use std::time::Duration;

use pivotsim_msgs as msgs;

use crate::common::Common;
use crate::net::ZenohLink;

/// A random 32-bit number (the standard library's per-process random hasher keys, mixed with the
/// time and the process id).
pub fn random_u32() -> u32 {
    let mut h = RandomState::new().build_hasher();
    h.write_u64(crate::net::now_ns());
    h.write_u32(std::process::id());
    let v = h.finish();
    (v ^ (v >> 32)) as u32
}

/// The `q`-quantile (0 ≤ q ≤ 1) of sorted values, nearest rank.
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Bin edges (µs) of the latency histogram: 1-2-5 steps.
pub const HIST_EDGES_US: [f64; 14] =
    [10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1e3, 2e3, 5e3, 1e4, 2e4, 5e4, 1e5, 2e5];

/// An ASCII histogram of latencies (µs) on 1-2-5 bins; empty bins at both ends are left out.
pub fn histogram(values_us: &[f64], width: usize) -> String {
    let n_bins = HIST_EDGES_US.len() + 1;
    let mut counts = vec![0usize; n_bins];
    for &v in values_us {
        let i = HIST_EDGES_US.iter().position(|&e| v < e).unwrap_or(HIST_EDGES_US.len());
        counts[i] += 1;
    }
    let label = |i: usize| -> String {
        let fmt = |us: f64| {
            if us >= 1000.0 { format!("{} ms", us / 1000.0) } else { format!("{us} µs") }
        };
        if i == 0 {
            format!("< {}", fmt(HIST_EDGES_US[0]))
        } else if i == HIST_EDGES_US.len() {
            format!("≥ {}", fmt(HIST_EDGES_US[i - 1]))
        } else {
            format!("{}–{}", fmt(HIST_EDGES_US[i - 1]), fmt(HIST_EDGES_US[i]))
        }
    };
    let (Some(first), Some(last)) = (counts.iter().position(|&c| c > 0), counts.iter().rposition(|&c| c > 0))
    else {
        return String::from("  (no samples)\n");
    };
    let max = counts.iter().copied().max().unwrap_or(1).max(1);
    let labels: Vec<String> = (first..=last).map(label).collect();
    let lw = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    let mut out = String::new();
    for (i, l) in (first..=last).zip(labels) {
        let c = counts[i];
        let bar = (c * width).div_ceil(max);
        let pad = lw - l.chars().count();
        out.push_str(&format!("  {}{l} | {:<width$} {c}\n", " ".repeat(pad), "#".repeat(bar)));
    }
    out
}

/// Counts of frames received, by outcome.
#[derive(Debug, Default, Clone, Copy)]
pub struct FrameCounts {
    /// Decoded.
    pub ok: u64,
    /// Did not decode (skipped).
    pub malformed: u64,
}

/// Sequences a stream skipped: the server numbers its steps `+1` each and never restarts them, so
/// a jump from `s` to `s + k` lost `k − 1` steps on the way (a repeat, `k = 0`, is a paused
/// server's re-send; a step back is another server's stream or a restart and counts nothing).
#[derive(Debug, Default, Clone, Copy)]
pub struct SequenceGaps {
    last: Option<u64>,
    /// Steps never received.
    pub skipped: u64,
}

impl SequenceGaps {
    /// Records the sequence of a received frame.
    pub fn see(&mut self, seq: u64) {
        if let Some(last) = self.last
            && seq > last
        {
            self.skipped = self.skipped.saturating_add(seq - last - 1);
        }
        self.last = Some(seq);
    }
}

/// The scene description if a server answers on Zenoh within `timeout` (for body names); `None`
/// otherwise. Opens its own session when `link` is `None`.
pub fn scene_best_effort(
    common: &Common,
    link: Option<&ZenohLink>,
    timeout: Duration,
) -> Option<msgs::SceneDescription> {
    match link {
        Some(l) => l.scene(timeout).ok(),
        None => {
            let world = common.world().ok()?;
            let l = ZenohLink::open(&common.zenoh(), &world, timeout).ok()?;
            l.scene(timeout).ok()
        }
    }
}

/// The connection of an input-sending command (`drive`, `send`): a Zenoh link when inputs go over
/// Zenoh, and the scene description — over that link, or over a session of its own (waiting at
/// most 1 s) when inputs go over iceoryx2.
pub fn input_link(
    common: &Common,
    transport: crate::net::TransportKind,
    timeout: Duration,
) -> anyhow::Result<(Option<ZenohLink>, Option<msgs::SceneDescription>)> {
    let link = match transport {
        crate::net::TransportKind::Zenoh => Some(common.open_zenoh()?),
        crate::net::TransportKind::Iceoryx2 => None,
    };
    let wait = if link.is_some() { timeout } else { timeout.min(Duration::from_secs(1)) };
    let scene = scene_best_effort(common, link.as_ref(), wait);
    Ok((link, scene))
}

/// A body's display name.
pub fn body_name(scene: Option<&msgs::SceneDescription>, id: u32) -> String {
    scene.and_then(|s| s.body(id)).map_or_else(|| format!("body{id}"), |b| b.name.clone())
}

/// Rotation angle (rad) of a unit quaternion `(x, y, z, w)`, and the yaw/pitch/roll (rad).
pub fn euler_zyx(q: [f64; 4]) -> [f64; 3] {
    let [x, y, z, w] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

#[cfg(test)]
mod tests {
    #[test]
    fn sequence_gaps_count_skipped_steps_only() {
        let mut g = SequenceGaps::default();
        for s in [539, 540, 540, 541, 1245, 1246] {
            g.see(s);
        }
        assert_eq!(g.skipped, 1245 - 541 - 1);
        g.see(3);
        g.see(4);
        assert_eq!(g.skipped, 703);
    }

    use super::*;

    #[test]
    fn percentiles_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.5), 50.0);
        assert_eq!(percentile(&v, 0.99), 99.0);
        assert_eq!(percentile(&v, 1.0), 100.0);
        assert_eq!(percentile(&v, 0.0), 1.0);
        assert!(percentile(&[], 0.5).is_nan());
    }

    #[test]
    fn histogram_bins_and_bars() {
        let h = histogram(&[15.0, 15.0, 60.0, 3000.0], 10);
        assert!(h.contains("10 µs–20 µs | ########## 2"), "{h}");
        assert!(h.contains("2 ms–5 ms"), "{h}");
        assert!(!h.contains("< 10 µs"), "{h}");
        assert_eq!(histogram(&[], 10), "  (no samples)\n");
    }

    #[test]
    fn euler_of_a_quarter_turn_about_y() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let e = euler_zyx([0.0, s, 0.0, s]);
        assert!((e[1] - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
    }
}
