//! The wall clock of the frames.

/// Nanoseconds since the UNIX epoch (0 if the system clock is before it).
pub fn wall_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_clock_is_after_2020_and_moves_forward() {
        let a = super::wall_ns();
        assert!(a > 1_577_836_800_000_000_000, "{a}");
        std::thread::sleep(std::time::Duration::from_millis(2));
        assert!(super::wall_ns() > a);
    }
}
