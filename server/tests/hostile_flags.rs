//! Every numeric flag of every `pivotsim-server` subcommand, given hostile values (NaN, ±inf,
//! negative, zero, 1e-300, 1e300, past the integer range, not a number): the binary refuses them
//! with an error or gives them their documented meaning, and never panics. Serving runs use no
//! transport and a step cap, so every row ends by itself.

use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_pivotsim-server");

const HOSTILE_FLOATS: [&str; 10] = ["nan", "inf", "-inf", "-1", "0", "-0", "1e-300", "1e300", "1e309", "x"];
const HOSTILE_INTS: [&str; 6] = ["-1", "0", "1e3", "18446744073709551616", "nan", "x"];

fn data(file: &str) -> String {
    format!("{}/tests/data/{file}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn hostile_values_of_every_numeric_flag_never_panic() {
    let serve = ["serve", "--scene", "pendulum", "--no-zenoh", "--no-iceoryx2"];
    let problem = data("siconos/lcp_mmc.txt");
    let mut cases: Vec<Vec<&str>> = Vec::new();
    for v in HOSTILE_FLOATS {
        cases.push([&serve[..], &["--steps", "2", "--rtf", v]].concat());
        cases.push([&serve[..], &["--steps", "2", "--fast", "--status-interval", v]].concat());
        cases.push(vec!["run", "--scene", "pendulum", "--json", "--duration", v]);
        cases.push(vec!["solve", &problem, "--tol", v]);
        cases.push([&serve[..], &["--steps", "2", "--fast", "--max-solve-us", v]].concat());
    }
    // Scene directories that are none: missing, a file, a device, empty.
    for dir in ["/no/such/scene/dir", "/etc/hostname", "/dev/null", ""] {
        cases.push([&serve[..], &["--steps", "2", "--fast", "--scene-dir", dir]].concat());
    }
    // Scene overrides: a value the scene refuses, a key that names nothing, no `=`.
    for set in
        ["max_solve_us=-1", "max_solve_us=nan", "max_pivot_steps=0", "body.nobody.mass=1", "timestep", "="]
    {
        cases.push([&serve[..], &["--steps", "2", "--fast", "--set", set]].concat());
        cases.push(vec!["run", "--scene", "pendulum", "--json", "--duration", "0.1", "--set", set]);
    }
    for v in HOSTILE_INTS {
        cases.push([&serve[..], &["--steps", "2", "--fast", "--deadman-ms", v]].concat());
        cases.push([&serve[..], &["--fast", "--steps", v]].concat());
        cases.push([&serve[..], &["--steps", "2", "--fast", "--max-scene-bytes", v]].concat());
        for flag in ["--every", "--dump-hard"] {
            let dump = ["--dump-mlcp", "/nonexistent", flag, v];
            cases.push(
                [&["run", "--scene", "pendulum", "--json", "--duration", "0.1"][..], &dump[..]].concat(),
            );
        }
        cases.push(vec!["solve", &problem, "--max-steps", v]);
        cases.push([&serve[..], &["--steps", "2", "--fast", "--threads", v]].concat());
        cases.push(vec!["run", "--scene", "pendulum", "--json", "--duration", "0.1", "--threads", v]);
    }
    cases.push(vec!["run", "--scene", "pendulum", "--json", "--duration", "0.1", "--threads", "257"]);
    // The values the issue named, once more on their own: they panicked or were taken silently.
    cases.push([&serve[..], &["--steps", "1", "--rtf", "1e-300"]].concat());
    cases.push([&serve[..], &["--steps", "1", "--status-interval", "inf"]].concat());
    cases.push([&serve[..], &["--steps", "1", "--deadman-ms", "0"]].concat());
    pivotsim_tests::assert_no_panic(BIN, &cases, Duration::from_secs(20));
}

#[test]
fn the_hostile_values_named_in_the_issue_are_clear_errors() {
    let serve = ["serve", "--scene", "pendulum", "--no-zenoh", "--no-iceoryx2", "--steps", "1"];
    for (flag, value, says) in [
        ("--rtf", "1e-300", "step period"),
        ("--rtf", "nan", "finite number > 0"),
        ("--status-interval", "inf", "seconds"),
        ("--status-interval", "nan", "seconds"),
        ("--status-interval", "-1", "seconds"),
        ("--deadman-ms", "0", "0"),
        ("--threads", "0", "1 ..= 256"),
        ("--threads", "257", "1 ..= 256"),
    ] {
        let args: Vec<String> = serve.iter().chain(&[flag, value]).map(|s| s.to_string()).collect();
        let o = pivotsim_tests::run(BIN, &args, Duration::from_secs(20));
        assert!(matches!(o.code, Some(1 | 2)), "{flag} {value}: exit {:?}\n{}", o.code, o.stderr);
        assert!(
            o.stderr.contains(flag) || o.stderr.contains("real-time factor"),
            "{flag} {value}: {}",
            o.stderr
        );
        assert!(o.stderr.contains(says), "{flag} {value}: {}", o.stderr);
    }
}
