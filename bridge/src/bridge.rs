//! The bridge loop. Two threads: the main loop waits for the newest frames from the server and
//! publishes them to ROS (`/tf`, `/pivotsim/pose_array`, `/clock` per pose frame; `/tf_static` (static
//! bodies and the joint frames of the joint, cylinder and drum sensors) and `/pivotsim/markers`
//! per scene; `/pivotsim/signal_values`, the wrenches and
//! `/pivotsim/contact_markers` per signals frame; `/rosout` per event; `/pivotsim/diagnostics` on a
//! timer), and the joy thread waits on the `/joy` subscription and forwards each valid message to
//! the server at once.

use std::collections::HashMap;
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

use crate::convert::{self, BridgeHealth, JoyTranslator, SceneInfo, SignalCounters, SignalLayout};
use crate::ros_msgs::*;
use crate::zenoh_link::{self, ZenohLink};
use crate::{BridgeConfig, BridgeReport, dds, topics};

/// A publisher that counts (and logs, rate-limited) its failures instead of waiting.
struct Out<M: Serialize> {
    name: String,
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

/// The wall clock now.
fn wall_now() -> Time {
    let ns =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default().as_nanos();
    Time::from_nanos(ns.min(i64::MAX as u128) as i64)
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

/// The ROS side's publishers.
struct Outputs {
    tf: Out<TFMessage>,
    tf_static: Out<TFMessage>,
    poses: Out<PoseArray>,
    markers: Out<MarkerArray>,
    stats: Out<DiagnosticArray>,
    clock: Out<Clock>,
    signals: Out<Float64MultiArray>,
    signal_names: Out<RosString>,
    contact_markers: Out<MarkerArray>,
    rosout: Out<Log>,
    /// Publish failures of all of them.
    failed: Arc<AtomicU64>,
}

impl Outputs {
    /// Declares every output topic on `node` with its QoS (`dds::qos`).
    fn create(node: &mut ros2_client::Node) -> anyhow::Result<Outputs> {
        let failed = Arc::new(AtomicU64::new(0));
        macro_rules! out {
            ($t:ty, $name:expr, $qos:expr) => {{
                let qos = $qos;
                let topic = dds::topic::<$t>(node, $name, &qos)?;
                Out::<$t> {
                    name: $name.to_string(),
                    publisher: node
                        .create_publisher(&topic, Some(qos))
                        .map_err(|e| anyhow!("{}: {e:?}", $name))?,
                    failed: failed.clone(),
                }
            }};
        }
        Ok(Outputs {
            tf: out!(TFMessage, topics::TF, dds::qos::stream()),
            tf_static: out!(TFMessage, topics::TF_STATIC, dds::qos::latched()),
            poses: out!(PoseArray, topics::POSES, dds::qos::stream()),
            markers: out!(MarkerArray, topics::MARKERS, dds::qos::latched()),
            stats: out!(DiagnosticArray, topics::STATS, dds::qos::diagnostics()),
            clock: out!(Clock, topics::CLOCK, dds::qos::stream()),
            signals: out!(Float64MultiArray, topics::SIGNALS, dds::qos::signals()),
            signal_names: out!(RosString, topics::SIGNAL_NAMES, dds::qos::latched()),
            contact_markers: out!(MarkerArray, topics::CONTACT_MARKERS, dds::qos::signals()),
            rosout: out!(Log, topics::ROSOUT, dds::qos::rosout()),
            failed,
        })
    }

    /// A force sensor's wrench publisher on `name` (created when the sensor first appears).
    fn wrench(&self, node: &mut ros2_client::Node, name: &str) -> anyhow::Result<Out<WrenchStamped>> {
        let qos = dds::qos::signals();
        let topic = dds::topic::<WrenchStamped>(node, name, &qos)?;
        Ok(Out {
            name: name.to_string(),
            publisher: node.create_publisher(&topic, Some(qos)).map_err(|e| anyhow!("{name}: {e:?}"))?,
            failed: self.failed.clone(),
        })
    }
}

/// Subscribes to the joystick topic and starts the joy thread that forwards it to the server.
fn spawn_joy(
    node: &mut ros2_client::Node,
    config: &BridgeConfig,
    link: &Arc<ZenohLink>,
    translator: &Arc<Mutex<JoyTranslator>>,
    shutdown: &Arc<AtomicBool>,
) -> anyhow::Result<std::thread::JoinHandle<anyhow::Result<()>>> {
    let joy_qos = dds::qos::joy();
    let joy_topic = dds::topic::<Joy>(node, &config.joy_topic, &joy_qos)?;
    let joy_sub =
        node.create_subscription::<Joy>(&joy_topic, Some(joy_qos)).map_err(|e| anyhow!("/joy: {e:?}"))?;
    let (link, translator, shutdown) = (link.clone(), translator.clone(), shutdown.clone());
    Ok(std::thread::Builder::new().name("joy".into()).spawn(move || {
        let r = joy_thread(joy_sub, link, translator, shutdown.clone());
        if let Err(e) = &r {
            warn!("joy thread stopped: {e:#}");
        }
        r
    })?)
}

/// The main loop's state: the scene, the last frames, and when each timer is due.
struct Bridge<'a> {
    config: &'a BridgeConfig,
    world: msgs::WorldName,
    link: Arc<ZenohLink>,
    out: Outputs,
    node: ros2_client::Node,
    translator: Arc<Mutex<JoyTranslator>>,
    source_id: u32,
    scene: Option<SceneInfo>,
    static_sent: bool,
    last_request: Option<Instant>,
    want_scene: bool,
    frame: msgs::PoseFrame,
    last_sim: f64,
    /// Sequence and simulation time of the last frame published for the current scene.
    published: Option<(u64, u64)>,
    solver: Option<msgs::SolverStats>,
    last_frame: Option<Instant>,
    next_stats: Instant,
    next_markers: Instant,
    next_log: Option<Instant>,
    report: BridgeReport,
    /// The last signals frame that decoded (`have_signals`), and the buffer the next one decodes
    /// into.
    signals: msgs::SignalsFrame,
    have_signals: bool,
    signals_scratch: msgs::SignalsFrame,
    /// Sequence and simulation time of the last signals frame published.
    signals_published: Option<(u64, u64)>,
    /// The channel layout of the current signals frames and its wrench publishers by topic.
    layout: Option<SignalLayout>,
    wrench_outs: HashMap<String, Out<WrenchStamped>>,
    array: Float64MultiArray,
    /// Whether the last contact array drew contacts.
    contacts_shown: bool,
    counters: SignalCounters,
}

impl Bridge<'_> {
    /// Asks for the scene on start, when the frames stop matching it, and while there is none.
    fn request_scene_when_due(&mut self) {
        let retry = if self.scene.is_some() { Duration::from_millis(500) } else { Duration::from_secs(1) };
        if (self.want_scene || self.scene.is_none()) && self.last_request.is_none_or(|t| t.elapsed() >= retry)
        {
            self.link.request_scene();
            self.last_request = Some(Instant::now());
            self.want_scene = false;
        }
    }

    /// A scene description reply: a new scene gets its markers at once and its static frames anew.
    fn on_scene(&mut self, bytes: &[u8]) {
        match msgs::SceneDescription::decode(bytes) {
            Ok(d) if self.scene.as_ref().is_none_or(|s| s.description != d) => {
                info!("scene `{}`: {} bodies", d.scene, d.bodies.len());
                let s = SceneInfo::new(d);
                self.out.markers.publish(convert::scene_markers(&s, true));
                self.next_markers = Instant::now() + self.config.markers_period;
                self.scene = Some(s);
                self.static_sent = false;
                self.published = None;
                // Force sensors are classified by the description's sensors: again on the next
                // signals frame.
                self.layout = None;
            }
            Ok(_) => {}
            Err(e) => warn!("scene description: {e}"),
        }
    }

    fn on_stats(&mut self, bytes: &[u8]) {
        match msgs::SolverStats::decode(bytes) {
            Ok(s) => self.solver = Some(s),
            Err(e) => warn!("stats frame: {e}"),
        }
    }

    /// A pose frame: `/tf`, `/tf_static` (once per scene), `/pivotsim/pose_array` and `/clock`.
    fn on_poses(&mut self, bytes: &[u8]) {
        if let Err(e) = self.frame.decode_into(bytes) {
            warn!("pose frame: {e}");
            return;
        }
        let (frame, config) = (&self.frame, self.config);
        if frame.sim_time < self.last_sim {
            self.want_scene = true; // reset or a new scene
        }
        self.last_sim = frame.sim_time;
        let repeat = self.published == Some((frame.sequence, frame.sim_time.to_bits()));
        match &self.scene {
            // A paused server repeats its last frame (same sequence and time): with simulation
            // stamps that would be the same transforms at the same time again, which tf2 reports
            // as TF_REPEATED_DATA: skip it. Wall stamps are fresh, so those repeats go out (not on
            // /clock).
            Some(_) if repeat && config.stamp == crate::StampSource::Sim => {}
            Some(s) if s.matches(frame) => {
                let stamp = config.stamp.stamp(frame.sim_time, frame.wall_time_ns);
                let (moving, mut fixed) = convert::transforms(s, frame, stamp, &config.world_frame);
                if !self.static_sent {
                    // One latched message (keep last 1): the static bodies and the joint frames.
                    fixed.transforms.extend(convert::joint_frame_transforms(s, stamp, &config.world_frame));
                }
                if !self.static_sent && !fixed.transforms.is_empty() {
                    self.static_sent = self.out.tf_static.publish(fixed);
                }
                if !moving.transforms.is_empty() && self.out.tf.publish(moving) {
                    self.report.tf_published += 1;
                }
                self.out.poses.publish(convert::pose_array(frame, stamp, &config.world_frame));
                if !repeat {
                    self.out.clock.publish(Clock { clock: Time::from_secs_f64(frame.sim_time) });
                }
                self.published = Some((frame.sequence, frame.sim_time.to_bits()));
            }
            _ => self.want_scene = true,
        }
    }

    /// The stamp of a signals frame: its simulation time, or with `--stamp wall` the wall time
    /// of the pose frame of the same step (the clock here when that frame is not the latest).
    fn signals_stamp(&self, sequence: u64, sim_time: f64) -> Time {
        match self.config.stamp {
            crate::StampSource::Sim => Time::from_secs_f64(sim_time),
            crate::StampSource::Wall if self.frame.sequence == sequence => {
                crate::StampSource::Wall.stamp(sim_time, self.frame.wall_time_ns)
            }
            crate::StampSource::Wall => wall_now(),
        }
    }

    /// New channel names (first frame, new scene): the wrench publishers of the new force
    /// sensors (those no longer present are dropped; at most `MAX_WRENCH_TOPICS`), and the names
    /// on `/pivotsim/signal_names`.
    fn set_layout(&mut self, layout: SignalLayout) {
        self.wrench_outs.retain(|topic, _| layout.wrenches.iter().any(|w| &w.topic == topic));
        let mut refused = layout.wrenches_refused as u64;
        for w in &layout.wrenches {
            if !self.wrench_outs.contains_key(&w.topic) {
                match self.out.wrench(&mut self.node, &w.topic) {
                    Ok(o) => {
                        self.wrench_outs.insert(w.topic.clone(), o);
                    }
                    Err(e) => {
                        warn!("force sensor `{}`: no publisher: {e:#}", w.sensor);
                        refused += 1;
                    }
                }
            }
        }
        self.counters.wrench_topics = self.wrench_outs.len() as u64;
        self.counters.wrench_sensors_refused = refused;
        let topics: Vec<&str> = layout.wrenches.iter().map(|w| w.topic.as_str()).collect();
        info!(
            "signals: {} channels; wrenches on {topics:?}; {refused} force sensors refused",
            self.signals.channels.len()
        );
        self.out.signal_names.publish(RosString { data: layout.names_text() });
        self.layout = Some(layout);
    }

    /// A signals frame: `/pivotsim/signal_values`, a wrench per force sensor and the contact arrows. A
    /// frame that does not decode is counted and dropped.
    fn on_signals(&mut self, bytes: &[u8]) {
        if let Err(e) = self.signals_scratch.decode_into(bytes) {
            self.counters.signals_decode_failed += 1;
            let n = self.counters.signals_decode_failed;
            if n <= 10 || n.is_multiple_of(1000) {
                warn!("signals frame: {e} ({n} undecodable so far)");
            }
            return;
        }
        std::mem::swap(&mut self.signals, &mut self.signals_scratch);
        self.have_signals = true;
        let (sequence, sim_time) = (self.signals.sequence, self.signals.sim_time);
        // A paused server repeats its last frame: with simulation stamps nothing new to say.
        if self.config.stamp == crate::StampSource::Sim
            && self.signals_published == Some((sequence, sim_time.to_bits()))
        {
            return;
        }
        if !self.layout.as_ref().is_some_and(|l| l.matches(&self.signals)) {
            let scene = self.scene.as_ref().map(|s| &s.description);
            self.set_layout(SignalLayout::new(&self.signals, scene));
        }
        let stamp = self.signals_stamp(sequence, sim_time);
        let world_frame = &self.config.world_frame;
        convert::signals_array(&self.signals, &mut self.array);
        self.out.signals.publish(self.array.clone());
        if let Some(layout) = &self.layout {
            for w in &layout.wrenches {
                if let (Some(out), Some(m)) =
                    (self.wrench_outs.get(&w.topic), convert::wrench(w, &self.signals, stamp, world_frame))
                    && out.publish(m)
                {
                    self.report.wrenches_published += 1;
                }
            }
        }
        // The arrows while there are contacts, and once more (a lone DELETEALL) when they are gone.
        let contacts = !self.signals.contacts.is_empty();
        if contacts || self.contacts_shown {
            self.out.contact_markers.publish(convert::contact_markers(
                &self.signals,
                self.config.force_scale,
                stamp,
                world_frame,
            ));
        }
        self.contacts_shown = contacts;
        self.signals_published = Some((sequence, sim_time.to_bits()));
    }

    /// An events frame: each event as a `/rosout` line (and in the bridge's own log).
    fn on_events(&mut self, bytes: &[u8]) {
        let e = match msgs::EventsFrame::decode(bytes) {
            Ok(e) => e,
            Err(e) => {
                self.counters.events_decode_failed += 1;
                let n = self.counters.events_decode_failed;
                if n <= 10 || n.is_multiple_of(1000) {
                    warn!("events frame: {e} ({n} undecodable so far)");
                }
                return;
            }
        };
        for r in &e.events {
            let stamp = match self.config.stamp {
                crate::StampSource::Sim => Time::from_secs_f64(r.time),
                crate::StampSource::Wall => wall_now(),
            };
            let line = convert::event_log(r, stamp, &self.config.node_name);
            info!("{}", line.msg);
            if self.out.rosout.publish(line) {
                self.counters.events_logged += 1;
            }
        }
    }

    fn signal_counters(&self) -> SignalCounters {
        let i = &self.link.inbox;
        SignalCounters {
            signals_frames: i.signals_frames.load(Ordering::Relaxed),
            signals_frames_skipped: i.signals_frames_skipped.load(Ordering::Relaxed),
            events_frames: i.events_frames.load(Ordering::Relaxed),
            events_frames_dropped: i.events_frames_dropped.load(Ordering::Relaxed),
            ..self.counters
        }
    }

    fn health(&self) -> BridgeHealth {
        BridgeHealth {
            world: self.world.as_str().to_string(),
            scene: self.scene.as_ref().map(|s| s.description.scene.clone()),
            pose_frames: self.link.inbox.pose_frames.load(Ordering::Relaxed),
            pose_frames_skipped: self.link.inbox.pose_frames_skipped.load(Ordering::Relaxed),
            server_silent_s: self.last_frame.map(|t| t.elapsed().as_secs_f64()),
            ros_publish_failed: self.out.failed.load(Ordering::Relaxed),
            joy: self.translator.lock().map(|t| t.counters).unwrap_or_default(),
            source_id: self.source_id,
            signals: self.signal_counters(),
        }
    }

    /// The timers: markers again (late joiners), `/pivotsim/diagnostics`, the log line.
    fn on_timers(&mut self, now: Instant) {
        if now >= self.next_markers {
            if let Some(s) = &self.scene {
                self.out.markers.publish(convert::scene_markers(s, false));
            }
            self.next_markers = now + self.config.markers_period;
        }
        if now >= self.next_stats {
            let stamp = match (&self.solver, self.config.stamp) {
                (Some(s), crate::StampSource::Sim) => Time::from_secs_f64(s.sim_time),
                _ => self.config.stamp.stamp(self.last_sim.max(0.0), self.frame.wall_time_ns),
            };
            let signals = self.have_signals.then_some(&self.signals);
            self.out.stats.publish(convert::diagnostics(
                self.solver.as_ref(),
                signals,
                &self.health(),
                stamp,
            ));
            self.next_stats = now + self.config.stats_period;
        }
        if let Some(t) = self.next_log.filter(|t| now >= *t) {
            let h = self.health();
            info!(
                "pose frames {} ({} skipped), /tf {}, signals frames {} ({} skipped, {} undecodable), {} wrenches, {} events logged, joy {} received / {} forwarded / {} rejected, {} ROS publish failures",
                h.pose_frames,
                h.pose_frames_skipped,
                self.report.tf_published,
                h.signals.signals_frames,
                h.signals.signals_frames_skipped,
                h.signals.signals_decode_failed,
                self.report.wrenches_published,
                h.signals.events_logged,
                h.joy.received,
                h.joy.forwarded,
                h.joy.rejected_total(),
                h.ros_publish_failed
            );
            self.next_log = self.config.log_interval.map(|iv| t.max(now) + iv);
        }
    }

    /// One round: the scene request, the newest frames (waiting at most until the next timer or
    /// 100 ms), then the timers.
    fn round(&mut self) {
        self.request_scene_when_due();
        let wait = self
            .next_stats
            .min(self.next_markers)
            .saturating_duration_since(Instant::now())
            .min(Duration::from_millis(100));
        let new = self.link.inbox.take(wait);
        self.last_frame = new.last_frame.or(self.last_frame);
        if let Some(bytes) = new.scene {
            self.on_scene(&bytes);
        }
        if let Some(bytes) = new.stats {
            self.on_stats(&bytes);
        }
        if let Some(bytes) = new.poses {
            self.on_poses(&bytes);
        }
        if let Some(bytes) = new.signals {
            self.on_signals(&bytes);
        }
        for bytes in new.events {
            self.on_events(&bytes);
        }
        self.on_timers(Instant::now());
    }
}

/// Runs the bridge until `shutdown` is set: the Zenoh link, the DDS node, the output topics, the
/// joy thread, then rounds of `Bridge::round`.
pub fn run(config: &BridgeConfig, shutdown: Arc<AtomicBool>) -> anyhow::Result<BridgeReport> {
    let world = msgs::WorldName::new(config.world.clone()).map_err(|e| anyhow!("world name: {e}"))?;
    let zc = zenoh_link::config(&config.connect, config.zenoh_config.as_deref())?;
    let link = Arc::new(ZenohLink::open(zc, world.clone())?);
    let context = dds::context(config.domain_id, &config.dds_interfaces)?;
    let mut node = dds::node(&context, &config.node_name)?;
    let out = Outputs::create(&mut node)?;
    let source_id = config.source_id.unwrap_or_else(random_source_id);
    let translator = Arc::new(Mutex::new(JoyTranslator::new(source_id)));
    let joy = spawn_joy(&mut node, config, &link, &translator, &shutdown)?;
    info!(
        "bridging world `{}` (Zenoh {:?}) to ROS 2 domain {} as node /{}, joystick source {source_id}",
        world.as_str(),
        config.connect,
        config.domain_id,
        config.node_name
    );
    let mut b = Bridge {
        config,
        world,
        link,
        out,
        node,
        translator,
        source_id,
        scene: None,
        static_sent: false,
        last_request: None,
        want_scene: true,
        frame: msgs::PoseFrame::default(),
        last_sim: f64::NEG_INFINITY,
        published: None,
        solver: None,
        last_frame: None,
        next_stats: Instant::now(),
        next_markers: Instant::now() + config.markers_period,
        next_log: config.log_interval.map(|iv| Instant::now() + iv),
        report: BridgeReport::default(),
        signals: msgs::SignalsFrame::default(),
        have_signals: false,
        signals_scratch: msgs::SignalsFrame::default(),
        signals_published: None,
        layout: None,
        wrench_outs: HashMap::new(),
        array: Float64MultiArray::default(),
        contacts_shown: false,
        counters: SignalCounters::default(),
    };
    while !shutdown.load(Ordering::Relaxed) && !joy.is_finished() {
        b.round();
    }
    shutdown.store(true, Ordering::Relaxed);
    let joy_result = joy.join().map_err(|_| anyhow!("joy thread panicked"))?;
    let signals = b.signal_counters();
    let mut report = b.report;
    report.pose_frames = b.link.inbox.pose_frames.load(Ordering::Relaxed);
    report.joy = b.translator.lock().map(|t| t.counters).unwrap_or_default();
    report.ros_publish_failed = b.out.failed.load(Ordering::Relaxed);
    report.signals = signals;
    info!("bridge stopped: {report:?}");
    joy_result.map(|()| report)
}
