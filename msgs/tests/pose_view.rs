//! The subscriber and publisher hot paths: the borrowed pose view yields exactly the encoded
//! bodies, the writer matches the owned encoder, and encoding into a reused buffer does not grow
//! it again.

mod common;

use common::*;
use pivotsim_msgs::*;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn view_yields_exactly_the_encoded_bodies(f in pose_frame()) {
        let mut buf = Vec::new();
        f.encode(&mut buf).unwrap();
        let view = PoseFrameView::parse(&buf).unwrap();
        prop_assert_eq!(view.len(), f.bodies.len());
        prop_assert_eq!(view.is_empty(), f.bodies.is_empty());
        prop_assert_eq!((view.sim_time(), view.wall_time_ns()), (f.sim_time, f.wall_time_ns));
        let it = view.bodies();
        prop_assert_eq!(it.len(), f.bodies.len());
        let mut n = 0;
        for (got, want) in it.zip(&f.bodies) {
            prop_assert_eq!(&got, want);
            // Bit-exact, not just ==: -0.0 stays -0.0.
            prop_assert_eq!(got.position.map(f64::to_bits), want.position.map(f64::to_bits));
            n += 1;
        }
        prop_assert_eq!(n, f.bodies.len());
        for (i, want) in f.bodies.iter().enumerate() {
            prop_assert_eq!(view.get(i), Some(*want));
        }
        prop_assert!(view.bodies().rev().eq(f.bodies.iter().rev().copied()));
    }

    #[test]
    fn writer_matches_owned_encoder(f in pose_frame()) {
        let mut a = Vec::new();
        f.encode(&mut a).unwrap();
        let mut b = Vec::new();
        let mut w = PoseFrameWriter::begin(&mut b, f.sequence, f.sim_time, f.wall_time_ns).unwrap();
        for body in &f.bodies {
            w.push(body).unwrap();
        }
        prop_assert_eq!(w.len(), f.bodies.len());
        prop_assert_eq!(w.finish(), &a[..]);
    }
}

#[test]
fn writer_buffer_is_a_valid_frame_after_every_push() {
    let mut buf = Vec::new();
    let mut w = PoseFrameWriter::begin(&mut buf, 3, 1.0, 0).unwrap();
    assert!(w.is_empty());
    w.push(&sample_body(1)).unwrap();
    w.push(&sample_body(2)).unwrap();
    let bytes = w.finish();
    let ids: Vec<u32> = PoseFrameView::parse(bytes).unwrap().bodies().map(|b| b.id).collect();
    assert_eq!(ids, [1, 2]);
    for n in 0..4u32 {
        let mut b = Vec::new();
        let mut w = PoseFrameWriter::begin(&mut b, 0, 0.0, 0).unwrap();
        assert_eq!(PoseFrameView::parse(w.as_bytes()).unwrap().len(), 0);
        for i in 0..n {
            w.push(&sample_body(i)).unwrap();
            assert_eq!(PoseFrameView::parse(w.as_bytes()).unwrap().len(), i as usize + 1);
        }
    }
}

#[test]
fn reused_buffers_do_not_grow_on_the_second_encode() {
    let mut rng = Rng(42);
    let frames = sample_frames();
    for (kind, bytes) in &frames {
        let m = Message::decode(bytes).unwrap();
        let mut buf = Vec::new();
        m.encode(&mut buf).unwrap();
        let (cap, ptr) = (buf.capacity(), buf.as_ptr());
        m.encode(&mut buf).unwrap();
        assert_eq!((buf.capacity(), buf.as_ptr()), (cap, ptr), "{kind}");
        assert_eq!(&buf, bytes);
    }
    // Same size, different content: pose frames of 50 bodies.
    let mut buf = Vec::new();
    let mut f = PoseFrame { bodies: vec![sample_body(0); 50], ..sample_pose() };
    f.encode(&mut buf).unwrap();
    let (cap, ptr) = (buf.capacity(), buf.as_ptr());
    for step in 0..20 {
        f.sequence += 1;
        for b in &mut f.bodies {
            b.position[0] = rng.next() as f64 / u64::MAX as f64;
        }
        f.encode(&mut buf).unwrap();
        assert_eq!((buf.capacity(), buf.as_ptr()), (cap, ptr), "step {step}");
        let mut w = PoseFrameWriter::begin(&mut buf, f.sequence, f.sim_time, 0).unwrap();
        for b in &f.bodies {
            w.push(b).unwrap();
        }
        assert_eq!((buf.capacity(), buf.as_ptr()), (cap, ptr), "writer, step {step}");
    }
    // Decoding into reused owned values does not grow them either.
    let mut owned = PoseFrame::default();
    owned.decode_into(&buf).unwrap();
    let cap = owned.bodies.capacity();
    owned.decode_into(&buf).unwrap();
    assert_eq!(owned.bodies.capacity(), cap);
}
