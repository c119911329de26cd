//! `ping`: pose latency from the server's publish to this process's receive.
//!
//! Every pose frame carries the server's wall clock (`wall_time_ns`, ns since the epoch) taken when
//! the step's frames were encoded, right before they are published. On the same host both sides
//! read the same clock, so `receive time − wall_time_ns` is the one-way latency of the transport
//! plus the server's publish call. The receive time is taken in the Zenoh subscriber callback, or
//! in the iceoryx2 polling thread right after `receive()` (which polls every `--poll-us`; 0 spins,
//! yielding the CPU, which measures the transport itself but keeps one core busy).
//!
//! Across hosts the difference also contains the clock offset: use it on one host.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::net::{Stream, TransportKind};
use crate::stop::interrupted;
use crate::util::{histogram, percentile};

/// `ping` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Transport to measure.
    #[arg(long, value_enum, default_value = "zenoh")]
    pub transport: TransportKind,
    /// Pose frames to measure.
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub count: u64,
    /// Pose frames to skip first (connection warm-up).
    #[arg(long, default_value_t = 5, value_name = "N")]
    pub warmup: u64,
    /// iceoryx2 polling period in µs (0: spin).
    #[arg(long, default_value_t = 10, value_name = "US")]
    pub poll_us: u64,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Latency statistics (µs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Samples.
    pub count: usize,
    /// Minimum.
    pub min: f64,
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Maximum.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl Summary {
    /// From unsorted samples.
    pub fn of(samples: &mut [f64]) -> Summary {
        samples.sort_by(f64::total_cmp);
        let n = samples.len();
        Summary {
            count: n,
            min: samples.first().copied().unwrap_or(f64::NAN),
            p50: percentile(samples, 0.50),
            p90: percentile(samples, 0.90),
            p99: percentile(samples, 0.99),
            max: samples.last().copied().unwrap_or(f64::NAN),
            mean: samples.iter().sum::<f64>() / n.max(1) as f64,
        }
    }
}

/// Runs `ping`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let poll = Duration::from_micros(args.poll_us);
    let stream = Stream::open(&common.server()?, args.transport, &[Topic::Poses], 4096, poll, None)?;
    let start = Instant::now();
    eprintln!(
        "pivotsim-client: ping over {:?}, world `{}`: {} pose frames after {} warm-up",
        args.transport, common.world, args.count, args.warmup
    );
    let mut sampled = sample(common, args, &stream)?;
    let wall = start.elapsed().as_secs_f64();
    let s = Summary::of(&mut sampled.samples);
    if s.count == 0 {
        bail!("no samples");
    }
    print_report(args, &s, &sampled, stream.inbox.dropped(), wall);
    Ok(ExitCode::SUCCESS)
}

/// The latencies (µs) of `args.count` new pose frames after the warm-up, and what was passed over.
struct Sampled {
    samples: Vec<f64>,
    /// Frames that did not parse.
    malformed: u64,
    /// Negative latencies (counted as 0).
    negative: u64,
    /// Frames of a step already seen.
    repeats: u64,
}

/// Receives pose frames until `args.count` samples, Ctrl-C, or no frame for the idle timeout (an
/// error when no sample came at all).
fn sample(common: &Common, args: &Args, stream: &Stream) -> Result<Sampled> {
    let idle = common.timeout_or(5.0);
    let mut out = Sampled {
        samples: Vec::with_capacity(args.count.min(1 << 20) as usize),
        malformed: 0,
        negative: 0,
        repeats: 0,
    };
    let mut skipped = 0u64;
    let mut last_seq: Option<u64> = None;
    let mut last_frame = Instant::now();
    while (out.samples.len() as u64) < args.count {
        if interrupted() {
            break;
        }
        if last_frame.elapsed() >= idle {
            if out.samples.is_empty() {
                bail!(
                    "no pose frames for {:.1} s over {:?} (server running, not paused, world `{}`?)",
                    idle.as_secs_f64(),
                    args.transport,
                    common.world
                );
            }
            eprintln!("pivotsim-client: no pose frames for {:.1} s: stopping", idle.as_secs_f64());
            break;
        }
        let Some(r) = stream.inbox.recv_timeout(Duration::from_millis(50)) else { continue };
        let Ok(v) = msgs::PoseFrameView::parse(&r.bytes) else {
            out.malformed += 1;
            continue;
        };
        last_frame = Instant::now();
        if last_seq == Some(v.sequence()) {
            // The same step published again (a control request republishes): not a new sample.
            out.repeats += 1;
            continue;
        }
        last_seq = Some(v.sequence());
        if skipped < args.warmup {
            skipped += 1;
            continue;
        }
        let lat_ns = r.recv_ns as i128 - v.wall_time_ns() as i128;
        if lat_ns < 0 {
            out.negative += 1;
        }
        out.samples.push(lat_ns.max(0) as f64 / 1e3);
    }
    Ok(out)
}

/// Prints the summary `s` (one JSON object with `--json`, else lines and a histogram);
/// `dropped` frames were lost over the inbox in `wall` seconds.
fn print_report(args: &Args, s: &Summary, sampled: &Sampled, dropped: u64, wall: f64) {
    let Sampled { samples, malformed, negative, repeats } = sampled;
    if args.json {
        println!(
            "{}",
            serde_json::json!({
                "transport": format!("{:?}", args.transport).to_lowercase(),
                "count": s.count, "min_us": s.min, "p50_us": s.p50, "p90_us": s.p90,
                "p99_us": s.p99, "max_us": s.max, "mean_us": s.mean,
                "malformed": malformed, "dropped": dropped, "negative": negative,
            })
        );
    } else {
        println!(
            "ping over {:?}: {} pose frames in {:.1} s ({} malformed, {} dropped, {} repeated)",
            args.transport, s.count, wall, malformed, dropped, repeats
        );
        println!(
            "latency µs: min {:.1}  p50 {:.1}  p90 {:.1}  p99 {:.1}  max {:.1}  mean {:.1}",
            s.min, s.p50, s.p90, s.p99, s.max, s.mean
        );
        if *negative > 0 {
            println!("({negative} negative differences counted as 0: clocks differ? use ping on one host)");
        }
        print!("{}", histogram(samples, 50));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_of_a_ramp() {
        let mut v: Vec<f64> = (0..1000).rev().map(f64::from).collect();
        let s = Summary::of(&mut v);
        assert_eq!(s.count, 1000);
        assert_eq!((s.min, s.p50, s.p90, s.p99, s.max), (0.0, 499.0, 899.0, 989.0, 999.0));
    }
}
