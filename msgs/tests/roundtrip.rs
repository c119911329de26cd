//! Round trips of every message kind: random valid messages (bounded sizes) encode, decode to the
//! same value, re-encode to the same bytes, and have the documented frame length.

mod common;

use common::*;
use pivotsim_msgs::*;
use proptest::prelude::*;

fn header_of(b: &[u8]) -> Header {
    header::peek(b).expect("an encoded frame has a valid header")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn pose_frame_round_trip(f in pose_frame()) {
        let mut buf = Vec::new();
        f.encode(&mut buf).unwrap();
        prop_assert_eq!(buf.len(), HEADER_LEN + POSE_FIXED_LEN + BODY_RECORD_LEN * f.bodies.len());
        prop_assert_eq!(header_of(&buf).kind, Kind::PoseFrame);
        prop_assert_eq!(&PoseFrame::decode(&buf).unwrap(), &f);
        let view = PoseFrameView::parse(&buf).unwrap();
        prop_assert_eq!(view.sequence(), f.sequence);
        prop_assert_eq!(view.len(), f.bodies.len());
        prop_assert!(view.bodies().eq(f.bodies.iter().copied()));
        let mut again = Vec::new();
        view.to_frame().encode(&mut again).unwrap();
        prop_assert_eq!(again, buf);
    }

    #[test]
    fn solver_stats_round_trip(s in solver_stats()) {
        let mut buf = Vec::new();
        s.encode(&mut buf).unwrap();
        prop_assert_eq!(buf.len(), HEADER_LEN + STATS_FIXED_LEN + ISLAND_RECORD_LEN * s.islands.len());
        prop_assert_eq!(header_of(&buf).kind, Kind::SolverStats);
        let d = SolverStats::decode(&buf).unwrap();
        prop_assert_eq!(&d, &s);
        let mut again = Vec::new();
        d.encode(&mut again).unwrap();
        prop_assert_eq!(again, buf);
    }

    #[test]
    fn signals_round_trip(s in signals_frame()) {
        let mut buf = Vec::new();
        s.encode(&mut buf).unwrap();
        prop_assert_eq!(buf.len(), HEADER_LEN + SIGNALS_FIXED_LEN + CHANNEL_RECORD_LEN * s.channels.len() + CONTACT_RECORD_LEN * s.contacts.len());
        prop_assert_eq!(header_of(&buf).kind, Kind::Signals);
        let d = SignalsFrame::decode(&buf).unwrap();
        prop_assert_eq!(&d, &s);
        let mut again = Vec::new();
        d.encode(&mut again).unwrap();
        prop_assert_eq!(again, buf);
    }

    #[test]
    fn events_round_trip(e in events_frame()) {
        let mut buf = Vec::new();
        e.encode(&mut buf).unwrap();
        prop_assert_eq!(buf.len(), HEADER_LEN + EVENTS_FIXED_LEN + EVENT_RECORD_LEN * e.events.len());
        prop_assert_eq!(header_of(&buf).kind, Kind::Events);
        let d = EventsFrame::decode(&buf).unwrap();
        prop_assert_eq!(&d, &e);
        let mut again = Vec::new();
        d.encode(&mut again).unwrap();
        prop_assert_eq!(again, buf);
    }

    #[test]
    fn inputs_round_trip(cmd in input()) {
        let mut buf = Vec::new();
        cmd.encode(&mut buf).unwrap();
        let expected = HEADER_LEN + match &cmd {
            InputCommand::Joystick(_) => JOYSTICK_LEN,
            InputCommand::Winch(_) => WINCH_LEN,
            InputCommand::Boom(b) => BOOM_FIXED_LEN + BOOM_ENTRY_LEN * b.targets.len(),
            InputCommand::Actuator(_) => ACTUATOR_LEN,
        };
        prop_assert_eq!(buf.len(), expected);
        prop_assert_eq!(header_of(&buf).kind, cmd.kind());
        prop_assert_eq!(InputCommand::decode(&buf).unwrap(), cmd);
    }

    #[test]
    fn control_requests_round_trip(r in control_request()) {
        let mut buf = Vec::new();
        r.encode(&mut buf).unwrap();
        prop_assert!(header_of(&buf).kind.is_json());
        prop_assert_eq!(ControlRequest::decode(&buf).unwrap(), r);
    }

    #[test]
    fn control_replies_round_trip(r in control_reply()) {
        let mut buf = Vec::new();
        r.encode(&mut buf).unwrap();
        prop_assert_eq!(header_of(&buf).kind, Kind::ControlReply);
        prop_assert_eq!(ControlReply::decode(&buf).unwrap(), r);
    }

    #[test]
    fn scene_descriptions_round_trip(s in scene()) {
        let mut buf = Vec::new();
        s.encode(&mut buf).unwrap();
        prop_assert_eq!(header_of(&buf).kind, Kind::SceneDescription);
        let d = SceneDescription::decode(&buf).unwrap();
        prop_assert_eq!(&d, &s);
        let mut again = Vec::new();
        d.encode(&mut again).unwrap();
        prop_assert_eq!(again, buf);
    }

    #[test]
    fn any_message_round_trip(m in message()) {
        let mut buf = Vec::new();
        m.encode(&mut buf).unwrap();
        prop_assert_eq!(header_of(&buf).kind, m.kind());
        prop_assert_eq!(header_of(&buf).payload_len, buf.len() - HEADER_LEN);
        prop_assert!(buf.len() - HEADER_LEN <= m.kind().max_payload_len());
        prop_assert_eq!(Message::decode(&buf).unwrap(), m);
    }
}

#[test]
fn every_kind_has_a_sample_that_decodes() {
    let frames = sample_frames();
    // The samples keep the older kinds at their indices (tests address them so); one per kind.
    let mut kinds: Vec<Kind> = frames.iter().map(|(k, _)| *k).collect();
    kinds.sort_by_key(|k| k.code());
    assert_eq!(kinds, Kind::ALL);
    for (kind, bytes) in frames {
        let m = Message::decode(&bytes).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert_eq!(m.kind(), kind);
    }
}

#[test]
fn largest_pose_frame_round_trips() {
    let f = PoseFrame { bodies: vec![sample_body(1); MAX_BODIES], ..sample_pose() };
    let mut buf = Vec::new();
    f.encode(&mut buf).unwrap();
    assert_eq!(buf.len() - HEADER_LEN, Kind::PoseFrame.max_payload_len());
    assert_eq!(PoseFrameView::parse(&buf).unwrap().len(), MAX_BODIES);
}
