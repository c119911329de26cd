//! The shipped access-control configuration (`deploy/zenoh/server-acl.json5`) on a live server
//! over Zenoh on loopback, world `bay2`, only configuration changed: a peer without credentials
//! cannot reach the server; an observer reads the scene but its control request is refused (Zenoh
//! ends the query at once without a reply, and the world is not paused); `operator-bay1`'s inputs
//! for `bay2` (another machine) are refused, never applied and counted as `other` in the stats
//! frame, once each; `operator-bay2`'s are applied; no peer reads the server's adminspace; the
//! instructor pauses and steps the world. Every wait is bounded.

#![cfg(feature = "live")]

use std::path::PathBuf;
use std::time::{Duration, Instant};

use pivotsim_link::zenoh_config::ZenohEndpoints;
use pivotsim_msgs as msgs;
use pivotsim_tests::{Server, temp_file};
use zenoh::Wait;

fn deploy(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../deploy/zenoh").join(file)
}

/// The shipped server configuration with its dictionary found from here (the file names it
/// relative to the repository root, where the README runs the server).
fn server_config() -> PathBuf {
    let text = std::fs::read_to_string(deploy("server-acl.json5")).unwrap();
    let dict = deploy("credentials.txt").canonicalize().unwrap();
    let text = text.replace("\"deploy/zenoh/credentials.txt\"", &format!("{:?}", dict.display().to_string()));
    temp_file("acl-server.json5", &text)
}

/// A session as `role` (a shipped client file), or without credentials (`None`).
fn session(server: &Server, role: Option<&str>) -> zenoh::Session {
    let e = ZenohEndpoints {
        config_file: role.map(|r| deploy(&format!("client-{r}.json5"))),
        ..ZenohEndpoints::client(vec![server.endpoint.clone()])
    };
    zenoh::open(e.config().unwrap()).wait().unwrap()
}

/// The scene description, waiting up to 5 s for the session to be admitted.
fn scene(server: &Server, s: &zenoh::Session, within: Duration) -> Option<msgs::SceneDescription> {
    let end = Instant::now() + within;
    while Instant::now() < end {
        if let Some(d) = server.scene(s) {
            return Some(d);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    None
}

/// A control request's reply, or `None` when none came within 1.5 s.
fn control(
    server: &Server,
    s: &zenoh::Session,
    id: u64,
    command: msgs::ControlCommand,
) -> Option<msgs::ControlReply> {
    let mut buf = Vec::new();
    msgs::ControlRequest { id, command }.encode(&mut buf).unwrap();
    let replies = s
        .get(server.key(msgs::Topic::Control))
        .payload(buf)
        .timeout(Duration::from_millis(1500))
        .wait()
        .unwrap();
    let reply = replies.recv_timeout(Duration::from_secs(2)).ok().flatten()?;
    msgs::ControlReply::decode(&reply.result().ok()?.payload().to_bytes()).ok()
}

fn winch(seq: u64, source: u32) -> Vec<u8> {
    let mut buf = Vec::new();
    msgs::InputCommand::Winch(msgs::WinchCommand {
        sequence: seq,
        source_id: source,
        actuator: msgs::ActuatorName::new("winch").unwrap(),
        drum_speed: 1.0,
    })
    .encode(&mut buf)
    .unwrap();
    buf
}

/// The latest stats frame seen within 2 s.
fn stats(server: &Server, s: &zenoh::Session) -> msgs::SolverStats {
    let sub = s.declare_subscriber(server.key(msgs::Topic::Stats)).wait().unwrap();
    let sample = sub.recv_timeout(Duration::from_secs(2)).unwrap().expect("a stats frame");
    msgs::SolverStats::decode(&sample.payload().to_bytes()).unwrap()
}

/// Inputs of `operator-bay1` sent to `bay2`.
const REFUSED: u64 = 10;

/// The first stats frame whose input counters hold at least `n` rejections, waiting up to
/// `within` (stats frames at 60 Hz); the last frame seen when none does.
fn counted(server: &Server, s: &zenoh::Session, n: u64, within: Duration) -> msgs::SolverStats {
    let sub = s.declare_subscriber(server.key(msgs::Topic::Stats)).wait().unwrap();
    let end = Instant::now() + within;
    let mut last = None;
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        let Ok(Some(sample)) = sub.recv_timeout(left) else { break };
        let st = msgs::SolverStats::decode(&sample.payload().to_bytes()).unwrap();
        if st.inputs.rejected_total() >= n {
            return st;
        }
        last = Some(st);
    }
    last.expect("a stats frame")
}

/// Puts `n` winch inputs from `s` on `key`, 20 ms apart.
fn put_inputs(s: &zenoh::Session, key: &str, source: u32, n: u64) {
    let p = s.declare_publisher(key.to_string()).wait().unwrap();
    for k in 1..=n {
        p.put(winch(k, source)).wait().unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn roles_of_the_shipped_configuration_are_enforced_by_zenoh() {
    let config = server_config();
    let rig = temp_file("acl-rig.toml", include_str!("../../server/tests/support/rig.toml"));
    let server = Server::start_with(&rig.display().to_string(), "acl", move |c| {
        c.world = "bay2".into();
        c.iceoryx2 = false;
        c.zenoh.as_mut().unwrap().config_file = Some(config.clone());
    });
    let key = server.key(msgs::Topic::Winch);

    // No credentials: no connection, so nothing answers.
    let stranger = session(&server, None);
    assert!(
        scene(&server, &stranger, Duration::from_secs(1)).is_none(),
        "an unauthenticated peer was served"
    );

    let observer = session(&server, Some("observer"));
    let d = scene(&server, &observer, Duration::from_secs(5)).expect("the observer reads the scene");
    assert_eq!(d.scene, "rig");
    let t = Instant::now();
    let r = control(&server, &observer, 1, msgs::ControlCommand::Pause);
    let took = t.elapsed();
    assert!(r.is_none(), "an observer's control request was answered: {r:?}");
    // Refused, not lost: Zenoh finishes the query at once (no reply), well before its 1.5 s timeout.
    println!("the observer's refused control request ended after {took:?}");
    assert!(took < Duration::from_millis(1000), "the refused query ran into its timeout ({took:?})");

    let instructor = session(&server, Some("instructor"));
    scene(&server, &instructor, Duration::from_secs(5)).expect("the instructor reads the scene");
    // Still running: the observer's pause was not applied.
    let r = control(&server, &instructor, 2, msgs::ControlCommand::Step { count: 1 }).expect("a reply");
    assert!(
        matches!(&r.outcome, msgs::ControlOutcome::Error(f) if f.code == msgs::ControlErrorCode::Busy),
        "{r:?}"
    );
    assert_eq!(stats(&server, &instructor).inputs.accepted, 0);

    // An operator of bay1 drives bay2: refused by the rules, never applied, and counted as
    // `other` (read from Zenoh's access-control drop count within about a second).
    let bay1 = session(&server, Some("operator-bay1"));
    scene(&server, &bay1, Duration::from_secs(5)).expect("an operator reads the scene");
    let t = Instant::now();
    put_inputs(&bay1, &key, 11, REFUSED);
    let st = counted(&server, &instructor, REFUSED, Duration::from_secs(5));
    println!("{REFUSED} refused inputs counted {:?} after the first put", t.elapsed());
    assert_eq!(st.inputs.accepted, 0, "bay1's inputs reached bay2");
    assert_eq!(st.inputs.rejected_for(msgs::RejectReason::Other), REFUSED, "{:?}", st.inputs);
    assert_eq!(st.inputs.rejected_total(), REFUSED, "{:?}", st.inputs);
    // Counted once: another read of the drop count later adds nothing.
    std::thread::sleep(Duration::from_millis(1200));
    assert_eq!(stats(&server, &instructor).inputs.rejected_total(), REFUSED, "counted twice");

    // bay2's own operator drives it; its inputs are not counted as refused.
    let bay2 = session(&server, Some("operator-bay2"));
    scene(&server, &bay2, Duration::from_secs(5)).expect("an operator reads the scene");
    put_inputs(&bay2, &key, 12, 10);
    std::thread::sleep(Duration::from_millis(1200));
    let st = stats(&server, &instructor);
    assert!(st.inputs.accepted >= 5, "bay2's operator was not heard");
    assert_eq!(
        st.inputs.rejected_total(),
        REFUSED,
        "an allowed input was counted as refused: {:?}",
        st.inputs
    );

    // The server's adminspace (on for the count) is closed to peers, the instructor included.
    let seen = adminspace_seen(&instructor);
    assert!(seen.is_empty(), "a peer read the server's adminspace: {seen:?}");

    // The instructor steers.
    let r = control(&server, &instructor, 3, msgs::ControlCommand::Pause).expect("a reply");
    assert!(matches!(&r.outcome, msgs::ControlOutcome::Ok(s) if s.paused), "{r:?}");
    let r = control(&server, &instructor, 4, msgs::ControlCommand::Step { count: 2 }).expect("a reply");
    assert!(matches!(&r.outcome, msgs::ControlOutcome::Ok(_)), "{r:?}");
    server.stop();
}

/// On the same host iceoryx2 is protected by file permissions: its shared memory and the files
/// that describe its services are the server user's alone (`rw-------`; directories at most
/// `rwxr-x---`), so another user of the host can neither write inputs into the `cmd` service nor
/// open the frames. Checked on every resource a running server's world has while it serves.
#[test]
fn iceoryx2_resources_of_a_server_are_writable_by_its_user_only() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let since = std::time::SystemTime::now() - Duration::from_secs(1);
    let server = Server::start_with("pendulum", "iox-perm", |c| c.zenoh = None);
    std::thread::sleep(Duration::from_millis(300));
    let mut checked = 0;
    let mut bad = Vec::new();
    let mut walk = vec![PathBuf::from("/dev/shm"), PathBuf::from("/tmp/iceoryx2")];
    while let Some(p) = walk.pop() {
        let Ok(meta) = std::fs::symlink_metadata(&p) else { continue };
        if meta.is_dir() {
            if let Ok(rd) = std::fs::read_dir(&p) {
                walk.extend(rd.flatten().map(|e| e.path()));
            }
            continue;
        }
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        // iceoryx2's one host-wide segment, `iox2_…_node.<version>.global_mgmt` (16 bytes: the
        // counter that numbers nodes), is shared by every user on purpose (`rw-rw-rw-`); it holds
        // no service and no frame, so it is not a way in to a world's inputs.
        if name.ends_with(".global_mgmt") {
            continue;
        }
        let ours = p.starts_with("/tmp/iceoryx2") || name.starts_with("iox2_");
        let fresh = meta.modified().is_ok_and(|m| m >= since);
        if !(ours && fresh) {
            continue;
        }
        checked += 1;
        let mode = meta.permissions().mode() & 0o777;
        if mode & 0o077 != 0 {
            bad.push(format!("{} {mode:o} uid {}", p.display(), meta.uid()));
        }
    }
    server.stop();
    assert!(checked > 0, "no iceoryx2 resource found to check");
    assert!(bad.is_empty(), "resources open to other users: {bad:?}");
}

/// What a peer (here the instructor) reads of a server's adminspace: the keys of the replies to
/// `@/**` that are not its own session's.
fn adminspace_seen(s: &zenoh::Session) -> Vec<String> {
    let replies = s.get("@/**").timeout(Duration::from_millis(500)).wait().unwrap();
    let own = format!("@/{}/", s.zid());
    let mut seen = Vec::new();
    while let Ok(Some(r)) = replies.recv_timeout(Duration::from_secs(1)) {
        if let Ok(sample) = r.result()
            && !sample.key_expr().as_str().starts_with(&own)
        {
            seen.push(sample.key_expr().to_string());
        }
    }
    seen
}

/// The server opens its adminspace (read) to count refused puts. Zenoh's access control applies
/// to a peer's queries on `@/**` like any other: with the shipped file's default changed to
/// `allow`, the `adminspace` deny rule alone keeps every peer out (a deny rule wins); without it
/// the same peer reads the server's whole adminspace (metrics, declarations, links), which shows
/// the query does reach the server.
#[test]
fn the_adminspace_rule_closes_the_servers_adminspace_to_every_peer() {
    let shipped = std::fs::read_to_string(server_config()).unwrap();
    let allow = shipped.replace("default_permission: \"deny\"", "default_permission: \"allow\"");
    assert_ne!(allow, shipped);
    let without_rule = allow.replace("\"serve\", \"adminspace\"]", "\"serve\"]");
    assert_ne!(without_rule, allow);
    for (tag, text, open) in [("acl-admin-rule", allow, false), ("acl-admin-none", without_rule, true)] {
        let config = temp_file(&format!("{tag}.json5"), &text);
        let server = Server::start_with("pendulum", tag, move |c| {
            c.world = "bay2".into();
            c.iceoryx2 = false;
            c.zenoh.as_mut().unwrap().config_file = Some(config.clone());
        });
        let instructor = session(&server, Some("instructor"));
        scene(&server, &instructor, Duration::from_secs(5)).expect("the instructor reads the scene");
        let seen = adminspace_seen(&instructor);
        server.stop();
        if open {
            assert!(seen.iter().any(|k| k.ends_with("/metrics")), "{tag}: {seen:?}");
        } else {
            assert!(seen.is_empty(), "{tag}: a peer read the server's adminspace: {seen:?}");
        }
    }
}
