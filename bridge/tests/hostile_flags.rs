//! Every numeric flag of `pivotsim-ros2-bridge`, given hostile values (NaN, ±inf, negative, zero,
//! 1e-300, 1e300, past the integer range, not a number): refused with a clear error or taken with
//! its documented meaning, never a panic. No server runs: an accepted row waits for one and is
//! stopped at the harness's time limit.

use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_pivotsim-ros2-bridge");

#[test]
fn hostile_values_of_every_numeric_flag_never_panic() {
    let endpoint = pivotsim_tests::free_endpoint();
    let world = format!("hostile-{}", std::process::id());
    let base = ["--connect", &endpoint, "--world", &world, "--dds-interface", "127.0.0.1"];
    let mut rows: Vec<Vec<&str>> = Vec::new();
    for v in ["nan", "inf", "-1", "0", "1e-300", "1e300", "x"] {
        rows.push(vec!["--stats-rate", v]);
        rows.push(vec!["--log-interval", v]);
        rows.push(vec!["--force-scale", v]);
    }
    for v in ["-1", "65536", "1e3", "x"] {
        rows.push(vec!["--domain-id", v]);
    }
    for v in ["-1", "4294967296", "x"] {
        rows.push(vec!["--source-id", v]);
    }
    let cases: Vec<Vec<&str>> = rows.into_iter().map(|r| base.iter().copied().chain(r).collect()).collect();
    pivotsim_tests::assert_no_panic(BIN, &cases, Duration::from_secs(3));
}

#[test]
fn rates_and_intervals_out_of_range_are_clear_errors() {
    for (flag, v) in [
        ("--stats-rate", "1e-300"),
        ("--stats-rate", "nan"),
        ("--log-interval", "1e300"),
        ("--force-scale", "0"),
        ("--force-scale", "inf"),
        ("--force-scale", "-1"),
    ] {
        let args: Vec<String> = [flag, v].iter().map(|s| s.to_string()).collect();
        let o = pivotsim_tests::run(BIN, &args, Duration::from_secs(10));
        assert_eq!(o.code, Some(2), "{flag} {v}: {}", o.stderr);
        assert!(o.stderr.contains(flag), "{flag} {v}: {}", o.stderr);
    }
}
