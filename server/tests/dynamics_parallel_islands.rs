//! Islands solved in parallel (`World::set_threads`) give the serial result to the bit: each
//! island has its own solver slot and the world gathers the answers in island order
//! (`step.rs`, "Islands in parallel"). Checked on a hand-built world of separate hinge chains (every
//! step takes the parallel path, counted) and on every built-in scene as shipped, script included.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, JointBuilder, MAX_THREADS, ThreadsError, World, WorldSettings, box_inertia,
};
use pivotsim_server::scene;

/// Every body's position, orientation and velocities, as bits.
fn state_bits(w: &World) -> Vec<u64> {
    w.bodies()
        .iter()
        .flat_map(|b| {
            let q = b.orientation().into_inner();
            [
                b.position().x,
                b.position().y,
                b.position().z,
                q.i,
                q.j,
                q.k,
                q.w,
                b.linvel().x,
                b.linvel().y,
                b.linvel().z,
                b.angvel().x,
                b.angvel().y,
                b.angvel().z,
            ]
        })
        .map(f64::to_bits)
        .collect()
}

/// Six separate hinge chains of 6–11 links hanging from the static ground, each started off its
/// equilibrium: six islands of 30–55 rows, all worth a thread.
fn chains(threads: usize) -> World {
    let mut w = World::new(WorldSettings::default()).unwrap();
    w.set_threads(threads).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    for c in 0..6 {
        let links = 6 + c;
        let x = 3.0 * c as f64;
        let mut prev = None;
        for i in 0..links {
            // Each chain leans sideways by a different angle, so that it swings.
            let lean = 0.1 * (c + 1) as f64;
            let z = -(i as f64 + 0.5);
            let pos = Vector3::new(x, lean * -z, z);
            let mass = 1.0 + 0.3 * i as f64;
            let b = w
                .add_body(
                    BodyBuilder::dynamic(
                        &format!("c{c}l{i}"),
                        mass,
                        box_inertia(mass, Vector3::new(0.1, 0.1, 0.5)),
                    )
                    .position(pos),
                )
                .unwrap();
            let anchor = Vector3::new(x, lean * (i as f64), -(i as f64));
            let parent = prev.or(Some(ground));
            w.add_joint(JointBuilder::hinge(&format!("c{c}j{i}"), b, parent, anchor, Vector3::x())).unwrap();
            prev = Some(b);
        }
    }
    w
}

#[test]
fn separate_chains_solve_in_parallel_bit_for_bit() {
    let steps = 300;
    let mut serial = chains(1);
    let mut worlds = [chains(2), chains(3)];
    for step in 0..steps {
        serial.step().unwrap();
        let expected = state_bits(&serial);
        for w in &mut worlds {
            w.step().unwrap();
            assert_eq!(state_bits(w), expected, "{} threads, step {step}", w.threads());
        }
    }
    assert!(serial.bodies().iter().any(|b| b.angvel().norm() > 0.1), "the chains swing");
    assert_eq!(serial.parallel_solves(), 0);
    for w in &worlds {
        // Every solve of every step ran on the pool (a re-solve counts as one more).
        assert!(
            w.parallel_solves() >= steps,
            "{} threads: {} parallel solves",
            w.threads(),
            w.parallel_solves()
        );
        assert_eq!(w.island_stats().len(), 6);
    }
}

#[test]
fn every_builtin_scene_is_bit_identical_with_parallel_islands() {
    for b in scene::BUILTIN {
        let mut serial = scene::load(b.name).unwrap();
        let mut parallel = scene::load(b.name).unwrap();
        parallel.world.set_threads(2).unwrap();
        assert_eq!(parallel.world.threads(), 2);
        for step in 0..240 {
            serial.step().unwrap();
            parallel.step().unwrap();
            if step % 10 == 9 {
                assert_eq!(state_bits(&parallel.world), state_bits(&serial.world), "{} step {step}", b.name);
            }
        }
        eprintln!(
            "{}: {} of 240+ solves on the pool, islands with rows in the last step: {:?}",
            b.name,
            parallel.world.parallel_solves(),
            parallel.world.island_stats().iter().map(|s| s.rows).collect::<Vec<_>>()
        );
    }
}

#[test]
fn bad_thread_counts_are_typed_errors_and_change_nothing() {
    let mut w = chains(1);
    assert_eq!(w.set_threads(0), Err(ThreadsError::Count { threads: 0, max: MAX_THREADS }));
    assert_eq!(
        w.set_threads(MAX_THREADS + 1),
        Err(ThreadsError::Count { threads: MAX_THREADS + 1, max: MAX_THREADS })
    );
    assert_eq!(w.threads(), 1);
    w.set_threads(2).unwrap();
    assert!(matches!(w.set_threads(0), Err(ThreadsError::Count { .. })));
    assert_eq!(w.threads(), 2, "a refused count keeps the pool");
    w.step().unwrap();
    assert_eq!(w.parallel_solves(), 1);
    w.set_threads(1).unwrap();
    w.step().unwrap();
    assert_eq!(w.parallel_solves(), 1, "one thread: the serial path");
}
