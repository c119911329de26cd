//! Actuator names: short ASCII identifiers that fit a fixed 32-byte wire field.
//!
//! A name is 1 to 32 bytes from `[A-Za-z0-9_.\-/]` (letters, digits, underscore, dot, hyphen,
//! slash). On the wire it occupies a 32-byte field: the name's bytes, then NUL (`0x00`) up to the
//! end of the field (no NUL when the name is exactly 32 bytes). A field whose first byte is NUL is
//! an empty name; a non-NUL byte after the first NUL is an error, so each name has exactly one
//! encoding. The same rules apply to the actuator names of the scene description.

use std::fmt;

/// Bytes of the wire field, and longest name.
pub const MAX_ACTUATOR_NAME_LEN: usize = 32;

/// Why a string or wire field is not a valid actuator name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameError {
    /// No characters.
    #[error("empty actuator name")]
    Empty,
    /// More than [`MAX_ACTUATOR_NAME_LEN`] bytes.
    #[error("actuator name of {len} bytes (at most {MAX_ACTUATOR_NAME_LEN})")]
    TooLong {
        /// Length in bytes.
        len: usize,
    },
    /// A byte outside `[A-Za-z0-9_.\-/]`.
    #[error("byte 0x{byte:02x} at {index} is not allowed in an actuator name")]
    InvalidChar {
        /// Byte offset in the name.
        index: usize,
        /// The byte.
        byte: u8,
    },
    /// A non-NUL byte after the terminating NUL of a wire field.
    #[error("non-NUL byte after the end of the name at field offset {index}")]
    Padding {
        /// Offset in the 32-byte field.
        index: usize,
    },
}

/// Whether `b` may appear in an actuator name.
#[inline]
pub fn is_name_byte(b: u8) -> bool {
    b.is_ascii_alphanumeric() || matches!(b, b'_' | b'.' | b'-' | b'/')
}

/// Checks `s` against the actuator name rules.
pub fn validate_actuator_name(s: &str) -> Result<(), NameError> {
    let b = s.as_bytes();
    if b.is_empty() {
        return Err(NameError::Empty);
    }
    if b.len() > MAX_ACTUATOR_NAME_LEN {
        return Err(NameError::TooLong { len: b.len() });
    }
    match b.iter().position(|&c| !is_name_byte(c)) {
        Some(index) => Err(NameError::InvalidChar { index, byte: b[index] }),
        None => Ok(()),
    }
}

/// A valid actuator name stored inline (`Copy`, no allocation).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct ActuatorName {
    field: [u8; MAX_ACTUATOR_NAME_LEN],
    len: u8,
}

impl ActuatorName {
    /// Checks and stores `s`.
    pub fn new(s: &str) -> Result<ActuatorName, NameError> {
        validate_actuator_name(s)?;
        let mut field = [0u8; MAX_ACTUATOR_NAME_LEN];
        field[..s.len()].copy_from_slice(s.as_bytes());
        Ok(ActuatorName { field, len: s.len() as u8 })
    }

    /// Reads a NUL-padded wire field.
    pub fn from_field(field: &[u8; MAX_ACTUATOR_NAME_LEN]) -> Result<ActuatorName, NameError> {
        let len = field.iter().position(|&b| b == 0).unwrap_or(MAX_ACTUATOR_NAME_LEN);
        if let Some(i) = field[len..].iter().position(|&b| b != 0) {
            return Err(NameError::Padding { index: len + i });
        }
        if len == 0 {
            return Err(NameError::Empty);
        }
        if let Some(index) = field[..len].iter().position(|&c| !is_name_byte(c)) {
            return Err(NameError::InvalidChar { index, byte: field[index] });
        }
        Ok(ActuatorName { field: *field, len: len as u8 })
    }

    /// The NUL-padded wire field.
    #[inline]
    pub fn field(&self) -> &[u8; MAX_ACTUATOR_NAME_LEN] {
        &self.field
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        // Only ASCII bytes are ever stored, so this never takes the fallback.
        std::str::from_utf8(&self.field[..self.len as usize]).unwrap_or_default()
    }

    /// Length in bytes.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Always false (names are never empty); present for API symmetry.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl fmt::Debug for ActuatorName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ActuatorName({:?})", self.as_str())
    }
}

impl fmt::Display for ActuatorName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for ActuatorName {
    type Err = NameError;

    fn from_str(s: &str) -> Result<Self, NameError> {
        ActuatorName::new(s)
    }
}

impl TryFrom<&str> for ActuatorName {
    type Error = NameError;

    fn try_from(s: &str) -> Result<Self, NameError> {
        ActuatorName::new(s)
    }
}

impl PartialEq<str> for ActuatorName {
    fn eq(&self, other: &str) -> bool {
        self.as_str() == other
    }
}

impl PartialEq<&str> for ActuatorName {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_checks_every_rule() {
        assert_eq!(ActuatorName::new("boom/slew-1.a_b").unwrap().as_str(), "boom/slew-1.a_b");
        assert_eq!(ActuatorName::new(""), Err(NameError::Empty));
        assert_eq!(ActuatorName::new(&"a".repeat(33)), Err(NameError::TooLong { len: 33 }));
        assert!(ActuatorName::new(&"a".repeat(32)).is_ok());
        assert_eq!(ActuatorName::new("a b"), Err(NameError::InvalidChar { index: 1, byte: b' ' }));
        assert!(matches!(ActuatorName::new("é"), Err(NameError::InvalidChar { index: 0, .. })));
    }

    #[test]
    fn field_round_trip_and_padding() {
        let n = ActuatorName::new("winch").unwrap();
        let f = *n.field();
        assert_eq!(&f[..6], b"winch\0");
        assert_eq!(ActuatorName::from_field(&f), Ok(n));
        let full = ActuatorName::new(&"z".repeat(32)).unwrap();
        assert_eq!(ActuatorName::from_field(full.field()), Ok(full));
        let mut bad = f;
        bad[10] = b'x';
        assert_eq!(ActuatorName::from_field(&bad), Err(NameError::Padding { index: 10 }));
        assert_eq!(ActuatorName::from_field(&[0; 32]), Err(NameError::Empty));
        let mut ctl = f;
        ctl[1] = 0x01;
        assert_eq!(ActuatorName::from_field(&ctl), Err(NameError::InvalidChar { index: 1, byte: 1 }));
    }
}
