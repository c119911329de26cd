//! Snapshots (`snapshot/`): a scene restored from a snapshot continues bit for bit as the run that
//! was never interrupted — every pose, every deterministic solver statistic, the signals and
//! events — on every shipped scene; a damaged, foreign or other-version snapshot is refused with a
//! typed error and leaves the scene untouched.
//!
//! The reference is the uninterrupted run itself, stepped side by side with the restored one.

use pivotsim_server::dynamics::{IslandStats, World};
use pivotsim_server::scene::{self, BUILTIN, FaultRequest, Scene};
use pivotsim_server::snapshot::{MAGIC, SNAPSHOT_FORMAT, Snapshot, SnapshotError};

/// Everything a step leaves that must repeat bit for bit: poses and velocities (as bits), the
/// islands' deterministic statistics (wall times excluded), the step's bookkeeping, the signals'
/// channels and the events.
fn fingerprint(s: &Scene) -> Vec<u64> {
    let w = &s.world;
    let mut out = vec![w.steps(), w.time().to_bits(), w.input_work().to_bits()];
    for b in w.bodies() {
        let (x, q, v, w) = (b.position(), b.orientation(), b.linvel(), b.angvel());
        let vs = x.iter().chain(q.coords.iter()).chain(v.iter()).chain(w.iter());
        out.extend(vs.map(|c| c.to_bits()));
    }
    for st in w.island_stats() {
        out.extend(island_fingerprint(st));
    }
    out.push(w.last_substeps() as u64);
    out.push(w.last_guard_projections() as u64);
    out.push(w.geometric_stiffness_resolves());
    out.extend(s.signals.values().iter().map(|v| v.to_bits()));
    out.extend(s.signals.valid().iter().map(|&v| v as u64));
    for e in s.signals.events() {
        out.extend([e.kind as u64, e.time.to_bits(), e.value.to_bits(), e.level.to_bits()]);
    }
    out.push(s.signals.events_total());
    out
}

fn island_fingerprint(st: &IslandStats) -> [u64; 12] {
    [
        st.island as u64,
        st.bodies as u64,
        st.rows as u64,
        st.nnz as u64,
        st.variant as u64,
        st.status as u64,
        st.fallback as u64,
        st.pivot_steps as u64,
        st.iterations as u64,
        st.tight as u64,
        st.residual.to_bits(),
        st.max_violation.to_bits(),
    ]
}

fn step_n(s: &mut Scene, n: u64) {
    for _ in 0..n {
        s.step().unwrap_or_else(|e| panic!("{}: step {} failed: {e}", s.name, s.world.steps()));
    }
}

fn steps_for(world: &World, seconds: f64) -> u64 {
    (seconds / world.settings().timestep).round() as u64
}

/// Runs `scene` to `at` seconds, snapshots it through bytes, and steps the original and a scene
/// built from the snapshot alone `after` more seconds side by side, comparing every step.
fn round_trip(name: &str, mut original: Scene, at: f64, after: f64) {
    let n = steps_for(&original.world, at);
    step_n(&mut original, n);
    let snap = Snapshot::capture(&original, None).expect("capture");
    let bytes = snap.to_bytes().expect("encode");
    // Equal states encode to equal bytes (maps sorted).
    assert_eq!(
        bytes,
        Snapshot::capture(&original, None).unwrap().to_bytes().unwrap(),
        "{name}: encoding is not canonical"
    );
    let mut restored = Snapshot::from_bytes(&bytes).expect("decode").to_scene().expect("restore");
    // The items' every field (model and state) agree at the restore point.
    assert_eq!(format!("{:?}", original.world.bodies()), format!("{:?}", restored.world.bodies()), "{name}");
    assert_eq!(format!("{:?}", original.world.joints()), format!("{:?}", restored.world.joints()), "{name}");
    assert_eq!(
        format!("{:?}", original.world.couplings()),
        format!("{:?}", restored.world.couplings()),
        "{name}"
    );
    assert_eq!(
        fingerprint_state(&original),
        fingerprint_state(&restored),
        "{name}: signals at the restore point"
    );
    let n = steps_for(&original.world, after);
    for k in 0..n {
        step_n(&mut original, 1);
        step_n(&mut restored, 1);
        let (a, b) = (fingerprint(&original), fingerprint(&restored));
        if a != b {
            let at = a.iter().zip(&b).position(|(x, y)| x != y).unwrap_or(a.len().min(b.len()));
            panic!(
                "{name}: restored run diverges {} steps after the snapshot at {at}/{} (t = {:.4} s)",
                k + 1,
                a.len(),
                original.world.time()
            );
        }
    }
}

/// The signals' channels and counters (without the world's step bookkeeping).
fn fingerprint_state(s: &Scene) -> Vec<u64> {
    let mut out: Vec<u64> = s.signals.values().iter().map(|v| v.to_bits()).collect();
    out.push(s.signals.events_total());
    out
}

#[test]
fn every_shipped_scene_restored_at_5_s_continues_bit_for_bit() {
    for b in BUILTIN {
        let scene = scene::load(b.name).expect("builtin loads");
        round_trip(b.name, scene, 5.0, 5.0);
    }
}

#[test]
fn a_snapshot_keeps_faults_requested_live_and_their_aftermath() {
    // A live break request with a tension trigger and a hose burst (not declared in the file),
    // snapshotted before and after they fire.
    let mut crane = scene::load("crane").unwrap();
    step_n(&mut crane, 60);
    let joint = crane.world.joints().iter().find(|j| j.is_enabled()).unwrap().name().to_string();
    let actuator = crane.controls.actuators()[0].name().to_string();
    let burst =
        FaultRequest { kind: "hose_burst".into(), target: actuator, tension: None, to: None, ramp: None };
    crane.request_fault(&burst).unwrap();
    let brk = FaultRequest { kind: "break".into(), target: joint, tension: Some(1e12), to: None, ramp: None };
    crane.request_fault(&brk).unwrap();
    round_trip("crane + live faults", crane, 0.0, 2.0);
}

#[test]
fn a_snapshot_at_time_zero_is_the_loaded_scene() {
    round_trip("forklift at 0", scene::load("forklift").unwrap(), 0.0, 1.0);
}

#[test]
fn a_snapshot_of_another_scene_is_refused_and_changes_nothing() {
    let mut winch = scene::load("winch").unwrap();
    step_n(&mut winch, 30);
    let snap = Snapshot::capture(&winch, None).unwrap();
    let mut crane = scene::load("crane").unwrap();
    let before = fingerprint(&crane);
    let err = snap.restore_into(&mut crane).unwrap_err();
    assert!(matches!(err, SnapshotError::OtherScene { .. }), "{err}");
    assert_eq!(before, fingerprint(&crane));
    // The same scene with an override is another scene too.
    let over = [scene::SceneOverride { key: "contact_compliance".into(), value: "1e-9".into() }];
    let mut other = scene::load_with("winch", &over).unwrap();
    assert!(matches!(snap.restore_into(&mut other), Err(SnapshotError::OtherScene { .. })));
}

#[test]
fn damaged_files_are_refused_with_typed_errors() {
    let mut s = scene::load("winch").unwrap();
    step_n(&mut s, 30);
    let bytes = Snapshot::capture(&s, None).unwrap().to_bytes().unwrap();
    assert!(matches!(Snapshot::from_bytes(b"hello"), Err(SnapshotError::NotASnapshot)));
    let mut other_version = bytes.clone();
    other_version[MAGIC.len()..MAGIC.len() + 4].copy_from_slice(&(SNAPSHOT_FORMAT + 1).to_le_bytes());
    assert!(
        matches!(Snapshot::from_bytes(&other_version), Err(SnapshotError::Format { found }) if found == SNAPSHOT_FORMAT + 1)
    );
    // Every cut is refused (never a panic), and so is a trailing byte.
    for cut in (MAGIC.len() + 4..bytes.len()).step_by(97) {
        assert!(Snapshot::from_bytes(&bytes[..cut]).is_err(), "cut at {cut} accepted");
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(matches!(Snapshot::from_bytes(&longer), Err(SnapshotError::Corrupt(_))));
    // Flipped bytes: refused or, where the value still decodes, restored only if it fits the
    // scene; a scene is never left half-restored.
    for at in (MAGIC.len() + 4..bytes.len()).step_by(211) {
        let mut bad = bytes.clone();
        bad[at] ^= 0xa5;
        if let Ok(snap) = Snapshot::from_bytes(&bad) {
            let mut fresh = scene::load("winch").unwrap();
            let before = fingerprint(&fresh);
            if snap.restore_into(&mut fresh).is_err() {
                assert_eq!(before, fingerprint(&fresh), "byte {at}: a refused restore changed the scene");
            }
        }
    }
}

#[test]
fn a_snapshot_file_round_trips_and_runs_from_its_own_scene_text() {
    let dir = std::env::temp_dir().join(format!("pivotsim-snapshot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("offshore.snap");
    let mut s = scene::load("offshore").unwrap();
    step_n(&mut s, 45);
    let snap = Snapshot::capture(&s, None).unwrap();
    snap.write(&path).unwrap();
    let back = Snapshot::read(&path).unwrap();
    assert_eq!(back.to_bytes().unwrap(), snap.to_bytes().unwrap());
    assert_eq!(back.steps(), 45);
    let mut r = back.to_scene().unwrap();
    step_n(&mut s, 10);
    step_n(&mut r, 10);
    assert_eq!(fingerprint(&s), fingerprint(&r));
    assert!(matches!(Snapshot::read(&dir.join("missing.snap")), Err(SnapshotError::Io { .. })));
    std::fs::remove_dir_all(&dir).ok();
}
