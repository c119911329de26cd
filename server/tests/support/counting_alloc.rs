//! A counting global allocator for the allocation tests: every `alloc` and `realloc` is counted
//! per thread ([`allocations_during`] counts the calling thread's only, so that tests of one
//! binary running in parallel do not see each other's allocations); memory is served by the
//! system allocator. Include with `#[path = "support/counting_alloc.rs"] mod counting_alloc;`.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

thread_local! {
    // Const-initialized and without a destructor: touching it never allocates.
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

/// Every thread's allocations (for a test binary with one test: see [`process_allocations_during`]).
static PROCESS: AtomicUsize = AtomicUsize::new(0);

fn count() {
    PROCESS.fetch_add(1, Ordering::Relaxed);
    // `try_with`: during thread teardown the slot may be gone; those allocations are not ours.
    let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
}

// SAFETY: forwards every call unchanged to the system allocator; only counts.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations (including reallocations) made while `f` runs.
pub fn allocations_during(f: impl FnOnce()) -> usize {
    let before = ALLOCS.with(Cell::get);
    f();
    ALLOCS.with(Cell::get) - before
}

/// Mean allocations per call of `f` over `n` calls.
#[allow(dead_code)] // not every test binary that includes this module uses it
pub fn allocations_per_call(n: usize, mut f: impl FnMut()) -> f64 {
    allocations_during(|| (0..n).for_each(|_| f())) as f64 / n as f64
}

/// Allocations made by any thread of the process while `f` runs: for work spread over threads
/// (the solver pool). Counts other tests' allocations too, so only for a test binary with one test.
#[allow(dead_code)]
pub fn process_allocations_during(f: impl FnOnce()) -> usize {
    let before = PROCESS.load(Ordering::SeqCst);
    f();
    PROCESS.load(Ordering::SeqCst) - before
}
