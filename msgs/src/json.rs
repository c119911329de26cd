//! JSON payloads (kinds `0x0100..=0x01FF`): the low-rate messages in the same 16-byte header.
//!
//! The payload is one JSON object, UTF-8, no byte-order mark, no trailing data other than JSON
//! whitespace; objects with unknown fields are rejected. Numbers are finite (JSON has no NaN or
//! Inf); integers that a JavaScript client must read exactly stay below 2^53. A parse or schema
//! failure is [`FrameError::Json`]; the message's own rules are then checked with typed errors.

use crate::header::{self, FrameError, HEADER_LEN, Kind};

/// Clears `buf` and writes `value` as a frame of `kind`. Returns the payload length as the error
/// (and leaves `buf` empty) when it exceeds [`Kind::max_payload_len`].
pub(crate) fn encode<T: serde::Serialize>(buf: &mut Vec<u8>, kind: Kind, value: &T) -> Result<(), usize> {
    debug_assert!(kind.is_json());
    header::begin(buf, kind);
    // Serialising plain structs, enums, strings and numbers into a Vec cannot fail: there are no
    // maps with non-string keys, and the Vec's io::Write never errors.
    serde_json::to_writer(&mut *buf, value).expect("plain data serialises into a Vec");
    let len = buf.len() - HEADER_LEN;
    if len > kind.max_payload_len() {
        buf.clear();
        return Err(len);
    }
    header::set_payload_len(buf);
    Ok(())
}

/// Checks the header of `bytes` for `kind` and parses the JSON payload.
pub(crate) fn decode<'a, T: serde::Deserialize<'a>>(bytes: &'a [u8], kind: Kind) -> Result<T, FrameError> {
    let payload = header::expect(bytes, kind)?;
    serde_json::from_slice(payload).map_err(|e| FrameError::Json {
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize, serde::Deserialize, Debug, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct T {
        a: u32,
        b: String,
    }

    #[test]
    fn round_trip_and_errors() {
        let mut buf = Vec::new();
        let v = T { a: 1, b: "x".into() };
        encode(&mut buf, Kind::ControlRequest, &v).unwrap();
        assert_eq!(&buf[HEADER_LEN..], br#"{"a":1,"b":"x"}"#);
        assert_eq!(decode::<T>(&buf, Kind::ControlRequest), Ok(v));
        assert!(matches!(decode::<T>(&buf, Kind::ControlReply), Err(FrameError::WrongKind { .. })));
        let big = T { a: 1, b: "y".repeat(5000) };
        assert_eq!(encode(&mut buf, Kind::ControlRequest, &big), Err(5000 + 14));
        assert!(buf.is_empty());
        let mut bad = Vec::new();
        header::begin(&mut bad, Kind::ControlRequest);
        bad.extend_from_slice(br#"{"a":1,"b":"x","c":2}"#);
        header::set_payload_len(&mut bad);
        assert!(matches!(decode::<T>(&bad, Kind::ControlRequest), Err(FrameError::Json { line: 1, .. })));
    }
}
