//! The force sensors the bridge finds (from channel names alone) in the shipped scenes' signals
//! frames, as the server's engine produces them (no Zenoh, no DDS): the contact sums get a
//! world-frame wrench topic each, the scalar sensors (cable, tipping, cylinder, drum, tension)
//! none, and every frame matches its own layout.

use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_ros2_bridge::convert::{SignalLayout, WrenchKind};
use pivotsim_server::serve::Engine;

fn layout(scene: &str) -> (SignalLayout, msgs::SignalsFrame) {
    let world = msgs::WorldName::new(format!("bridge-{scene}")).unwrap();
    let mut e = Engine::new(scene, world, Duration::from_secs(60)).unwrap();
    assert!(e.tick(Instant::now()));
    let f = msgs::SignalsFrame::decode(e.signals_frame()).unwrap();
    (SignalLayout::new(&f), f)
}

#[test]
fn shipped_scenes_give_a_wrench_per_contact_sum_and_none_for_scalars() {
    for (scene, want) in [
        ("crane", &["/pivotsim/signals/outriggers"][..]),
        ("forklift", &["/pivotsim/signals/forks_load"][..]),
        ("winch", &[][..]),
    ] {
        let (l, f) = layout(scene);
        assert!(l.matches(&f), "{scene}");
        let topics: Vec<&str> = l.wrenches.iter().map(|w| w.topic.as_str()).collect();
        assert_eq!(topics, want, "{scene}: {:?}", l.names_text());
        assert!(
            l.wrenches.iter().all(|w| w.kind == WrenchKind::ContactSum && w.frame_id("world") == "world")
        );
        assert_eq!(l.wrenches_refused, 0);
        assert_eq!(l.names_text().lines().count(), f.channels.len());
    }
}
