//! Two servers of the same world name would interleave their streams under one set of keys: the
//! second must refuse to start, over Zenoh (a server it is connected to holds the world's
//! liveliness token) and over iceoryx2 (the world's pose service already has a live publisher on
//! this host). Everything on loopback; a refused start returns at once.

#![cfg(feature = "live")]

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use pivotsim_server::serve::{ServeConfig, ServeError, ZenohOptions, run};
use pivotsim_tests::{Server, free_endpoint};

/// A bounded run (one step, as fast as possible) of `world` with the given transports.
fn second(world: &str, zenoh: Option<ZenohOptions>, iceoryx2: bool) -> Result<u64, ServeError> {
    let config = ServeConfig {
        scene: "pendulum".into(),
        world: world.into(),
        zenoh,
        iceoryx2,
        realtime_factor: None,
        max_steps: Some(1),
        ..ServeConfig::default()
    };
    run(&config, Arc::new(AtomicBool::new(false))).map(|r| r.steps)
}

#[test]
fn a_second_server_of_the_same_world_refuses_to_start() {
    let first = Server::start("pendulum", "dup");
    let world = first.world.to_string();
    let connected = ZenohOptions {
        listen: vec![free_endpoint()],
        connect: vec![first.endpoint.clone()],
        ..Default::default()
    };

    // Over Zenoh: connected to the first server, which holds the world's token.
    match second(&world, Some(connected.clone()), false) {
        Err(ServeError::WorldTaken { transport: "zenoh", world: w, .. }) => assert_eq!(w, world),
        other => panic!("zenoh: {other:?}"),
    }
    // Over iceoryx2: the same host, the world's pose service already published.
    match second(&world, None, true) {
        Err(e @ ServeError::WorldTaken { transport: "iceoryx2", .. }) => {
            assert!(e.to_string().contains("--world"), "the error says what to do: {e}");
        }
        other => panic!("iceoryx2: {other:?}"),
    }
    // Another world on the same network and host is fine.
    let other = format!("{world}-other");
    assert_eq!(second(&other, Some(connected.clone()), true).unwrap(), 1);

    // Once the first server is gone, the world is free again on both transports.
    first.stop();
    assert_eq!(second(&world, None, true).unwrap(), 1);
    let alone = ZenohOptions { listen: vec![free_endpoint()], ..Default::default() };
    assert_eq!(second(&world, Some(alone), false).unwrap(), 1);
}
