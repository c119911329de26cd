//! Bounded, seeded fuzzing of every decoder: truncation at every byte offset always errors (with
//! the header left alone, and with the header patched to the shorter length), bit flips and random
//! payloads never panic, and whatever decodes re-encodes consistently — byte for byte for the
//! binary kinds, whose encoding is canonical.

mod common;

use common::*;
use pivotsim_msgs::*;

/// Runs every decoder that could be pointed at these bytes; returns the generic decoder's result.
fn decode_all(b: &[u8]) -> Result<Message, MessageError> {
    let _ = PoseFrameView::parse(b).map(|v| v.bodies().map(|x| x.id).sum::<u32>());
    let _ = PoseFrame::decode(b);
    let _ = SolverStats::decode(b);
    let _ = SignalsFrame::decode(b);
    let _ = EventsFrame::decode(b);
    let _ = InputCommand::decode(b);
    let _ = ControlRequest::decode(b);
    let _ = ControlReply::decode(b);
    let _ = SceneDescription::decode(b);
    let _ = header::peek(b);
    Message::decode(b)
}

/// A frame that decoded must re-encode to itself (binary) or to an equal message (JSON).
fn check_consistent(bytes: &[u8], m: &Message) {
    let mut again = Vec::new();
    m.encode(&mut again).expect("a decoded message encodes");
    if m.kind().is_json() {
        assert_eq!(&Message::decode(&again).unwrap(), m);
    } else {
        assert_eq!(again, bytes, "binary encoding is canonical ({})", m.kind());
    }
}

#[test]
fn truncation_at_every_offset_errors() {
    for (kind, frame) in sample_frames() {
        for cut in 0..frame.len() {
            let t = &frame[..cut];
            match decode_all(t) {
                Err(MessageError::Frame(FrameError::Truncated { available, .. })) => {
                    assert_eq!(available, cut)
                }
                other => panic!("{kind} cut at {cut}: {other:?}"),
            }
        }
    }
}

#[test]
fn truncation_with_a_consistent_header_errors() {
    for (kind, frame) in sample_frames() {
        for cut in HEADER_LEN..frame.len() {
            let mut t = frame[..cut].to_vec();
            t[8..12].copy_from_slice(&((cut - HEADER_LEN) as u32).to_le_bytes());
            assert!(decode_all(&t).is_err(), "{kind} cut at {cut} with patched length decoded");
        }
    }
}

#[test]
fn appended_bytes_error() {
    for (kind, frame) in sample_frames() {
        let mut t = frame.clone();
        t.push(b'x');
        assert!(
            matches!(decode_all(&t), Err(MessageError::Frame(FrameError::TrailingBytes { .. }))),
            "{kind}"
        );
        let len = (t.len() - HEADER_LEN) as u32;
        t[8..12].copy_from_slice(&len.to_le_bytes());
        assert!(decode_all(&t).is_err(), "{kind} with one more payload byte decoded");
    }
}

#[test]
fn bit_flips_never_panic() {
    let mut rng = Rng(0x5EED_0001);
    let mut decoded = 0usize;
    for (kind, frame) in sample_frames() {
        let rounds = if kind.is_json() { 1500 } else { 4000 };
        for _ in 0..rounds {
            let mut b = frame.clone();
            for _ in 0..1 + rng.below(4) {
                let i = rng.below(b.len());
                b[i] ^= 1 << rng.below(8);
            }
            if let Ok(m) = decode_all(&b) {
                check_consistent(&b, &m);
                decoded += 1;
            }
        }
    }
    // Many flips land in values (ids, sequence numbers, finite floats) and still decode.
    assert!(decoded > 1000, "only {decoded} flipped frames decoded");
}

#[test]
fn byte_substitutions_in_payloads_never_panic() {
    let mut rng = Rng(0x5EED_0002);
    let specials: [u8; 8] = [0x00, 0xFF, 0x7F, 0x80, b'"', b'{', b'\\', b'9'];
    for (_, frame) in sample_frames() {
        for _ in 0..1500 {
            let mut b = frame.clone();
            for _ in 0..1 + rng.below(3) {
                let i = HEADER_LEN + rng.below(b.len() - HEADER_LEN);
                b[i] = if rng.below(2) == 0 { specials[rng.below(specials.len())] } else { rng.next() as u8 };
            }
            if let Ok(m) = decode_all(&b) {
                check_consistent(&b, &m);
            }
        }
    }
}

#[test]
fn random_payloads_under_valid_headers_never_panic() {
    let mut rng = Rng(0x5EED_0003);
    for _ in 0..20_000 {
        let kind = Kind::ALL[rng.below(Kind::ALL.len())];
        let len = match rng.below(4) {
            0 => rng.below(64),
            1 => rng.below(400),
            2 => 32 + 112 * rng.below(4),
            3 if rng.below(2) == 0 => match rng.below(2) {
                0 => 40 + 48 * rng.below(3) + 56 * rng.below(3),
                _ => 32 + 64 * rng.below(4),
            },
            _ => 176 + 40 * rng.below(4),
        };
        let mut b = Vec::with_capacity(HEADER_LEN + len);
        b.extend_from_slice(&MAGIC);
        b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        b.extend_from_slice(&kind.code().to_le_bytes());
        b.extend_from_slice(&(len as u32).to_le_bytes());
        b.extend_from_slice(&0u32.to_le_bytes());
        b.extend((0..len).map(|_| if rng.below(3) == 0 { 0 } else { rng.next() as u8 }));
        if let Ok(m) = decode_all(&b) {
            check_consistent(&b, &m);
        }
    }
}
