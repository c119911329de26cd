//! `record`: poses, stats and operator inputs seen on the wire, into an MCAP file.
//!
//! **Format.** The channels of `fox::topics` — the same topics and schemas as the live view
//! (`foxglove`), so one Foxglove layout opens both: the SDK's well-known protobuf schemas for the 3D
//! panel, JSON with a JSON schema for the rest; chunks are zstd-compressed.
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/pivotsim/poses` | `pivotsim.PoseFrame` (json) | sequence, sim time, wall time, every body (id, name, position, orientation, velocities) |
//! | `/pivotsim/stats` | `pivotsim.SolverStats` (json) | the stats frame, per-island records, input counters by reject reason |
//! | `/tf` | `foxglove.FrameTransforms` (protobuf) | `world` → body name transforms: the 3D panel shows every body's frame |
//! | `/pivotsim/scene` | `foxglove.SceneUpdate` (protobuf) | the bodies' shapes once at the start (when the server answers) |
//! | `/pivotsim/description` | `pivotsim.SceneDescription` (json) | the scene description once at the start (when the server answers) |
//! | `/pivotsim/signals` | `pivotsim.Signals` (json) | every signals frame: `values.<sensor>.<channel>` (null on a dropout), counters |
//! | `/pivotsim/contacts` | `pivotsim.Contacts` (json) | every signals frame: per contact the bodies, state, normal and friction force |
//! | `/pivotsim/contact_forces` | `foxglove.SceneUpdate` (protobuf) | every signals frame: the contact forces as arrows (the largest 0.5 m long) |
//! | `/pivotsim/events` | `pivotsim.Events` (json) | every events frame: name, kind, time, value, level per event |
//! | `/pivotsim/cmd/joystick` … `cmd/actuator` | `pivotsim.Joystick` … (json) | inputs, as seen (channel added at the first one) |
//! | `/pivotsim/wire/poses` | none, encoding `pivotsim-wire` | every pose frame byte for byte (for `pivotsim-server replay` to compare) |
//! | `/pivotsim/wire/applied` | none, encoding `pivotsim-wire` | the server's applied frames (Zenoh): what changed the world before each step |
//! | `/pivotsim/wire/keyframes` | none, encoding `pivotsim-wire` | the server's keyframes (Zenoh): snapshots every few seconds and at new scene states |
//!
//! **Replay.** The last three channels are the wire frames as published (`msgs/README.md`,
//! "Journal"); `pivotsim-server replay FILE.mcap` reproduces the session from them bit for bit.
//! Over Zenoh the recorder asks the server for a keyframe when it starts (control op `keyframe`),
//! so the replay can start at the recording's beginning; over iceoryx2 there is no journal.
//!
//! Faults sent live (`pivotsim-client fault`) are in the recording as `fault` events with their
//! sim time, and their effect (a dropout, a parted rope's tension) in the signals: a recording
//! replays them.
//!
//! The world is in the metadata record `pivotsim` (with the transport, scene, timestep and clock),
//! not in the topics. The message sequence is the step number for poses, stats and transforms, a
//! counter for inputs.
//!
//! **Clocks.** Log time is always the receive time, so it never runs backwards, not even across a
//! `reset` or a `load_scene` (a player orders by log time). The publish time and the header stamps
//! inside messages (`/tf`, the scene, the contact arrows) follow `--clock`: `sim` (the default)
//! is the frame's simulation time, as the ROS 2 bridge stamps `/tf` and `/clock` and as the live
//! view stamps by default, so a recording overlays a `ros2 bag` of the bridge (whose log time is
//! also its receive time) and a recording of the live view; `wall` is the server's `wall_time_ns`
//! for poses and transforms and the receive time for the rest. Inputs carry no simulation time:
//! their publish time is the receive time under both clocks.
//!
//! **Which inputs are seen.** iceoryx2: every input published on the host's `cmd` service.
//! Zenoh: inputs of the peers this client is connected to; peers do not forward each other's
//! traffic, so inputs that other consoles send to the server are only seen when they also connect
//! to this recorder (`record --listen tcp/127.0.0.1:PORT`, the console `--connect` to both).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::fox::topics::{self, ChannelSpec};
use crate::fox::{self, Clock, frames, scene};
use crate::net::{Received, Stream, TransportKind};
use crate::stop::{interrupted, secs};
use crate::tojson;

/// `record` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output file (`.mcap`).
    pub file: PathBuf,
    /// Transport to record from.
    #[arg(long, value_enum, default_value = "zenoh")]
    pub transport: TransportKind,
    /// Stop after this many seconds (default: at Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Stop after this many pose frames.
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Leave out the `/tf` channel (`foxglove.FrameTransforms`).
    #[arg(long)]
    pub no_tf: bool,
    /// Publish times and header stamps: the simulation time (as the ROS 2 bridge and the live
    /// view) or the wall clock. Log time is the receive time under both.
    #[arg(long, value_enum, default_value = "sim")]
    pub clock: Clock,
}

struct Channels {
    poses: u16,
    stats: u16,
    tf: Option<u16>,
    signals: u16,
    contacts: u16,
    contact_forces: u16,
    events: u16,
    inputs: Vec<(Topic, u16)>,
    input_seq: u32,
    wire_poses: u16,
    wire_applied: u16,
    wire_keyframes: u16,
}

fn add_channel(w: &mut McapWriter, spec: &ChannelSpec) -> Result<u16> {
    let schema_id = w.add_schema(&spec.schema.name, &spec.schema.encoding, &spec.schema.data)?;
    Ok(w.add_channel(schema_id, &spec.topic, &spec.encoding, &BTreeMap::new())?)
}

/// A channel of wire frames, byte for byte (no schema: `msgs/README.md` is theirs).
fn wire_channel(w: &mut McapWriter, topic: &str) -> Result<u16> {
    Ok(w.add_channel(0, topic, msgs::RECORD_WIRE_ENCODING, &BTreeMap::new())?)
}

fn write(w: &mut McapWriter, channel: u16, seq: u32, log: u64, publish: u64, data: &[u8]) -> Result<()> {
    let header = mcap::records::MessageHeader {
        channel_id: channel,
        sequence: seq,
        log_time: log,
        publish_time: publish,
    };
    w.write_to_known_channel(&header, data)?;
    Ok(())
}

fn write_json(
    w: &mut McapWriter,
    channel: u16,
    seq: u32,
    log: u64,
    publish: u64,
    v: &serde_json::Value,
) -> Result<()> {
    write(w, channel, seq, log, publish, &serde_json::to_vec(v)?)
}

type McapWriter = mcap::Writer<BufWriter<File>>;

/// The file with its metadata (world, transport, scene, step) and the channels known from the
/// start: poses, stats, transforms (unless `--no-tf`) and the scene (written at once).
fn open_file(
    args: &Args,
    world: &msgs::WorldName,
    scene: Option<&msgs::SceneDescription>,
) -> Result<(McapWriter, Channels)> {
    let file = File::create(&args.file).with_context(|| format!("cannot create {}", args.file.display()))?;
    let mut w = mcap::Writer::with_options(
        BufWriter::new(file),
        mcap::WriteOptions::new().profile("").library(concat!("pivotsim-client ", env!("CARGO_PKG_VERSION"))),
    )?;
    let mut meta = BTreeMap::new();
    meta.insert("world".to_string(), world.to_string());
    meta.insert("transport".to_string(), format!("{:?}", args.transport).to_lowercase());
    meta.insert("clock".to_string(), format!("{:?}", args.clock).to_lowercase());
    if let Some(s) = scene {
        meta.insert("scene".to_string(), s.scene.clone());
        meta.insert("timestep".to_string(), s.timestep.to_string());
    }
    w.write_metadata(&mcap::records::Metadata { name: "pivotsim".into(), metadata: meta })?;
    let mut ch = Channels {
        poses: add_channel(&mut w, &topics::poses())?,
        stats: add_channel(&mut w, &topics::stats())?,
        tf: None,
        signals: add_channel(&mut w, &topics::signals())?,
        contacts: add_channel(&mut w, &topics::contacts())?,
        contact_forces: add_channel(&mut w, &topics::contact_forces())?,
        events: add_channel(&mut w, &topics::events())?,
        inputs: Vec::new(),
        input_seq: 0,
        wire_poses: wire_channel(&mut w, msgs::RECORD_TOPIC_POSES)?,
        wire_applied: wire_channel(&mut w, msgs::RECORD_TOPIC_APPLIED)?,
        wire_keyframes: wire_channel(&mut w, msgs::RECORD_TOPIC_KEYFRAMES)?,
    };
    if !args.no_tf {
        ch.tf = Some(add_channel(&mut w, &topics::tf())?);
    }
    if let Some(s) = scene {
        // Before the first frame: stamped at the scene's start on the simulation clock (the
        // entities are frame-locked, they follow their bodies' transforms).
        let now = crate::net::now_ns();
        let stamp = args.clock.stamp(0.0, now);
        let shapes = scene::scene_update(s, frames::timestamp(stamp));
        let id = add_channel(&mut w, &topics::scene())?;
        write(&mut w, id, 0, now, stamp, &topics::encode(&shapes.update))?;
        let id = add_channel(&mut w, &topics::description())?;
        write_json(&mut w, id, 0, now, stamp, &serde_json::to_value(s)?)?;
    }
    Ok((w, ch))
}

/// What was written so far.
#[derive(Debug, Default)]
struct Counts {
    poses: u64,
    stats: u64,
    signals: u64,
    events: u64,
    inputs: u64,
    applied: u64,
    keyframes: u64,
    malformed: u64,
}

/// The recording: the file, its channels and the counts.
struct Recorder<'a> {
    w: McapWriter,
    ch: Channels,
    scene: Option<&'a msgs::SceneDescription>,
    clock: Clock,
    n: Counts,
}

impl Recorder<'_> {
    /// A pose frame, and its transforms unless `--no-tf`.
    fn poses(&mut self, r: &Received) -> Result<bool> {
        let Ok(v) = msgs::PoseFrameView::parse(&r.bytes) else { return Ok(false) };
        let seq = v.sequence() as u32;
        let stamp = self.clock.stamp(v.sim_time(), v.wall_time_ns());
        let json = tojson::pose_json(&v, self.scene, |_| true);
        write_json(&mut self.w, self.ch.poses, seq, r.recv_ns, stamp, &json)?;
        write(&mut self.w, self.ch.wire_poses, seq, r.recv_ns, stamp, &r.bytes)?;
        if let Some(tf) = self.ch.tf {
            let tfs = topics::encode(&frames::frame_transforms_at(&v, self.scene, stamp));
            write(&mut self.w, tf, seq, r.recv_ns, stamp, &tfs)?;
        }
        self.n.poses += 1;
        Ok(true)
    }

    fn stats(&mut self, r: &Received) -> Result<bool> {
        let Ok(s) = msgs::SolverStats::decode(&r.bytes) else { return Ok(false) };
        let json = tojson::stats_json(&s);
        let stamp = self.clock.stamp(s.sim_time, r.recv_ns);
        write_json(&mut self.w, self.ch.stats, s.sequence as u32, r.recv_ns, stamp, &json)?;
        self.n.stats += 1;
        Ok(true)
    }

    /// A signals frame: its channels and its contact states.
    fn signals(&mut self, r: &Received) -> Result<bool> {
        let Ok(s) = msgs::SignalsFrame::decode(&r.bytes) else { return Ok(false) };
        let seq = s.sequence as u32;
        let stamp = self.clock.stamp(s.sim_time, r.recv_ns);
        let json = fox::signals::signals_json(&s);
        write_json(&mut self.w, self.ch.signals, seq, r.recv_ns, stamp, &json)?;
        let json = fox::signals::contacts_json(&s, self.scene);
        write_json(&mut self.w, self.ch.contacts, seq, r.recv_ns, stamp, &json)?;
        let arrows = topics::encode(&fox::signals::contact_forces(&s, frames::timestamp(stamp)));
        write(&mut self.w, self.ch.contact_forces, seq, r.recv_ns, stamp, &arrows)?;
        self.n.signals += 1;
        Ok(true)
    }

    fn events(&mut self, r: &Received) -> Result<bool> {
        let Ok(e) = msgs::EventsFrame::decode(&r.bytes) else { return Ok(false) };
        let json = fox::signals::events_json(&e);
        let stamp = self.clock.stamp(e.sim_time, r.recv_ns);
        write_json(&mut self.w, self.ch.events, e.sequence as u32, r.recv_ns, stamp, &json)?;
        self.n.events += 1;
        Ok(true)
    }

    /// An applied frame or a keyframe of the server's journal, as it came.
    fn journal(&mut self, r: &Received, keyframe: bool) -> Result<bool> {
        let (channel, seq) = match keyframe {
            true => match msgs::KeyframeView::parse(&r.bytes) {
                Ok(k) => (self.ch.wire_keyframes, k.sequence),
                Err(_) => return Ok(false),
            },
            false => match msgs::AppliedFrame::decode(&r.bytes) {
                Ok(a) => (self.ch.wire_applied, a.sequence),
                Err(_) => return Ok(false),
            },
        };
        write(&mut self.w, channel, seq as u32, r.recv_ns, r.recv_ns, &r.bytes)?;
        match keyframe {
            true => self.n.keyframes += 1,
            false => self.n.applied += 1,
        }
        Ok(true)
    }

    /// An input, on its topic's channel (added at its first message).
    fn input(&mut self, r: &Received) -> Result<bool> {
        let Ok(c) = msgs::InputCommand::decode(&r.bytes) else { return Ok(false) };
        let topic = crate::send::topic_of(&c);
        let id = match self.ch.inputs.iter().find(|(t, _)| *t == topic) {
            Some((_, id)) => *id,
            None => {
                let id = add_channel(&mut self.w, &topics::input(topic))?;
                self.ch.inputs.push((topic, id));
                id
            }
        };
        write_json(&mut self.w, id, self.ch.input_seq, r.recv_ns, r.recv_ns, &tojson::input_json(&c))?;
        self.ch.input_seq = self.ch.input_seq.wrapping_add(1);
        self.n.inputs += 1;
        Ok(true)
    }

    /// One received frame; `true` for a frame from the server (poses or stats).
    fn frame(&mut self, r: &Received) -> Result<bool> {
        let (from_server, ok) = match r.topic {
            Some(Topic::Poses) => (true, self.poses(r)?),
            Some(Topic::Stats) => (true, self.stats(r)?),
            Some(Topic::Signals) => (true, self.signals(r)?),
            Some(Topic::Events) => (true, self.events(r)?),
            Some(Topic::Applied) => (true, self.journal(r, false)?),
            Some(Topic::Keyframes) => (true, self.journal(r, true)?),
            Some(t) if Topic::INPUTS.contains(&t) => (false, self.input(r)?),
            _ => (false, false),
        };
        if !ok {
            self.n.malformed += 1;
        }
        Ok(from_server && ok)
    }
}

/// Runs `record`: the stream and the scene, the file, then frames until the end, the count,
/// Ctrl-C or a silence longer than `--timeout`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let world = common.world()?;
    let mut topics = vec![
        Topic::Poses,
        Topic::Stats,
        Topic::Signals,
        Topic::Events,
        Topic::Joystick,
        Topic::Winch,
        Topic::Boom,
        Topic::Actuator,
    ];
    if matches!(args.transport, TransportKind::Zenoh) {
        topics.extend([Topic::Applied, Topic::Keyframes]);
    }
    let stream =
        Stream::open(&common.server()?, args.transport, &topics, 8192, Duration::from_micros(500), None)?;
    let scene = crate::util::scene_best_effort(common, stream.zenoh(), common.timeout_or(2.0));
    if scene.is_none() {
        eprintln!("pivotsim-client: no scene description: bodies named by id, no scene channel");
    }
    let (w, ch) = open_file(args, &world, scene.as_ref())?;
    // A keyframe of the state now: the replay's starting point (best effort: an older server, or
    // one that does not answer, leaves the recording to the next periodic keyframe).
    if let Some(z) = stream.zenoh() {
        let req = msgs::ControlRequest {
            id: u64::from(crate::util::random_u32()),
            command: msgs::ControlCommand::Keyframe,
        };
        match z.control(&req, common.timeout_or(2.0)) {
            Ok(r) if matches!(r.outcome, msgs::ControlOutcome::Ok(_)) => {}
            Ok(r) => eprintln!("pivotsim-client: the server refused a keyframe: {:?}", r.outcome),
            Err(e) => eprintln!("pivotsim-client: no keyframe requested: {e:#}"),
        }
    }
    let mut rec = Recorder { w, ch, scene: scene.as_ref(), clock: args.clock, n: Counts::default() };
    let end = args.duration.map(|d| Instant::now() + secs(d));
    let idle = common.timeout.map(secs);
    let tty = std::io::stderr().is_terminal();
    let mut last_frame = Instant::now();
    let mut last_status = Instant::now();
    let start = Instant::now();
    let mut outcome = Ok(());
    eprintln!(
        "pivotsim-client: recording world `{world}` via {:?} into {} (Ctrl-C stops)",
        args.transport,
        args.file.display()
    );
    loop {
        if interrupted()
            || end.is_some_and(|e| Instant::now() >= e)
            || args.count.is_some_and(|c| rec.n.poses >= c)
        {
            break;
        }
        if let Some(idle) = idle
            && last_frame.elapsed() >= idle
        {
            outcome = Err(format!("no frames for {:.1} s", idle.as_secs_f64()));
            break;
        }
        if tty && last_status.elapsed() >= Duration::from_secs(1) {
            last_status = Instant::now();
            let n = &rec.n;
            eprint!(
                "\r{:6.1} s  poses {}  stats {}  signals {}  events {}  inputs {}  malformed {}  dropped {}   ",
                start.elapsed().as_secs_f64(),
                n.poses,
                n.stats,
                n.signals,
                n.events,
                n.inputs,
                n.malformed,
                stream.inbox.dropped()
            );
        }
        let Some(r) = stream.inbox.recv_timeout(Duration::from_millis(50)) else { continue };
        if rec.frame(&r)? {
            last_frame = Instant::now();
        }
    }
    rec.w.finish()?;
    let mut inner = rec.w.into_inner();
    inner.flush()?;
    if tty {
        eprintln!();
    }
    let n = &rec.n;
    eprintln!(
        "pivotsim-client: wrote {}: {} pose frames, {} stats, {} signals, {} events, {} inputs, {} applied, {} keyframes in {:.1} s ({} malformed skipped, {} dropped)",
        args.file.display(),
        n.poses,
        n.stats,
        n.signals,
        n.events,
        n.inputs,
        n.applied,
        n.keyframes,
        start.elapsed().as_secs_f64(),
        n.malformed,
        stream.inbox.dropped()
    );
    if let Err(e) = outcome {
        bail!("{e} (the file holds what came before)");
    }
    Ok(ExitCode::SUCCESS)
}
