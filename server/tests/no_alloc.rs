//! The hot path allocates nothing: after a first solve has sized the workspace, solving a problem
//! of the same size again performs no heap allocation, for every variant (a counting global
//! allocator watches).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use pivotsim_server::solver::{Solver, SolverOptions, Variant};

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

#[test]
fn second_solve_allocates_nothing() {
    let plain = common::banded_problem(300, 10, 3, 0.5);
    let friction = common::random_problem(60, 7, true, 0.1, 1.0);
    // Paper-like islands exercise the projected-Newton safeguard and the coupled Newton update;
    // Confeti (semidefinite) the proximal mode.
    let shared = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let extreme =
        pivotsim_server::solver::io::read_mlcp_file(&shared.join("mlcp-scene/scene-extreme200.txt")).unwrap();
    let confeti =
        pivotsim_server::solver::io::read_mlcp_file(&shared.join("mlcp/Confeti-ex13-Fc3D-SBM.txt")).unwrap();
    for p in [&plain, &friction, &extreme, &confeti] {
        for v in Variant::ALL {
            let mut s = Solver::new(SolverOptions { variant: v, max_steps: 1000, ..Default::default() });
            let mut lam = vec![0.0; p.n()];
            let first = ALLOCS.load(Ordering::Relaxed);
            s.solve(p, &mut lam);
            assert!(ALLOCS.load(Ordering::Relaxed) > first, "{v}: the first solve must size the workspace");
            let before = ALLOCS.load(Ordering::Relaxed);
            let st = s.solve(p, &mut lam);
            let steps = st.pivot_steps;
            let after = ALLOCS.load(Ordering::Relaxed);
            assert_eq!(
                after - before,
                0,
                "{v}: {} allocations in the second solve ({steps} steps)",
                after - before
            );
        }
    }
}
