//! The client against a real server over real transports on loopback: Zenoh on a free port,
//! iceoryx2 on a world name of its own, every run bounded in time.

mod common;

use std::time::{Duration, Instant};

use common::{ClientOf, DRUM, Server, field, spawn_client};
use serde_json::Value;

const LIMIT: Duration = Duration::from_secs(30);

/// The steps `watch --plain` printed: their sequence numbers.
fn sequences(stdout: &str) -> Vec<u64> {
    stdout.lines().filter_map(|l| field(l, "seq")).map(|s| s.parse().unwrap()).collect()
}

/// One `watch --json` step of `server`.
fn snapshot(server: &Server) -> Value {
    let out = server.client(&["--timeout", "10", "watch", "--count", "1", "--json"], LIMIT).ok();
    serde_json::from_str(out.stdout.lines().next().expect("a JSON line")).expect("JSON")
}

fn body<'a>(snap: &'a Value, name: &str) -> &'a Value {
    snap["bodies"].as_array().unwrap().iter().find(|b| b["name"] == name).unwrap_or_else(|| panic!("{name}"))
}

fn quat(b: &Value) -> [f64; 4] {
    let q = &b["orientation"];
    ["x", "y", "z", "w"].map(|k| q[k].as_f64().unwrap())
}

/// Rotation angle between two unit quaternions (rad).
fn angle(a: [f64; 4], b: [f64; 4]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    2.0 * d.abs().min(1.0).acos()
}

/// The `sequence N` of a `control` reply.
fn reply_sequence(stdout: &str) -> u64 {
    let mut w = stdout.split_whitespace();
    while let Some(x) = w.next() {
        if x == "sequence" {
            return w.next().unwrap().parse().unwrap();
        }
    }
    panic!("no sequence in {stdout:?}");
}

#[test]
fn watch_count_5_sees_5_steps_in_order_over_both_transports() {
    let s = Server::start("pendulum", "watch");
    for transport in ["zenoh", "iceoryx2"] {
        let out =
            s.client(&["--timeout", "10", "watch", "--count", "5", "--transport", transport], LIMIT).ok();
        let seq = sequences(&out.stdout);
        assert_eq!(seq.len(), 5, "{transport}: {}", out.stdout);
        assert!(seq.windows(2).all(|w| w[1] > w[0]), "{transport}: not increasing: {seq:?}");
        // Body names come from the scene queryable.
        assert!(out.stdout.contains("upper=("), "{}", out.stdout);
        assert!(out.stderr.contains("0 malformed"), "{}", out.stderr);
    }
}

#[test]
fn scene_answers_with_the_bodies() {
    let s = Server::start(DRUM, "scene");
    let out = s.client(&["scene"], LIMIT).ok();
    assert!(out.stdout.contains("scene client_drum"), "{}", out.stdout);
    for name in ["drum", "slider", "axle", "rail", "winch", "slide"] {
        assert!(out.stdout.contains(name), "{name} missing:\n{}", out.stdout);
    }
    let out = s.client(&["scene", "--json"], LIMIT).ok();
    let d: pivotsim_msgs::SceneDescription = serde_json::from_str(&out.stdout).expect("scene JSON");
    let names: Vec<&str> = d.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(names, ["drum", "slider"]);
    assert_eq!(d.world, s.world.as_str());
    assert_eq!(d.actuators.len(), 2);
}

#[test]
fn control_pause_then_step_3_advances_exactly_3() {
    let s = Server::start("pendulum", "control");
    let paused = s.client(&["control", "pause"], LIMIT).ok();
    assert!(paused.stdout.contains("paused"), "{}", paused.stdout);
    let s0 = reply_sequence(&paused.stdout);
    let stepped = s.client(&["control", "step", "3"], LIMIT).ok();
    assert_eq!(reply_sequence(&stepped.stdout), s0 + 3, "{}", stepped.stdout);
    // The stepped state is published: a watcher started now sees nothing newer while paused.
    let resumed = s.client(&["control", "resume"], LIMIT).ok();
    assert!(resumed.stdout.contains("running"), "{}", resumed.stdout);
    // Typed errors exit non-zero.
    let busy = s.client(&["control", "step", "1"], LIMIT);
    assert_eq!(busy.code, Some(2), "{busy:?}");
    assert!(busy.stderr.contains("error (busy)"), "{}", busy.stderr);
    let unknown = s.client(&["control", "load", "no_such_scene"], LIMIT);
    assert_eq!(unknown.code, Some(2), "{unknown:?}");
    assert!(unknown.stderr.contains("unknown_scene"), "{}", unknown.stderr);
    let variant = s.client(&["control", "--json", "variant", "pgs"], LIMIT).ok();
    let reply: Value = serde_json::from_str(variant.stdout.trim()).unwrap();
    assert_eq!(reply["outcome"]["ok"]["variant"], "pgs");
    let bad = s.client(&["control", "variant", "fastest"], LIMIT);
    assert_ne!(bad.code, Some(0));
}

#[test]
fn send_winch_and_actuator_move_the_joints() {
    let s = Server::start(DRUM, "send");
    let before = snapshot(&s);
    let q0 = quat(body(&before, "drum"));
    assert_eq!(body(&before, "slider")["position"]["x"], 3.0);

    // Winch over Zenoh, held for 0.4 s at 1 rad/s, then the deadman holds the drum.
    let out = s.client(&["send", "--hold", "0.4", "winch", "winch", "1.0"], LIMIT).ok();
    assert!(out.stdout.contains("accepted") && !out.stdout.contains("rejected"), "{}", out.stdout);
    // Position actuator over iceoryx2: one frame, the slider goes to x = 3 + 0.5.
    let out = s
        .client(&["send", "--transport", "iceoryx2", "actuator", "slide", "0.5", "--mode", "position"], LIMIT)
        .ok();
    assert!(out.stdout.contains("1 accepted"), "{}", out.stdout);
    std::thread::sleep(Duration::from_millis(600));
    let after = snapshot(&s);
    let turned = angle(q0, quat(body(&after, "drum")));
    assert!(turned > 0.3, "the drum turned {turned} rad");
    let x = body(&after, "slider")["position"]["x"].as_f64().unwrap();
    assert!((x - 3.5).abs() < 0.02, "slider at x = {x}");
    // Held by the deadman (velocity motor at 0): the drum does not keep turning.
    let later = snapshot(&s);
    let drift = angle(quat(body(&after, "drum")), quat(body(&later, "drum")));
    assert!(drift < 0.01, "the drum drifted {drift} rad after the deadman");

    // Refused before sending: an actuator the scene lacks; sent anyway with --force, the server
    // rejects it and the client exits 2.
    let out = s.client(&["send", "actuator", "nope", "1"], LIMIT);
    assert_ne!(out.code, Some(0));
    assert!(out.stderr.contains("unknown actuator"), "{}", out.stderr);
    let out = s.client(&["send", "--force", "winch", "slide", "1"], LIMIT);
    assert_eq!(out.code, Some(2), "{out:?}");
    assert!(out.stdout.contains("unknown-actuator"), "{}", out.stdout);
}

#[test]
fn drive_with_constant_axes_turns_the_drum() {
    let s = Server::start(DRUM, "drive");
    let q0 = quat(body(&snapshot(&s), "drum"));
    for transport in ["zenoh", "iceoryx2"] {
        let out = s
            .client(
                &["drive", "--transport", transport, "--axes", "0.5", "--duration", "0.3", "--rate", "40"],
                LIMIT,
            )
            .ok();
        let line =
            out.stdout.lines().find(|l| l.starts_with("sent ")).unwrap_or_else(|| panic!("{}", out.stdout));
        let sent: u64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
        assert!((8..=14).contains(&sent), "{transport}: {}", out.stdout);
    }
    std::thread::sleep(Duration::from_millis(400));
    let turned = angle(q0, quat(body(&snapshot(&s), "drum")));
    assert!(turned > 0.4, "the drum turned {turned} rad");
}

fn ping(s: &Server, transport: &str) {
    let out = s.client(&["ping", "--count", "200", "--transport", transport], LIMIT).ok();
    let line =
        out.stdout.lines().find(|l| l.starts_with("latency µs:")).unwrap_or_else(|| panic!("{}", out.stdout));
    let value = |k: &str| -> f64 {
        let mut w = line.split_whitespace();
        while let Some(x) = w.next() {
            if x == k {
                return w.next().unwrap().parse().unwrap();
            }
        }
        panic!("{k} missing in {line}");
    };
    let (p50, p90, p99, max) = (value("p50"), value("p90"), value("p99"), value("max"));
    assert!(p50 > 0.0 && p50 <= p90 && p90 <= p99 && p99 <= max, "{line}");
    assert!(p50 < 100_000.0, "{transport}: p50 {p50} µs on loopback");
    assert!(out.stdout.contains("200 pose frames"), "{}", out.stdout);
    assert!(out.stdout.contains(" | #"), "no histogram:\n{}", out.stdout);
    eprintln!("{transport}: {line}");
}

#[test]
fn ping_200_over_zenoh() {
    let s = Server::start("pendulum", "pingz");
    ping(&s, "zenoh");
}

#[test]
fn ping_200_over_iceoryx2() {
    let s = Server::start("pendulum", "pingi");
    ping(&s, "iceoryx2");
}

/// A channel of a recording: its schema (name, encoding) and its messages.
#[derive(Debug, Default)]
struct Recorded {
    schema: String,
    schema_encoding: String,
    messages: Vec<Vec<u8>>,
    /// Each message's (log time, publish time).
    times: Vec<(u64, u64)>,
}

impl Recorded {
    /// The messages as JSON (a `json` channel).
    fn json(&self) -> Vec<Value> {
        self.messages.iter().map(|m| serde_json::from_slice(m).expect("message is JSON")).collect()
    }
}

/// Every message of every channel of an MCAP file, by topic; checks each channel's encodings and
/// that the summary's message counts match what was read.
fn read_mcap(path: &std::path::Path) -> std::collections::BTreeMap<String, Recorded> {
    let bytes = std::fs::read(path).unwrap();
    let mut out: std::collections::BTreeMap<String, Recorded> = std::collections::BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        // The wire channels (for `pivotsim-server replay`) carry frames byte for byte, no schema.
        if m.channel.message_encoding == pivotsim_msgs::RECORD_WIRE_ENCODING {
            assert!(m.channel.schema.is_none(), "{}", m.channel.topic);
            pivotsim_msgs::Message::decode(&m.data).expect("a wire frame");
            continue;
        }
        let schema = m.channel.schema.as_ref().expect("schema");
        assert!(!schema.data.is_empty(), "{}: empty schema", m.channel.topic);
        match m.channel.message_encoding.as_str() {
            "json" => {
                assert_eq!(schema.encoding, "jsonschema", "{}", m.channel.topic);
                serde_json::from_slice::<Value>(&schema.data).expect("schema is JSON");
            }
            "protobuf" => assert_eq!(schema.encoding, "protobuf", "{}", m.channel.topic),
            e => panic!("{}: message encoding {e}", m.channel.topic),
        }
        let e = out.entry(m.channel.topic.clone()).or_insert_with(|| Recorded {
            schema: schema.name.clone(),
            schema_encoding: schema.encoding.clone(),
            messages: Vec::new(),
            times: Vec::new(),
        });
        e.times.push((m.log_time, m.publish_time));
        e.messages.push(m.data.into_owned());
    }
    let summary = mcap::Summary::read(&bytes).unwrap().expect("summary");
    let stats = summary.stats.as_ref().expect("statistics");
    for (id, ch) in &summary.channels {
        if ch.message_encoding == pivotsim_msgs::RECORD_WIRE_ENCODING {
            continue;
        }
        // A channel may hold no message (a topic that published nothing while recording).
        let counted = stats.channel_message_counts.get(id).copied().unwrap_or(0);
        let read = out.get(&ch.topic).map_or(0, |r| r.messages.len());
        assert_eq!(counted as usize, read, "{}: summary count", ch.topic);
    }
    out
}

fn send_all_four(args: &[String]) {
    for cmd in [
        &["winch", "winch", "0.5"][..],
        &["actuator", "slide", "0.2", "--mode", "position"],
        &["boom", "winch=0.25", "slide=0.1"],
        &["joystick", "--axes", "0.1"],
    ] {
        let mut a = args.to_vec();
        a.extend(cmd.iter().map(|s| s.to_string()));
        common::run_client(&a, LIMIT).ok();
    }
}

/// The count the recorder printed before `label` (`… 812 signals, 1 events, …`).
fn printed_count(stderr: &str, label: &str) -> usize {
    let line = stderr.lines().find(|l| l.contains("wrote ")).unwrap_or_else(|| panic!("{stderr}"));
    let before = line.split(&format!(" {label},")).next().unwrap();
    before.rsplit(' ').next().unwrap().parse().unwrap_or_else(|_| panic!("{label} in {line}"))
}

/// Sends the dropout fault on the test scene's `axle` sensor.
fn drop_out_axle(server_args: &[String]) {
    let mut a = server_args.to_vec();
    a.extend(["fault", "dropout", "axle"].map(String::from));
    common::run_client(&a, LIMIT).ok();
}

/// The signals, contacts and events channels: schemas, one message per frame the recorder counted,
/// the `axle` sensor's channels plottable, and the live dropout fault replayable from the file.
fn check_signals(path: &std::path::Path, stderr: &str) {
    let m = read_mcap(path);
    for (t, schema) in [
        ("/pivotsim/signals", "pivotsim.Signals"),
        ("/pivotsim/contacts", "pivotsim.Contacts"),
        ("/pivotsim/events", "pivotsim.Events"),
    ] {
        let r = m.get(t).unwrap_or_else(|| panic!("no channel {t}: {:?}", m.keys()));
        assert_eq!((r.schema.as_str(), r.schema_encoding.as_str()), (schema, "jsonschema"), "{t}");
    }
    let arrows = &m["/pivotsim/contact_forces"];
    assert_eq!(
        (arrows.schema.as_str(), arrows.schema_encoding.as_str()),
        ("foxglove.SceneUpdate", "protobuf")
    );
    let (signals, events) = (printed_count(stderr, "signals"), printed_count(stderr, "events"));
    assert!(signals >= 10, "{signals} signals frames");
    assert_eq!(m["/pivotsim/signals"].messages.len(), signals);
    assert_eq!(m["/pivotsim/contacts"].messages.len(), signals);
    assert_eq!(arrows.messages.len(), signals);
    assert_eq!(m["/pivotsim/events"].messages.len(), events);
    let sig = m["/pivotsim/signals"].json();
    assert!(sig.windows(2).all(|w| w[1]["sequence"].as_u64() > w[0]["sequence"].as_u64()));
    // Readings before the fault are numbers (the recorder subscribes before the fault is sent,
    // but over Zenoh its first frames may still arrive after it: judged on the frames before).
    let before =
        sig.iter().find(|f| f["dropout_count"] == 0).unwrap_or_else(|| panic!("no frame before the fault"));
    let first = &before["values"]["axle"];
    for c in ["fx", "fy", "fz", "tx", "ty", "tz"] {
        assert!(first[c].is_number(), "axle/{c} in {first}");
    }
    // The live fault: one `fault` event naming the sensor, then its channels dropped out.
    let ev: Vec<Value> =
        m["/pivotsim/events"].json().iter().flat_map(|e| e["events"].as_array().unwrap().clone()).collect();
    let fault =
        ev.iter().find(|e| e["kind"] == "fault").unwrap_or_else(|| panic!("no fault event in {ev:?}"));
    assert!(fault["name"].as_str().unwrap().contains("axle"), "{fault}");
    let last = sig.last().unwrap();
    assert!(last["values"]["axle"]["fx"].is_null(), "{last}");
    assert_eq!(last["dropout_count"], 6, "{last}");
}

/// Which clock a recording was made with (`record --clock`).
#[derive(Clone, Copy, PartialEq)]
enum Clock {
    Sim,
    Wall,
}

fn check_recording(path: &std::path::Path, clock: Clock) {
    let m = read_mcap(path);
    for (t, schema, encoding) in [
        ("/pivotsim/poses", "pivotsim.PoseFrame", "jsonschema"),
        ("/pivotsim/stats", "pivotsim.SolverStats", "jsonschema"),
        ("/tf", "foxglove.FrameTransforms", "protobuf"),
        ("/pivotsim/scene", "foxglove.SceneUpdate", "protobuf"),
        ("/pivotsim/description", "pivotsim.SceneDescription", "jsonschema"),
        ("/pivotsim/cmd/winch", "pivotsim.WinchCommand", "jsonschema"),
        ("/pivotsim/cmd/actuator", "pivotsim.ActuatorCommand", "jsonschema"),
        ("/pivotsim/cmd/boom", "pivotsim.BoomCommand", "jsonschema"),
        ("/pivotsim/cmd/joystick", "pivotsim.Joystick", "jsonschema"),
    ] {
        let r = m.get(t).unwrap_or_else(|| panic!("no channel {t}: {:?}", m.keys()));
        assert_eq!((r.schema.as_str(), r.schema_encoding.as_str()), (schema, encoding), "{t}");
        assert!(!r.messages.is_empty(), "no message on {t}");
    }
    let poses = m["/pivotsim/poses"].json();
    assert!(poses.len() >= 10, "{} pose messages", poses.len());
    assert!(poses.windows(2).all(|w| w[1]["sequence"].as_u64() > w[0]["sequence"].as_u64()));
    assert_eq!(poses[0]["bodies"][0]["name"], "drum");
    // Log time is the receive time, never backwards; the publish time follows `--clock`.
    let sim_ns = |p: &Value| (p["sim_time"].as_f64().unwrap() * 1e9).round() as u64;
    for t in ["/pivotsim/poses", "/tf"] {
        let times = &m[t].times;
        assert!(times.windows(2).all(|w| w[1].0 >= w[0].0), "{t}: log time ran backwards");
        for (p, &(log, publish)) in poses.iter().zip(times) {
            let expected = match clock {
                Clock::Sim => sim_ns(p),
                Clock::Wall => p["wall_time_ns"].as_u64().unwrap(),
            };
            assert_eq!(publish, expected, "{t}: publish time of {p}");
            assert!(log >= p["wall_time_ns"].as_u64().unwrap(), "{t}: received before it was sent");
        }
    }
    let sig = &m["/pivotsim/signals"];
    for (s, &(_, publish)) in sig.json().iter().zip(&sig.times) {
        if clock == Clock::Sim {
            assert_eq!(publish, sim_ns(s), "signals publish time");
        } else {
            assert!(publish > 1_000_000_000_000_000_000, "signals publish time {publish} is not wall time");
        }
    }
    // One transform message per pose frame; one scene update and one description.
    assert_eq!(m["/tf"].messages.len(), poses.len());
    assert_eq!(m["/pivotsim/scene"].messages.len(), 1);
    let tf = &m["/tf"].messages[0];
    // foxglove.FrameTransforms: the body names are the child frames (protobuf strings, in order).
    let (drum, slider) =
        (tf.windows(4).position(|w| w == b"drum"), tf.windows(6).position(|w| w == b"slider"));
    assert!(drum.is_some() && slider.is_some() && drum < slider, "child frames drum, slider");
    assert_eq!(m["/pivotsim/cmd/winch"].json()[0]["drum_speed"], 0.5);
    assert_eq!(m["/pivotsim/description"].json()[0]["scene"], "client_drum");
}

#[test]
fn record_over_iceoryx2_writes_every_channel() {
    let s = Server::start(DRUM, "reci");
    let dir = std::env::temp_dir().join(format!("pivotsim-client-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("iox.mcap");
    let mut a = s.args();
    a.extend(
        ["record", path.to_str().unwrap(), "--transport", "iceoryx2", "--duration", "20"].map(String::from),
    );
    let rec = spawn_client(&a, LIMIT);
    rec.wait_for_stderr("recording world", LIMIT);
    // Let the recorder's subscriptions settle so that readings before the fault are recorded.
    std::thread::sleep(std::time::Duration::from_millis(1000));
    drop_out_axle(&s.args());
    let mut a = s.args();
    a.extend(["send", "--transport", "iceoryx2"].map(String::from));
    let t = Instant::now();
    send_all_four(&a);
    eprintln!("four sends over iceoryx2 took {:?}", t.elapsed());
    // Ctrl-C ends the recording; the file is finished properly.
    // Frames after the fault (its event, the dropped-out readings) reach the recorder first.
    std::thread::sleep(std::time::Duration::from_millis(500));
    rec.interrupt();
    let out = rec.wait().ok();
    assert!(out.stderr.contains("4 inputs"), "{}", out.stderr);
    check_recording(&path, Clock::Sim);
    check_signals(&path, &out.stderr);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn record_over_zenoh_sees_inputs_of_peers_connected_to_it() {
    let s = Server::start(DRUM, "recz");
    let dir = std::env::temp_dir().join(format!("pivotsim-client-z-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("zenoh.mcap");
    let rec_endpoint = format!("tcp/127.0.0.1:{}", common::free_port());
    let mut a = s.args();
    a.extend(
        ["--listen", &rec_endpoint, "record", path.to_str().unwrap(), "--duration", "20", "--clock", "wall"]
            .map(String::from),
    );
    let rec = spawn_client(&a, LIMIT);
    rec.wait_for_stderr("recording world", LIMIT);
    // Let the recorder's subscriptions settle so that readings before the fault are recorded.
    std::thread::sleep(std::time::Duration::from_millis(1000));
    drop_out_axle(&s.args());
    let mut a = s.args();
    a.extend(["--connect", &rec_endpoint, "send"].map(String::from));
    send_all_four(&a);
    // Frames after the fault (its event, the dropped-out readings) reach the recorder first.
    std::thread::sleep(std::time::Duration::from_millis(500));
    rec.interrupt();
    let out = rec.wait().ok();
    check_recording(&path, Clock::Wall);
    check_signals(&path, &out.stderr);
    assert!(out.stderr.contains("0 malformed"), "{}", out.stderr);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn malformed_frames_are_counted_and_skipped() {
    use zenoh::Wait;
    let s = Server::start("pendulum", "bad");
    // The watcher listens; a test peer connects to it and publishes garbage on the poses and
    // stats keys between the server's frames.
    let listen = format!("tcp/127.0.0.1:{}", common::free_port());
    let mut a = s.args();
    a.extend(
        ["--listen", &listen, "--timeout", "10", "watch", "--plain", "--count", "120"].map(String::from),
    );
    let watch = spawn_client(&a, LIMIT);
    let mut c = zenoh::Config::default();
    c.insert_json5("mode", "\"peer\"").unwrap();
    c.insert_json5("connect/endpoints", &format!("[\"{listen}\"]")).unwrap();
    c.insert_json5("listen/endpoints", "[]").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false").unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    let session = loop {
        // The watcher needs a moment to listen.
        std::thread::sleep(Duration::from_millis(200));
        let z = zenoh::open(c.clone()).wait().unwrap();
        if z.info().peers_zid().wait().count() > 0 {
            break z;
        }
        assert!(Instant::now() < deadline, "cannot reach the watcher");
    };
    let poses = format!("pivotsim/{}/poses", s.world);
    let stats = format!("pivotsim/{}/stats", s.world);
    let mut valid_but_wrong = Vec::new();
    pivotsim_msgs::ControlRequest { id: 1, command: pivotsim_msgs::ControlCommand::Pause }
        .encode(&mut valid_but_wrong)
        .unwrap();
    // A connected peer may not have declared its subscriber yet: frames put before that reach
    // nobody (a full-suite run counted 0 of 30). Wait until the watcher subscribes.
    let probe = session.declare_publisher(poses.clone()).wait().unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    while !probe.matching_status().wait().unwrap().matching() {
        assert!(Instant::now() < deadline, "the watcher never subscribed to {poses}");
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(probe);
    for i in 0..10u8 {
        session.put(&poses, vec![i; 7]).wait().unwrap();
        session.put(&stats, b"PVSM\x01\x00\x02\x00\xff\xff\xff\xff\x00\x00\x00\x00".to_vec()).wait().unwrap();
        session.put(&poses, valid_but_wrong.clone()).wait().unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = watch.wait().ok();
    let seq = sequences(&out.stdout);
    assert_eq!(seq.len(), 120);
    let malformed: u64 = out
        .stderr
        .split(", ")
        .find_map(|p| p.strip_suffix(" malformed (skipped)"))
        .unwrap_or_else(|| panic!("{}", out.stderr))
        .parse()
        .unwrap();
    assert!(malformed >= 25, "{malformed} malformed counted of 30 sent:\n{}", out.stderr);
    drop(session);
}
