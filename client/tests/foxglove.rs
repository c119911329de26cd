//! `pivotsim-client foxglove` seen by a Foxglove WebSocket client written here from the published
//! protocol (ws-protocol `docs/spec.md`, subprotocol `foxglove.websocket.v1`): the handshake
//! selects the subprotocol — the SDK (0.30) no longer accepts `foxglove.websocket.v1` but speaks
//! the same v1 framing under the name `foxglove.sdk.v1`, which current Foxglove apps offer, so the
//! client offers both and requires the SDK's; the server sends `serverInfo` and `advertise` (JSON text frames); the
//! client sends `subscribe`; the server answers with binary message-data frames — opcode `0x01`,
//! subscription id (u32 LE), timestamp (u64 LE, ns), payload. The payloads are decoded here too:
//! `foxglove.FrameTransforms` and `foxglove.SceneUpdate` with a small protobuf reader (field
//! numbers from the schemas' `.proto` definitions), the stats as JSON.
//!
//! The forklift is served paused, the view connects and subscribes after the scene was published
//! (so its entities arrive only through the late-joiner path), then the server resumes and the
//! scripted operator drives the truck forward: the chassis' transform must move. A reset then
//! brings the scene again (new entities) and the chassis back. The signals channel
//! (`/pivotsim/signals`, JSON) is advertised with its JSON schema and its messages carry the
//! forklift's fork-load sensor (`values.forks_load.normal`, N). Every wait is bounded in time.

mod common;

use std::net::TcpStream;
use std::time::{Duration, Instant};

use common::{ClientOf, Server, spawn_client};
use serde_json::{Value, json};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket};

const LIMIT: Duration = Duration::from_secs(60);

/// A protobuf field value (wire types 0, 1, 2, 5).
#[derive(Debug, Clone, Copy)]
enum Field<'a> {
    Varint(u64),
    Fixed64([u8; 8]),
    Bytes(&'a [u8]),
    /// A 32-bit value (skipped: none of the fields read here has one).
    Fixed32,
}

fn varint(buf: &[u8], at: &mut usize) -> u64 {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let b = buf[*at];
        *at += 1;
        v |= u64::from(b & 0x7f) << shift;
        if b & 0x80 == 0 {
            return v;
        }
    }
    panic!("varint longer than 10 bytes");
}

/// The fields of one protobuf message, in order.
fn fields(buf: &[u8]) -> Vec<(u64, Field<'_>)> {
    let mut out = Vec::new();
    let mut at = 0;
    while at < buf.len() {
        let key = varint(buf, &mut at);
        let f = match key & 7 {
            0 => Field::Varint(varint(buf, &mut at)),
            1 => {
                at += 8;
                Field::Fixed64(buf[at - 8..at].try_into().unwrap())
            }
            2 => {
                let n = varint(buf, &mut at) as usize;
                at += n;
                Field::Bytes(&buf[at - n..at])
            }
            5 => {
                at += 4;
                Field::Fixed32
            }
            t => panic!("wire type {t}"),
        };
        out.push((key >> 3, f));
    }
    out
}

fn bytes_of(buf: &[u8], number: u64) -> Vec<&[u8]> {
    fields(buf)
        .into_iter()
        .filter_map(|(n, f)| match f {
            Field::Bytes(b) if n == number => Some(b),
            _ => None,
        })
        .collect()
}

fn string_of(buf: &[u8], number: u64) -> String {
    bytes_of(buf, number).first().map(|b| String::from_utf8(b.to_vec()).unwrap()).unwrap_or_default()
}

/// A `double` field (0 when absent: proto3 leaves defaults out).
fn double_of(buf: &[u8], number: u64) -> f64 {
    fields(buf)
        .into_iter()
        .find_map(|(n, f)| match f {
            Field::Fixed64(b) if n == number => Some(f64::from_le_bytes(b)),
            _ => None,
        })
        .unwrap_or(0.0)
}

/// `foxglove.FrameTransforms` (transforms = 1; FrameTransform: parent_frame_id = 2,
/// child_frame_id = 3, translation = 4 as Vector3 x = 1, y = 2, z = 3): (parent, child, x, y, z).
fn transforms(payload: &[u8]) -> Vec<(String, String, [f64; 3])> {
    bytes_of(payload, 1)
        .into_iter()
        .map(|t| {
            let tr = bytes_of(t, 4).first().copied().unwrap_or(&[]);
            (string_of(t, 2), string_of(t, 3), [1, 2, 3].map(|i| double_of(tr, i)))
        })
        .collect()
}

/// `foxglove.SceneUpdate` (entities = 2; SceneEntity: frame_id = 2, id = 3, frame_locked = 5,
/// cubes = 8, spheres = 9, cylinders = 10, triangles = 12): (id, frame, locked, primitives).
fn entities(payload: &[u8]) -> Vec<(String, String, bool, usize)> {
    bytes_of(payload, 2)
        .into_iter()
        .map(|e| {
            let f = fields(e);
            let locked = f.iter().any(|(n, v)| *n == 5 && matches!(v, Field::Varint(1)));
            let prims = f.iter().filter(|(n, _)| [8, 9, 10, 12].contains(n)).count();
            (string_of(e, 3), string_of(e, 2), locked, prims)
        })
        .collect()
}

/// A message-data frame: (subscription id, timestamp ns, payload).
fn message_data(b: &[u8]) -> (u32, u64, &[u8]) {
    assert!(b.len() >= 13, "a message-data frame is at least 13 bytes: {}", b.len());
    assert_eq!(b[0], 0x01, "opcode of message data");
    (
        u32::from_le_bytes(b[1..5].try_into().unwrap()),
        u64::from_le_bytes(b[5..13].try_into().unwrap()),
        &b[13..],
    )
}

/// Subprotocols offered: the ws-protocol spec's name and the SDK's name for the same v1 framing.
const OFFERED: &str = "foxglove.websocket.v1, foxglove.sdk.v1";

/// Connects offering [`OFFERED`]; the server must select `foxglove.sdk.v1`. Reads time out after
/// 200 ms.
fn connect(port: u16) -> WebSocket<TcpStream> {
    let deadline = Instant::now() + Duration::from_secs(10);
    let stream = loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => break s,
            Err(e) => assert!(Instant::now() < deadline, "cannot connect to {port}: {e}"),
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    stream.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    let mut req = format!("ws://127.0.0.1:{port}").into_client_request().unwrap();
    req.headers_mut().insert("Sec-WebSocket-Protocol", OFFERED.parse().unwrap());
    let (ws, resp) = tungstenite::client::client(req, stream).expect("the WebSocket handshake");
    let proto = resp.headers().get("Sec-WebSocket-Protocol").map(|v| v.to_str().unwrap().to_string());
    assert_eq!(proto.as_deref(), Some("foxglove.sdk.v1"), "the server selects the v1 subprotocol");
    ws
}

/// The next message, or `None` when none came within the read timeout.
fn next(ws: &mut WebSocket<TcpStream>) -> Option<Message> {
    match ws.read() {
        Ok(m) => Some(m),
        Err(tungstenite::Error::Io(e))
            if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) =>
        {
            None
        }
        Err(e) => panic!("WebSocket: {e}"),
    }
}

/// The port the view printed (`… on ws://127.0.0.1:PORT …`).
fn printed_port(stderr: &str) -> u16 {
    let rest = stderr.split("on ws://127.0.0.1:").nth(1).unwrap_or_else(|| panic!("no address in {stderr}"));
    rest.split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap()
}

#[test]
fn foxglove_view_streams_the_forklift_moving() {
    let s = Server::start_with("forklift", "fox", |c| c.start_paused = true);
    let mut a = s.args();
    a.extend(["--timeout", "30", "foxglove", "--port", "0", "--duration", "50"].map(String::from));
    let view = spawn_client(&a, LIMIT);
    // Connect once the scene was sent: its entities can then only come as a late joiner's copy.
    view.wait_for_stderr("as scene entities", Duration::from_secs(30));
    let mut ws = connect(printed_port(&view.stderr_so_far()));

    // serverInfo, then the channels.
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut info = None;
    let mut channels: Vec<Value> = Vec::new();
    let wanted = ["/tf", "/pivotsim/scene", "/pivotsim/stats", "/pivotsim/signals", "/pivotsim/events"];
    while !wanted.iter().all(|t| channels.iter().any(|c| c["topic"] == *t)) {
        assert!(Instant::now() < deadline, "not advertised within 20 s: {channels:?}");
        match next(&mut ws) {
            Some(Message::Text(t)) => {
                let v: Value = serde_json::from_str(t.as_str()).expect("a JSON text frame");
                match v["op"].as_str() {
                    Some("serverInfo") => info = Some(v),
                    Some("advertise") => channels.extend(v["channels"].as_array().unwrap().iter().cloned()),
                    _ => {}
                }
            }
            Some(Message::Binary(_)) => panic!("message data before any subscription"),
            _ => {}
        }
    }
    let info = info.expect("serverInfo comes first");
    assert_eq!(info["metadata"]["world"], s.world.as_str(), "{info}");
    let channel = |topic: &str| channels.iter().find(|c| c["topic"] == topic).unwrap().clone();
    let (tf, scene, stats) = (channel("/tf"), channel("/pivotsim/scene"), channel("/pivotsim/stats"));
    assert_eq!(
        (tf["encoding"].as_str(), tf["schemaName"].as_str()),
        (Some("protobuf"), Some("foxglove.FrameTransforms"))
    );
    assert_eq!(scene["schemaName"], "foxglove.SceneUpdate");
    assert_eq!(
        (stats["encoding"].as_str(), stats["schemaName"].as_str()),
        (Some("json"), Some("pivotsim.SolverStats"))
    );
    assert_eq!(stats["schemaEncoding"], "jsonschema");
    assert!(!tf["schema"].as_str().unwrap().is_empty(), "the protobuf schema is sent");
    let signals = channel("/pivotsim/signals");
    assert_eq!(
        (signals["encoding"].as_str(), signals["schemaName"].as_str(), signals["schemaEncoding"].as_str()),
        (Some("json"), Some("pivotsim.Signals"), Some("jsonschema"))
    );
    let schema: Value = serde_json::from_str(signals["schema"].as_str().unwrap()).expect("a JSON schema");
    assert!(schema["properties"]["values"].is_object(), "{schema}");
    assert_eq!(channel("/pivotsim/events")["schemaName"], "pivotsim.Events");

    let subscribe = json!({"op": "subscribe", "subscriptions": [
        {"id": 10, "channelId": tf["id"]}, {"id": 11, "channelId": scene["id"]}, {"id": 12, "channelId": stats["id"]},
        {"id": 13, "channelId": signals["id"]}]});
    ws.send(Message::Text(subscribe.to_string().into())).unwrap();

    // Paused: the first chassis transform, the scene (late joiner) and a stats message.
    let mut first: Option<[f64; 3]> = None;
    let mut last = [0.0; 3];
    let mut scene_entities = Vec::new();
    let mut stats_seen = 0;
    let mut signals_seen = 0;
    let mut resumed = false;
    let mut tf_frames = 0;
    let deadline = Instant::now() + Duration::from_secs(40);
    loop {
        assert!(
            Instant::now() < deadline,
            "the chassis did not move within 40 s: first {first:?}, last {last:?}, {tf_frames} transform frames, \
             {} entities, {stats_seen} stats, {signals_seen} signals, resumed {resumed}",
            scene_entities.len()
        );
        let Some(Message::Binary(b)) = next(&mut ws) else { continue };
        let (sub, stamp, payload) = message_data(&b);
        // The simulation clock (the default `--clock sim`): ns of simulation time, as `/clock`.
        assert!(stamp < 3_600_000_000_000, "timestamps are simulation-time ns: {stamp}");
        match sub {
            10 => {
                tf_frames += 1;
                let t = transforms(payload);
                assert!(t.len() > 10, "one transform per body: {}", t.len());
                // Bodies hang off `world`; the sensed joints' frames (`joint/<joint>`) off their
                // bodies (the forklift's lift cylinders).
                assert!(
                    t.iter().all(|(parent, child, _)| parent == "world" || child.starts_with("joint/")),
                    "{t:?}"
                );
                let (_, _, p) = t.iter().find(|(_, child, _)| child == "chassis").expect("a chassis frame");
                first.get_or_insert(*p);
                last = *p;
            }
            11 => scene_entities = entities(payload),
            12 => {
                let v: Value = serde_json::from_slice(payload).expect("stats are JSON");
                assert!(v["total_solve_us"].is_number(), "{v}");
                stats_seen += 1;
            }
            13 => {
                let v: Value = serde_json::from_slice(payload).expect("signals are JSON");
                let load = &v["values"]["forks_load"];
                assert!(load["normal"].is_number() && load["sliding"].is_number(), "{v}");
                assert!(v["values"]["lift_l"]["force"].is_number(), "{v}");
                signals_seen += 1;
            }
            other => panic!("unknown subscription id {other}"),
        }
        if !resumed && first.is_some() && !scene_entities.is_empty() && stats_seen > 0 {
            let (session, _) = s.connect();
            let reply = s.control(&session, 1, pivotsim_msgs::ControlCommand::Resume);
            assert!(matches!(reply.outcome, pivotsim_msgs::ControlOutcome::Ok(_)), "{reply:?}");
            resumed = true;
        }
        let moved = first.map_or(0.0, |f| ((last[0] - f[0]).powi(2) + (last[1] - f[1]).powi(2)).sqrt());
        if resumed && moved > 0.05 && signals_seen > 0 {
            eprintln!(
                "chassis {first:?} → {last:?} ({moved:.3} m) after {tf_frames} transform frames; {} entities, {stats_seen} stats, {signals_seen} signals",
                scene_entities.len()
            );
            break;
        }
    }
    // The scene's shapes: one frame-locked entity per body, drawn in the body's frame.
    let chassis = scene_entities.iter().find(|e| e.0 == "chassis").expect("a chassis entity");
    assert_eq!(chassis.1, "chassis");
    assert!(chassis.2, "frame-locked");
    assert!(chassis.3 >= 1, "the chassis has primitives");
    assert!(scene_entities.len() > 10, "{} entities", scene_entities.len());
    // A reset (simulation time back to 0) makes the view send the scene again, and the chassis
    // returns to its start.
    let (session, _) = s.connect();
    let reply = s.control(&session, 2, pivotsim_msgs::ControlCommand::Reset);
    assert!(matches!(reply.outcome, pivotsim_msgs::ControlOutcome::Ok(_)), "{reply:?}");
    let deadline = Instant::now() + Duration::from_secs(20);
    let (mut rescene, mut back) = (false, false);
    while !(rescene && back) {
        assert!(
            Instant::now() < deadline,
            "after the reset: scene again {rescene}, chassis back {back}\n{}",
            view.stderr_so_far()
        );
        let Some(Message::Binary(b)) = next(&mut ws) else { continue };
        let (sub, _, payload) = message_data(&b);
        match sub {
            10 => {
                let t = transforms(payload);
                let (_, _, p) = t.iter().find(|(_, child, _)| child == "chassis").unwrap();
                back |= (p[0] - first.unwrap()[0]).abs() < 1e-9;
            }
            11 => rescene |= entities(payload).len() == scene_entities.len(),
            _ => {}
        }
    }
    drop(ws);
    view.interrupt();
    let out = view.wait().ok();
    assert!(out.stderr.contains("0 malformed"), "{}", out.stderr);
    // The per-stream and per-topic loss tables.
    assert!(out.stderr.contains("per stream (from the server)"), "{}", out.stderr);
    assert!(out.stderr.contains("  /tf "), "{}", out.stderr);
}

/// An HTTP upgrade request offering `protocols` (tungstenite's client, no subprotocol logic).
fn offer(port: u16, protocols: &str) -> Result<(WebSocket<TcpStream>, String), (u16, String)> {
    let stream = TcpStream::connect(("127.0.0.1", port)).expect("connect");
    stream.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    let mut req = format!("ws://127.0.0.1:{port}").into_client_request().unwrap();
    req.headers_mut().insert("Sec-WebSocket-Protocol", protocols.parse().unwrap());
    match tungstenite::client::client(req, stream) {
        Ok((ws, resp)) => {
            let proto = resp.headers().get("Sec-WebSocket-Protocol").map(|v| v.to_str().unwrap().to_string());
            Ok((ws, proto.unwrap_or_default()))
        }
        Err(tungstenite::HandshakeError::Failure(tungstenite::Error::Http(r))) => {
            let body = r.body().as_ref().map(|b| String::from_utf8_lossy(b).into_owned()).unwrap_or_default();
            Err((r.status().as_u16(), body))
        }
        Err(e) => panic!("handshake: {e}"),
    }
}

/// A client that offers only the ws-protocol specification's name, `foxglove.websocket.v1` (as the
/// `@foxglove/ws-protocol` npm client does), is answered with that name and gets the server info,
/// the channels and transforms; a client offering no known name is refused with a 400 that names
/// the subprotocol to offer.
#[test]
fn a_client_offering_only_websocket_v1_connects() {
    let s = Server::start("pendulum", "foxv1");
    let mut a = s.args();
    a.extend(["--timeout", "30", "foxglove", "--port", "0", "--duration", "40"].map(String::from));
    let view = spawn_client(&a, LIMIT);
    view.wait_for_stderr("on ws://127.0.0.1:", Duration::from_secs(30));
    let port = printed_port(&view.stderr_so_far());

    let refused = offer(port, "foxglove.websocket.v2").expect_err("an unknown subprotocol is refused");
    assert_eq!(refused.0, 400);
    assert!(
        refused.1.contains("foxglove.websocket.v1") && refused.1.contains("foxglove.sdk.v1"),
        "{}",
        refused.1
    );

    let (mut ws, proto) = offer(port, "foxglove.websocket.v1").expect("foxglove.websocket.v1 is accepted");
    assert_eq!(proto, "foxglove.websocket.v1", "the server answers with the name the client offered");
    let deadline = Instant::now() + Duration::from_secs(20);
    let (mut info, mut tf) = (None, None);
    while info.is_none() || tf.is_none() {
        assert!(Instant::now() < deadline, "no serverInfo/advertise of /tf within 20 s");
        if let Some(Message::Text(t)) = next(&mut ws) {
            let v: Value = serde_json::from_str(t.as_str()).unwrap();
            match v["op"].as_str() {
                Some("serverInfo") => info = Some(v),
                Some("advertise") => {
                    tf =
                        tf.or(v["channels"].as_array().unwrap().iter().find(|c| c["topic"] == "/tf").cloned())
                }
                _ => {}
            }
        }
    }
    assert_eq!(info.unwrap()["metadata"]["world"], s.world.as_str());
    let tf = tf.unwrap();
    let subscribe = json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": tf["id"]}]});
    ws.send(Message::Text(subscribe.to_string().into())).unwrap();
    let mut frames = 0;
    while frames < 20 {
        assert!(Instant::now() < deadline, "{frames} transform frames within 20 s");
        if let Some(Message::Binary(b)) = next(&mut ws) {
            let (sub, _, payload) = message_data(&b);
            assert_eq!(sub, 1);
            assert!(!transforms(payload).is_empty());
            frames += 1;
        }
    }
    drop(ws);
    view.interrupt();
    let out = view.wait().ok();
    // The relay counted what it forwarded on /tf, and the view says what it lost.
    let row = out
        .stderr
        .lines()
        .find(|l| l.trim_start().starts_with("/tf "))
        .unwrap_or_else(|| panic!("{}", out.stderr));
    let relayed: u64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!(relayed >= 20, "{row}");
}
