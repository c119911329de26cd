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
        assert_eq!(l.names_text().lines().count(), f.channels.len());
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
