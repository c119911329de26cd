//! The hot paths allocate nothing: parsing a pose frame and iterating its bodies from a byte slice,
//! and encoding pose frames, stats and inputs into a buffer that has already grown, decoding
//! stats into a reused value, and binary inputs other than boom commands.
//!
//! A counting global allocator wraps the system allocator for this test binary only (the one
//! `unsafe` of the crate's tests: `GlobalAlloc` is an unsafe trait). The file holds a single test so
//! that no other test thread allocates while the counter is read.
#![allow(unsafe_code)]

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use common::*;
use pivotsim_msgs::*;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded unchanged to the system allocator; the counter is atomic.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations_in(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    f();
    ALLOCATIONS.load(Ordering::SeqCst) - before
}

#[test]
fn hot_paths_do_not_allocate() {
    assert!(
        allocations_in(|| drop(std::hint::black_box(Vec::<u8>::with_capacity(10)))) >= 1,
        "counter works"
    );
    let frames = sample_frames();
    let f = PoseFrame { bodies: (0..200).map(sample_body).collect(), ..sample_pose() };
    let mut buf = Vec::new();
    f.encode(&mut buf).unwrap();

    let n = allocations_in(|| {
        let view = PoseFrameView::parse(&buf).unwrap();
        let mut sum = 0.0;
        for b in view.bodies() {
            sum += b.position[0] + f64::from(b.id);
        }
        assert!(sum > 0.0);
        assert_eq!(view.bodies().count(), 200);
    });
    assert_eq!(n, 0, "parse + iterate");

    let n = allocations_in(|| {
        f.encode(&mut buf).unwrap();
        let mut w = PoseFrameWriter::begin(&mut buf, 2, 1.0, 3).unwrap();
        for b in &f.bodies {
            w.push(b).unwrap();
        }
    });
    assert_eq!(n, 0, "encode into a grown buffer");

    let mut owned = PoseFrame::decode(&buf).unwrap();
    let n = allocations_in(|| owned.decode_into(&buf).unwrap());
    assert_eq!(n, 0, "decode_into a grown frame");

    let stats = SolverStats::decode(&frames[1].1).unwrap();
    let mut sbuf = Vec::new();
    stats.encode(&mut sbuf).unwrap();
    let mut sdec = stats.clone();
    let n = allocations_in(|| {
        stats.encode(&mut sbuf).unwrap();
        sdec.decode_into(&sbuf).unwrap();
    });
    assert_eq!(n, 0, "stats encode + decode_into");

    let mut ibuf = Vec::with_capacity(256);
    for (_, bytes) in &frames[2..6] {
        let cmd = InputCommand::decode(bytes).unwrap();
        let n = allocations_in(|| cmd.encode(&mut ibuf).unwrap());
        assert_eq!(n, 0, "encode {:?}", cmd.kind());
        if !matches!(cmd, InputCommand::Boom(_)) {
            let n = allocations_in(|| drop(InputCommand::decode(bytes).unwrap()));
            assert_eq!(n, 0, "decode {:?}", cmd.kind());
        }
    }
}
