//! The force sensors the bridge finds in the shipped scenes' signals frames, as the server's
//! engine produces them with its scene description (no Zenoh, no DDS): with the description the
//! contact sums get a world-frame wrench each, the cylinders and drums a wrench along or about
//! their joint's axis in the joint's frame (on `/tf_static` under the joint's child), and the
//! scalar sensors (cable, tipping, tension) none; without it (an older server) only the contact
//! sums, found by their channel names. Every frame matches its own layout.

use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_ros2_bridge::convert::{SceneInfo, SignalLayout, WrenchKind, joint_frame_transforms};
use pivotsim_ros2_bridge::ros_msgs::Time;
use pivotsim_server::serve::Engine;

fn frames(scene: &str) -> (msgs::SceneDescription, msgs::SignalsFrame) {
    let world = msgs::WorldName::new(format!("bridge-{scene}")).unwrap();
    let mut e = Engine::new(scene, world, Duration::from_secs(60)).unwrap();
    assert!(e.tick(Instant::now()));
    let d = msgs::SceneDescription::decode(e.description()).unwrap();
    (d, msgs::SignalsFrame::decode(e.signals_frame()).unwrap())
}

#[test]
fn shipped_scenes_give_wrenches_by_sensor_kind_and_none_for_scalars() {
    use WrenchKind::{ContactSum, Cylinder, Drum};
    for (scene, want) in [
        (
            "crane",
            &[
                ("outriggers", ContactSum, "world"),
                ("luff", Cylinder, "joint/luff"),
                ("drum", Drum, "joint/hoist"),
            ][..],
        ),
        (
            "forklift",
            &[
                ("forks_load", ContactSum, "world"),
                ("lift_l", Cylinder, "joint/lift_l"),
                ("lift_r", Cylinder, "joint/lift_r"),
            ][..],
        ),
        ("winch", &[("drum", Drum, "joint/winch")][..]),
    ] {
        let (d, f) = frames(scene);
        let l = SignalLayout::new(&f, Some(&d));
        assert!(l.matches(&f), "{scene}");
        let got: Vec<(&str, WrenchKind, String)> =
            l.wrenches.iter().map(|w| (w.sensor.as_str(), w.kind, w.frame_id("world"))).collect();
        let want: Vec<(&str, WrenchKind, String)> =
            want.iter().map(|(s, k, f)| (*s, *k, f.to_string())).collect();
        assert_eq!(got, want, "{scene}: {:?}", l.names_text());
        assert_eq!(l.wrenches_refused, 0);
        assert_eq!(l.names_text().split('\n').count(), f.channels.len(), "{scene}: one line per channel");
        // Each joint frame a wrench is in goes on /tf_static under the joint's child.
        let tf = joint_frame_transforms(&SceneInfo::new(d.clone()), Time::default(), "world");
        for w in l.wrenches.iter().filter(|w| w.kind != ContactSum) {
            let joint = d.joint(w.joint.as_deref().unwrap()).unwrap();
            let child = &d.body(joint.child).unwrap().name;
            let t = tf.iter().find(|t| t.child_frame_id == w.frame_id("world")).expect("on /tf_static");
            assert_eq!(&t.header.frame_id, child, "{scene}: {}", w.sensor);
        }
        // Without the description: the contact sums alone, by their channel names.
        let l = SignalLayout::new(&f, None);
        assert!(l.wrenches.iter().all(|w| w.kind == ContactSum && w.frame_id("world") == "world"));
        assert_eq!(l.wrenches.len(), want.iter().filter(|w| w.1 == ContactSum).count(), "{scene}");
    }
}

/// Every message the bridge publishes for 2 s of a shipped scene, as JSON by topic: the last
/// pose frame's `/tf`, `/tf_static`, `/pivotsim/pose_array`, `/clock`; the description's markers;
/// the last signals frame's `/pivotsim/signal_values`, wrenches and contact arrows; the
/// diagnostics of the last stats and signals frames.
fn published(scene: &str) -> std::collections::HashMap<String, Vec<serde_json::Value>> {
    use pivotsim_ros2_bridge::convert;
    use pivotsim_ros2_bridge::ros_msgs::{Clock, Float64MultiArray};
    use pivotsim_ros2_bridge::topics;
    let world = msgs::WorldName::new(format!("layout-{scene}")).unwrap();
    let mut e = Engine::new(scene, world, Duration::from_secs(60)).unwrap();
    let t0 = Instant::now();
    for i in 0..120 {
        assert!(e.tick(t0 + Duration::from_secs_f64(i as f64 / 60.0)), "{scene}");
    }
    let d = msgs::SceneDescription::decode(e.description()).unwrap();
    let poses = msgs::PoseFrame::decode(e.pose_frame()).unwrap();
    let stats = msgs::SolverStats::decode(e.stats_frame()).unwrap();
    let signals = msgs::SignalsFrame::decode(e.signals_frame()).unwrap();
    let stamp = Time::from_secs_f64(poses.sim_time);
    let info = SceneInfo::new(d.clone());
    let mut out: std::collections::HashMap<String, Vec<serde_json::Value>> = Default::default();
    let mut put = |topic: &str, v: serde_json::Value| out.entry(topic.to_string()).or_default().push(v);
    fn json<T: serde::Serialize>(v: &T) -> serde_json::Value {
        serde_json::to_value(v).unwrap()
    }
    let (tf, tf_static) = convert::transforms(&info, &poses, stamp, "world");
    put(topics::TF, json(&tf));
    put(topics::TF_STATIC, json(&tf_static));
    put(topics::POSES, json(&convert::pose_array(&poses, stamp, "world")));
    put(topics::CLOCK, json(&Clock { clock: stamp }));
    put(topics::MARKERS, json(&convert::scene_markers(&info, true)));
    let mut array = Float64MultiArray::default();
    convert::signals_array(&signals, &mut array);
    put(topics::SIGNALS, json(&array));
    put(topics::CONTACT_MARKERS, json(&convert::contact_markers(&signals, 0.001, stamp, "world")));
    let layout = SignalLayout::new(&signals, Some(&d));
    for w in &layout.wrenches {
        if let Some(m) = convert::wrench(w, &signals, stamp, "world") {
            put(&w.topic, json(&m));
        }
    }
    let health = convert::BridgeHealth { world: format!("layout-{scene}"), ..Default::default() };
    put(topics::STATS, json(&convert::diagnostics(Some(&stats), Some(&signals), &health, stamp)));
    out
}

/// The shipped ROS 2 layout (`docs/foxglove/pivotsim-ros2-layout.json`) resolves on this path:
/// its 3D panel's topics are topics the bridge publishes (and the frame it follows is the world
/// frame of every `/tf` transform); every Plot path parses, names a topic the bridge publishes and
/// reaches a plottable value (a number, or a numeric string of a `KeyValue`) in the messages the
/// bridge makes from at least one shipped scene's frames — the solver and input statistics in
/// every scene; a path stamped by `headerStamp` is on a message with a header stamp.
#[test]
fn the_ros2_layout_resolves_against_what_the_bridge_publishes() {
    use pivotsim_ros2_bridge::topics;
    use pivotsim_tests::layout::{layout_refs, parse, plottable, resolve};
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/foxglove/pivotsim-ros2-layout.json");
    let layout: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let refs = layout_refs(&layout);
    assert!(!refs.topics.is_empty() && refs.plot_paths.len() >= 19, "{refs:?}");
    let scenes: Vec<(&str, std::collections::HashMap<String, Vec<serde_json::Value>>)> =
        pivotsim_server::scene::BUILTIN.iter().map(|b| (b.name, published(b.name))).collect();
    let fixed: Vec<&str> = topics::published().iter().map(|(t, _)| *t).collect();
    let is_published = |t: &str| fixed.contains(&t) || scenes.iter().any(|(_, m)| m.contains_key(t));
    for t in &refs.topics {
        assert!(is_published(t), "3D topic {t} is not published by the bridge");
    }
    for f in &refs.frames {
        for (scene, m) in &scenes {
            let tf = &m[topics::TF][0]["transforms"];
            assert!(
                tf.as_array().unwrap().iter().all(|t| &t["header"]["frame_id"] == f),
                "{scene}: frame {f}"
            );
        }
    }
    let mut resolved = 0;
    for (p, method) in &refs.plot_paths {
        let mp = parse(p).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            fixed.contains(&mp.topic.as_str()) || mp.topic.starts_with(topics::WRENCH_PREFIX),
            "{p}: topic not published by the bridge"
        );
        let status = ["pivotsim: solver", "pivotsim: inputs"].iter().any(|s| p.contains(&format!("\"{s}\"")));
        let mut found = Vec::new();
        for (scene, m) in &scenes {
            let msgs = m.get(&mp.topic).map(Vec::as_slice).unwrap_or_default();
            let ok = msgs.iter().any(|msg| {
                let header = method != "headerStamp" || msg["header"]["stamp"]["sec"].is_number();
                header && resolve(msg, &mp.steps).into_iter().any(plottable)
            });
            assert!(ok || !status, "{p}: nothing plottable in {scene}");
            if ok {
                found.push(*scene);
            }
        }
        assert!(!found.is_empty(), "{p}: resolves in no shipped scene");
        println!("{p}: {found:?}");
        resolved += 1;
    }
    println!("{resolved} plot paths resolved; 3D topics {:?}", refs.topics);
}
