//! The `pivotsim-server solve` command as a user runs it: JSON keys, solution file, located errors.

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pivotsim-server"))
}

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/scene-shaped/scene-crane430.txt")
}

#[test]
fn solve_json_has_the_documented_keys_and_writes_the_solution() {
    let dir = std::env::temp_dir().join(format!("pivotsim-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sol = dir.join("lambda.txt");
    let out = bin()
        // Cold, this island needs 34 pivot steps from all-free and 64 from the interior point start:
        // a cap above both, so the test is about the output, not the start.
        .args([
            "solve",
            example().to_str().unwrap(),
            "--variant",
            "auto",
            "--max-steps",
            "200",
            "--json",
            "--solution",
        ])
        .arg(&sol)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The object is `SolveStats` as it serializes (plus the file): every field, under its name.
    let fields = serde_json::to_value(pivotsim_server::solver::SolveStats::default()).unwrap();
    for key in fields.as_object().unwrap().keys().map(String::as_str).chain(["file"]) {
        assert!(v.get(key).is_some(), "missing key {key}");
    }
    for key in
        ["m", "variant", "status", "pivot_steps", "tight", "residual_rel", "total_us", "bandwidth_after"]
    {
        assert!(v.get(key).is_some(), "missing documented key {key}");
    }
    assert_eq!(v["m"], 430);
    assert_eq!(v["variant"], "auto");
    assert_eq!(v["status"], "converged");
    assert!(v["residual_rel"].as_f64().unwrap() <= 1e-9);
    // The solution file holds λ in the problem's order: its residual must be the reported one.
    let text = std::fs::read_to_string(&sol).unwrap();
    let lambda = pivotsim_server::solver::io::parse_solution(&text).unwrap();
    let p = pivotsim_server::solver::io::read_mlcp_file(&example()).unwrap();
    let mut w = vec![0.0; p.n()];
    let (_, rel) = p.natural_residual(&lambda, &mut w);
    assert!((rel - v["residual_rel"].as_f64().unwrap()).abs() <= 1e-12);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn every_variant_name_is_accepted_and_unknown_ones_are_refused() {
    for v in ["full", "downdate", "skyline", "skyline-refactor", "incremental", "auto", "pgs"] {
        let out =
            bin().args(["solve", example().to_str().unwrap(), "--variant", v, "--json"]).output().unwrap();
        assert!(out.status.success(), "{v}: {}", String::from_utf8_lossy(&out.stderr));
    }
    let out = bin().args(["solve", example().to_str().unwrap(), "--variant", "dantzig"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("dantzig"));
}

#[test]
fn a_broken_file_is_a_located_error() {
    let dir = std::env::temp_dir().join(format!("pivotsim-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.txt");
    std::fs::write(&bad, "# comment\n2 0\n1 0\n0 x\n1 1\n0 0\ninf inf\n-1 -1\n").unwrap();
    let out = bin().args(["solve", bad.to_str().unwrap()]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 4"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pattern_writes_an_svg_with_the_reordered_bandwidth() {
    let out = std::env::temp_dir().join(format!("pivotsim-cli-pattern-{}.svg", std::process::id()));
    let o = bin().args(["pattern", example().to_str().unwrap(), "--out"]).arg(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("bandwidth 425→28"), "{text}");
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(svg.starts_with("<svg"));
    std::fs::remove_file(&out).ok();
}
