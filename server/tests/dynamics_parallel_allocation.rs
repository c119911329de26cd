//! Islands solved in parallel allocate next to nothing per step once warm, on any thread: the
//! solver pool's threads are made once (`World::set_threads`) and each island slot keeps its
//! buffers. What is left is rayon's: handing a step's work to the pool from the stepping thread
//! pushes one job onto the pool's injector queue, which allocates a block of 63 slots when the last
//! one fills — one allocation every 63 steps, on the stepping thread (measured: 4 in 300); the
//! pool's threads allocate nothing. The allocator counts every thread of the process here, so this
//! binary holds this one test.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{BodyBuilder, JointBuilder, World, WorldSettings, sphere_inertia};

#[path = "support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::{allocations_during, process_allocations_during};

/// Six chains of 10–15 ball-jointed links hanging from a ceiling, each started off its
/// equilibrium: six islands of 30–45 rows.
fn chains() -> World {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let ceiling = w.add_body(BodyBuilder::static_body("ceiling")).unwrap();
    for c in 0..6 {
        let x = 2.0 * c as f64;
        let mut prev = Some(ceiling);
        for i in 0..10 + c {
            let at = Vector3::new(x + 0.3 * i as f64, 0.0, -0.2 * i as f64);
            let b = w
                .add_body(
                    BodyBuilder::dynamic(&format!("c{c}l{i}"), 1.0, sphere_inertia(1.0, 0.05)).position(at),
                )
                .unwrap();
            let anchor = at + Vector3::new(-0.15, 0.0, 0.1);
            w.add_joint(JointBuilder::ball(&format!("c{c}j{i}"), b, prev, anchor)).unwrap();
            prev = Some(b);
        }
    }
    w
}

#[test]
fn parallel_steps_allocate_nothing_once_warm() {
    let mut w = chains();
    w.set_threads(2).unwrap();
    for _ in 0..200 {
        w.step().unwrap();
    }
    let before = w.parallel_solves();
    let steps = 300;
    let mut own = 0;
    let all = process_allocations_during(|| {
        own = allocations_during(|| {
            for _ in 0..steps {
                w.step().unwrap();
            }
        })
    });
    assert_eq!(w.parallel_solves() - before, steps, "every step's islands ran on the pool");
    // One injector block per 63 steps, with room for a block begun before the count.
    let bound = steps as usize / 63 + 1;
    assert!(
        own <= bound,
        "the stepping thread allocated {own} times in {steps} parallel steps (bound {bound})"
    );
    assert_eq!(all, own, "the pool's threads allocated {} times in {steps} steps", all - own);
}
