//! The bridge end to end on loopback: an in-process server (ephemeral Zenoh port, unique world),
//! the bridge binary as another process, and a ROS 2 node (ros2-client, DDS) in this test
//! process, on a DDS domain of its own with DDS confined to 127.0.0.1 (discovery by unicast to
//! the localhost discovery ports: no multicast needed on `lo`). Every wait is bounded.
//!
//! - `/tf` carries every moving body's frame and `/tf_static` the static one, with transforms
//!   equal to the Zenoh pose frame of the same simulation time; `/pivotsim/pose_array`, `/clock` and
//!   the markers arrive too; paused, nothing repeats, and under lockstep (`step 5`) `/clock`
//!   follows the stepped time to its last step.
//! - A `/joy` stream moves the driven joint; when it stops, the server's deadman trips.
//! - Malformed `/joy` (33 axes, a NaN axis) is rejected and counted by the bridge (its
//!   diagnostics on `/pivotsim/diagnostics`) and never reaches the server.
//! - The operator signals: a hanging load's joint reaction arrives as a `WrenchStamped` in the
//!   joint's frame, which `/tf_static` places under the load, and turned into the world with the
//!   transforms it is (0, 0, m·g); a resting crate's support force arrives in `world` as m·g;
//!   every channel on `/pivotsim/signal_values`, the crate's contacts as arrows, a live fault as a
//!   `/rosout` line, and a malformed signals frame is counted without stopping anything.

#![cfg(feature = "ros2")]

use std::collections::{BTreeSet, HashMap};
use std::net::Ipv4Addr;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use pivotsim_msgs as msgs;
use pivotsim_ros2_bridge::convert::{DIAG_BRIDGE, DIAG_INPUTS, DIAG_SIGNALS};
use pivotsim_ros2_bridge::ros_msgs::*;
use pivotsim_ros2_bridge::{dds, topics};
use pivotsim_server::serve::{ServeConfig, ZenohOptions};
use pivotsim_tests::{Server, temp_file, temp_path};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{Node, QosProfile, Subscription};
use zenoh::Wait;

/// A static base and a drum on a hinge about y, driven by joystick axis 0 at 2 rad/s full stick.
const RIG: &str = r#"
[scene]
name = "joyrig"
[[body]]
name = "base"
kind = "static"
position = [0, 0, 0]
[[body.shape]]
type = "box"
size = [2, 2, 0.2]
[[body]]
name = "drum"
mass = 10
inertia = [1, 1, 1]
position = [0, 0, 1]
[[body.shape]]
type = "cylinder"
radius = 0.3
length = 0.5
rotation = [90, 0, 0]
[[body]]
name = "hook"
mass = 1
position = [0.5, 0, 1]
[[body.shape]]
type = "ball"
radius = 0.1
[[joint]]
name = "axle"
type = "hinge"
a = "drum"
anchor = [0, 0, 1]
axis = [0, 1, 0]
[[joint]]
name = "arm"
type = "fixed"
a = "hook"
b = "drum"
anchor = [0.5, 0, 1]
[[actuator]]
name = "spin"
type = "velocity"
joints = ["axle"]
scale = [2.0]
max_force = 1e6
[[joystick.axis]]
index = 0
actuator = "spin"
deadzone = 0.0
"#;

/// A static ground, a 10 kg crate resting on it (contact sum `support`, its contact points), and a
/// 5 kg ball, turned, hanging 1 m below a ball joint to the world (joint sensor `hang.rope`,
/// tension `rope`).
const SIGRIG: &str = r#"
[scene]
name = "sigrig"
[[body]]
name = "ground"
kind = "static"
position = [0, 0, 0]
[[body.shape]]
type = "box"
size = [4, 4, 0.2]
[[body]]
name = "crate"
mass = 10
position = [0, 0, 0.35]
[[body.shape]]
type = "box"
size = [0.5, 0.5, 0.5]
[[body]]
name = "load"
mass = 5
position = [1.5, 0, 1]
rotation = [30, 20, 10]
[[body.shape]]
type = "ball"
radius = 0.1
[[joint]]
name = "rope"
type = "ball"
a = "load"
anchor = [1.5, 0, 2]
[[sensor]]
name = "hang.rope"
type = "joint"
joint = "rope"
[[sensor]]
name = "rope"
type = "tension"
joint = "rope"
[[sensor]]
name = "support"
type = "contact_sum"
bodies = ["crate"]
[[sensor]]
name = "crate_contacts"
type = "contacts"
bodies = ["crate"]
"#;

/// Tests in this file, each with a domain of its own (`domain(0)` … `domain(TESTS - 1)`).
const TESTS: u16 = 5;

/// A DDS domain per test (and per process, so that concurrent runs rarely meet): 20 ..= 199, well
/// inside the range whose RTPS port numbers fit in 16 bits. The stride is the number of tests, so
/// that two processes in neighbouring buckets never share one (with a stride of 4 and five tests,
/// one run's last test met the next bucket's first: two concurrent runs saw each other's frames).
fn domain(test: u16) -> u16 {
    assert!(test < TESTS, "domain({test}): raise TESTS");
    20 + (std::process::id() % 36) as u16 * TESTS + test
}

/// The harness server on the test rig, Zenoh only (the bridge reads Zenoh).
fn start_server(tag: &str) -> Server {
    start_scene(tag, RIG)
}

/// The harness server on a scene, Zenoh only.
fn start_scene(tag: &str, toml: &str) -> Server {
    let scene = temp_file(&format!("ros2-{tag}.toml"), toml);
    Server::start_with(&scene.display().to_string(), &format!("r-{tag}"), |c| c.iceoryx2 = false)
}

/// The bridge binary, killed on drop; its log goes to a file shown when a test fails.
struct Bridge {
    child: Child,
    log: PathBuf,
}

impl Bridge {
    fn spawn(server: &Server, domain: u16, tag: &str) -> Bridge {
        Bridge::spawn_with(server, domain, tag, &[])
    }

    /// With more arguments.
    fn spawn_with(server: &Server, domain: u16, tag: &str, more: &[&str]) -> Bridge {
        let log = temp_path(&format!("ros2-{tag}.log"));
        let child = Command::new(env!("CARGO_BIN_EXE_pivotsim-ros2-bridge"))
            .args(["--world", server.world.as_str(), "--connect", &server.endpoint])
            .args(more)
            .args(["--domain-id", &domain.to_string(), "--dds-interface", "127.0.0.1"])
            .args(["--stats-rate", "20", "--source-id", "4242", "--log-interval", "1"])
            .env("RUST_LOG", "info,zenoh=warn,rustdds=error,ros2_client=error")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .expect("the bridge binary starts");
        Bridge { child, log }
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for Bridge {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if std::thread::panicking() {
            eprintln!("---- bridge log ----\n{}", self.log());
        }
    }
}

/// A Zenoh client of the server with the latest stats and every pose frame by simulation time.
struct Watcher {
    session: zenoh::Session,
    _subs: Vec<zenoh::pubsub::Subscriber<()>>,
    frames: Arc<Mutex<HashMap<i64, msgs::PoseFrame>>>,
    latest_pose: Arc<Mutex<Option<msgs::PoseFrame>>>,
    stats: Arc<Mutex<Option<msgs::SolverStats>>>,
    description: msgs::SceneDescription,
}

fn nanos(t: f64) -> i64 {
    Time::from_secs_f64(t).as_nanos()
}

impl Watcher {
    fn connect(server: &Server) -> Watcher {
        let (s, description) = server.connect();
        let frames = Arc::new(Mutex::new(HashMap::new()));
        let latest_pose = Arc::new(Mutex::new(None));
        let stats = Arc::new(Mutex::new(None));
        let (f, lp) = (frames.clone(), latest_pose.clone());
        let poses = s
            .declare_subscriber(server.key(msgs::Topic::Poses))
            .callback(move |sample| {
                let p = msgs::PoseFrame::decode(&sample.payload().to_bytes()).unwrap();
                f.lock().unwrap().insert(nanos(p.sim_time), p.clone());
                *lp.lock().unwrap() = Some(p);
            })
            .wait()
            .unwrap();
        let st = stats.clone();
        let stats_sub = s
            .declare_subscriber(server.key(msgs::Topic::Stats))
            .callback(move |sample| {
                *st.lock().unwrap() = Some(msgs::SolverStats::decode(&sample.payload().to_bytes()).unwrap());
            })
            .wait()
            .unwrap();
        Watcher { session: s, _subs: vec![poses, stats_sub], frames, latest_pose, stats, description }
    }

    /// Sends a control command and checks that it succeeded.
    fn control(&self, server: &Server, command: msgs::ControlCommand) {
        let r = server.control(&self.session, 1, command);
        assert!(matches!(r.outcome, msgs::ControlOutcome::Ok(_)), "{r:?}");
    }

    fn stats(&self) -> Option<msgs::SolverStats> {
        self.stats.lock().unwrap().clone()
    }

    fn body_id(&self, name: &str) -> u32 {
        self.description.bodies.iter().find(|b| b.name == name).unwrap().id
    }

    /// Angular velocity about y of the latest frame's body `name`.
    fn omega_y(&self, name: &str) -> f64 {
        let id = self.body_id(name);
        let p = self.latest_pose.lock().unwrap().clone().expect("a pose frame");
        p.bodies.iter().find(|b| b.id == id).unwrap().angular_velocity[1]
    }
}

/// A ROS 2 node of the test on the domain, DDS on loopback only.
fn ros_node(domain: u16, name: &str) -> (ros2_client::Context, Node) {
    let ctx = dds::context(domain, &[Ipv4Addr::LOCALHOST.into()]).unwrap();
    let node = dds::node(&ctx, name).unwrap();
    (ctx, node)
}

fn reliable(depth: usize) -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .history(History::KeepLast { depth })
}

fn latched() -> QosProfile {
    reliable(1).durability(Durability::TransientLocal)
}

fn subscribe<M: RosType + serde::de::DeserializeOwned + 'static>(
    node: &mut Node,
    name: &str,
    qos: QosProfile,
) -> Subscription<M> {
    let topic = dds::topic::<M>(node, name, &qos).unwrap();
    node.create_subscription::<M>(&topic, Some(qos)).unwrap()
}

fn drain<M: serde::de::DeserializeOwned + 'static>(s: &Subscription<M>, out: &mut Vec<(M, Instant)>) {
    while let Ok(Some((m, _))) = s.take() {
        out.push((m, Instant::now()));
    }
}

fn wall_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_nanos() as u64
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

#[test]
fn tf_carries_every_body_frame_with_the_zenoh_poses() {
    let server = start_server("tf");
    let watcher = Watcher::connect(&server);
    let d = domain(0);
    let bridge = Bridge::spawn(&server, d, "tf");
    let (_ctx, mut node) = ros_node(d, "tf_probe");
    let tf_sub = subscribe::<TFMessage>(&mut node, topics::TF, reliable(100));
    let static_sub = subscribe::<TFMessage>(&mut node, topics::TF_STATIC, latched());
    let poses_sub = subscribe::<PoseArray>(&mut node, topics::POSES, reliable(100));
    let markers_sub = subscribe::<MarkerArray>(&mut node, topics::MARKERS, latched());
    let clock_sub = subscribe::<Clock>(&mut node, topics::CLOCK, reliable(100));

    let (mut tf, mut fixed, mut poses, mut markers, mut clock) = (vec![], vec![], vec![], vec![], vec![]);
    let mut latency_ms = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(30);
    while Instant::now() < deadline
        && (tf.len() < 60 || fixed.is_empty() || markers.is_empty() || poses.len() < 30 || clock.len() < 30)
    {
        let n = tf.len();
        drain(&tf_sub, &mut tf);
        // Latency: the server's wall clock at the end of the step → here.
        let now = wall_ns();
        let frames = watcher.frames.lock().unwrap();
        for (m, _) in &tf[n..] {
            if let Some(f) = frames.get(&m.transforms[0].header.stamp.as_nanos()) {
                latency_ms.push((now.saturating_sub(f.wall_time_ns)) as f64 / 1e6);
            }
        }
        drop(frames);
        drain(&static_sub, &mut fixed);
        drain(&poses_sub, &mut poses);
        drain(&markers_sub, &mut markers);
        drain(&clock_sub, &mut clock);
        std::thread::sleep(Duration::from_millis(2));
    }
    assert!(tf.len() >= 60, "{} /tf messages in 30 s", tf.len());
    assert!(!fixed.is_empty(), "no /tf_static");
    assert!(!markers.is_empty(), "no markers");
    assert!(poses.len() >= 30 && clock.len() >= 30, "{} poses, {} clock", poses.len(), clock.len());

    let names: HashMap<&str, u32> =
        watcher.description.bodies.iter().map(|b| (b.name.as_str(), b.id)).collect();
    let frames = watcher.frames.lock().unwrap();
    let check = |t: &TransformStamped, f: &msgs::PoseFrame| {
        assert_eq!(t.header.frame_id, "world");
        let id = names[t.child_frame_id.as_str()];
        let b = f.bodies.iter().find(|b| b.id == id).unwrap();
        let tr = &t.transform;
        let got = [tr.translation.x, tr.translation.y, tr.translation.z];
        let q = [tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w];
        for k in 0..3 {
            assert!(
                (got[k] - b.position[k]).abs() <= 1e-9,
                "{}: {got:?} vs {:?}",
                t.child_frame_id,
                b.position
            );
        }
        for k in 0..4 {
            assert!(
                (q[k] - b.orientation[k]).abs() <= 1e-9,
                "{}: {q:?} vs {:?}",
                t.child_frame_id,
                b.orientation
            );
        }
    };
    // Every /tf message: the moving bodies, equal to the Zenoh frame of the same time.
    let mut matched = 0;
    for (m, _) in &tf {
        let frame_ids: BTreeSet<&str> = m.transforms.iter().map(|t| t.child_frame_id.as_str()).collect();
        assert_eq!(frame_ids, BTreeSet::from(["drum", "hook"]));
        let stamp = m.transforms[0].header.stamp;
        assert!(m.transforms.iter().all(|t| t.header.stamp == stamp));
        if let Some(f) = frames.get(&stamp.as_nanos()) {
            for t in &m.transforms {
                check(t, f);
            }
            matched += 1;
        }
    }
    assert!(matched >= 50, "{matched} of {} /tf messages matched a Zenoh frame", tf.len());
    // /tf_static: the base, at its Zenoh pose.
    let st = &fixed.last().unwrap().0;
    assert_eq!(st.transforms.iter().map(|t| t.child_frame_id.as_str()).collect::<Vec<_>>(), ["base"]);
    let any_frame = frames.values().next().unwrap();
    check(&st.transforms[0], any_frame);
    // Every body has a frame on /tf or /tf_static.
    let all: BTreeSet<&str> = names.keys().copied().collect();
    assert_eq!(all, BTreeSet::from(["base", "drum", "hook"]));
    // /pivotsim/pose_array: every body, in the frame's order, equal to the Zenoh frame.
    let mut pose_matched = 0;
    for (p, _) in &poses {
        assert_eq!(p.header.frame_id, "world");
        if let Some(f) = frames.get(&p.header.stamp.as_nanos()) {
            assert_eq!(p.poses.len(), f.bodies.len());
            for (a, b) in p.poses.iter().zip(&f.bodies) {
                assert_eq!([a.position.x, a.position.y, a.position.z], b.position);
                assert_eq!(
                    [a.orientation.x, a.orientation.y, a.orientation.z, a.orientation.w],
                    b.orientation
                );
            }
            pose_matched += 1;
        }
    }
    assert!(pose_matched >= 20, "{pose_matched} PoseArrays matched");
    // /clock: simulation time, increasing, equal to frames' times.
    assert!(clock.windows(2).all(|w| w[1].0.clock > w[0].0.clock));
    assert!(clock.iter().filter(|(c, _)| frames.contains_key(&c.clock.as_nanos())).count() >= 20);
    // Markers: every body's shapes in its own frame.
    let m = &markers.last().unwrap().0;
    for body in ["base", "drum", "hook"] {
        assert!(
            m.markers.iter().any(|k| k.ns == body && k.header.frame_id == body && k.frame_locked),
            "{body}"
        );
    }
    let cube = m.markers.iter().find(|k| k.ns == "base").unwrap();
    assert_eq!((cube.type_, cube.scale), (Marker::CUBE, Vector3 { x: 2.0, y: 2.0, z: 0.2 }));
    let cyl = m.markers.iter().find(|k| k.ns == "drum").unwrap();
    assert_eq!(cyl.type_, Marker::CYLINDER);
    assert!((cyl.scale.x - 0.6).abs() < 1e-12 && (cyl.scale.z - 0.5).abs() < 1e-12);

    drop(frames);
    // Paused, the server repeats its last frame; the bridge does not repeat the transforms
    // (tf2 would report TF_REPEATED_DATA) nor the clock.
    watcher.control(&server, msgs::ControlCommand::Pause);
    std::thread::sleep(Duration::from_millis(300));
    let (mut after, mut clock_after) = (vec![], vec![]);
    drain(&tf_sub, &mut after);
    drain(&clock_sub, &mut clock_after);
    let wall_before = watcher.latest_pose.lock().unwrap().as_ref().unwrap().wall_time_ns;
    after.clear();
    clock_after.clear();
    std::thread::sleep(Duration::from_millis(500));
    drain(&tf_sub, &mut after);
    drain(&clock_sub, &mut clock_after);
    let wall_after = watcher.latest_pose.lock().unwrap().as_ref().unwrap().wall_time_ns;
    assert!(wall_after > wall_before, "the paused server keeps publishing");
    assert_eq!((after.len(), clock_after.len()), (0, 0), "paused: /tf and /clock repeated");

    // Lockstep: `step 5` on the paused world publishes five new states; /clock follows them: each
    // message is one of the steps' times, increasing, and the last step's time always arrives
    // (the bridge keeps the newest pose frame, so a burst's intermediate steps may be skipped).
    let paused_at = watcher.latest_pose.lock().unwrap().as_ref().unwrap().sim_time;
    let r = server.control(&watcher.session, 2, msgs::ControlCommand::Step { count: 5 });
    let stepped = match r.outcome {
        msgs::ControlOutcome::Ok(s) => s,
        other => panic!("step 5: {other:?}"),
    };
    let h = (stepped.sim_time - paused_at) / 5.0;
    assert!(h > 0.0, "step 5 advanced the time");
    let want: Vec<i64> = (1..=5).map(|k| nanos(paused_at + k as f64 * h)).collect();
    let last = *want.last().unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    while !clock_after.iter().any(|(c, _)| (c.clock.as_nanos() - last).abs() <= 1)
        && Instant::now() < deadline
    {
        std::thread::sleep(Duration::from_millis(20));
        drain(&clock_sub, &mut clock_after);
    }
    std::thread::sleep(Duration::from_millis(300));
    drain(&clock_sub, &mut clock_after);
    let got: Vec<i64> = clock_after.iter().map(|(c, _)| c.clock.as_nanos()).collect();
    assert!(!got.is_empty() && got.windows(2).all(|w| w[1] > w[0]), "/clock {got:?}");
    assert!((got.last().unwrap() - last).abs() <= 1, "/clock ends at the last step: {got:?}, steps {want:?}");
    for g in &got {
        assert!(want.iter().any(|w| (g - w).abs() <= 1), "/clock {g} is no step's time: {want:?}");
    }

    let mut ms = latency_ms.clone();
    if !ms.is_empty() {
        let (p50, p99, max) = (percentile(&mut ms, 0.5), percentile(&mut ms, 0.99), percentile(&mut ms, 1.0));
        eprintln!(
            "server step end → /tf received: {} samples, p50 {p50:.2} ms, p99 {p99:.2} ms, max {max:.2} ms (includes up to 2 ms polling)",
            ms.len()
        );
    }
    let first = tf.first().unwrap().1;
    let last = tf.last().unwrap().1;
    eprintln!(
        "/tf rate {:.1} Hz over {:.2} s",
        (tf.len() - 1) as f64 / (last - first).as_secs_f64(),
        (last - first).as_secs_f64()
    );
    drop(bridge);
}

fn joy(axes: Vec<f32>) -> Joy {
    Joy { header: Header::default(), axes, buttons: vec![0, 0] }
}

#[test]
fn joy_moves_the_machine_and_its_absence_trips_the_deadman() {
    let server = start_server("joy");
    let watcher = Watcher::connect(&server);
    let d = domain(1);
    let bridge = Bridge::spawn(&server, d, "joy");
    let (_ctx, mut node) = ros_node(d, "joy_probe");
    let qos = reliable(10);
    let topic = dds::topic::<Joy>(&mut node, topics::JOY, &qos).unwrap();
    let publisher = node.create_publisher::<Joy>(&topic, Some(qos)).unwrap();

    // Full stick at 50 Hz until the server takes inputs (discovery included), then 1 s more.
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut live_since = None;
    while live_since.is_none_or(|t: Instant| t.elapsed() < Duration::from_secs(1)) {
        assert!(Instant::now() < deadline, "the server took no /joy input within 30 s");
        publisher.publish(joy(vec![1.0, 0.0])).unwrap();
        std::thread::sleep(Duration::from_millis(20));
        if live_since.is_none()
            && watcher.stats().is_some_and(|s| s.inputs.accepted > 0 && !s.inputs.deadman_active)
        {
            live_since = Some(Instant::now());
        }
    }
    let s = watcher.stats().unwrap();
    assert!(!s.inputs.deadman_active);
    assert_eq!(s.inputs.rejected_total(), 0, "{:?}", s.inputs);
    let w = watcher.omega_y("drum");
    assert!((w - 2.0).abs() < 0.05, "drum at {w} rad/s, 2 expected (full stick × scale 2)");
    // Stop: the deadman trips within its 250 ms (+ a step, + loopback), the drum stops.
    let stopped = Instant::now();
    let tripped = loop {
        let s = watcher.stats().unwrap();
        if s.inputs.deadman_active {
            break stopped.elapsed();
        }
        assert!(stopped.elapsed() < Duration::from_secs(3), "the deadman did not trip within 3 s");
        std::thread::sleep(Duration::from_millis(5));
    };
    assert!(tripped >= Duration::from_millis(200), "deadman after {tripped:?}: too early");
    assert!(tripped <= Duration::from_millis(600), "deadman after {tripped:?}");
    std::thread::sleep(Duration::from_millis(300));
    let s = watcher.stats().unwrap();
    assert!(s.inputs.deadman_trips >= 1);
    let w = watcher.omega_y("drum");
    assert!(w.abs() < 0.05, "drum still at {w} rad/s after the deadman");
    eprintln!("deadman tripped {tripped:?} after the last /joy; {} inputs accepted", s.inputs.accepted);
    drop(bridge);
}

#[test]
fn malformed_joy_is_rejected_and_counted_by_the_bridge() {
    let server = start_server("bad");
    let watcher = Watcher::connect(&server);
    let d = domain(2);
    let bridge = Bridge::spawn(&server, d, "bad");
    let (_ctx, mut node) = ros_node(d, "bad_probe");
    let qos = reliable(10);
    let topic = dds::topic::<Joy>(&mut node, topics::JOY, &qos).unwrap();
    let publisher = node.create_publisher::<Joy>(&topic, Some(qos)).unwrap();
    let stats_sub = subscribe::<DiagnosticArray>(&mut node, topics::STATS, reliable(10));

    let count = |a: &DiagnosticArray, key: &str| -> u64 {
        a.get(DIAG_BRIDGE).and_then(|s| s.value(key)).map(|v| v.parse().unwrap()).unwrap_or(0)
    };
    let mut latest: Option<DiagnosticArray> = None;
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut sent = 0u64;
    loop {
        assert!(Instant::now() < deadline, "bridge diagnostics did not count the malformed /joy: {latest:?}");
        // 33 axes, then a NaN axis.
        publisher.publish(joy(vec![0.0; 33])).unwrap();
        let mut nan = vec![0.0; 4];
        nan[1] = f32::NAN;
        publisher.publish(joy(nan)).unwrap();
        sent += 2;
        std::thread::sleep(Duration::from_millis(50));
        let mut got = Vec::new();
        drain(&stats_sub, &mut got);
        if let Some((a, _)) = got.pop() {
            latest = Some(a);
        }
        if let Some(a) = &latest
            && count(a, "joy_rejected.oversize") >= 3
            && count(a, "joy_rejected.non-finite") >= 3
        {
            break;
        }
    }
    let a = latest.unwrap();
    let (received, rejected, forwarded) =
        (count(&a, "joy_received"), count(&a, "joy_rejected"), count(&a, "joy_forwarded"));
    assert_eq!(forwarded, 0);
    assert_eq!(received, rejected, "every /joy received was rejected");
    assert_eq!(rejected, count(&a, "joy_rejected.oversize") + count(&a, "joy_rejected.non-finite"));
    assert!(received <= sent);
    // The bridge's status carries its counters; the server's input status says nothing came.
    let st = a.get(DIAG_BRIDGE).unwrap();
    assert_eq!(st.value("joy_source_id"), Some("4242"));
    let inputs = a.get(DIAG_INPUTS).expect("server input status");
    assert_eq!(inputs.value("accepted"), Some("0"));
    assert_eq!(inputs.value("rejected"), Some("0"));
    // Over Zenoh: the server received none of them.
    let s = watcher.stats().unwrap();
    assert_eq!((s.inputs.accepted, s.inputs.rejected_total()), (0, 0), "{:?}", s.inputs);
    // And the log says so.
    std::thread::sleep(Duration::from_millis(1100));
    let log = bridge.log();
    assert!(log.contains("/joy rejected (oversize)") && log.contains("/joy rejected (non-finite)"), "{log}");
    // A valid Joy afterwards is forwarded with the next sequence and accepted.
    let deadline = Instant::now() + Duration::from_secs(10);
    while watcher.stats().is_none_or(|s| s.inputs.accepted == 0) {
        assert!(Instant::now() < deadline, "a valid /joy after malformed ones was not accepted");
        publisher.publish(joy(vec![0.5])).unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(watcher.stats().unwrap().inputs.rejected_total(), 0);
    drop(bridge);
}

#[test]
fn bridge_waits_for_a_late_server_and_never_slows_it() {
    // The bridge first: it connects to an endpoint nobody listens on yet.
    let endpoint = pivotsim_tests::free_endpoint();
    let world = format!("r{}-late", std::process::id());
    let d = domain(3);
    let log = temp_path("ros2-late.log");
    let child = Command::new(env!("CARGO_BIN_EXE_pivotsim-ros2-bridge"))
        .args(["--world", &world, "--connect", &endpoint])
        .args(["--domain-id", &d.to_string(), "--dds-interface", "127.0.0.1", "--stats-rate", "20"])
        .env_remove("RUST_LOG") // its default log filter
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let bridge = Bridge { child, log };
    let (_ctx, mut node) = ros_node(d, "late_probe");
    let stats_sub = subscribe::<DiagnosticArray>(&mut node, topics::STATS, reliable(10));
    let tf_sub = subscribe::<TFMessage>(&mut node, topics::TF, reliable(100));
    // A subscriber that never reads.
    let _stalled = subscribe::<TFMessage>(&mut node, topics::TF, reliable(1));
    let stale = |deadline: Instant| loop {
        assert!(Instant::now() < deadline, "no bridge diagnostics");
        let mut got = Vec::new();
        drain(&stats_sub, &mut got);
        if let Some((a, _)) = got.pop() {
            break a;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let a = stale(Instant::now() + Duration::from_secs(30));
    let st = a.get(DIAG_BRIDGE).unwrap();
    assert_eq!(st.level, DiagnosticStatus::STALE, "{st:?}");
    assert_eq!(st.value("server_silent_s"), Some("never heard"));
    assert!(a.get(DIAG_INPUTS).is_none());

    // Now the server, on that endpoint and world.
    let scene = temp_file("ros2-late.toml", RIG);
    let config = ServeConfig {
        scene: scene.display().to_string(),
        world: world.clone(),
        zenoh: Some(ZenohOptions { listen: vec![endpoint.clone()], ..ZenohOptions::default() }),
        iceoryx2: false,
        ..ServeConfig::default()
    };
    let server = Server::spawn(config);
    let watcher = Watcher::connect(&server);
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut tf = Vec::new();
    while tf.len() < 10 {
        assert!(Instant::now() < deadline, "the bridge did not pick up the late server within 30 s");
        drain(&tf_sub, &mut tf);
        std::thread::sleep(Duration::from_millis(10));
    }
    // The server's step rate with the bridge and a stalled ROS subscriber attached.
    while watcher.latest_pose.lock().unwrap().is_none() {
        assert!(Instant::now() < deadline, "no pose frame over Zenoh");
        std::thread::sleep(Duration::from_millis(10));
    }
    let first = watcher.latest_pose.lock().unwrap().clone().unwrap().sequence;
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_secs(2));
    let last = watcher.latest_pose.lock().unwrap().clone().unwrap().sequence;
    let rate = (last - first) as f64 / t0.elapsed().as_secs_f64();
    assert!((50.0..=70.0).contains(&rate), "{rate:.1} steps/s (60 expected)");
    drain(&stats_sub, &mut Vec::new());
    let a = stale(Instant::now() + Duration::from_secs(5));
    assert_eq!(a.get(DIAG_BRIDGE).unwrap().level, DiagnosticStatus::OK);
    assert!(a.get(DIAG_INPUTS).is_some());
    eprintln!("late server: bridged; server at {rate:.1} steps/s with a stalled /tf subscriber");
    // Stopped as a user stops it (SIGTERM, as Ctrl-C), confined to loopback DDS: it exits within
    // 10 s, and its log (a file) has no ERROR line (RustDDS's "leave_multicast_group" for sockets
    // that joined no group) and no colour codes.
    let mut bridge = bridge;
    let pid = bridge.child.id().to_string();
    assert!(Command::new("kill").args(["-TERM", &pid]).status().unwrap().success());
    let deadline = Instant::now() + Duration::from_secs(10);
    let status = loop {
        if let Some(s) = bridge.child.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "the bridge did not stop within 10 s of SIGTERM");
        std::thread::sleep(Duration::from_millis(20));
    };
    let log = bridge.log();
    assert!(status.success(), "{status:?}: {log}");
    assert!(log.contains(" INFO "), "{log}");
    assert!(!log.contains("ERROR"), "an ERROR on shutdown: {log}");
    assert!(!log.contains('\u{1b}'), "colour codes in a log file: {log:?}");
    drop(bridge);
}

/// `|a − b| ≤ tol · |b|`.
fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs()
}

/// `q v q*` for a unit quaternion `q`.
fn rotate(q: Quaternion, v: Vector3) -> Vector3 {
    let (u, w) = ([q.x, q.y, q.z], q.w);
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    };
    let v = [v.x, v.y, v.z];
    let t = cross(u, v).map(|x| 2.0 * x);
    let c = cross(u, t);
    Vector3 { x: v[0] + w * t[0] + c[0], y: v[1] + w * t[1] + c[1], z: v[2] + w * t[2] + c[2] }
}

/// The quaternion product `a b`.
fn compose(a: Quaternion, b: Quaternion) -> Quaternion {
    Quaternion {
        w: a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
        x: a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        y: a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        z: a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
    }
}

#[test]
fn signals_reach_ros_as_wrenches_arrays_arrows_and_log_lines() {
    const G: f64 = 9.81;
    let server = start_scene("sig", SIGRIG);
    let watcher = Watcher::connect(&server);
    let d = domain(4);
    // A Zenoh peer of the test that the bridge connects to as well (peers do not route between
    // others: the server would not pass this one's frames on), to send it a malformed frame.
    let inject_at = pivotsim_tests::free_endpoint();
    let zc =
        pivotsim_link::zenoh_config::ZenohEndpoints { listen: vec![inject_at.clone()], ..Default::default() };
    let injector = zenoh::open(zc.config().unwrap()).wait().unwrap();
    let bridge = Bridge::spawn_with(&server, d, "sig", &["--connect", &inject_at]);
    let (_ctx, mut node) = ros_node(d, "sig_probe");
    let rope_topic = topics::wrench("hang.rope");
    assert_eq!(rope_topic, "/pivotsim/signals/hang_rope");
    let rope_sub = subscribe::<WrenchStamped>(&mut node, &rope_topic, reliable(100));
    let support_sub = subscribe::<WrenchStamped>(&mut node, &topics::wrench("support"), reliable(100));
    let array_sub = subscribe::<Float64MultiArray>(&mut node, topics::SIGNALS, reliable(100));
    let names_sub = subscribe::<RosString>(&mut node, topics::SIGNAL_NAMES, latched());
    let arrows_sub = subscribe::<MarkerArray>(&mut node, topics::CONTACT_MARKERS, reliable(10));
    let rosout_sub = subscribe::<Log>(&mut node, topics::ROSOUT, reliable(100));
    let stats_sub = subscribe::<DiagnosticArray>(&mut node, topics::STATS, reliable(10));
    let tf_static_sub = subscribe::<TFMessage>(&mut node, topics::TF_STATIC, latched());
    let tf_sub = subscribe::<TFMessage>(&mut node, topics::TF, reliable(100));

    // Readings after 1 s of simulation: the load hangs still and the crate rests.
    let settled = |t: Time| t.as_nanos() >= 1_000_000_000;
    let (mut rope, mut support, mut arrays, mut names, mut arrows) = (vec![], vec![], vec![], vec![], vec![]);
    let (mut statics, mut tfs) = (vec![], vec![]);
    let deadline = Instant::now() + Duration::from_secs(30);
    let enough = |r: &[(WrenchStamped, Instant)], s: &[(WrenchStamped, Instant)]| {
        r.iter().filter(|(w, _)| settled(w.header.stamp)).count() >= 20
            && s.iter().filter(|(w, _)| settled(w.header.stamp)).count() >= 20
    };
    while Instant::now() < deadline
        && !(enough(&rope, &support)
            && arrays.len() >= 20
            && !names.is_empty()
            && arrows.len() >= 20
            && !statics.is_empty())
    {
        drain(&tf_static_sub, &mut statics);
        drain(&tf_sub, &mut tfs);
        drain(&rope_sub, &mut rope);
        drain(&support_sub, &mut support);
        drain(&array_sub, &mut arrays);
        drain(&names_sub, &mut names);
        drain(&arrows_sub, &mut arrows);
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(enough(&rope, &support), "{} rope and {} support wrenches in 30 s", rope.len(), support.len());
    assert!(
        arrays.len() >= 20 && !names.is_empty() && arrows.len() >= 20 && !statics.is_empty(),
        "{} arrays, {} name lists, {} arrow arrays, {} /tf_static messages",
        arrays.len(),
        names.len(),
        arrows.len(),
        statics.len()
    );
    drain(&tf_sub, &mut tfs);

    // The joint sensor's frame is on /tf_static, a child of the load (the joint's body `a`, its
    // child), in one latched message with the static ground; its origin is the anchor.
    // (Settled wrenches: before the scene description reaches the bridge, a joint sensor's frame
    // is unknown to it.)
    let frame_id = rope.iter().find(|(w, _)| settled(w.header.stamp)).unwrap().0.header.frame_id.clone();
    assert_eq!(frame_id, "joint/rope");
    let latched = &statics.last().unwrap().0;
    let children: BTreeSet<&str> = latched.transforms.iter().map(|t| t.child_frame_id.as_str()).collect();
    assert_eq!(children, BTreeSet::from(["ground", "joint/rope"]));
    let joint = latched.transforms.iter().find(|t| t.child_frame_id == frame_id).unwrap();
    assert_eq!(joint.header.frame_id, "load");
    // The load's pose on /tf at a wrench's stamp.
    let load_at = |stamp: Time| {
        tfs.iter()
            .flat_map(|(m, _): &(TFMessage, Instant)| &m.transforms)
            .find(|t| t.child_frame_id == "load" && t.header.stamp == stamp)
            .map(|t| t.transform)
    };

    // The hanging load: the joint holds its weight. Its wrench, turned into the world with the
    // load's /tf transform and the joint frame's /tf_static one, is the force on the load:
    // (0, 0, +m g), within 1e-6 relative, and no torque about the anchor.
    let (m_load, m_crate) = (5.0, 10.0);
    let mut checked = 0;
    for (w, _) in rope.iter().filter(|(w, _)| settled(w.header.stamp)) {
        assert_eq!(w.header.frame_id, frame_id);
        let f = w.wrench.force;
        let n = (f.x * f.x + f.y * f.y + f.z * f.z).sqrt();
        assert!(close(n, m_load * G, 1e-6), "rope |F| = {n} N, {} expected", m_load * G);
        let Some(load) = load_at(w.header.stamp) else { continue };
        let r = compose(load.rotation, joint.transform.rotation);
        let fw = rotate(r, f);
        let err = (fw.x * fw.x + fw.y * fw.y + (fw.z - m_load * G).powi(2)).sqrt();
        assert!(
            err <= 1e-6 * m_load * G,
            "force on the load in the world {fw:?}, (0, 0, {}) expected",
            m_load * G
        );
        let tw = rotate(r, w.wrench.torque);
        assert!((tw.x * tw.x + tw.y * tw.y + tw.z * tw.z).sqrt() <= 1e-6 * m_load * G, "torque {tw:?}");
        let t = joint.transform.translation;
        let o = rotate(load.rotation, t);
        let p = load.translation;
        let anchor = [p.x + o.x, p.y + o.y, p.z + o.z];
        assert!(
            (anchor[0] - 1.5).abs() < 1e-6 && anchor[1].abs() < 1e-6 && (anchor[2] - 2.0).abs() < 1e-6,
            "the joint frame's origin {anchor:?} is not the anchor"
        );
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} rope wrenches had the load's /tf transform of their stamp");
    // The resting crate: the ground pushes it up with its weight, world frame, no torque.
    for (w, _) in support.iter().filter(|(w, _)| settled(w.header.stamp)) {
        assert_eq!(w.header.frame_id, "world");
        let f = w.wrench.force;
        assert!(close(f.z, m_crate * G, 1e-6), "support fz = {} N, {} expected", f.z, m_crate * G);
        assert!(f.x.abs() <= 1e-6 * m_crate * G && f.y.abs() <= 1e-6 * m_crate * G, "{f:?}");
        assert_eq!(w.wrench.torque, Vector3::default());
    }
    // Stamped with simulation time, increasing.
    assert!(rope.windows(2).all(|w| w[1].0.header.stamp > w[0].0.header.stamp));

    // Every channel on /pivotsim/signal_values, named by line on /pivotsim/signal_names.
    let text = &names.last().unwrap().0.data;
    // One line per channel: split at '\n' (not `lines()`, which forgives a trailing newline).
    let names: Vec<String> = text.split('\n').map(str::to_string).collect();
    let at = |n: &str| names.iter().position(|x| x == n).unwrap_or_else(|| panic!("{n} in {names:?}"));
    let (tension, fz) = (at("rope/tension"), at("support/fz"));
    let last = &arrays.last().unwrap().0;
    assert_eq!(last.layout.dim.len(), 1);
    assert_eq!(
        (last.layout.dim[0].label.as_str(), last.layout.dim[0].size as usize),
        ("channels", names.len())
    );
    assert_eq!(last.data.len(), names.len(), "{text:?}");
    assert!(close(last.data[tension], m_load * G, 1e-6), "tension {}", last.data[tension]);
    assert!(close(last.data[fz], m_crate * G, 1e-6), "support/fz {}", last.data[fz]);

    // The crate's contacts: a DELETEALL, then pressed points as arrows from the point along the
    // force on B; together they carry the weight (0.001 m/N by default).
    let a = &arrows.last().unwrap().0;
    assert_eq!(a.markers[0].action, Marker::DELETEALL);
    let pressed = &a.markers[1..];
    assert!(!pressed.is_empty(), "no contact arrows");
    let mut sum = [0.0; 3];
    for m in pressed {
        assert_eq!((m.type_, m.header.frame_id.as_str(), m.points.len()), (Marker::ARROW, "world", 2));
        assert!(m.color.g > 0.5 && m.color.r < 0.5, "a resting crate sticks: {:?}", m.color);
        let (p, q) = (m.points[0], m.points[1]);
        assert!((p.z - 0.1).abs() < 1e-3, "contact point at z = {}", p.z);
        for (k, d) in [q.x - p.x, q.y - p.y, q.z - p.z].into_iter().enumerate() {
            sum[k] += d / 0.001;
        }
    }
    assert!(close(sum[2].abs(), m_crate * G, 1e-6), "arrows sum to {sum:?} N");

    // A live fault: a /rosout WARN line; the support sensor drops out (no wrench, NaN).
    let fault = msgs::ControlCommand::Fault {
        fault: msgs::FaultKind::Dropout,
        target: "support".into(),
        tension: None,
        to: None,
        ramp: None,
    };
    watcher.control(&server, fault);
    let mut logs = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(10);
    let fault_line = loop {
        assert!(Instant::now() < deadline, "no fault line on /rosout: {logs:?}");
        drain(&rosout_sub, &mut logs);
        if let Some((l, _)) =
            logs.iter().find(|(l, _)| l.msg.starts_with("pivotsim event") && l.msg.contains(" fault "))
        {
            break l.clone();
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    assert_eq!(fault_line.level, Log::WARN);
    assert_eq!(fault_line.name, "pivotsim_bridge");
    std::thread::sleep(Duration::from_millis(300));
    drain(&support_sub, &mut Vec::new());
    drain(&array_sub, &mut Vec::new());
    std::thread::sleep(Duration::from_millis(300));
    let (mut after, mut arrays_after) = (vec![], vec![]);
    drain(&support_sub, &mut after);
    drain(&array_sub, &mut arrays_after);
    assert!(after.is_empty(), "{} support wrenches while it drops out", after.len());
    let last = &arrays_after.last().expect("arrays keep coming").0;
    assert!(last.data[fz].is_nan() && close(last.data[tension], m_load * G, 1e-6));

    // A malformed signals frame on the server's key: counted by the bridge, which goes on.
    let bad = injector.declare_publisher(server.key(msgs::Topic::Signals)).wait().unwrap();
    let mut sent = 0;
    let count = |a: &DiagnosticArray, key: &str| -> u64 {
        a.get(DIAG_BRIDGE).and_then(|s| s.value(key)).map(|v| v.parse().unwrap()).unwrap_or(0)
    };
    let deadline = Instant::now() + Duration::from_secs(10);
    let diag = loop {
        assert!(Instant::now() < deadline, "the malformed signals frame was not counted");
        if sent < 20 {
            bad.put(b"PVSM not a frame".to_vec()).wait().unwrap();
            sent += 1;
        }
        let mut got = Vec::new();
        drain(&stats_sub, &mut got);
        if let Some((a, _)) = got.into_iter().rev().find(|(a, _)| count(a, "signals_decode_failed") >= 1) {
            break a;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let failed = count(&diag, "signals_decode_failed");
    assert!((1..=sent).contains(&failed), "{failed} undecodable of {sent} sent");
    assert_eq!(count(&diag, "wrench_topics"), 2);
    assert!(count(&diag, "events_logged") >= 1);
    let sig = diag.get(DIAG_SIGNALS).expect("signals status");
    assert_eq!(sig.value("support/fz"), Some("dropout"));
    let mut more = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(5);
    while more.len() < 5 {
        assert!(Instant::now() < deadline, "no wrenches after the malformed frame");
        drain(&rope_sub, &mut more);
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(bridge.log().contains("signals frame:"), "the bridge logs the malformed frame");
    drop(bridge);
}
