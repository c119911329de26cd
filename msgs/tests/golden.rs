//! The byte dumps and JSON examples of `msgs/README.md` are what the code encodes and decodes, so
//! the documentation and the implementation cannot drift apart.

mod common;

use common::*;
use pivotsim_msgs::*;

const README: &str = include_str!("../README.md");

/// Lines of the fenced block that follows `marker` (the marker line, then a ``` fence).
fn block_after(marker: &str) -> Vec<&'static str> {
    let start = README.find(marker).unwrap_or_else(|| panic!("README has no {marker}"));
    let mut lines = README[start..].lines().skip(1);
    assert!(lines.next().is_some_and(|l| l.starts_with("```")), "{marker} is not followed by a fence");
    lines.take_while(|l| !l.starts_with("```")).collect()
}

/// Parses `OFFSET | hex bytes | comment` lines; checks that offsets are contiguous.
fn hex_dump(marker: &str) -> Vec<u8> {
    let mut bytes = Vec::new();
    for line in block_after(marker) {
        let mut cols = line.split('|');
        let offset = usize::from_str_radix(cols.next().unwrap().trim(), 16).unwrap();
        assert_eq!(offset, bytes.len(), "offset column of {line:?}");
        for h in cols.next().unwrap().split_whitespace() {
            bytes.push(u8::from_str_radix(h, 16).unwrap_or_else(|_| panic!("bad hex {h:?} in {line:?}")));
        }
    }
    bytes
}

fn dump(b: &[u8]) -> String {
    b.chunks(8)
        .enumerate()
        .map(|(i, c)| {
            format!("{:04x} | {}", 8 * i, c.iter().map(|x| format!("{x:02x}")).collect::<Vec<_>>().join(" "))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn golden_pose_frame() {
    let want = hex_dump("<!-- golden:pose-frame -->");
    let mut got = Vec::new();
    sample_pose().encode(&mut got).unwrap();
    assert_eq!(got, want, "encoded:\n{}", dump(&got));
    assert_eq!(want.len(), 160);
    assert_eq!(PoseFrame::decode(&want).unwrap(), sample_pose());
    let view = PoseFrameView::parse(&want).unwrap();
    assert_eq!(view.bodies().collect::<Vec<_>>(), [sample_body(7)]);
}

#[test]
fn golden_stats_frame() {
    let want = hex_dump("<!-- golden:stats -->");
    let mut got = Vec::new();
    sample_stats().encode(&mut got).unwrap();
    assert_eq!(got, want, "encoded:\n{}", dump(&got));
    assert_eq!(want.len(), 232);
    assert_eq!(SolverStats::decode(&want).unwrap(), sample_stats());
    // Every field of the fixed part is non-trivial (no counter or flag left at 0), so that the
    // example pins each one's offset.
    let s = sample_stats();
    assert!(s.inputs.rejected.iter().all(|&n| n > 0), "{:?}", s.inputs.rejected);
    assert!(s.overruns > 0 && s.inputs.accepted > 0 && s.inputs.deadman_trips > 0 && s.unstable_steps > 0);
    assert!(s.inputs.deadman_active && s.unstable && s.islands[0].fallback);
    let d = s.degraded;
    assert!(d.capped > 0 && d.inexact > 0 && d.budget > 0 && d.fallback > 0);
    assert_eq!(s.totals, StepTotals::from_islands(&s.islands));
}

#[test]
fn golden_winch_command() {
    let want = hex_dump("<!-- golden:winch -->");
    let cmd = InputCommand::Winch(WinchCommand {
        sequence: 42,
        source_id: 3,
        actuator: name("winch"),
        drum_speed: -0.5,
    });
    let mut got = Vec::new();
    cmd.encode(&mut got).unwrap();
    assert_eq!(got, want, "encoded:\n{}", dump(&got));
    assert_eq!(InputCommand::decode(&want).unwrap(), cmd);
}

#[test]
fn golden_signals_and_events() {
    let want = hex_dump("<!-- golden:signals -->");
    let mut got = Vec::new();
    sample_signals().encode(&mut got).unwrap();
    assert_eq!(got, want, "encoded:\n{}", dump(&got));
    assert_eq!(want.len(), 208);
    assert_eq!(SignalsFrame::decode(&want).unwrap(), sample_signals());
    let want = hex_dump("<!-- golden:events -->");
    sample_events().encode(&mut got).unwrap();
    assert_eq!(got, want, "encoded:\n{}", dump(&got));
    assert_eq!(want.len(), 112);
    assert_eq!(EventsFrame::decode(&want).unwrap(), sample_events());
}

/// The signals example follows the page's own contact convention: the normal points from A to B
/// and the record's forces are those on B. Body 5 (A) rests on the ground (B, body 0) at z = 0, so
/// the normal points down into the ground, the ground is pushed down and body 5 up.
#[test]
fn golden_signals_contact_follows_the_normal_convention() {
    let s = sample_signals();
    let c = &s.contacts[0];
    assert_eq!((c.body_a, c.body_b), (5, 0));
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    assert_eq!(dot(c.normal, c.normal), 1.0, "a unit normal");
    // From A (above) to B (below): down. The normal force on B is normal_force · normal.
    assert!(c.normal[2] < 0.0, "the normal points from body 5 down into the ground");
    let on_ground = c.normal.map(|n| c.normal_force * n);
    let on_body = on_ground.map(|f| -f);
    assert!(on_ground[2] < 0.0 && on_body[2] > 0.0, "the ground is pushed down, body 5 up");
    // Friction on B is tangential, of length friction_force; slipping, at its bound μ λ_n.
    assert_eq!(dot(c.friction, c.normal), 0.0);
    assert_eq!(dot(c.friction, c.friction).sqrt(), c.friction_force);
    assert_eq!(c.state, ContactCode::Slip);
    assert!(c.friction_force <= c.normal_force);
    // The README's bytes say the same.
    let want = hex_dump("<!-- golden:signals -->");
    assert_eq!(SignalsFrame::decode(&want).unwrap().contacts[0].normal, [0.0, 0.0, -1.0]);
}

fn json_frame(kind: Kind, json: &str) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&MAGIC);
    b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    b.extend_from_slice(&kind.code().to_le_bytes());
    b.extend_from_slice(&(json.len() as u32).to_le_bytes());
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(json.as_bytes());
    b
}

#[test]
fn readme_control_examples_decode_and_encode_identically() {
    let requests = block_after("<!-- example:control-request -->");
    assert_eq!(requests.len(), 13);
    let mut buf = Vec::new();
    for line in requests {
        let r = ControlRequest::decode(&json_frame(Kind::ControlRequest, line))
            .unwrap_or_else(|e| panic!("{line}: {e}"));
        r.encode(&mut buf).unwrap();
        assert_eq!(&buf[HEADER_LEN..], line.as_bytes(), "compact encoding of {line}");
    }
    for line in block_after("<!-- example:control-reply -->") {
        let r = ControlReply::decode(&json_frame(Kind::ControlReply, line))
            .unwrap_or_else(|e| panic!("{line}: {e}"));
        r.encode(&mut buf).unwrap();
        assert_eq!(&buf[HEADER_LEN..], line.as_bytes(), "compact encoding of {line}");
    }
}

#[test]
fn readme_scene_example_decodes() {
    let json = block_after("<!-- example:scene -->").join("\n");
    let s = SceneDescription::decode(&json_frame(Kind::SceneDescription, &json)).unwrap();
    assert_eq!(s.world, "demo");
    assert_eq!(s.bodies.len(), 5);
    assert_eq!(s.joints[0].parent, None);
    assert_eq!(s.actuator("winch").map(|a| a.kind), Some(ActuatorKind::Winch));
    let kinds: Vec<&str> = s
        .bodies
        .iter()
        .flat_map(|b| &b.colliders)
        .map(|c| match c.shape {
            Shape::Ball { .. } => "ball",
            Shape::Box { .. } => "box",
            Shape::Capsule { .. } => "capsule",
            Shape::Cylinder { .. } => "cylinder",
            Shape::ConvexHull { .. } => "convex_hull",
            Shape::Heightfield { .. } => "heightfield",
            Shape::Trimesh { .. } => "trimesh",
        })
        .collect();
    assert_eq!(kinds, ["box", "heightfield", "cylinder", "capsule", "convex_hull", "ball", "trimesh"]);
    // Joint frames on the child, and the sensors.
    let axle = s.joint("drum_axle").unwrap().frame.clone().unwrap();
    assert_eq!((axle.body, axle.position), (Some(1), [0.0, 0.0, 2.0]));
    let kinds: Vec<&str> = s.sensors.iter().map(|x| x.kind_name()).collect();
    assert_eq!(kinds, ["drum", "joint", "cable", "contact_sum", "tipping", "contacts"]);
    assert_eq!(s.sensor("hook.load").and_then(|x| x.joint()), Some("hook_mount"));
    assert_eq!(
        s.sensor("crate_ground"),
        Some(&SensorInfo::ContactSum { name: "crate_ground".into(), bodies: vec![4], with: Some(vec![0]) })
    );
    // Nullable fields may be omitted.
    let omitted = json.replace(r#", "limits": null"#, "");
    assert_ne!(omitted, json);
    assert_eq!(SceneDescription::decode(&json_frame(Kind::SceneDescription, &omitted)).unwrap(), s);
    let with_null = json.replace(r#""with": [0]"#, r#""with": null"#);
    let without = json.replace(r#", "with": [0]"#, "");
    assert_ne!(without, json);
    assert_eq!(
        SceneDescription::decode(&json_frame(Kind::SceneDescription, &with_null)).unwrap(),
        SceneDescription::decode(&json_frame(Kind::SceneDescription, &without)).unwrap()
    );
}

/// A description of an older server (no joint frames, no sensors) still decodes; one without them
/// is written without the keys, as before.
#[test]
fn scene_without_frames_and_sensors_decodes_as_before() {
    let json = block_after("<!-- example:scene -->").join("\n");
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v.as_object_mut().unwrap().remove("sensors");
    for j in v["joints"].as_array_mut().unwrap() {
        j.as_object_mut().unwrap().remove("frame");
    }
    let old = v.to_string();
    assert!(!old.contains("frame") && !old.contains("sensors"));
    let s = SceneDescription::decode(&json_frame(Kind::SceneDescription, &old)).unwrap();
    assert!(s.sensors.is_empty() && s.joints.iter().all(|j| j.frame.is_none()));
    let full = SceneDescription::decode(&json_frame(Kind::SceneDescription, &json)).unwrap();
    let mut stripped = full.clone();
    stripped.sensors.clear();
    stripped.joints.iter_mut().for_each(|j| j.frame = None);
    assert_eq!(s, stripped);
    let mut buf = Vec::new();
    s.encode(&mut buf).unwrap();
    let text = std::str::from_utf8(&buf[HEADER_LEN..]).unwrap();
    assert!(!text.contains("\"frame\"") && !text.contains("\"sensors\""), "{text}");
    // A joint frame without sensors, and sensors that need no frame, are fine too.
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["sensors"] = serde_json::json!([{"name": "t", "kind": "tension", "joint": "cable0"}]);
    v["joints"][1].as_object_mut().unwrap().remove("frame");
    SceneDescription::decode(&json_frame(Kind::SceneDescription, &v.to_string())).unwrap();
}

#[test]
fn readme_sizes_match_the_constants() {
    let row = |kind: &str| README.lines().find(|l| l.starts_with(&format!("| `{kind}`"))).unwrap();
    let max =
        |kind: &str| row(kind).rsplit('|').nth(2).unwrap().trim().replace(' ', "").parse::<usize>().unwrap();
    for k in Kind::ALL {
        assert_eq!(max(&format!("0x{:04x}", k.code())), k.max_payload_len(), "{k}");
    }
    assert_eq!(HEADER_LEN + POSE_FIXED_LEN, 48);
    assert_eq!(HEADER_LEN + STATS_FIXED_LEN, 192);
    assert_eq!(HEADER_LEN + SIGNALS_FIXED_LEN, 56);
    assert_eq!(HEADER_LEN + EVENTS_FIXED_LEN, 48);
    assert_eq!(HEADER_LEN + BOOM_FIXED_LEN, 32);
    assert_eq!(HEADER_LEN + JOYSTICK_LEN, 168);
    assert_eq!(HEADER_LEN + WINCH_LEN, 72);
    assert_eq!(HEADER_LEN + ACTUATOR_LEN, 72);
}

/// Each reply example answers a request example with the same id, and its code is one that
/// request's op can get (a `load_refused` or `unknown_scene` answers a `load_scene`, …).
#[test]
fn readme_reply_examples_answer_their_requests() {
    let requests: Vec<ControlRequest> = block_after("<!-- example:control-request -->")
        .into_iter()
        .map(|l| ControlRequest::decode(&json_frame(Kind::ControlRequest, l)).unwrap())
        .collect();
    let replies = block_after("<!-- example:control-reply -->");
    assert!(replies.len() >= 3);
    let mut codes = Vec::new();
    for line in replies {
        let reply = ControlReply::decode(&json_frame(Kind::ControlReply, line)).unwrap();
        let req = requests
            .iter()
            .find(|r| r.id == reply.id)
            .unwrap_or_else(|| panic!("{line}: no request example has id {}", reply.id));
        let op = serde_json::to_value(&req.command).unwrap()["op"].as_str().unwrap().to_string();
        match &reply.outcome {
            ControlOutcome::Ok(status) => {
                if let ControlCommand::SetVariant { variant } = req.command {
                    assert_eq!(status.variant, variant, "{line}");
                }
                // Lockstep replies say how many steps they took; no other reply does.
                let lockstep =
                    matches!(req.command, ControlCommand::Step { .. } | ControlCommand::RunUntil { .. });
                assert_eq!(status.steps.is_some(), lockstep, "{line}");
            }
            ControlOutcome::Error(f) => {
                use ControlErrorCode as C;
                let ops: &[&str] = match f.code {
                    C::UnknownScene | C::SceneLoadFailed => &["load_scene", "reset"],
                    C::LoadRefused => &["load_scene", "reset", "snapshot", "restore"],
                    C::UnknownVariant => &["set_variant"],
                    C::FaultRejected => &["fault"],
                    C::Busy => &["step", "run_until"],
                    C::InThePast => &["run_until"],
                    C::SnapshotFailed => &["snapshot", "restore"],
                    C::InvalidRequest | C::Internal => &[],
                };
                assert!(ops.is_empty() || ops.contains(&op.as_str()), "{line} answers a `{op}` request");
                codes.push(f.code);
            }
        }
    }
    assert!(codes.contains(&ControlErrorCode::LoadRefused), "the example shows load_refused");
}
