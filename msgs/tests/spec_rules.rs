//! Rules of `msgs/README.md` that say which of several faults wins, or what an edge value gets:
//! the order of the input checks (section "Order of the input checks": a frame with two faults
//! gets the error and reject reason of the check that comes first), the control ids that are not
//! a u64, where every input kind carries `sequence` and `source_id` (one `stale` counter per
//! source, whatever the kind), and the header's flags error naming the current version.

mod common;

use common::*;
use pivotsim_msgs::*;

fn set_u32(b: &mut [u8], off: usize, v: u32) {
    b[off..off + 4].copy_from_slice(&v.to_le_bytes());
}

fn set_f64(b: &mut [u8], off: usize, v: f64) {
    b[off..off + 8].copy_from_slice(&v.to_le_bytes());
}

fn set_f32(b: &mut [u8], off: usize, v: f32) {
    b[off..off + 4].copy_from_slice(&v.to_le_bytes());
}

fn bytes(cmd: &InputCommand) -> Vec<u8> {
    let mut b = Vec::new();
    cmd.encode(&mut b).unwrap();
    b
}

/// Frame offset of a payload offset.
const P: usize = HEADER_LEN;

fn winch() -> Vec<u8> {
    bytes(&InputCommand::Winch(WinchCommand {
        sequence: 1,
        source_id: 2,
        actuator: name("winch"),
        drum_speed: 0.5,
    }))
}

fn joystick() -> Vec<u8> {
    bytes(&InputCommand::Joystick(Joystick::new(1, 2, &[0.5, -0.5], 0b1, 2).unwrap()))
}

fn actuator() -> Vec<u8> {
    bytes(&InputCommand::Actuator(ActuatorCommand {
        sequence: 1,
        source_id: 2,
        mode: ActuatorMode::Velocity,
        actuator: name("slew"),
        value: 0.1,
    }))
}

fn boom(n: usize) -> Vec<u8> {
    let targets =
        (0..n).map(|i| BoomTarget { actuator: name(&format!("lever{i}")), value: 0.1 * i as f64 }).collect();
    bytes(&InputCommand::Boom(BoomCommand { sequence: 1, source_id: 2, targets }))
}

/// Frame offset of boom entry `i`'s name field.
fn entry(i: usize) -> usize {
    P + BOOM_FIXED_LEN + BOOM_ENTRY_LEN * i
}

/// Decodes `b`, expecting a failure; returns the error and the reason the server counts.
fn rejected(b: &[u8]) -> (DecodeError<InputError>, RejectReason) {
    let e = InputCommand::decode(b).expect_err("a frame with faults decoded");
    let r = e.reject_reason();
    (e, r)
}

#[test]
fn boom_count_is_checked_before_the_layout() {
    // count 17 with 16 records: the count is over the bound before the layout is looked at.
    let mut b = boom(16);
    assert_eq!(b.len(), HEADER_LEN + Kind::Boom.max_payload_len());
    set_u32(&mut b, P + 12, 17);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::TooManyTargets { count: 17 }));
    assert_eq!(r, RejectReason::Oversize, "oversize, not malformed");
    // count 3 with 2 records: within the bound, so the layout decides.
    let mut b = boom(2);
    set_u32(&mut b, P + 12, 3);
    let (e, r) = rejected(&b);
    assert!(
        matches!(e, DecodeError::Frame(FrameError::PayloadLength { expected: 136, found: 96, .. })),
        "{e:?}"
    );
    assert_eq!(r, RejectReason::Malformed);
    // count 17 with 17 records: the header's payload bound comes first.
    let mut b = boom(16);
    let last = b[entry(15)..entry(16)].to_vec();
    b.extend_from_slice(&last);
    let len = b.len() - HEADER_LEN;
    set_u32(&mut b, 8, len as u32);
    set_u32(&mut b, P + 12, 17);
    let (e, r) = rejected(&b);
    assert!(
        matches!(e, DecodeError::Frame(FrameError::PayloadTooLarge { declared: 696, max: 656, .. })),
        "{e:?}"
    );
    assert_eq!(r, RejectReason::Oversize);
}

#[test]
fn header_checks_come_before_the_kind_and_the_payload() {
    // Flags set and a trailing byte: flags are checked before the length.
    let mut b = winch();
    set_u32(&mut b, 12, 1);
    b.push(0);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Frame(FrameError::Flags { found: 1 }));
    assert_eq!(r, RejectReason::Version);
    // A stats frame declaring more than the stats maximum: the bound comes before "not an input".
    let frames = sample_frames();
    let (kind, stats) = &frames[1];
    assert_eq!(*kind, Kind::SolverStats);
    let mut b = stats.clone();
    set_u32(&mut b, 8, (Kind::SolverStats.max_payload_len() + 1) as u32);
    let (e, r) = rejected(&b);
    assert!(
        matches!(e, DecodeError::Frame(FrameError::PayloadTooLarge { kind: Kind::SolverStats, .. })),
        "{e:?}"
    );
    assert_eq!(r, RejectReason::Oversize);
    // The same frame as sent: a well-formed frame that is not an input.
    let (e, r) = rejected(stats);
    assert_eq!(e, DecodeError::Frame(FrameError::NotAnInput { found: Kind::SolverStats }));
    assert_eq!(r, RejectReason::Version);
    // A version and a magic fault together: the magic comes first.
    let mut b = winch();
    b[0] = b'X';
    b[4] = 9;
    assert!(matches!(rejected(&b).0, DecodeError::Frame(FrameError::BadMagic { .. })));
}

#[test]
fn reserved_bytes_come_before_counts_and_values() {
    // Joystick: a reserved byte set and 40 axes.
    let mut b = joystick();
    b[P + 14] = 1;
    b[P + 12] = 40;
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Frame(FrameError::ReservedNonZero { offset: P + 14 }));
    assert_eq!(r, RejectReason::Malformed);
    // Winch: a reserved byte set and a NaN drum speed.
    let mut b = winch();
    b[P + 13] = 7;
    set_f64(&mut b, P + 48, f64::NAN);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Frame(FrameError::ReservedNonZero { offset: P + 13 }));
    assert_eq!(r, RejectReason::Malformed);
}

#[test]
fn actuator_mode_code_comes_before_its_reserved_bytes() {
    let mut b = actuator();
    b[P + 12] = 7;
    b[P + 13] = 1;
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::UnknownMode { code: 7 }));
    assert_eq!(r, RejectReason::OutOfRange);
    // With a valid mode the reserved byte is what is wrong.
    b[P + 12] = 1;
    assert_eq!(rejected(&b).0, DecodeError::Frame(FrameError::ReservedNonZero { offset: P + 13 }));
}

#[test]
fn joystick_counts_then_axes_in_index_order_then_buttons() {
    let axis = |i: usize| P + 24 + 4 * i;
    // 40 axes and a NaN axis: the count first.
    let mut b = joystick();
    b[P + 12] = 40;
    set_f32(&mut b, axis(1), f32::NAN);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::TooManyAxes { count: 40 }));
    assert_eq!(r, RejectReason::Oversize);
    // Axis 0 out of range, axis 1 NaN: index order.
    let mut b = joystick();
    set_f32(&mut b, axis(0), 2.0);
    set_f32(&mut b, axis(1), f32::NAN);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::AxisOutOfRange { axis: 0, value: 2.0 }));
    assert_eq!(r, RejectReason::OutOfRange);
    // Axis 0 NaN, axis 1 out of range.
    let mut b = joystick();
    set_f32(&mut b, axis(0), f32::NAN);
    set_f32(&mut b, axis(1), 2.0);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::NonFinite { field: "axes", entry: Some(0) }));
    assert_eq!(r, RejectReason::NonFinite);
    // Axis 0 NaN and a button bit beyond button_count: the axes before the buttons.
    let mut b = joystick();
    set_f32(&mut b, axis(0), f32::NAN);
    b[P + 16] = 0b100;
    assert_eq!(rejected(&b).1, RejectReason::NonFinite);
    // An unused axis set (slot 5, beyond axis_count 2) and stray buttons: the axes first.
    let mut b = joystick();
    set_f32(&mut b, axis(5), -0.0);
    b[P + 16] = 0b100;
    assert_eq!(rejected(&b).0, DecodeError::Invalid(InputError::UnusedAxis { axis: 5 }));
}

#[test]
fn name_fields_come_before_values() {
    // Winch: broken name padding and a NaN drum speed.
    let mut b = winch();
    b[P + 16 + 10] = b'x';
    set_f64(&mut b, P + 48, f64::NAN);
    let (e, r) = rejected(&b);
    assert!(
        matches!(e, DecodeError::Invalid(InputError::Name { source: NameError::Padding { index: 10 }, .. })),
        "{e:?}"
    );
    assert_eq!(r, RejectReason::Malformed);
    // Boom: entry 0's value NaN, entry 1's name empty: every name before any value.
    let mut b = boom(2);
    set_f64(&mut b, entry(0) + 32, f64::NAN);
    b[entry(1)..entry(1) + 32].fill(0);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::Name { entry: Some(1), source: NameError::Empty }));
    assert_eq!(r, RejectReason::OutOfRange);
}

#[test]
fn boom_entries_are_checked_in_order_value_before_duplicate() {
    // Entry 1 repeats entry 0, entry 2's value is NaN: entry 1 fails first.
    let mut b = boom(3);
    let first = b[entry(0)..entry(0) + 32].to_vec();
    b[entry(1)..entry(1) + 32].copy_from_slice(&first);
    set_f64(&mut b, entry(2) + 32, f64::NAN);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::DuplicateTarget { name: "lever0".into() }));
    assert_eq!(r, RejectReason::OutOfRange);
    // Entry 1 both repeats entry 0 and has a NaN value: within an entry, the value first.
    set_f64(&mut b, entry(2) + 32, 0.0);
    set_f64(&mut b, entry(1) + 32, f64::INFINITY);
    let (e, r) = rejected(&b);
    assert_eq!(e, DecodeError::Invalid(InputError::NonFinite { field: "value", entry: Some(1) }));
    assert_eq!(r, RejectReason::NonFinite);
}

/// `stale` is one counter per `source_id` across the four input kinds: every kind carries
/// `sequence` (u64) at payload offset 0 and `source_id` (u32) at 8, so the server reads the pair
/// the same way whatever the kind.
#[test]
fn every_input_kind_carries_sequence_and_source_at_the_same_offsets() {
    let frames = [joystick(), winch(), boom(1), actuator()];
    for mut b in frames {
        b[P..P + 8].copy_from_slice(&0x0102_0304_0506_0708u64.to_le_bytes());
        set_u32(&mut b, P + 8, 0xCAFE);
        let cmd = InputCommand::decode(&b).unwrap();
        assert_eq!((cmd.sequence(), cmd.source_id()), (0x0102_0304_0506_0708, 0xCAFE), "{}", cmd.kind());
    }
}

fn control_frame(json: &str) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&MAGIC);
    b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    b.extend_from_slice(&Kind::ControlRequest.code().to_le_bytes());
    b.extend_from_slice(&(json.len() as u32).to_le_bytes());
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(json.as_bytes());
    b
}

#[test]
fn control_ids_that_are_not_u64_get_invalid_request_with_id_0() {
    for id in ["18446744073709551616", "-1", "1.5", "1e3", "\"7\"", "null"] {
        let json = format!(r#"{{"id":{id},"command":{{"op":"pause"}}}}"#);
        let b = control_frame(&json);
        let e = ControlRequest::decode(&b).expect_err(&json);
        assert!(matches!(e, DecodeError::Frame(FrameError::Json { .. })), "{json}: {e:?}");
        assert_eq!(ControlRequest::peek_id(&b), None, "{json}");
        let reply = ControlRequest::rejection(&b, &e);
        assert_eq!(reply.id, 0, "{json}");
        let ControlOutcome::Error(f) = reply.outcome else { panic!("{json}: ok") };
        assert_eq!(f.code, ControlErrorCode::InvalidRequest, "{json}");
    }
    // No id at all: the same.
    let b = control_frame(r#"{"command":{"op":"pause"}}"#);
    assert_eq!(ControlRequest::rejection(&b, &ControlRequest::decode(&b).unwrap_err()).id, 0);
    // The ends of the u64 range are ids like any other (echoed exactly, also above 2^53).
    for id in [0, 1, (1u64 << 53) + 1, u64::MAX] {
        let b = control_frame(&format!(r#"{{"id":{id},"command":{{"op":"pause"}}}}"#));
        assert_eq!(ControlRequest::decode(&b).unwrap().id, id);
        // A request that fails for another reason still gets its id back.
        let bad = control_frame(&format!(r#"{{"id":{id},"command":{{"op":"explode"}}}}"#));
        let reply = ControlRequest::rejection(&bad, &ControlRequest::decode(&bad).unwrap_err());
        assert_eq!(reply.id, id);
    }
}

#[test]
fn flags_error_names_the_current_version() {
    let text = FrameError::Flags { found: 1 }.to_string();
    assert!(text.ends_with(&format!("must be 0 in version {FORMAT_VERSION})")), "{text}");
}
