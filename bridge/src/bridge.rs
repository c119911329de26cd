//! The bridge loop. Two threads: the main loop waits for the newest frames from the server and
//! publishes them to ROS (`/tf`, `/pivotsim/poses`, `/clock` per pose frame; `/tf_static` and
//! `/pivotsim/markers` per scene; `/pivotsim/stats` on a timer), and the joy thread waits on the
//! `/joy` subscription and forwards each valid message to the server at once.

use std::collections::hash_map::RandomState;
use std::hash::BuildHasher;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::anyhow;
use pivotsim_msgs as msgs;
use ros2_client::Publisher;
use ros2_client::dds::rustdds::mio1;
use serde::Serialize;
use tracing::{info, warn};

use crate::convert::{self, BridgeHealth, JoyTranslator, SceneInfo};
use crate::ros_msgs::*;
use crate::zenoh_link::{self, ZenohLink};
use crate::{BridgeConfig, BridgeReport, dds, topics};

/// A publisher that counts (and logs, rate-limited) its failures instead of waiting.
struct Out<M: Serialize> {
    name: &'static str,
    publisher: Publisher<M>,
    failed: Arc<AtomicU64>,
}

impl<M: Serialize> Out<M> {
    fn publish(&self, m: M) -> bool {
        match self.publisher.publish(m) {
            Ok(()) => true,
            Err(e) => {
                let n = self.failed.fetch_add(1, Ordering::Relaxed);
                if n.is_multiple_of(1000) {
                    warn!("publish on {}: {e} ({} failures so far)", self.name, n + 1);
                }
                false
            }
        }
    }
}

fn random_source_id() -> u32 {
    let h = RandomState::new().hash_one((std::process::id(), Instant::now()));
    (h ^ (h >> 32)) as u32
}

fn joy_thread(
    mut sub: ros2_client::Subscription<Joy>,
    link: Arc<ZenohLink>,
    translator: Arc<Mutex<JoyTranslator>>,
    shutdown: Arc<AtomicBool>,
) -> anyhow::Result<()> {
    let mut poll = mio1::Poll::new()?;
    let mut events = mio1::Events::with_capacity(16);
    poll.registry().register(&mut sub, mio1::Token(0), mio1::Interest::READABLE)?;
    let mut buf = Vec::with_capacity(msgs::JOYSTICK_LEN);
    while !shutdown.load(Ordering::Relaxed) {
        if let Err(e) = poll.poll(&mut events, Some(Duration::from_millis(100)))
            && e.kind() != std::io::ErrorKind::Interrupted
        {
            return Err(e.into());
        }
        // Edge-triggered: read until empty, on every wake-up and timeout.
        loop {
            let joy = match sub.take() {
                Ok(Some((joy, _))) => joy,
                Ok(None) => break,
                Err(e) => {
                    // A sample that does not deserialize as sensor_msgs/Joy.
                    let mut t = translator.lock().map_err(|_| anyhow!("poisoned"))?;
                    t.counters.received += 1;
                    t.counters.rejected[msgs::RejectReason::Malformed.code() as usize] += 1;
                    warn!("/joy: undecodable sample ({e})");
                    continue;
                }
            };
            let (result, total) = {
                let mut t = translator.lock().map_err(|_| anyhow!("poisoned"))?;
                let r = t.translate(&joy, &mut buf);
                (r, t.counters.rejected_total())
            };
            match result {
                Ok(()) => {
                    if let Err(e) = link.put_joystick(&buf) {
                        translator.lock().map_err(|_| anyhow!("poisoned"))?.counters.put_failed += 1;
                        warn!("/joy: {e}");
                    }
                }
                Err(reason) => {
                    if total <= 10 || total.is_multiple_of(100) {
                        warn!(
                            "/joy rejected ({}): {} axes, {} buttons; {total} rejected so far",
                            reason.name(),
                            joy.axes.len(),
                            joy.buttons.len()
                        );
                    }
                }
            }
        }
    }
    Ok(())
}

/// Runs the bridge until `shutdown` is set.
pub fn run(config: &BridgeConfig, shutdown: Arc<AtomicBool>) -> anyhow::Result<BridgeReport> {
    let world = msgs::WorldName::new(config.world.clone()).map_err(|e| anyhow!("world name: {e}"))?;
    let zc = zenoh_link::config(&config.connect, config.zenoh_config.as_deref())?;
    let link = Arc::new(ZenohLink::open(zc, world.clone())?);
    let context = dds::context(config.domain_id, &config.dds_interfaces)?;
    let mut node = dds::node(&context, &config.node_name)?;
    let failed = Arc::new(AtomicU64::new(0));
    macro_rules! out {
        ($t:ty, $name:expr, $qos:expr) => {{
            let qos = $qos;
            let topic = dds::topic::<$t>(&mut node, $name, &qos)?;
            Out::<$t> {
                name: $name,
                publisher: node
                    .create_publisher(&topic, Some(qos))
                    .map_err(|e| anyhow!("{}: {e:?}", $name))?,
                failed: failed.clone(),
            }
        }};
    }
    let tf = out!(TFMessage, topics::TF, dds::qos::stream());
    let tf_static = out!(TFMessage, topics::TF_STATIC, dds::qos::latched());
    let poses = out!(PoseArray, topics::POSES, dds::qos::stream());
    let markers = out!(MarkerArray, topics::MARKERS, dds::qos::latched());
    let stats = out!(DiagnosticArray, topics::STATS, dds::qos::diagnostics());
    let clock = out!(Clock, topics::CLOCK, dds::qos::stream());
    let joy_qos = dds::qos::joy();
    let joy_topic = dds::topic::<Joy>(&mut node, &config.joy_topic, &joy_qos)?;
    let joy_sub =
        node.create_subscription::<Joy>(&joy_topic, Some(joy_qos)).map_err(|e| anyhow!("/joy: {e:?}"))?;

    let source_id = config.source_id.unwrap_or_else(random_source_id);
    let translator = Arc::new(Mutex::new(JoyTranslator::new(source_id)));
    let joy = {
        let (link, translator, shutdown) = (link.clone(), translator.clone(), shutdown.clone());
        std::thread::Builder::new().name("joy".into()).spawn(move || {
            let r = joy_thread(joy_sub, link, translator, shutdown.clone());
            if let Err(e) = &r {
                warn!("joy thread stopped: {e:#}");
            }
            r
        })?
    };
    info!(
        "bridging world `{}` (Zenoh {:?}) to ROS 2 domain {} as node /{}, joystick source {source_id}",
        world.as_str(),
        config.connect,
        config.domain_id,
        config.node_name
    );

    let mut scene: Option<SceneInfo> = None;
    let mut static_sent = false;
    let mut last_request: Option<Instant> = None;
    let mut want_scene = true;
    let mut frame = msgs::PoseFrame::default();
    let mut last_sim = f64::NEG_INFINITY;
    // Sequence and simulation time of the last frame published for the current scene.
    let mut published: Option<(u64, u64)> = None;
    let mut solver: Option<msgs::SolverStats> = None;
    let mut last_frame: Option<Instant> = None;
    let mut next_stats = Instant::now();
    let mut next_markers = Instant::now() + config.markers_period;
    let mut next_log = config.log_interval.map(|iv| Instant::now() + iv);
    let mut report = BridgeReport::default();

    while !shutdown.load(Ordering::Relaxed) && !joy.is_finished() {
        // Scene: ask on start, when the frames stop matching it, and while there is none.
        let retry = if scene.is_some() { Duration::from_millis(500) } else { Duration::from_secs(1) };
        if (want_scene || scene.is_none()) && last_request.is_none_or(|t| t.elapsed() >= retry) {
            link.request_scene();
            last_request = Some(Instant::now());
            want_scene = false;
        }
        let now = Instant::now();
        let wait =
            next_stats.min(next_markers).saturating_duration_since(now).min(Duration::from_millis(100));
        let new = link.inbox.take(wait);
        last_frame = new.last_frame.or(last_frame);
        if let Some(bytes) = new.scene {
            match msgs::SceneDescription::decode(&bytes) {
                Ok(d) if scene.as_ref().is_none_or(|s| s.description != d) => {
                    info!("scene `{}`: {} bodies", d.scene, d.bodies.len());
                    let s = SceneInfo::new(d);
                    markers.publish(convert::scene_markers(&s, true));
                    next_markers = Instant::now() + config.markers_period;
                    scene = Some(s);
                    static_sent = false;
                    published = None;
                }
                Ok(_) => {}
                Err(e) => warn!("scene description: {e}"),
            }
        }
        if let Some(bytes) = new.stats {
            match msgs::SolverStats::decode(&bytes) {
                Ok(s) => solver = Some(s),
                Err(e) => warn!("stats frame: {e}"),
            }
        }
        if let Some(bytes) = new.poses {
            match frame.decode_into(&bytes) {
                Ok(()) => {
                    if frame.sim_time < last_sim {
                        want_scene = true; // reset or a new scene
                    }
                    last_sim = frame.sim_time;
                    let repeat = published == Some((frame.sequence, frame.sim_time.to_bits()));
                    match &scene {
                        // A paused server repeats its last frame (same sequence and time): with
                        // simulation stamps that would be the same transforms at the same time
                        // again, which tf2 reports as TF_REPEATED_DATA: skip it. Wall stamps
                        // are fresh, so those repeats go out (not on /clock).
                        Some(_) if repeat && config.stamp == crate::StampSource::Sim => {}
                        Some(s) if s.matches(&frame) => {
                            let stamp = config.stamp.stamp(frame.sim_time, frame.wall_time_ns);
                            let (moving, fixed) = convert::transforms(s, &frame, stamp, &config.world_frame);
                            if !static_sent && !fixed.transforms.is_empty() {
                                static_sent = tf_static.publish(fixed);
                            }
                            if !moving.transforms.is_empty() && tf.publish(moving) {
                                report.tf_published += 1;
                            }
                            poses.publish(convert::pose_array(&frame, stamp, &config.world_frame));
                            if !repeat {
                                clock.publish(Clock { clock: Time::from_secs_f64(frame.sim_time) });
                            }
                            published = Some((frame.sequence, frame.sim_time.to_bits()));
                        }
                        _ => want_scene = true,
                    }
                }
                Err(e) => warn!("pose frame: {e}"),
            }
        }
        let now = Instant::now();
        if now >= next_markers {
            if let Some(s) = &scene {
                markers.publish(convert::scene_markers(s, false));
            }
            next_markers = now + config.markers_period;
        }
        let health = || BridgeHealth {
            world: world.as_str().to_string(),
            scene: scene.as_ref().map(|s| s.description.scene.clone()),
            pose_frames: link.inbox.pose_frames.load(Ordering::Relaxed),
            pose_frames_skipped: link.inbox.pose_frames_skipped.load(Ordering::Relaxed),
            server_silent_s: last_frame.map(|t| t.elapsed().as_secs_f64()),
            ros_publish_failed: failed.load(Ordering::Relaxed),
            joy: translator.lock().map(|t| t.counters).unwrap_or_default(),
            source_id,
        };
        if now >= next_stats {
            let stamp = match (&solver, config.stamp) {
                (Some(s), crate::StampSource::Sim) => Time::from_secs_f64(s.sim_time),
                _ => config.stamp.stamp(last_sim.max(0.0), frame.wall_time_ns),
            };
            stats.publish(convert::diagnostics(solver.as_ref(), &health(), stamp));
            next_stats = now + config.stats_period;
        }
        if let Some(t) = next_log.filter(|t| now >= *t) {
            let h = health();
            info!(
                "pose frames {} ({} skipped), /tf {}, joy {} received / {} forwarded / {} rejected, {} ROS publish failures",
                h.pose_frames,
                h.pose_frames_skipped,
                report.tf_published,
                h.joy.received,
                h.joy.forwarded,
                h.joy.rejected_total(),
                h.ros_publish_failed
            );
            next_log = config.log_interval.map(|iv| t.max(now) + iv);
        }
    }
    shutdown.store(true, Ordering::Relaxed);
    let joy_result = joy.join().map_err(|_| anyhow!("joy thread panicked"))?;
    report.pose_frames = link.inbox.pose_frames.load(Ordering::Relaxed);
    report.joy = translator.lock().map(|t| t.counters).unwrap_or_default();
    report.ros_publish_failed = failed.load(Ordering::Relaxed);
    info!("bridge stopped: {report:?}");
    joy_result.map(|()| report)
}
