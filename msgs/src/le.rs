//! Little-endian reads and writes of fixed-width fields.
//!
//! Every binary field on the wire is little-endian and read through these helpers, never through a
//! pointer cast: the crate has no `unsafe`, and a buffer handed over by a transport need not be
//! aligned. Reads index a slice whose length the caller has checked against the layout, so a read
//! out of range is a bug of this crate (the fuzz tests would find it), never a property of the input.

/// Copies `N` bytes starting at `off`.
#[inline]
pub(crate) fn array<const N: usize>(b: &[u8], off: usize) -> [u8; N] {
    let mut a = [0u8; N];
    a.copy_from_slice(&b[off..off + N]);
    a
}

#[inline]
pub(crate) fn u16_at(b: &[u8], off: usize) -> u16 {
    u16::from_le_bytes(array(b, off))
}

#[inline]
pub(crate) fn u32_at(b: &[u8], off: usize) -> u32 {
    u32::from_le_bytes(array(b, off))
}

#[inline]
pub(crate) fn u64_at(b: &[u8], off: usize) -> u64 {
    u64::from_le_bytes(array(b, off))
}

#[inline]
pub(crate) fn f32_at(b: &[u8], off: usize) -> f32 {
    f32::from_le_bytes(array(b, off))
}

#[inline]
pub(crate) fn f64_at(b: &[u8], off: usize) -> f64 {
    f64::from_le_bytes(array(b, off))
}

/// Reads `N` consecutive `f64` starting at `off`.
#[inline]
pub(crate) fn f64s_at<const N: usize>(b: &[u8], off: usize) -> [f64; N] {
    std::array::from_fn(|i| f64_at(b, off + 8 * i))
}

/// Appends `x` to `buf`.
#[inline]
pub(crate) fn put_f64s(buf: &mut Vec<u8>, x: &[f64]) {
    for v in x {
        buf.extend_from_slice(&v.to_le_bytes());
    }
}

/// Overwrites the 4 bytes at `off` with `v`.
#[inline]
pub(crate) fn patch_u32(buf: &mut [u8], off: usize, v: u32) {
    buf[off..off + 4].copy_from_slice(&v.to_le_bytes());
}

/// Offset of the first non-zero byte of `b`, if any.
#[inline]
pub(crate) fn first_non_zero(b: &[u8]) -> Option<usize> {
    b.iter().position(|&x| x != 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_are_little_endian() {
        let b = [1u8, 2, 3, 4, 5, 6, 7, 8, 9];
        assert_eq!(u16_at(&b, 0), 0x0201);
        assert_eq!(u32_at(&b, 1), 0x0504_0302);
        assert_eq!(u64_at(&b, 1), 0x0908_0706_0504_0302);
        let mut v = Vec::new();
        put_f64s(&mut v, &[1.5, -2.0]);
        assert_eq!(f64s_at::<2>(&v, 0), [1.5, -2.0]);
        v.extend_from_slice(&0.25f32.to_le_bytes());
        assert_eq!(f32_at(&v, 16), 0.25);
        patch_u32(&mut v, 0, 0xdead_beef);
        assert_eq!(u32_at(&v, 0), 0xdead_beef);
        assert_eq!(first_non_zero(&[0, 0, 3]), Some(2));
    }
}
