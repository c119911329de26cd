//! The conversions against hand-computed messages.

use super::*;

fn joy(axes: Vec<f32>, buttons: Vec<i32>) -> Joy {
    Joy { header: Header::default(), axes, buttons }
}

#[test]
fn joy_becomes_a_joystick_frame_with_fresh_sequences() {
    let mut t = JoyTranslator::new(77);
    let mut buf = Vec::new();
    t.translate(&joy(vec![0.5, -1.0], vec![0, 1, 1]), &mut buf).unwrap();
    let msgs::InputCommand::Joystick(j) = msgs::InputCommand::decode(&buf).unwrap() else { panic!() };
    assert_eq!(
        (j.sequence, j.source_id, j.axes(), j.buttons, j.button_count),
        (1, 77, &[0.5, -1.0][..], 0b110, 3)
    );
    t.translate(&joy(vec![], vec![]), &mut buf).unwrap();
    assert_eq!(msgs::InputCommand::decode(&buf).unwrap().sequence(), 2);
    assert_eq!(t.counters.forwarded, 2);
}

#[test]
fn malformed_joy_is_rejected_and_counted_by_reason() {
    let mut t = JoyTranslator::new(1);
    let mut buf = Vec::new();
    let r = msgs::RejectReason::Oversize;
    assert_eq!(t.translate(&joy(vec![0.0; 33], vec![]), &mut buf), Err(r));
    assert!(buf.is_empty());
    assert_eq!(t.translate(&joy(vec![], vec![0; 65]), &mut buf), Err(r));
    assert_eq!(t.translate(&joy(vec![0.0, f32::NAN], vec![]), &mut buf), Err(msgs::RejectReason::NonFinite));
    assert_eq!(t.translate(&joy(vec![f32::INFINITY], vec![]), &mut buf), Err(msgs::RejectReason::NonFinite));
    assert_eq!(t.translate(&joy(vec![1.5], vec![]), &mut buf), Err(msgs::RejectReason::OutOfRange));
    assert_eq!(t.translate(&joy(vec![], vec![2]), &mut buf), Err(msgs::RejectReason::OutOfRange));
    assert_eq!(t.counters.rejected_for(r), 2);
    assert_eq!(t.counters.rejected_for(msgs::RejectReason::NonFinite), 2);
    assert_eq!(t.counters.rejected_total(), 6);
    assert_eq!((t.counters.received, t.counters.forwarded), (6, 0));
    // 32 axes is the most a frame carries: accepted, sequence 1.
    t.translate(&joy(vec![0.25; 32], vec![1; 64]), &mut buf).unwrap();
    assert_eq!(msgs::InputCommand::decode(&buf).unwrap().sequence(), 1);
}

#[test]
fn hull_of_a_tetrahedron_has_four_outward_faces() {
    let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let t = hull_triangles(&v);
    assert_eq!(t.len(), 4);
    let c = [0.25, 0.25, 0.25];
    for [a, b, d] in t {
        let (e1, e2) = (sub(v[b], v[a]), sub(v[d], v[a]));
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        assert!(dot(n, sub(v[a], c)) > 0.0, "outward");
    }
}

#[test]
fn rotate_turns_z_onto_minus_y_about_x() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let r = rotate([h, 0.0, 0.0, h], [0.0, 0.0, 1.0]);
    assert!((r[0]).abs() < 1e-12 && (r[1] + 1.0).abs() < 1e-12 && r[2].abs() < 1e-12, "{r:?}");
}

#[test]
fn markers_cover_every_shape_in_the_body_frame() {
    let q = [0.0, 0.0, 0.0, 1.0];
    let col = |shape| msgs::Collider { shape, position: [0.0, 0.0, 0.5], orientation: q };
    let body = msgs::BodyInfo {
        id: 3,
        name: "hook".into(),
        kind: msgs::BodyKind::Dynamic,
        mass: 1.0,
        visuals: Vec::new(),
        colliders: vec![
            col(msgs::Shape::Box { half_extents: [1.0, 2.0, 3.0] }),
            col(msgs::Shape::Capsule { radius: 0.1, half_height: 0.2 }),
            col(msgs::Shape::Heightfield {
                rows: 2,
                cols: 3,
                extent: [2.0, 1.0],
                heights: msgs::HeightData::Inline(vec![0.0; 6]),
            }),
            col(msgs::Shape::Trimesh { mesh: msgs::MeshData::Reference("file:///m.stl".into()) }),
        ],
    };
    let mut m = Vec::new();
    body_markers(&body, &mut m);
    let kinds: Vec<_> = m.iter().map(|m| (m.id, m.type_)).collect();
    assert_eq!(
        kinds,
        [
            (0, Marker::CUBE),
            (4, Marker::CYLINDER),
            (5, Marker::SPHERE),
            (6, Marker::SPHERE),
            (8, Marker::TRIANGLE_LIST),
            (12, Marker::MESH_RESOURCE)
        ]
    );
    assert_eq!(m[0].scale, Vector3 { x: 2.0, y: 4.0, z: 6.0 });
    assert!(m.iter().all(|m| m.header.frame_id == "hook" && m.ns == "hook" && m.frame_locked));
    assert!((m[2].pose.position.z - 0.7).abs() < 1e-12 && (m[3].pose.position.z - 0.3).abs() < 1e-12);
    assert_eq!(m[4].points.len(), 2 * 2 * 3);
    assert_eq!(m[5].mesh_resource, "file:///m.stl");
}

fn channel(name: &str, value: f64) -> msgs::SignalChannel {
    msgs::SignalChannel { name: msgs::ActuatorName::new(name).unwrap(), dropout: false, value }
}

/// A joint sensor `hoist.rope`, a contact sum `support`, a scalar tension and a cylinder
/// force, with one stick, one slip and one open contact.
fn signals_frame() -> msgs::SignalsFrame {
    let mut channels = Vec::new();
    for (c, v) in [("fx", 1.0), ("fy", -2.0), ("fz", 49.05), ("tx", 0.5), ("ty", 0.25), ("tz", -0.125)] {
        channels.push(channel(&format!("hoist.rope/{c}"), v));
    }
    for (c, v) in
        [("fx", 3.0), ("fy", 0.0), ("fz", 98.1), ("normal", 98.1), ("friction", 3.0), ("points", 4.0)]
    {
        channels.push(channel(&format!("support/{c}"), v));
    }
    channels.push(channel("rope/tension", 49.1));
    channels.push(channel("lift/force", 1200.0));
    let contact = |state, point: [f64; 3], normal_force, friction: [f64; 3]| msgs::ContactRecord {
        body_a: 1,
        body_b: 2,
        state,
        point,
        normal_force,
        friction_force: friction.iter().map(|x| x * x).sum::<f64>().sqrt(),
        normal: [0.0, 0.0, 1.0],
        friction,
    };
    msgs::SignalsFrame {
        sequence: 9,
        sim_time: 1.5,
        channels,
        contacts: vec![
            contact(msgs::ContactCode::Stick, [1.0, 2.0, 0.5], 100.0, [0.0, 0.0, 0.0]),
            contact(msgs::ContactCode::Slip, [-1.0, 0.0, 0.0], 50.0, [20.0, -10.0, 0.0]),
            contact(msgs::ContactCode::Open, [0.0, 0.0, 0.0], 0.0, [0.0, 0.0, 0.0]),
        ],
        ..Default::default()
    }
}

#[test]
fn sensor_names_become_valid_topic_tokens() {
    assert_eq!(topic_token("hoist.rope-1"), "hoist_rope_1");
    assert_eq!(topic_token("forks_load"), "forks_load");
    assert_eq!(topic_token("2nd"), "s2nd");
    assert_eq!(topic_token("a//b"), "a_b");
    assert_eq!(topic_token("_x__y_"), "x_y");
    assert_eq!(topic_token("-./"), "sensor");
    assert_eq!(crate::topics::wrench("boom/left"), "/pivotsim/signals/boom_left");
    for name in ["hoist.rope-1", "2nd", "a//b", "-./", "x"] {
        let t = crate::topics::wrench(name);
        assert!(ros2_name_ok(&t), "{t}");
    }
}

/// The ROS 2 topic name rules the tokens must meet.
fn ros2_name_ok(t: &str) -> bool {
    t.starts_with('/')
        && !t.ends_with('/')
        && !t.contains("//")
        && !t.contains("__")
        && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/')
        && t[1..].split('/').all(|tok| !tok.is_empty() && !tok.starts_with(|c: char| c.is_ascii_digit()))
}

/// The channel indices of a wrench of force channels `f` and torque channels `t`.
fn ch(f: Option<[usize; 3]>, t: Option<[usize; 3]>) -> [Option<usize>; 6] {
    let mut c = [None; 6];
    for (k, i) in f.into_iter().flatten().chain(t.into_iter().flatten()).enumerate() {
        c[if f.is_some() { k } else { k + 3 }] = Some(i);
    }
    c
}

#[test]
fn without_a_description_force_sensors_are_found_by_their_channels() {
    let f = signals_frame();
    let l = SignalLayout::new(&f, None);
    assert!(l.matches(&f));
    assert_eq!(l.wrenches_refused, 0);
    assert_eq!(
        l.wrenches,
        [
            WrenchSensor {
                sensor: "hoist.rope".into(),
                topic: "/pivotsim/signals/hoist_rope".into(),
                kind: WrenchKind::Joint,
                joint: None,
                channels: ch(Some([0, 1, 2]), Some([3, 4, 5])),
            },
            WrenchSensor {
                sensor: "support".into(),
                topic: "/pivotsim/signals/support".into(),
                kind: WrenchKind::ContactSum,
                joint: None,
                channels: ch(Some([6, 7, 8]), None),
            },
        ]
    );
    assert_eq!(l.wrenches[0].frame_id("world"), "joint_frame/hoist_rope");
    assert_eq!(l.wrenches[1].frame_id("map"), "map");
    let names = l.names_text();
    assert_eq!(names.split('\n').count(), 14, "one line per channel, no trailing newline");
    assert_eq!(names.lines().nth(12), Some("rope/tension"));
    // Another order of the same names is another layout.
    let mut g = f.clone();
    g.channels.swap(12, 13);
    assert!(!l.matches(&g));
    g.channels.pop();
    assert!(!l.matches(&g));
    // A description without sensors (an older server): the same.
    let d = description();
    let old = msgs::SceneDescription { sensors: vec![], ..d };
    assert_eq!(SignalLayout::new(&f, Some(&old)), l);
}

/// The scene of [`signals_frame`]: a static `beam`, a `hook` hanging from it on the ball joint
/// `rope` (frame on the hook, rotated), a `crate`, a `cylinder` body on the prismatic `lift`
/// to the world (frame on the world), a `drum` on the hinge `reel`, and sensors of several
/// kinds (two joint sensors on `rope`).
fn description() -> msgs::SceneDescription {
    let body = |id, name: &str, kind| msgs::BodyInfo {
        id,
        name: name.into(),
        kind,
        mass: if kind == msgs::BodyKind::Dynamic { 1.0 } else { 0.0 },
        visuals: Vec::new(),
        colliders: vec![],
    };
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let d = msgs::SceneDescription {
        world: "w".into(),
        scene: "s".into(),
        timestep: 0.01,
        gravity: [0.0, 0.0, -9.81],
        bodies: vec![
            body(4, "beam", msgs::BodyKind::Static),
            body(5, "hook", msgs::BodyKind::Dynamic),
            body(6, "crate", msgs::BodyKind::Dynamic),
            body(7, "cylinder", msgs::BodyKind::Dynamic),
            body(8, "drum", msgs::BodyKind::Dynamic),
        ],
        joints: vec![
            msgs::JointInfo {
                name: "rope".into(),
                kind: msgs::JointKind::Ball,
                parent: Some(4),
                child: 5,
                frame: Some(msgs::JointFrame {
                    body: Some(5),
                    position: [0.0, 0.0, 1.0],
                    orientation: [0.0, h, 0.0, h],
                }),
            },
            msgs::JointInfo {
                name: "lift".into(),
                kind: msgs::JointKind::Prismatic,
                parent: None,
                child: 7,
                frame: Some(msgs::JointFrame {
                    body: None,
                    position: [3.0, 0.0, 0.5],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                }),
            },
            msgs::JointInfo {
                name: "reel".into(),
                kind: msgs::JointKind::Hinge,
                parent: None,
                child: 8,
                frame: Some(msgs::JointFrame {
                    body: Some(8),
                    position: [0.0; 3],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                }),
            },
        ],
        sensors: vec![
            msgs::SensorInfo::Joint { name: "hoist.rope".into(), joint: "rope".into() },
            msgs::SensorInfo::ContactSum { name: "support".into(), bodies: vec![6], with: None },
            msgs::SensorInfo::Tension { name: "rope".into(), joint: "rope".into() },
            msgs::SensorInfo::Cylinder { name: "lift".into(), joint: "lift".into() },
            msgs::SensorInfo::Drum { name: "spool".into(), joint: "reel".into() },
            msgs::SensorInfo::Joint { name: "rope.again".into(), joint: "rope".into() },
        ],
        ..Default::default()
    };
    d.validate().unwrap_or_else(|e| panic!("{e}"));
    d
}

#[test]
fn with_a_description_force_sensors_are_classified_by_their_kind() {
    let f = signals_frame();
    let d = description();
    let l = SignalLayout::new(&f, Some(&d));
    let got: Vec<_> = l.wrenches.iter().map(|w| (w.sensor.as_str(), w.kind, w.joint.as_deref())).collect();
    assert_eq!(
        got,
        [
            ("hoist.rope", WrenchKind::Joint, Some("rope")),
            ("support", WrenchKind::ContactSum, None),
            ("lift", WrenchKind::Cylinder, Some("lift")),
        ]
    );
    assert_eq!(l.wrenches[0].channels, ch(Some([0, 1, 2]), Some([3, 4, 5])));
    assert_eq!(l.wrenches[2].channels, [Some(13), None, None, None, None, None]);
    let frames: Vec<String> = l.wrenches.iter().map(|w| w.frame_id("world")).collect();
    assert_eq!(frames, ["joint/rope", "world", "joint/lift"]);
    // The tension is no wrench though it has a joint; the drum `spool` has no channel here.
    // A listed sensor whose channels are not those of its kind is no force sensor; one the
    // description does not list falls back to the channel names.
    let mut d2 = d.clone();
    d2.sensors[0] = msgs::SensorInfo::ContactSum { name: "hoist.rope".into(), bodies: vec![6], with: None };
    d2.sensors[1] = msgs::SensorInfo::Joint { name: "other".into(), joint: "rope".into() };
    let l2 = SignalLayout::new(&f, Some(&d2));
    let got: Vec<_> = l2.wrenches.iter().map(|w| (w.sensor.as_str(), w.kind, w.joint.as_deref())).collect();
    assert_eq!(
        got,
        [
            ("hoist.rope", WrenchKind::ContactSum, None),
            ("support", WrenchKind::ContactSum, None),
            ("lift", WrenchKind::Cylinder, Some("lift")),
        ]
    );
    let mut d3 = d.clone();
    d3.sensors[0] = msgs::SensorInfo::Tipping { name: "hoist.rope".into(), bodies: vec![5], touch: 0.0 };
    assert!(SignalLayout::new(&f, Some(&d3)).wrenches.iter().all(|w| w.sensor != "hoist.rope"));
}

#[test]
fn joint_frames_go_on_tf_static_under_their_body_once_each() {
    let d = description();
    let scene = SceneInfo::new(d);
    let stamp = Time { sec: 2, nanosec: 0 };
    let t = joint_frame_transforms(&scene, stamp, "map");
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // `rope` once (two joint sensors read it), `lift` under the world frame, `reel` for the drum.
    assert_eq!(
        t,
        [
            TransformStamped {
                header: Header { stamp, frame_id: "hook".into() },
                child_frame_id: "joint/rope".into(),
                transform: Transform {
                    translation: Vector3 { x: 0.0, y: 0.0, z: 1.0 },
                    rotation: Quaternion::from_array([0.0, h, 0.0, h]),
                },
            },
            TransformStamped {
                header: Header { stamp, frame_id: "map".into() },
                child_frame_id: "joint/lift".into(),
                transform: Transform {
                    translation: Vector3 { x: 3.0, y: 0.0, z: 0.5 },
                    rotation: Quaternion::from_array([0.0, 0.0, 0.0, 1.0]),
                },
            },
            TransformStamped {
                header: Header { stamp, frame_id: "drum".into() },
                child_frame_id: "joint/reel".into(),
                transform: Transform {
                    translation: Vector3::default(),
                    rotation: Quaternion::from_array([0.0, 0.0, 0.0, 1.0]),
                },
            },
        ]
    );
    // Without sensors, or without frames, no joint frames.
    let mut d = scene.description.clone();
    d.joints.iter_mut().for_each(|j| j.frame = None);
    d.sensors.retain(|s| matches!(s, msgs::SensorInfo::ContactSum { .. }));
    assert!(joint_frame_transforms(&SceneInfo::new(d), stamp, "map").is_empty());
}

#[test]
fn alike_names_get_distinct_topics_and_the_count_is_bounded() {
    let mut f = msgs::SignalsFrame::default();
    for s in ["a-b", "a.b"] {
        for c in ["fx", "fy", "fz"] {
            f.channels.push(channel(&format!("{s}/{c}"), 0.0));
        }
    }
    let l = SignalLayout::new(&f, None);
    let topics: Vec<&str> = l.wrenches.iter().map(|w| w.topic.as_str()).collect();
    assert_eq!(topics, ["/pivotsim/signals/a_b", "/pivotsim/signals/a_b_2"]);
    let mut f = msgs::SignalsFrame::default();
    for i in 0..MAX_WRENCH_TOPICS + 6 {
        for c in ["fx", "fy", "fz"] {
            f.channels.push(channel(&format!("s{i}/{c}"), 0.0));
        }
    }
    let l = SignalLayout::new(&f, None);
    assert_eq!((l.wrenches.len(), l.wrenches_refused), (MAX_WRENCH_TOPICS, 6));
}

#[test]
fn wrench_carries_the_channels_in_their_frame() {
    let f = signals_frame();
    let l = SignalLayout::new(&f, None);
    let stamp = Time { sec: 1, nanosec: 500_000_000 };
    let w = wrench(&l.wrenches[0], &f, stamp, "world").unwrap();
    assert_eq!(
        w,
        WrenchStamped {
            header: Header { stamp, frame_id: "joint_frame/hoist_rope".into() },
            wrench: Wrench {
                force: Vector3 { x: 1.0, y: -2.0, z: 49.05 },
                torque: Vector3 { x: 0.5, y: 0.25, z: -0.125 },
            },
        }
    );
    let w = wrench(&l.wrenches[1], &f, stamp, "world").unwrap();
    assert_eq!(w.header.frame_id, "world");
    assert_eq!(w.wrench, Wrench { force: Vector3 { x: 3.0, y: 0.0, z: 98.1 }, torque: Vector3::default() });
    // A dropped-out channel: no wrench.
    let mut g = f.clone();
    g.channels[4] = msgs::SignalChannel { dropout: true, value: 0.0, ..g.channels[4] };
    assert!(wrench(&l.wrenches[0], &g, stamp, "world").is_none());
    assert!(wrench(&l.wrenches[1], &g, stamp, "world").is_some());
    // A frame of fewer channels than the layout: no wrench, no panic.
    g.channels.truncate(7);
    assert!(wrench(&l.wrenches[1], &g, stamp, "world").is_none());
}

#[test]
fn described_wrenches_are_in_the_joint_frames_and_axial_ones_along_x() {
    let mut f = signals_frame();
    f.channels.push(channel("spool/torque", -250.0));
    let l = SignalLayout::new(&f, Some(&description()));
    let stamp = Time { sec: 1, nanosec: 0 };
    let by =
        |n: &str| wrench(l.wrenches.iter().find(|w| w.sensor == n).unwrap(), &f, stamp, "world").unwrap();
    let rope = by("hoist.rope");
    assert_eq!(rope.header.frame_id, "joint/rope");
    assert_eq!(rope.wrench.force, Vector3 { x: 1.0, y: -2.0, z: 49.05 });
    let lift = by("lift");
    assert_eq!(lift.header.frame_id, "joint/lift");
    assert_eq!(
        lift.wrench,
        Wrench { force: Vector3 { x: 1200.0, y: 0.0, z: 0.0 }, torque: Vector3::default() }
    );
    let spool = by("spool");
    assert_eq!(spool.header.frame_id, "joint/reel");
    assert_eq!(
        spool.wrench,
        Wrench { force: Vector3::default(), torque: Vector3 { x: -250.0, y: 0.0, z: 0.0 } }
    );
    // A drum that drops out: none.
    let last = f.channels.len() - 1;
    f.channels[last].dropout = true;
    f.channels[last].value = 0.0;
    let w = l.wrenches.iter().find(|w| w.sensor == "spool").unwrap();
    assert!(wrench(w, &f, stamp, "world").is_none());
}

#[test]
fn signals_array_is_the_channels_in_order_with_nan_on_dropout() {
    let mut f = signals_frame();
    f.channels[13] = msgs::SignalChannel { dropout: true, value: 0.0, ..f.channels[13] };
    let mut a = Float64MultiArray::default();
    signals_array(&f, &mut a);
    assert_eq!(
        a.layout,
        MultiArrayLayout {
            dim: vec![MultiArrayDimension { label: "channels".into(), size: 14, stride: 14 }],
            data_offset: 0
        }
    );
    assert_eq!(a.data.len(), 14);
    assert_eq!(&a.data[..3], &[1.0, -2.0, 49.05]);
    assert_eq!(a.data[12], 49.1);
    assert!(a.data[13].is_nan());
    // Reused for a smaller frame.
    f.channels.truncate(2);
    signals_array(&f, &mut a);
    assert_eq!((a.data.as_slice(), a.layout.dim.len(), a.layout.dim[0].size), (&[1.0, -2.0][..], 1, 2));
}

#[test]
fn contact_arrows_run_from_the_point_along_the_force_coloured_by_state() {
    let f = signals_frame();
    let stamp = Time { sec: 1, nanosec: 500_000_000 };
    let m = contact_markers(&f, 0.01, stamp, "world");
    assert_eq!(m.markers.len(), 3, "DELETEALL, stick, slip; the open contact is not drawn");
    let clear = &m.markers[0];
    assert_eq!(
        (clear.action, clear.ns.as_str(), clear.header.frame_id.as_str()),
        (Marker::DELETEALL, CONTACTS_NS, "world")
    );
    let (stick, slip) = (&m.markers[1], &m.markers[2]);
    for (a, id) in [(stick, 0), (slip, 1)] {
        assert_eq!((a.type_, a.action, a.id, a.ns.as_str()), (Marker::ARROW, Marker::ADD, id, CONTACTS_NS));
        assert_eq!(a.header, Header { stamp, frame_id: "world".into() });
        assert_eq!(a.scale, Vector3 { x: 0.01, y: 0.02, z: 0.0 });
    }
    // 100 N up at (1, 2, 0.5), 0.01 m/N: 1 m long.
    assert_eq!(stick.points, [Point { x: 1.0, y: 2.0, z: 0.5 }, Point { x: 1.0, y: 2.0, z: 1.5 }]);
    // 50 N up + (20, −10, 0) N friction at (−1, 0, 0).
    assert_eq!(slip.points, [Point { x: -1.0, y: 0.0, z: 0.0 }, Point { x: -0.8, y: -0.1, z: 0.5 }]);
    assert_eq!(stick.color, ColorRGBA { r: 0.1, g: 0.8, b: 0.1, a: 1.0 });
    assert_eq!(slip.color, ColorRGBA { r: 1.0, g: 0.45, b: 0.0, a: 1.0 });
    assert_eq!(contact_color(msgs::ContactCode::Open), ColorRGBA { r: 0.5, g: 0.5, b: 0.5, a: 1.0 });
    // No contacts: only the DELETEALL, so the previous arrows vanish.
    let empty = contact_markers(&msgs::SignalsFrame::default(), 0.01, stamp, "world");
    assert_eq!(empty.markers.len(), 1);
}

#[test]
fn events_are_log_lines_warn_for_raised_and_faults() {
    let e = msgs::EventRecord {
        name: msgs::ActuatorName::new("hoist-overload").unwrap(),
        kind: msgs::EventCode::Raised,
        time: 2.5,
        value: 31000.0,
        level: 30000.0,
    };
    let stamp = Time { sec: 2, nanosec: 500_000_000 };
    let l = event_log(&e, stamp, "pivotsim_bridge");
    assert_eq!(
        l,
        Log {
            stamp,
            level: Log::WARN,
            name: "pivotsim_bridge".into(),
            msg: "pivotsim event hoist-overload raised at t = 2.500 s: value 31000, level 30000".into(),
            ..Log::default()
        }
    );
    assert_eq!(event_level(msgs::EventCode::Cleared), Log::INFO);
    assert_eq!(event_level(msgs::EventCode::Fault), Log::WARN);
    assert_eq!(event_level(msgs::EventCode::FaultRejected), Log::WARN);
}

#[test]
fn diagnostics_list_every_channel_and_the_signal_counters() {
    let mut f = signals_frame();
    let h = BridgeHealth {
        signals: SignalCounters { signals_decode_failed: 3, wrench_topics: 2, ..Default::default() },
        ..Default::default()
    };
    let a = diagnostics(None, Some(&f), &h, Time::default());
    let s = a.get(DIAG_SIGNALS).unwrap();
    assert_eq!(s.level, DiagnosticStatus::OK);
    assert_eq!(s.value("support/fz"), Some("98.1"));
    assert_eq!(s.value("contacts"), Some("3"));
    assert_eq!((s.value("contacts_stick"), s.value("contacts_slip")), (Some("1"), Some("1")));
    assert_eq!(s.value("dropout_count"), Some("0"));
    let b = a.get(DIAG_BRIDGE).unwrap();
    assert_eq!((b.value("signals_decode_failed"), b.value("wrench_topics")), (Some("3"), Some("2")));
    f.channels[12] = msgs::SignalChannel { dropout: true, value: 0.0, ..f.channels[12] };
    let a = diagnostics(None, Some(&f), &h, Time::default());
    let s = a.get(DIAG_SIGNALS).unwrap();
    assert_eq!((s.level, s.value("rope/tension")), (DiagnosticStatus::WARN, Some("dropout")));
    assert_eq!(s.value("dropout_count"), Some("1"));
    assert!(diagnostics(None, None, &h, Time::default()).get(DIAG_SIGNALS).is_none());
}
