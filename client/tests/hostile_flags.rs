//! Every numeric flag of every `pivotsim-client` command, given hostile values (NaN, ±inf,
//! negative, zero, 1e-300, 1e300, past the integer range, not a number), against a live server:
//! the client refuses them or gives them their documented meaning (a non-finite or negative
//! duration is zero, a huge one about a century; rates are clamped), and never panics. Every row
//! is bounded by a count, a duration or the harness's time limit.

mod common;

use std::time::Duration;

use common::{CLIENT, ClientOf, DRUM, Server};

const FLOATS: [&str; 7] = ["nan", "inf", "-1", "0", "1e-300", "1e300", "x"];
const INTS: [&str; 4] = ["-1", "0", "18446744073709551616", "x"];

#[test]
fn hostile_values_of_every_numeric_flag_never_panic() {
    let s = Server::start(DRUM, "hostile");
    let base = s.args();
    let dir = std::env::temp_dir().join(format!("pivotsim-client-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mcap = dir.join("h.mcap").display().to_string();
    let booms: Vec<String> = FLOATS.iter().map(|v| format!("winch={v}")).collect();
    let mut rows: Vec<Vec<&str>> = Vec::new();
    for (v, boom) in FLOATS.into_iter().zip(&booms) {
        rows.push(vec!["--timeout", v, "watch", "--count", "2", "--plain"]);
        rows.push(vec!["watch", "--count", "2", "--plain", "--duration", v]);
        rows.push(vec!["drive", "--axes", "0", "--duration", "0.3", "--rate", v]);
        rows.push(vec!["drive", "--axes", "0", "--duration", v]);
        rows.push(vec!["drive", "--duration", "0.2", "--axes", v]);
        rows.push(vec!["send", "--hold", v, "joystick", "--axes", "0"]);
        rows.push(vec!["send", "--hold", "0.2", "--rate", v, "joystick", "--axes", "0"]);
        rows.push(vec!["send", "winch", "winch", v]);
        rows.push(vec!["send", "actuator", "slide", v, "--mode", "position"]);
        rows.push(vec!["send", "boom", boom]);
        rows.push(vec!["record", &mcap, "--count", "2", "--duration", v]);
        rows.push(vec!["foxglove", "--port", "0", "--count", "2", "--duration", v]);
    }
    for v in INTS {
        rows.push(vec!["watch", "--duration", "1", "--plain", "--count", v]);
        rows.push(vec!["watch", "--count", "2", "--plain", "--max-bodies", v]);
        rows.push(vec!["drive", "--axes", "0", "--duration", "0.2", "--buttons", v]);
        rows.push(vec!["drive", "--axes", "0", "--duration", "0.2", "--source-id", v]);
        rows.push(vec!["send", "--source-id", v, "joystick", "--axes", "0"]);
        rows.push(vec!["send", "joystick", "--axes", "0", "--buttons", v]);
        rows.push(vec!["control", "step", v]);
        rows.push(vec!["record", &mcap, "--duration", "1", "--count", v]);
        rows.push(vec!["ping", "--count", v]);
        rows.push(vec!["ping", "--count", "5", "--warmup", v]);
        rows.push(vec!["ping", "--count", "5", "--poll-us", v]);
        rows.push(vec!["foxglove", "--port", "0", "--duration", "1", "--count", v]);
        rows.push(vec!["foxglove", "--duration", "0.5", "--port", v]);
    }
    for host in ["x", "", "999.1.1.1", "::1", "127.0.0.1:80"] {
        rows.push(vec!["foxglove", "--duration", "0.5", "--port", "0", "--host", host]);
    }
    let cases: Vec<Vec<&str>> =
        rows.into_iter().map(|r| base.iter().map(String::as_str).chain(r).collect()).collect();
    pivotsim_tests::assert_no_panic(CLIENT, &cases, Duration::from_secs(8));
    std::fs::remove_dir_all(&dir).ok();
}
