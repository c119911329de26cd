//! Every malformed case of the wire format gives its typed error: frame-level (truncated, trailing
//! bytes, oversized, bad magic, unknown version or kind, flags, layout, reserved bytes), non-finite
//! values anywhere, non-unit quaternions, joystick axes out of range, unknown solver variant names,
//! empty or too-long actuator names, and too many entries.

mod common;

use common::*;
use pivotsim_msgs::*;

fn encode(m: &Message) -> Vec<u8> {
    let mut b = Vec::new();
    m.encode(&mut b).unwrap();
    b
}

fn set_u32(b: &mut [u8], off: usize, v: u32) {
    b[off..off + 4].copy_from_slice(&v.to_le_bytes());
}

fn set_f64(b: &mut [u8], off: usize, v: f64) {
    b[off..off + 8].copy_from_slice(&v.to_le_bytes());
}

fn pose_bytes() -> Vec<u8> {
    encode(&Message::Pose(sample_pose()))
}

fn pose_err(b: &[u8]) -> DecodeError<PoseError> {
    let e = PoseFrameView::parse(b).unwrap_err();
    assert_eq!(PoseFrame::decode(b).unwrap_err(), e, "view and owned decoders agree");
    e
}

fn invalid_pose(b: &[u8]) -> PoseError {
    pose_err(b)
        .invalid()
        .cloned()
        .unwrap_or_else(|| panic!("expected a content error, got {:?}", pose_err(b)))
}

fn frame_err(b: &[u8]) -> FrameError {
    match Message::decode(b).unwrap_err() {
        MessageError::Frame(f) => f,
        e => panic!("expected a frame error, got {e:?}"),
    }
}

const BODY0: usize = HEADER_LEN + POSE_FIXED_LEN;

#[test]
fn truncated_and_trailing_bytes() {
    let b = pose_bytes();
    assert_eq!(frame_err(&b[..10]), FrameError::Truncated { needed: 16, available: 10 });
    assert_eq!(frame_err(&b[..100]), FrameError::Truncated { needed: b.len(), available: 100 });
    let mut long = b.clone();
    long.push(0);
    assert_eq!(frame_err(&long), FrameError::TrailingBytes { expected: b.len(), available: b.len() + 1 });
}

#[test]
fn declared_payload_above_the_kind_maximum() {
    for (kind, mut b) in sample_frames() {
        let max = kind.max_payload_len();
        set_u32(&mut b, 8, (max + 1) as u32);
        assert_eq!(frame_err(&b), FrameError::PayloadTooLarge { kind, declared: max + 1, max });
    }
    let mut b = pose_bytes();
    set_u32(&mut b, 8, u32::MAX);
    assert!(matches!(frame_err(&b), FrameError::PayloadTooLarge { .. }));
}

#[test]
fn bad_magic_version_kind_flags() {
    let b = pose_bytes();
    let mut m = b.clone();
    m[..4].copy_from_slice(b"PVSX");
    assert_eq!(frame_err(&m), FrameError::BadMagic { found: *b"PVSX" });
    // Every other version, the earlier ones included: a decoder reads exactly one.
    for version in (0..FORMAT_VERSION).chain([FORMAT_VERSION + 1, 0xFFFF]) {
        let mut v = b.clone();
        v[4..6].copy_from_slice(&version.to_le_bytes());
        assert_eq!(frame_err(&v), FrameError::UnsupportedVersion { found: version });
    }
    for code in [0u16, 7, 0x0014, 0x0103, 0x0200, 0xFFFF] {
        let mut k = b.clone();
        k[6..8].copy_from_slice(&code.to_le_bytes());
        assert_eq!(frame_err(&k), FrameError::UnknownKind { found: code });
    }
    let mut f = b.clone();
    set_u32(&mut f, 12, 0x8000_0000);
    assert_eq!(frame_err(&f), FrameError::Flags { found: 0x8000_0000 });
}

#[test]
fn wrong_kind_for_the_decoder() {
    let frames = sample_frames();
    let stats = &frames[1].1;
    assert_eq!(
        pose_err(stats),
        FrameError::WrongKind { expected: Kind::PoseFrame, found: Kind::SolverStats }.into()
    );
    assert_eq!(InputCommand::decode(stats), Err(FrameError::NotAnInput { found: Kind::SolverStats }.into()));
    let pose = pose_bytes();
    assert!(matches!(SolverStats::decode(&pose), Err(DecodeError::Frame(FrameError::WrongKind { .. }))));
    assert!(matches!(ControlRequest::decode(&pose), Err(DecodeError::Frame(FrameError::WrongKind { .. }))));
    assert!(matches!(SceneDescription::decode(&pose), Err(DecodeError::Frame(FrameError::WrongKind { .. }))));
}

#[test]
fn pose_layout_errors() {
    let b = pose_bytes();
    // Body count says 2, payload holds 1 record.
    let mut c = b.clone();
    set_u32(&mut c, HEADER_LEN + 24, 2);
    assert_eq!(
        pose_err(&c),
        FrameError::PayloadLength { kind: Kind::PoseFrame, expected: 32 + 224, found: 144 }.into()
    );
    // Payload shorter than the fixed part (header consistent with the buffer).
    let mut s = b[..HEADER_LEN + 20].to_vec();
    set_u32(&mut s, 8, 20);
    assert_eq!(
        pose_err(&s),
        FrameError::PayloadLength { kind: Kind::PoseFrame, expected: 32, found: 20 }.into()
    );
    let mut r = b.clone();
    r[HEADER_LEN + 30] = 1;
    assert_eq!(pose_err(&r), FrameError::ReservedNonZero { offset: HEADER_LEN + 30 }.into());
}

#[test]
fn too_many_bodies() {
    let mut b = pose_bytes();
    set_u32(&mut b, HEADER_LEN + 24, MAX_BODIES as u32 + 1);
    assert_eq!(invalid_pose(&b), PoseError::TooManyBodies { count: MAX_BODIES + 1 });
    let f = PoseFrame { bodies: vec![sample_body(0); MAX_BODIES + 1], ..sample_pose() };
    assert_eq!(f.encode(&mut Vec::new()), Err(PoseError::TooManyBodies { count: MAX_BODIES + 1 }));
}

#[test]
fn non_finite_pose_fields() {
    let fields = [
        (8, "position"),
        (16, "position"),
        (24, "position"),
        (32, "orientation"),
        (56, "orientation"),
        (64, "linear_velocity"),
        (80, "linear_velocity"),
        (88, "angular_velocity"),
        (104, "angular_velocity"),
    ];
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for (off, field) in fields {
            let mut b = pose_bytes();
            set_f64(&mut b, BODY0 + off, bad);
            assert_eq!(invalid_pose(&b), PoseError::NonFinite { body: Some(0), field }, "{field} at {off}");
        }
        let mut b = pose_bytes();
        set_f64(&mut b, HEADER_LEN + 8, bad);
        assert_eq!(invalid_pose(&b), PoseError::NonFinite { body: None, field: "sim_time" });
    }
    let mut b = pose_bytes();
    set_f64(&mut b, HEADER_LEN + 8, -0.5);
    assert_eq!(invalid_pose(&b), PoseError::NegativeSimTime { value: -0.5 });
}

#[test]
fn non_unit_quaternion_and_flags() {
    let mut b = pose_bytes();
    set_f64(&mut b, BODY0 + 56, 1.0 + 2e-6);
    assert!(matches!(invalid_pose(&b), PoseError::NonUnitQuaternion { body: 0, .. }));
    set_f64(&mut b, BODY0 + 56, 0.0);
    assert!(matches!(invalid_pose(&b), PoseError::NonUnitQuaternion { body: 0, norm } if norm == 0.0));
    // Within tolerance is accepted.
    set_f64(&mut b, BODY0 + 56, 1.0 + 5e-7);
    assert!(PoseFrameView::parse(&b).is_ok());
    let mut f = pose_bytes();
    set_u32(&mut f, BODY0 + 4, 0x10);
    assert_eq!(invalid_pose(&f), PoseError::BodyFlags { body: 0, flags: 0x10 });
}

#[test]
fn stats_content_errors() {
    let frames = sample_frames();
    let b = &frames[1].1;
    let island0 = HEADER_LEN + STATS_FIXED_LEN;
    let cases: Vec<(usize, f64, StatsError)> = vec![
        (HEADER_LEN + 8, f64::NAN, StatsError::NonFinite { island: None, field: "sim_time" }),
        (HEADER_LEN + 16, f64::INFINITY, StatsError::NonFinite { island: None, field: "step_wall_us" }),
        (HEADER_LEN + 56, f64::NAN, StatsError::NonFinite { island: None, field: "total_solve_us" }),
        (
            HEADER_LEN + 64,
            f64::NEG_INFINITY,
            StatsError::NonFinite { island: None, field: "max_residual_rel" },
        ),
        (island0 + 24, f64::NAN, StatsError::NonFinite { island: Some(0), field: "solve_us" }),
        (island0 + 40 + 32, f64::INFINITY, StatsError::NonFinite { island: Some(1), field: "residual_rel" }),
        (island0 + 24, -1.0, StatsError::Negative { island: Some(0), field: "solve_us", value: -1.0 }),
    ];
    for (off, v, want) in cases {
        let mut c = b.clone();
        set_f64(&mut c, off, v);
        assert_eq!(SolverStats::decode(&c), Err(DecodeError::Invalid(want)));
    }
    let mut c = b.clone();
    set_u32(&mut c, island0 + 16, 31);
    assert_eq!(
        SolverStats::decode(&c),
        Err(DecodeError::Invalid(StatsError::TightExceedsRows { island: Some(0), tight: 31, rows: 30 }))
    );
    let mut c = b.clone();
    set_u32(&mut c, HEADER_LEN + 24, MAX_ISLANDS as u32 + 1);
    assert_eq!(
        SolverStats::decode(&c),
        Err(DecodeError::Invalid(StatsError::TooManyIslands { count: MAX_ISLANDS + 1 }))
    );
    let mut c = b.clone();
    set_u32(&mut c, HEADER_LEN + 24, 3);
    assert!(matches!(SolverStats::decode(&c), Err(DecodeError::Frame(FrameError::PayloadLength { .. }))));
}

fn input_err(b: &[u8]) -> DecodeError<InputError> {
    InputCommand::decode(b).unwrap_err()
}

#[test]
fn joystick_errors() {
    let frames = sample_frames();
    let j = &frames[2].1;
    let axis = |i: usize| HEADER_LEN + 24 + 4 * i;
    for (v, want) in [
        (1.0001f32, InputError::AxisOutOfRange { axis: 1, value: 1.0001 }),
        (-2.0, InputError::AxisOutOfRange { axis: 1, value: -2.0 }),
        (f32::NAN, InputError::NonFinite { field: "axes", entry: Some(1) }),
        (f32::INFINITY, InputError::NonFinite { field: "axes", entry: Some(1) }),
    ] {
        let mut b = j.clone();
        b[axis(1)..axis(1) + 4].copy_from_slice(&v.to_le_bytes());
        assert_eq!(input_err(&b), DecodeError::Invalid(want));
    }
    let mut b = j.clone();
    b[axis(31)..axis(31) + 4].copy_from_slice(&0.5f32.to_le_bytes());
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::UnusedAxis { axis: 31 }));
    let mut b = j.clone();
    b[HEADER_LEN + 12] = 33;
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::TooManyAxes { count: 33 }));
    let mut b = j.clone();
    b[HEADER_LEN + 13] = 65;
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::TooManyButtons { count: 65 }));
    let mut b = j.clone();
    b[HEADER_LEN + 16 + 7] = 0x80;
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::UnusedButtons { buttons: 1 << 63 }));
    let mut b = j.clone();
    b[HEADER_LEN + 14] = 1;
    assert_eq!(input_err(&b), FrameError::ReservedNonZero { offset: HEADER_LEN + 14 }.into());
    assert_eq!(input_err(&b).reject_reason(), RejectReason::Malformed);
}

#[test]
fn actuator_name_errors() {
    let frames = sample_frames();
    let winch = &frames[3].1;
    let field = HEADER_LEN + 16;
    let mut b = winch.clone();
    b[field..field + 32].fill(0);
    let e = input_err(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::Name { entry: None, source: NameError::Empty }));
    assert_eq!(e.reject_reason(), RejectReason::OutOfRange);
    let mut b = winch.clone();
    b[field + 2] = b' ';
    assert_eq!(
        input_err(&b),
        DecodeError::Invalid(InputError::Name {
            entry: None,
            source: NameError::InvalidChar { index: 2, byte: b' ' }
        })
    );
    let mut b = winch.clone();
    b[field + 31] = b'x';
    assert_eq!(
        input_err(&b),
        DecodeError::Invalid(InputError::Name { entry: None, source: NameError::Padding { index: 31 } })
    );
    // Too long: refused when building the name, and in the scene description.
    assert_eq!(ActuatorName::new(&"n".repeat(33)), Err(NameError::TooLong { len: 33 }));
    assert_eq!(ActuatorName::new(""), Err(NameError::Empty));
    let mut s = sample_scene();
    s.actuators[0].name = "w".repeat(33);
    assert!(matches!(
        s.validate(),
        Err(SceneError::ActuatorName { source: NameError::TooLong { len: 33 }, .. })
    ));
    s.actuators[0].name.clear();
    assert!(matches!(s.validate(), Err(SceneError::ActuatorName { source: NameError::Empty, .. })));
}

#[test]
fn input_value_and_count_errors() {
    let frames = sample_frames();
    let (winch, boom, act) = (&frames[3].1, &frames[4].1, &frames[5].1);
    let mut b = winch.clone();
    set_f64(&mut b, HEADER_LEN + 48, f64::NAN);
    assert_eq!(
        input_err(&b),
        DecodeError::Invalid(InputError::NonFinite { field: "drum_speed", entry: None })
    );
    assert_eq!(input_err(&b).reject_reason(), RejectReason::NonFinite);
    let mut b = act.clone();
    set_f64(&mut b, HEADER_LEN + 48, f64::NEG_INFINITY);
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::NonFinite { field: "value", entry: None }));
    let mut b = act.clone();
    b[HEADER_LEN + 12] = 3;
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::UnknownMode { code: 3 }));
    let mut b = boom.clone();
    set_f64(&mut b, HEADER_LEN + 16 + 40 + 32, f64::INFINITY);
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::NonFinite { field: "value", entry: Some(1) }));
    let mut b = boom.clone();
    b.copy_within(HEADER_LEN + 16..HEADER_LEN + 48, HEADER_LEN + 56);
    assert_eq!(input_err(&b), DecodeError::Invalid(InputError::DuplicateTarget { name: "slew".into() }));
    let mut b = boom.clone();
    set_u32(&mut b, HEADER_LEN + 12, MAX_BOOM_TARGETS as u32 + 1);
    let e = input_err(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::TooManyTargets { count: MAX_BOOM_TARGETS + 1 }));
    assert_eq!(e.reject_reason(), RejectReason::Oversize);
    let mut b = boom.clone();
    set_u32(&mut b, HEADER_LEN + 12, 3);
    assert!(matches!(input_err(&b), DecodeError::Frame(FrameError::PayloadLength { kind: Kind::Boom, .. })));
}

fn json_frame(kind: Kind, json: &str) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(b"PVSM");
    b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    b.extend_from_slice(&kind.code().to_le_bytes());
    b.extend_from_slice(&(json.len() as u32).to_le_bytes());
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(json.as_bytes());
    b
}

#[test]
fn control_errors() {
    let req = |j: &str| ControlRequest::decode(&json_frame(Kind::ControlRequest, j));
    assert_eq!(
        req(r#"{"id":1,"command":{"op":"set_variant","variant":"Skyline"}}"#),
        Err(DecodeError::Invalid(ControlError::UnknownVariant { name: "Skyline".into() }))
    );
    assert_eq!(
        req(r#"{"id":1,"command":{"op":"step","count":0}}"#),
        Err(DecodeError::Invalid(ControlError::StepCount { count: 0 }))
    );
    assert_eq!(
        req(r#"{"id":1,"command":{"op":"step","count":3601}}"#),
        Err(DecodeError::Invalid(ControlError::StepCount { count: 3601 }))
    );
    assert_eq!(
        req(r#"{"id":1,"command":{"op":"load_scene","scene":""}}"#),
        Err(DecodeError::Invalid(ControlError::EmptyScene))
    );
    assert_eq!(
        req(r#"{"id":1,"command":{"op":"load_scene","scene":"a\u0000b"}}"#),
        Err(DecodeError::Invalid(ControlError::SceneChar { index: 1 }))
    );
    // A snapshot path must stay inside the server's snapshot directory.
    for (op, path) in [
        ("snapshot", "a/../b"),
        ("restore", "_/.."),
        ("restore", "/etc/x"),
        ("snapshot", "\\\\x"),
        ("restore", ""),
    ] {
        let j = format!(r#"{{"id":1,"command":{{"op":"{op}","path":"{path}"}}}}"#);
        assert_eq!(
            req(&j),
            Err(DecodeError::Invalid(ControlError::SnapshotPath { len: path.replace("\\\\", "\\").len() })),
            "{op} {path}"
        );
    }
    for (op, path) in [("snapshot", "a/.b/c..d"), ("restore", "rig/step-10.snap")] {
        let j = format!(r#"{{"id":1,"command":{{"op":"{op}","path":"{path}"}}}}"#);
        assert!(req(&j).is_ok(), "{op} {path}");
    }
    let long = format!(r#"{{"id":1,"command":{{"op":"load_scene","scene":"{}"}}}}"#, "s".repeat(257));
    assert_eq!(req(&long), Err(DecodeError::Invalid(ControlError::SceneTooLong { len: 257 })));
    for bad in
        [r#"{"id":1}"#, r#"{"id":1,"command":{"op":"step","count":1.5}}"#, "", "null", r#"{"id":1e400}"#]
    {
        assert!(matches!(req(bad), Err(DecodeError::Frame(FrameError::Json { .. }))), "{bad}");
    }
    let rep = |j: &str| ControlReply::decode(&json_frame(Kind::ControlReply, j));
    let status = r#"{"scene":"w","paused":true,"sequence":1,"sim_time":0.5,"variant":"fastest"}"#;
    assert_eq!(
        rep(&format!(r#"{{"id":1,"outcome":{{"ok":{status}}}}}"#)),
        Err(DecodeError::Invalid(ControlError::UnknownVariant { name: "fastest".into() }))
    );
    let status = r#"{"scene":"w","paused":true,"sequence":1,"sim_time":-0.5,"variant":"pgs"}"#;
    assert_eq!(
        rep(&format!(r#"{{"id":1,"outcome":{{"ok":{status}}}}}"#)),
        Err(DecodeError::Invalid(ControlError::SimTime { value: -0.5 }))
    );
    let msg = "m".repeat(MAX_MESSAGE_LEN + 1);
    let j = format!(r#"{{"id":1,"outcome":{{"error":{{"code":"busy","message":"{msg}"}}}}}}"#);
    assert_eq!(rep(&j), Err(DecodeError::Invalid(ControlError::MessageTooLong { len: MAX_MESSAGE_LEN + 1 })));
    assert!(matches!(
        rep(r#"{"id":1,"outcome":{"error":{"code":"teapot","message":""}}}"#),
        Err(DecodeError::Frame(FrameError::Json { .. }))
    ));
    // Encoding refuses what decoding would refuse.
    let nan = ServerStatus {
        scene: "w".into(),
        paused: false,
        sequence: 0,
        sim_time: f64::NAN,
        variant: SolverVariant::Pgs,
        steps: None,
    };
    assert!(matches!(ControlReply::ok(1, nan).encode(&mut Vec::new()), Err(ControlError::SimTime { .. })));
}

#[test]
fn scene_errors() {
    let ok = sample_scene();
    ok.validate().unwrap();
    let check = |f: &dyn Fn(&mut SceneDescription), want: &dyn Fn(&SceneError) -> bool| {
        let mut s = ok.clone();
        f(&mut s);
        let e = s.validate().unwrap_err();
        assert!(want(&e), "unexpected {e:?}");
        assert_eq!(s.encode(&mut Vec::new()), Err(e.clone()), "encode validates");
        // The same content, bypassing validation, is refused by the decoder.
        let j = serde_json::to_string(&s).unwrap();
        match SceneDescription::decode(&json_frame(Kind::SceneDescription, &j)) {
            Err(DecodeError::Invalid(d)) => assert_eq!(d, e),
            Err(DecodeError::Frame(FrameError::Json { .. })) => {} // NaN serialises as null
            other => panic!("decoder accepted invalid scene: {other:?}"),
        }
    };
    check(&|s| s.world = "bad world".into(), &|e| matches!(e, SceneError::World(KeyError::WorldChar { .. })));
    check(
        &|s| s.timestep = 0.0,
        &|e| matches!(e, SceneError::NonPositive { path, .. } if path == "timestep"),
    );
    check(
        &|s| s.gravity[2] = f64::NAN,
        &|e| matches!(e, SceneError::NonFinite { path } if path == "gravity"),
    );
    check(&|s| s.bodies[1].id = 0, &|e| matches!(e, SceneError::DuplicateBodyId { id: 0 }));
    check(&|s| s.bodies[1].name = "ground".into(), &|e| matches!(e, SceneError::DuplicateName { .. }));
    check(&|s| s.bodies[1].name = "x".repeat(65), &|e| matches!(e, SceneError::NameTooLong { len: 65, .. }));
    check(&|s| s.bodies[1].name = "a\nb".into(), &|e| matches!(e, SceneError::NameChar { index: 1, .. }));
    check(&|s| s.bodies[1].mass = 0.0, &|e| matches!(e, SceneError::NonPositive { .. }));
    check(
        &|s| s.bodies[0].colliders[0].orientation = [0.0, 0.0, 0.0, 0.9],
        &|e| matches!(e, SceneError::NonUnitQuaternion { path, .. } if path == "bodies[0].colliders[0].orientation"),
    );
    check(
        &|s| s.bodies[1].colliders[0].shape = Shape::Ball { radius: -1.0 },
        &|e| matches!(e, SceneError::NonPositive { path, .. } if path == "bodies[1].colliders[0].shape.radius"),
    );
    check(
        &|s| s.bodies[1].colliders[0].shape = Shape::Capsule { radius: 0.1, half_height: f64::INFINITY },
        &|e| matches!(e, SceneError::NonFinite { .. }),
    );
    check(&|s| s.bodies[1].colliders[0].shape = Shape::ConvexHull { vertices: vec![[0.0; 3]; 3] }, &|e| {
        matches!(e, SceneError::TooFew { count: 3, min: 4, .. })
    });
    check(
        &|s| {
            s.bodies[1].colliders[0].shape =
                Shape::ConvexHull { vertices: vec![[0.0; 3]; MAX_HULL_VERTICES + 1] }
        },
        &|e| matches!(e, SceneError::TooMany { max: MAX_HULL_VERTICES, .. }),
    );
    check(
        &|s| {
            s.bodies[1].colliders[0].shape = Shape::Heightfield {
                rows: 2,
                cols: 3,
                extent: [1.0, 1.0],
                heights: HeightData::Inline(vec![0.0; 5]),
            }
        },
        &|e| matches!(e, SceneError::HeightfieldSize { samples: Some(5), .. }),
    );
    check(
        &|s| {
            s.bodies[1].colliders[0].shape = Shape::Heightfield {
                rows: 1,
                cols: 3,
                extent: [1.0, 1.0],
                heights: HeightData::Reference("t.raw".into()),
            }
        },
        &|e| matches!(e, SceneError::HeightfieldSize { rows: 1, samples: None, .. }),
    );
    check(
        &|s| {
            s.bodies[1].colliders[0].shape = Shape::Trimesh {
                mesh: MeshData::Inline { vertices: vec![[0.0; 3]; 3], triangles: vec![[0, 1, 3]] },
            }
        },
        &|e| matches!(e, SceneError::MeshIndex { index: 3, vertices: 3, .. }),
    );
    check(
        &|s| s.bodies[1].colliders[0].shape = Shape::Trimesh { mesh: MeshData::Reference(String::new()) },
        &|e| matches!(e, SceneError::EmptyName { .. }),
    );
    check(&|s| s.bodies[1].colliders = vec![s.bodies[1].colliders[0].clone(); 65], &|e| {
        matches!(e, SceneError::TooMany { count: 65, max: 64, .. })
    });
    // Visual-only shapes are checked as colliders are, under their own path.
    check(
        &|s| {
            s.bodies[1].visuals =
                vec![Collider { shape: Shape::Ball { radius: -1.0 }, ..s.bodies[1].colliders[0].clone() }]
        },
        &|e| matches!(e, SceneError::NonPositive { path, .. } if path == "bodies[1].visuals[0].shape.radius"),
    );
    check(
        &|s| s.bodies[1].visuals = vec![s.bodies[1].colliders[0].clone(); 65],
        &|e| matches!(e, SceneError::TooMany { count: 65, max: 64, path } if path == "bodies[1].visuals"),
    );
    check(&|s| s.joints[0].child = 99, &|e| matches!(e, SceneError::UnknownBody { id: 99, .. }));
    check(&|s| s.joints[0].parent = Some(1), &|e| matches!(e, SceneError::SelfJoint { .. }));
    check(&|s| s.actuators[0].joint = Some("nope".into()), &|e| matches!(e, SceneError::UnknownJoint { .. }));
    check(&|s| s.actuators[1].name = "winch".into(), &|e| matches!(e, SceneError::DuplicateName { .. }));
    check(&|s| s.actuators[0].limits = Some([1.0, -1.0]), &|e| matches!(e, SceneError::Limits { .. }));
    check(&|s| s.joystick[0].actuator = "nope".into(), &|e| matches!(e, SceneError::UnknownActuator { .. }));
    check(&|s| s.joystick[0].input = JoystickInput::Axis(32), &|e| {
        matches!(e, SceneError::BindingIndex { index: 32, max: 32, .. })
    });
    check(&|s| s.joystick[0].input = JoystickInput::Button(64), &|e| {
        matches!(e, SceneError::BindingIndex { index: 64, max: 64, .. })
    });
    check(&|s| s.joystick = vec![s.joystick[0].clone(); MAX_BINDINGS + 1], &|e| {
        matches!(e, SceneError::TooMany { count: 97, .. })
    });
    check(&|s| s.scene = String::new(), &|e| matches!(e, SceneError::Scene(ControlError::EmptyScene)));
}

#[test]
fn scene_joint_frame_and_sensor_errors() {
    let ok = sample_scene();
    let check = |f: &dyn Fn(&mut SceneDescription), want: &dyn Fn(&SceneError) -> bool| {
        let mut s = ok.clone();
        f(&mut s);
        let e = s.validate().unwrap_err();
        assert!(want(&e), "unexpected {e:?}");
        assert_eq!(s.encode(&mut Vec::new()), Err(e.clone()), "encode validates");
        let j = serde_json::to_string(&s).unwrap();
        match SceneDescription::decode(&json_frame(Kind::SceneDescription, &j)) {
            Err(DecodeError::Invalid(d)) => assert_eq!(d, e),
            Err(DecodeError::Frame(FrameError::Json { .. })) => {} // NaN serialises as null
            other => panic!("decoder accepted invalid scene: {other:?}"),
        }
    };
    let frame = |s: &SceneDescription| s.joints[0].frame.clone().unwrap();
    let set_frame = |s: &mut SceneDescription, f: JointFrame| s.joints[0].frame = Some(f);
    // The frame's body: the child (1) or the parent (0); the world only for a world joint.
    for body in [Some(0), Some(1)] {
        let mut s = ok.clone();
        let f = JointFrame { body, ..frame(&s) };
        set_frame(&mut s, f);
        s.validate().unwrap();
    }
    check(
        &|s| {
            let f = JointFrame { body: None, ..frame(s) };
            set_frame(s, f)
        },
        &|e| matches!(e, SceneError::FrameBody { path, body: None } if path == "joints[0].frame.body"),
    );
    check(
        &|s| {
            s.bodies.push(BodyInfo { id: 7, name: "other".into(), ..s.bodies[1].clone() });
            let f = JointFrame { body: Some(7), ..frame(s) };
            set_frame(s, f)
        },
        &|e| matches!(e, SceneError::FrameBody { body: Some(7), .. }),
    );
    check(
        &|s| {
            let f = JointFrame { orientation: [0.0, 0.0, 0.0, 2.0], ..frame(s) };
            set_frame(s, f)
        },
        &|e| matches!(e, SceneError::NonUnitQuaternion { path, .. } if path == "joints[0].frame.orientation"),
    );
    check(
        &|s| {
            let f = JointFrame { position: [0.0, f64::NAN, 0.0], ..frame(s) };
            set_frame(s, f)
        },
        &|e| matches!(e, SceneError::NonFinite { path } if path == "joints[0].frame.position"),
    );
    // Sensors: names, joints, frames, joint kinds, body lists, touch.
    check(
        &|s| s.sensors[1] = SensorInfo::Tension { name: "drum.torque".into(), joint: "drum_axle".into() },
        &|e| matches!(e, SceneError::DuplicateName { path, .. } if path == "sensors[1].name"),
    );
    check(
        &|s| s.sensors[0] = SensorInfo::Joint { name: "bad name".into(), joint: "drum_axle".into() },
        &|e| matches!(e, SceneError::ActuatorName { path, .. } if path == "sensors[0].name"),
    );
    check(&|s| s.sensors[0] = SensorInfo::Joint { name: "x".repeat(33), joint: "drum_axle".into() }, &|e| {
        matches!(e, SceneError::ActuatorName { .. })
    });
    check(
        &|s| s.sensors[0] = SensorInfo::Joint { name: "j".into(), joint: "nope".into() },
        &|e| matches!(e, SceneError::UnknownJoint { path, name } if path == "sensors[0].joint" && name == "nope"),
    );
    check(
        &|s| s.joints[0].frame = None,
        &|e| matches!(e, SceneError::NoJointFrame { path, name } if path == "sensors[0].joint" && name == "drum_axle"),
    );
    check(&|s| s.sensors[0] = SensorInfo::Cylinder { name: "c".into(), joint: "drum_axle".into() }, &|e| {
        matches!(e, SceneError::SensorJointKind { sensor: "cylinder", joint: "hinge", .. })
    });
    check(
        &|s| s.sensors[0] = SensorInfo::Cable { name: "c".into(), joints: vec![] },
        &|e| matches!(e, SceneError::TooFew { path, count: 0, min: 1 } if path == "sensors[0].joints"),
    );
    check(
        &|s| {
            s.sensors[0] =
                SensorInfo::Cable { name: "c".into(), joints: vec!["drum_axle".into(), "x".into()] }
        },
        &|e| matches!(e, SceneError::UnknownJoint { path, .. } if path == "sensors[0].joints[1]"),
    );
    check(
        &|s| s.sensors[1] = SensorInfo::ContactSum { name: "base".into(), bodies: vec![1, 5], with: None },
        &|e| matches!(e, SceneError::UnknownBody { path, id: 5 } if path == "sensors[1].bodies[1]"),
    );
    check(
        &|s| {
            s.sensors[1] =
                SensorInfo::ContactSum { name: "base".into(), bodies: vec![1], with: Some(vec![0, 0]) }
        },
        &|e| matches!(e, SceneError::RepeatedBody { path, id: 0 } if path == "sensors[1].with[1]"),
    );
    check(
        &|s| s.sensors[1] = SensorInfo::Contacts { name: "base".into(), bodies: vec![] },
        &|e| matches!(e, SceneError::TooFew { path, .. } if path == "sensors[1].bodies"),
    );
    check(
        &|s| s.sensors[2] = SensorInfo::Tipping { name: "lmi".into(), bodies: vec![1], touch: -0.1 },
        &|e| matches!(e, SceneError::Negative { path, .. } if path == "sensors[2].touch"),
    );
    check(
        &|s| s.sensors[2] = SensorInfo::Tipping { name: "lmi".into(), bodies: vec![1], touch: f64::INFINITY },
        &|e| matches!(e, SceneError::NonFinite { path } if path == "sensors[2].touch"),
    );
    check(
        &|s| {
            s.sensors = (0..=MAX_SCENE_SENSORS)
                .map(|i| SensorInfo::Tension { name: format!("t{i}"), joint: "drum_axle".into() })
                .collect()
        },
        &|e| matches!(e, SceneError::TooMany { path, max: MAX_SCENE_SENSORS, .. } if path == "sensors"),
    );
}

#[test]
fn scene_sensor_schema_errors() {
    let bad = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut j = serde_json::to_value(sample_scene()).unwrap();
        edit(&mut j);
        let b = json_frame(Kind::SceneDescription, &j.to_string());
        let r = SceneDescription::decode(&b);
        assert!(matches!(r, Err(DecodeError::Frame(FrameError::Json { .. }))), "{j}: {r:?}");
    };
    bad(&|j| j["sensors"][0]["kind"] = "thermometer".into());
    bad(&|j| j["sensors"][0]["bodies"] = serde_json::json!([1])); // not a field of a drum sensor
    bad(&|j| {
        j["sensors"][0].as_object_mut().unwrap().remove("joint");
    });
    bad(&|j| j["joints"][0]["frame"]["axis"] = serde_json::json!([1.0, 0.0, 0.0]));
    bad(&|j| {
        j["joints"][0]["frame"].as_object_mut().unwrap().remove("orientation");
    });
}

#[test]
fn scene_json_schema_errors() {
    let mut j = serde_json::to_value(sample_scene()).unwrap();
    j["bodies"][0]["colliders"][0]["shape"]["type"] = "torus".into();
    let b = json_frame(Kind::SceneDescription, &j.to_string());
    assert!(matches!(SceneDescription::decode(&b), Err(DecodeError::Frame(FrameError::Json { .. }))));
    let mut j = serde_json::to_value(sample_scene()).unwrap();
    j["colour"] = "red".into();
    let b = json_frame(Kind::SceneDescription, &j.to_string());
    assert!(matches!(SceneDescription::decode(&b), Err(DecodeError::Frame(FrameError::Json { .. }))));
}

#[test]
fn inputs_against_the_scene() {
    let s = sample_scene();
    let winch = |n: &str| {
        InputCommand::Winch(WinchCommand { sequence: 1, source_id: 0, actuator: name(n), drum_speed: 0.0 })
    };
    assert_eq!(s.check_input(&winch("winch")), Ok(()));
    let e = s.check_input(&winch("hoist")).unwrap_err();
    assert_eq!(e, InputError::UnknownActuator { name: "hoist".into() });
    assert_eq!(e.reject_reason(), RejectReason::UnknownActuator);
    assert_eq!(
        s.check_input(&winch("slew")),
        Err(InputError::WrongActuatorKind { name: "slew".into(), expected: "winch" })
    );
    let boom = InputCommand::Boom(BoomCommand {
        sequence: 1,
        source_id: 0,
        targets: vec![
            BoomTarget { actuator: name("slew"), value: 0.1 },
            BoomTarget { actuator: name("stick"), value: 0.0 },
        ],
    });
    assert_eq!(s.check_input(&boom), Err(InputError::UnknownActuator { name: "stick".into() }));
}

#[test]
fn signals_and_events_content_errors() {
    let frames = sample_frames();
    let b = &frames.iter().find(|(k, _)| *k == Kind::Signals).unwrap().1;
    let inv = |c: &[u8]| SignalsFrame::decode(c).unwrap_err();
    let ch0 = HEADER_LEN + SIGNALS_FIXED_LEN;
    let ct0 = ch0 + 2 * CHANNEL_RECORD_LEN;
    let cases: Vec<(usize, f64, SignalsError)> = vec![
        (HEADER_LEN + 8, f64::NAN, SignalsError::NonFinite { record: None, field: "sim_time" }),
        (HEADER_LEN + 8, -0.5, SignalsError::Negative { record: None, field: "sim_time", value: -0.5 }),
        (ch0 + 40, f64::INFINITY, SignalsError::NonFinite { record: Some(0), field: "value" }),
        (ch0 + CHANNEL_RECORD_LEN + 40, 2.0, SignalsError::DropoutValue { record: 1, value: 2.0 }),
        (ct0 + 16, f64::NAN, SignalsError::NonFinite { record: Some(0), field: "point" }),
        (ct0 + 40, -1.0, SignalsError::Negative { record: Some(0), field: "normal_force", value: -1.0 }),
        (ct0 + 48, f64::NAN, SignalsError::NonFinite { record: Some(0), field: "friction_force" }),
        (ct0 + 64, f64::INFINITY, SignalsError::NonFinite { record: Some(0), field: "normal" }),
        (ct0 + 88, f64::NAN, SignalsError::NonFinite { record: Some(0), field: "friction" }),
    ];
    for (off, v, want) in cases {
        let mut c = b.clone();
        set_f64(&mut c, off, v);
        assert_eq!(inv(&c), DecodeError::Invalid(want), "offset {off}");
    }
    let mut c = b.clone();
    set_u32(&mut c, ch0 + 32, 4);
    assert_eq!(inv(&c), DecodeError::Invalid(SignalsError::ChannelFlags { record: 0, flags: 4 }));
    let mut c = b.clone();
    c[ch0 + 36] = 1;
    assert_eq!(inv(&c), DecodeError::Frame(FrameError::ReservedNonZero { offset: ch0 + 36 }));
    let mut c = b.clone();
    c[ch0 + 20] = b'x'; // after the name's NUL
    assert!(matches!(inv(&c), DecodeError::Invalid(SignalsError::Name { record: 0, .. })));
    let mut c = b.clone();
    c[ct0 + 8] = 3;
    assert!(matches!(inv(&c), DecodeError::Invalid(SignalsError::UnknownCode { what: "contact state", .. })));
    let mut c = b.clone();
    set_u32(&mut c, HEADER_LEN + 16, MAX_CHANNELS as u32 + 1);
    assert!(matches!(inv(&c), DecodeError::Invalid(SignalsError::TooMany { what: "channels", .. })));
    let mut c = b.clone();
    set_u32(&mut c, HEADER_LEN + 20, 2);
    assert!(matches!(inv(&c), DecodeError::Frame(FrameError::PayloadLength { .. })));

    let e = &frames.iter().find(|(k, _)| *k == Kind::Events).unwrap().1;
    let inv = |c: &[u8]| EventsFrame::decode(c).unwrap_err();
    let r0 = HEADER_LEN + EVENTS_FIXED_LEN;
    let mut c = e.clone();
    set_f64(&mut c, r0 + 40, -1.0);
    assert_eq!(
        inv(&c),
        DecodeError::Invalid(SignalsError::Negative { record: Some(0), field: "time", value: -1.0 })
    );
    let mut c = e.clone();
    set_f64(&mut c, r0 + 56, f64::NAN);
    assert_eq!(inv(&c), DecodeError::Invalid(SignalsError::NonFinite { record: Some(0), field: "level" }));
    let mut c = e.clone();
    c[r0 + 32] = 9;
    assert!(matches!(
        inv(&c),
        DecodeError::Invalid(SignalsError::UnknownCode { what: "event kind", code: 9, .. })
    ));
    let mut c = e.clone();
    c[r0 + 39] = 1;
    assert_eq!(inv(&c), DecodeError::Frame(FrameError::ReservedNonZero { offset: r0 + 39 }));
    let mut c = e.clone();
    set_u32(&mut c, HEADER_LEN + 16, MAX_EVENTS as u32 + 1);
    assert!(matches!(inv(&c), DecodeError::Invalid(SignalsError::TooMany { what: "events", .. })));
    assert!(matches!(SignalsFrame::decode(e), Err(DecodeError::Frame(FrameError::WrongKind { .. }))));
}

#[test]
fn fault_request_errors() {
    let req = |json: &str| ControlRequest::decode(&json_frame(Kind::ControlRequest, json));
    let ok = req(r#"{"id":1,"command":{"op":"fault","fault":"break","target":"rope/end","tension":2000.0}}"#);
    assert!(matches!(
        ok,
        Ok(ControlRequest { command: ControlCommand::Fault { fault: FaultKind::Break, .. }, .. })
    ));
    let ok = req(r#"{"id":1,"command":{"op":"fault","fault":"dropout","target":"lmi"}}"#).unwrap();
    assert!(matches!(ok.command, ControlCommand::Fault { tension: None, to: None, ramp: None, .. }));
    let bad = |json: &str| req(json).unwrap_err();
    assert!(matches!(
        bad(r#"{"id":1,"command":{"op":"fault","fault":"explode","target":"x"}}"#),
        DecodeError::Invalid(ControlError::UnknownFault { .. })
    ));
    assert!(matches!(
        bad(r#"{"id":1,"command":{"op":"fault","fault":"break","target":""}}"#),
        DecodeError::Invalid(ControlError::FaultTarget { len: 0 })
    ));
    assert!(matches!(
        bad(r#"{"id":1,"command":{"op":"fault","fault":"break","target":"a","tension":-1.0}}"#),
        DecodeError::Invalid(ControlError::FaultValue { field: "tension", .. })
    ));
    assert!(matches!(
        bad(r#"{"id":1,"command":{"op":"fault","fault":"brake_fade","target":"a","to":1.5}}"#),
        DecodeError::Invalid(ControlError::FaultValue { field: "to", .. })
    ));
    assert!(matches!(
        bad(r#"{"id":1,"command":{"op":"fault","fault":"break","target":"a","oops":1}}"#),
        DecodeError::Frame(FrameError::Json { .. })
    ));
    let nan = ControlRequest {
        id: 1,
        command: ControlCommand::Fault {
            fault: FaultKind::BrakeFade,
            target: "brake".into(),
            tension: None,
            to: None,
            ramp: Some(f64::NAN),
        },
    };
    let mut buf = Vec::new();
    assert!(nan.encode(&mut buf).is_err() && buf.is_empty());
}
