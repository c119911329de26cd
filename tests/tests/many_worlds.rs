//! Many worlds on one host: three servers of different world names run side by side, joined in one
//! Zenoh network (the second and third connect to the first) and on one iceoryx2 host. A client on
//! that network and an iceoryx2 subscriber per world each see their own world's frames only — its
//! scene's bodies, its sequence rising by one, nothing of the others interleaved — and a fourth
//! server that asks for a world already served is still refused. Everything on loopback; every wait
//! bounded.

#![cfg(feature = "live")]

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use pivotsim_msgs as msgs;
use pivotsim_server::serve::{ServeConfig, ServeError, ZenohOptions, run};
use pivotsim_tests::{Server, free_endpoint};
use zenoh::Wait;

/// A received pose frame: its sequence and its body ids.
type Frame = (u64, Vec<u32>);

/// The body ids of a world's pose frames, from its scene description.
fn body_ids(d: &msgs::SceneDescription) -> Vec<u32> {
    d.bodies.iter().map(|b| b.id).collect()
}

#[test]
fn three_worlds_side_by_side_each_client_sees_only_its_own() {
    let a = Server::start("pendulum", "mwa");
    let join = |c: &mut ServeConfig| {
        if let Some(z) = c.zenoh.as_mut() {
            z.connect = vec![a.endpoint.clone()];
        }
    };
    let b = Server::start_with("box_stack", "mwb", join);
    let c = Server::start_with("hanging_chain", "mwc", join);
    let servers = [&a, &b, &c];

    // One client on the whole network: connected to all three, subscribed to every world's poses.
    let endpoints: Vec<String> = servers.iter().map(|s| s.endpoint.clone()).collect();
    let config = pivotsim_link::zenoh_config::ZenohEndpoints::client(endpoints).config().unwrap();
    let session = zenoh::open(config).wait().unwrap();
    let mut expected = HashMap::new();
    for s in servers {
        let deadline = Instant::now() + Duration::from_secs(10);
        let d = loop {
            if let Some(d) = s.scene(&session) {
                break d;
            }
            assert!(Instant::now() < deadline, "{}: no scene description", s.world);
            std::thread::sleep(Duration::from_millis(50));
        };
        expected.insert(s.world.to_string(), (d.scene.clone(), body_ids(&d)));
    }
    let scenes: Vec<&str> = servers.iter().map(|s| expected[s.world.as_str()].0.as_str()).collect();
    assert_eq!(scenes, ["pendulum", "box_stack", "hanging_chain"], "each world answers with its own scene");
    // Each world's own key, and the wildcard over all of them.
    let own: Vec<_> = servers
        .iter()
        .map(|s| session.declare_subscriber(s.key(msgs::Topic::Poses)).wait().unwrap())
        .collect();
    let all = session.declare_subscriber("pivotsim/*/poses").wait().unwrap();
    // iceoryx2: each world's pose service on this host.
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let iox: Vec<_> = servers
        .iter()
        .map(|s| {
            let name = s.key(msgs::Topic::Poses);
            let service = node
                .service_builder(&name.as_str().try_into().unwrap())
                .publish_subscribe::<[u8]>()
                .open_or_create()
                .unwrap();
            let sub = service.subscriber_builder().create().unwrap();
            (service, sub)
        })
        .collect();

    // Frames per (world, path): sequence and body ids.
    let mut seen: HashMap<(String, &str), Vec<Frame>> = HashMap::new();
    let frame = |bytes: &[u8]| {
        let v = msgs::PoseFrameView::parse(bytes).expect("a pose frame");
        (v.sequence(), v.bodies().map(|b| b.id).collect::<Vec<u32>>())
    };
    let deadline = Instant::now() + Duration::from_secs(2);
    while Instant::now() < deadline {
        for (s, sub) in servers.iter().zip(&own) {
            while let Ok(Some(z)) = sub.try_recv() {
                let key = z.key_expr().as_str().to_string();
                assert_eq!(key, s.key(msgs::Topic::Poses), "a subscriber of {} got {key}", s.world);
                seen.entry((s.world.to_string(), "zenoh")).or_default().push(frame(&z.payload().to_bytes()));
            }
        }
        while let Ok(Some(z)) = all.try_recv() {
            let world = z.key_expr().as_str().split('/').nth(1).unwrap().to_string();
            seen.entry((world, "wildcard")).or_default().push(frame(&z.payload().to_bytes()));
        }
        for (s, (_, sub)) in servers.iter().zip(&iox) {
            while let Ok(Some(sample)) = sub.receive() {
                seen.entry((s.world.to_string(), "iceoryx2")).or_default().push(frame(sample.payload()));
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    for s in servers {
        let (scene, ids) = &expected[s.world.as_str()];
        for path in ["zenoh", "wildcard", "iceoryx2"] {
            let frames = seen.get(&(s.world.to_string(), path)).map(Vec::as_slice).unwrap_or_default();
            assert!(frames.len() >= 60, "{scene} over {path}: {} frames in 2 s", frames.len());
            for (_, bodies) in frames {
                assert_eq!(bodies, ids, "{scene} over {path}: a frame of another world");
            }
            for w in frames.windows(2) {
                assert_eq!(w[1].0, w[0].0 + 1, "{scene} over {path}: sequence {} after {}", w[1].0, w[0].0);
            }
        }
    }
    let worlds: Vec<String> = servers.iter().map(|s| s.world.to_string()).collect();
    assert!(
        seen.keys().all(|(w, _)| worlds.contains(w)),
        "only the three worlds publish: {:?}",
        seen.keys().collect::<Vec<_>>()
    );

    // A fourth server asking for the second world's name, on the same network and host: refused
    // on both transports, and the three keep stepping.
    let fourth = |zenoh: Option<ZenohOptions>, iceoryx2: bool| {
        let config = ServeConfig {
            scene: "pendulum".into(),
            world: b.world.to_string(),
            zenoh,
            iceoryx2,
            realtime_factor: None,
            max_steps: Some(1),
            ..ServeConfig::default()
        };
        run(&config, Arc::new(AtomicBool::new(false)))
    };
    let connected = ZenohOptions {
        listen: vec![free_endpoint()],
        connect: vec![a.endpoint.clone(), b.endpoint.clone()],
        ..Default::default()
    };
    assert!(matches!(fourth(Some(connected), false), Err(ServeError::WorldTaken { transport: "zenoh", .. })));
    assert!(matches!(fourth(None, true), Err(ServeError::WorldTaken { transport: "iceoryx2", .. })));
    drop((own, all, iox, node));
    for s in [c, b, a] {
        assert!(s.stop().steps > 60);
    }
}
