//! `pivotsim-server run` and `scenes` as a user runs them: the JSON summary's documented keys,
//! the stats and poses CSVs (one row per island per step, one per dynamic body per step), MLCP
//! dumps that read back as the islands' problems, and located errors for a broken scene file.

use std::path::PathBuf;
use std::process::Command;

use pivotsim_server::solver::io;
use pivotsim_tests::{temp_dir, temp_file};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pivotsim-server"))
}

#[test]
fn run_writes_the_summary_stats_poses_and_mlcp_dumps() {
    let dir = temp_dir("scene-cli-run");
    let (stats, poses, dump) = (dir.join("stats.csv"), dir.join("poses.csv"), dir.join("mlcp"));
    let out = bin()
        .args(["run", "--scene", "box_stack", "--duration", "1", "--json", "--every", "20"])
        .arg("--stats")
        .arg(&stats)
        .arg("--poses")
        .arg(&poses)
        .arg("--dump-mlcp")
        .arg(&dump)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "steps",
        "wall_s",
        "realtime_factor",
        "max_island_rows",
        "max_mass_ratio",
        "mean_solve_us",
        "p99_solve_us",
        "max_tight_fraction",
        "max_joint_error_m",
        "finite",
    ] {
        assert!(v.get(key).is_some(), "summary lacks `{key}`: {v}");
    }
    assert_eq!(v["steps"], 60);
    assert_eq!(v["finite"], true);
    assert_eq!(v["max_island_rows"], 120, "ten boxes, four corners each, three rows per corner");
    assert!((v["max_mass_ratio"].as_f64().unwrap() - 100.0).abs() < 1e-9);

    // Stats: one row per island per step; the box stack is one island.
    let mut r = csv::Reader::from_path(&stats).unwrap();
    let headers = r.headers().unwrap().clone();
    let col = |n: &str| headers.iter().position(|h| h == n).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 60);
    let last = &rows[59];
    assert_eq!(&last[col("step")], "60");
    assert_eq!(&last[col("rows")], "120");
    assert_eq!(&last[col("status")], "converged");

    // Poses: ten dynamic bodies per step, unit quaternions.
    let mut r = csv::Reader::from_path(&poses).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 600);
    for row in &rows {
        let q: Vec<f64> = (6..10).map(|i| row[i].parse().unwrap()).collect();
        assert!((q.iter().map(|c| c * c).sum::<f64>() - 1.0).abs() < 1e-12);
    }

    // Dumps at steps 1, 21, 41: each reads back as a 120-row problem.
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dump).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert_eq!(files.len(), 3, "{files:?}");
    assert_eq!(v["dumped"], 3);
    for f in files {
        let p = io::read_mlcp_file(&f).unwrap();
        assert_eq!(p.n(), 120, "{}", f.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn scenes_lists_every_builtin_and_a_broken_file_is_located() {
    let out = bin().arg("scenes").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for b in pivotsim_server::scene::BUILTIN {
        assert!(text.lines().any(|l| l.starts_with(b.name)), "{} missing from:\n{text}", b.name);
    }
    let f = temp_file(
        "scene-cli-broken.toml",
        "[scene]\nname = \"x\"\n[[body]]\nname = \"a\"\nmass = \"heavy\"\n",
    );
    let out = bin().args(["run", "--scene"]).arg(&f).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("{}:5:8", f.display())), "{err}");
    let out = bin().args(["run", "--scene", "no-such-scene"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("box_stack"), "lists the built-in names");
    let _ = std::fs::remove_file(&f);
}

/// The poses CSV rows of the steps after `step`.
fn pose_rows_after(path: &std::path::Path, step: u64) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .filter(|l| l.split(',').next().unwrap().parse::<u64>().unwrap() > step)
        .map(String::from)
        .collect()
}

#[test]
fn run_from_a_snapshot_repeats_the_uninterrupted_run_row_for_row() {
    let dir = temp_dir("scene-cli-snapshot");
    let (whole, rest, snap) = (dir.join("whole.csv"), dir.join("rest.csv"), dir.join("forklift.snap"));
    let out = bin()
        .args(["run", "--scene", "forklift", "--duration", "4", "--json", "--snapshot-at", "2.5"])
        .arg("--snapshot")
        .arg(&snap)
        .arg("--poses")
        .arg(&whole)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = bin()
        .args(["run", "--duration", "1.5", "--json", "--from"])
        .arg(&snap)
        .arg("--poses")
        .arg(&rest)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["steps"], 90);
    assert_eq!(v["stable"], true);
    let (a, b) = (pose_rows_after(&whole, 150), pose_rows_after(&rest, 150));
    assert!(a.len() >= 90 && a.len() % 90 == 0, "one row per dynamic body for each of steps 151..=240");
    assert_eq!(a, b, "the run from the snapshot differs from the uninterrupted run");

    // Bad input: a snapshot time outside the run, a missing or damaged file, --from with --set.
    let bad = |args: &[&str]| {
        let out = bin().args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let p = snap.to_str().unwrap();
    assert!(
        bad(&["run", "--scene", "forklift", "--duration", "1", "--snapshot-at", "5", "--snapshot", p])
            .contains("outside the run")
    );
    assert!(
        bad(&["run", "--scene", "forklift", "--duration", "1", "--snapshot-at", "NaN", "--snapshot", p])
            .contains("outside the run")
    );
    let missing = dir.join("missing.snap");
    assert!(bad(&["run", "--from", missing.to_str().unwrap()]).contains("missing.snap"));
    let garbage = dir.join("garbage.snap");
    std::fs::write(&garbage, b"PIVSNAP\0\x01\0\0\0garbage").unwrap();
    assert!(bad(&["run", "--from", garbage.to_str().unwrap()]).contains("damaged snapshot"));
    assert!(bad(&["run", "--from", p, "--set", "max_pivot_steps=5"]).contains("--set"));
    assert!(bad(&["run", "--snapshot-at", "1", "--scene", "forklift"]).contains("--snapshot"));
}
