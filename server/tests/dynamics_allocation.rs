//! The step's hot loop reuses its buffers: after the first steps of a scene have sized them, a step
//! allocates nothing — the island problem is refilled in place (`Mlcp::assign`) and the solver's
//! workspace is reused. A counting global allocator watches.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, JointBuilder, JointLimit, JointMotor, World, WorldSettings, sphere_inertia,
};

struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator; only counts.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// `chains` chains of `links` links hanging from a static ceiling (one island each).
fn scene(chains: usize, links: usize, projection: usize) -> World {
    let mut w =
        World::new(WorldSettings { projection_iterations: projection, ..Default::default() }).unwrap();
    let ceiling = w.add_body(BodyBuilder::static_body("ceiling")).unwrap();
    for c in 0..chains {
        let x = c as f64;
        let mut prev = None;
        for i in 0..links {
            let b = w
                .add_body(
                    BodyBuilder::dynamic(&format!("c{c}l{i}"), 1.0, sphere_inertia(1.0, 0.05))
                        .position(Vector3::new(x + 0.3 * i as f64, 0.0, -0.2 * i as f64)),
                )
                .unwrap();
            let anchor = Vector3::new(x + 0.3 * i as f64 - 0.15, 0.0, -0.2 * i as f64 + 0.1);
            let j = if i == 0 {
                JointBuilder::hinge(&format!("c{c}j{i}"), b, Some(ceiling), anchor, Vector3::y())
                    .limit(JointLimit::new(-0.5, 0.5))
                    .motor(JointMotor { target_speed: 0.2, max_force: 3.0 })
            } else {
                JointBuilder::ball(&format!("c{c}j{i}"), b, prev, anchor)
            };
            w.add_joint(j).unwrap();
            prev = Some(b);
        }
    }
    w
}

fn allocations_per_step(w: &mut World) -> (f64, usize) {
    // Warm-up long enough for every row set the scene goes through (limits coming and going) to
    // have sized the buffers once.
    for _ in 0..120 {
        w.step().unwrap();
    }
    let steps = 20;
    let before = ALLOCS.load(Ordering::Relaxed);
    for _ in 0..steps {
        w.step().unwrap();
    }
    let per_step = (ALLOCS.load(Ordering::Relaxed) - before) as f64 / steps as f64;
    let solves = w.island_stats().len() * (1 + w.settings().projection_iterations);
    (per_step, solves)
}

#[test]
fn steps_allocate_nothing_once_warm() {
    let mut per_solve = Vec::new();
    for (chains, links, proj) in [(1, 10, 0), (1, 40, 0), (4, 10, 0), (2, 10, 1)] {
        let mut w = scene(chains, links, proj);
        let (per_step, solves) = allocations_per_step(&mut w);
        println!(
            "{chains} chain(s) × {links} links, projection {proj}: {per_step} allocations per step, {solves} solves"
        );
        per_solve.push(per_step / solves as f64);
    }
    assert!(per_solve.iter().all(|&p| p == 0.0), "{per_solve:?}");
}
