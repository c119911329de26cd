//! `lockstep`: a controller in the loop that owns the clock — the closed-loop example to copy, and
//! the lockstep benchmark (round trips per second, latency of each round trip).
//!
//! ```text
//! pause ─▶ read the paused state's pose
//! repeat N times:
//!     u = gain · (target − measured)       measured: a body's coordinate from the last pose frame
//!     send u to the actuator               (an actuator command, in the actuator's mode)
//!     step 1 ─▶ reply: sequence S          (the server applies u at that step, then publishes)
//!     read the pose frame with sequence S  (it left the server before the reply)
//! ```
//!
//! The server takes the step only when asked, so the controller may take as long as it likes
//! between steps and the simulation never runs ahead of it; inputs sent before a `step` request
//! apply from that step (`msgs/README.md`, "Lockstep"). Over Zenoh the controller holds the
//! liveliness token `pivotsim/<world>/controller/c<id>` while it runs (`<id>` its input source
//! id), and over iceoryx2 its node bears that name, so the server can tell when it disappears. Over iceoryx2 (same host) the requests go to the
//! world's request-response service `pivotsim/<world>/control`, inputs to `…/cmd`, and the pose
//! frames are read from `…/poses` right after the reply, without a thread in between.
//!
//! Defaults fit the scene's description (read over Zenoh, waiting at most 1 s when the transport
//! is iceoryx2): the actuator is the first of the scene in velocity mode (else the first), the
//! body the child of the joint it drives, the measured coordinate the rotation about world y
//! (`pitch`, the pendulum's swing). Every run is bounded by `--steps` and `--max-seconds`.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;
use zenoh::Wait;

use crate::common::Common;
use crate::control::fresh_id;
use crate::control_link::{IoxControl, NAP, SPIN};
use crate::net::{Inbox, IoxInputs, TransportKind, ZenohLink, inbox, now_ns, wait_iox_subscriber};
use crate::stop::{interrupted, secs};
use crate::util::{percentile, random_u32, scene_best_effort};

/// `lockstep` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Transport of the requests, inputs and pose frames.
    #[arg(long, value_enum, default_value = "zenoh")]
    pub transport: TransportKind,
    /// Round trips (steps) to take.
    #[arg(long, default_value_t = 1000, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=100_000_000))]
    pub steps: u64,
    /// Stop after this many seconds even if steps are left.
    #[arg(long, default_value_t = 120.0, value_name = "SECONDS")]
    pub max_seconds: f64,
    /// Actuator the controller drives (default: the scene's first velocity actuator).
    #[arg(long, value_name = "NAME")]
    pub actuator: Option<String>,
    /// Body whose coordinate is measured, by name or id (default: the child of the actuator's
    /// joint).
    #[arg(long, value_name = "NAME|ID")]
    pub body: Option<String>,
    /// Coordinate measured: a position (x, y, z; m) or the rotation about a world axis (roll: x,
    /// pitch: y, yaw: z; rad).
    #[arg(long, value_enum, default_value = "pitch")]
    pub measure: Measure,
    /// Set point of the measured coordinate.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "VALUE")]
    pub target: f64,
    /// Proportional gain: command = gain · (target − measured), clamped to the actuator's limits.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_name = "K")]
    pub gain: f64,
    /// Round trips left out of the latency figures (warm-up).
    #[arg(long, default_value_t = 10, value_name = "N")]
    pub warmup: u64,
    /// Print a line every N steps (0: only the summary).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub every: u64,
    /// Resume real time at the end (default: the world stays paused).
    #[arg(long)]
    pub resume: bool,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// A coordinate of a body's pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Measure {
    /// Position x (m).
    X,
    /// Position y (m).
    Y,
    /// Position z (m).
    Z,
    /// Rotation about world x (rad).
    Roll,
    /// Rotation about world y (rad).
    Pitch,
    /// Rotation about world z (rad).
    Yaw,
}

impl Measure {
    /// The coordinate of `pose`; angles are the twist about the world axis, in (−π, π].
    pub fn of(self, pose: &msgs::BodyPose) -> f64 {
        let [x, y, z, w] = pose.orientation;
        let twist = |v: f64| wrap(2.0 * v.atan2(w));
        match self {
            Measure::X => pose.position[0],
            Measure::Y => pose.position[1],
            Measure::Z => pose.position[2],
            Measure::Roll => twist(x),
            Measure::Pitch => twist(y),
            Measure::Yaw => twist(z),
        }
    }

    /// Whether the coordinate is an angle (errors wrap).
    pub fn is_angle(self) -> bool {
        matches!(self, Measure::Roll | Measure::Pitch | Measure::Yaw)
    }
}

/// An angle in (−π, π].
fn wrap(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let r = a.rem_euclid(TAU);
    if r > PI { r - TAU } else { r }
}

/// What the controller drives and reads.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Actuator commanded.
    pub actuator: msgs::ActuatorName,
    /// The command's mode (the actuator's).
    pub mode: msgs::ActuatorMode,
    /// The range the command is clamped to, if the scene gives one.
    pub limits: Option<[f64; 2]>,
    /// Body measured.
    pub body: u32,
    /// Its name.
    pub body_name: String,
}

impl Plan {
    /// The actuator and body of `args`, with the scene's defaults when it is known.
    pub fn resolve(args: &Args, scene: Option<&msgs::SceneDescription>) -> Result<Plan> {
        let info = match (&args.actuator, scene) {
            (Some(n), Some(s)) => Some(s.actuator(n).ok_or_else(|| {
                let names: Vec<&str> = s.actuators.iter().map(|a| a.name.as_str()).collect();
                anyhow!("the scene has no actuator {n:?} (it has: {})", names.join(", "))
            })?),
            (None, Some(s)) => Some(
                s.actuators
                    .iter()
                    .find(|a| a.mode == msgs::ActuatorMode::Velocity)
                    .or_else(|| s.actuators.first())
                    .ok_or_else(|| anyhow!("the scene has no actuator to drive"))?,
            ),
            (Some(_), None) => None,
            (None, None) => {
                bail!("no scene description (is the server's Zenoh side up?): give --actuator and --body ID")
            }
        };
        let name = info.map_or_else(|| args.actuator.clone().unwrap_or_default(), |a| a.name.clone());
        let actuator = msgs::ActuatorName::new(&name).map_err(|e| anyhow!("actuator name {name:?}: {e}"))?;
        let (body, body_name) = match (&args.body, scene) {
            (Some(b), Some(s)) => {
                let found = s.bodies.iter().find(|x| &x.name == b || b.parse() == Ok(x.id));
                let found = found.ok_or_else(|| anyhow!("the scene has no body {b:?}"))?;
                (found.id, found.name.clone())
            }
            (Some(b), None) => {
                let id: u32 = b
                    .parse()
                    .map_err(|_| anyhow!("--body {b:?}: without a scene description, give the body's id"))?;
                (id, format!("body{id}"))
            }
            (None, Some(s)) => {
                let child = info.and_then(|a| a.joint.as_deref()).and_then(|j| s.joint(j)).map(|j| j.child);
                let found = child
                    .and_then(|id| s.body(id))
                    .or_else(|| s.bodies.iter().find(|b| b.kind == msgs::BodyKind::Dynamic))
                    .ok_or_else(|| anyhow!("the scene has no dynamic body to measure: give --body"))?;
                (found.id, found.name.clone())
            }
            (None, None) => bail!("no scene description: give --body ID"),
        };
        Ok(Plan {
            actuator,
            mode: info.map_or(msgs::ActuatorMode::Velocity, |a| a.mode),
            limits: info.and_then(|a| a.limits),
            body,
            body_name,
        })
    }

    /// The proportional command for `measured`: `gain · (target − measured)` (the error wrapped
    /// for angles), clamped to the limits; 0 when anything is not finite.
    pub fn command(&self, args: &Args, measured: f64) -> f64 {
        let mut e = args.target - measured;
        if args.measure.is_angle() {
            e = wrap(e);
        }
        let mut u = args.gain * e;
        if let Some([lo, hi]) = self.limits {
            u = u.clamp(lo, hi);
        }
        if u.is_finite() { u } else { 0.0 }
    }
}

type PoseSubscriber = Subscriber<ipc::Service, [u8], ()>;

/// The controller's side of one transport: control requests, one input topic, the pose stream.
enum Rig {
    Zenoh {
        link: ZenohLink,
        poses: Inbox,
        input: zenoh::pubsub::Publisher<'static>,
        _token: zenoh::liveliness::LivelinessToken,
    },
    Iox {
        control: IoxControl,
        poses: PoseSubscriber,
        inputs: IoxInputs,
        _poses_service: pivotsim_link::iox::ByteService,
    },
}

impl std::fmt::Debug for Rig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Rig::Zenoh { .. } => "Rig::Zenoh",
            Rig::Iox { .. } => "Rig::Iox",
        })
    }
}

/// The controller's token, `pivotsim/<world>/controller/c<source>`: its Zenoh liveliness token,
/// and over iceoryx2 its node's name.
fn controller_token(world: &msgs::WorldName, source: u32) -> Result<String> {
    let id =
        msgs::WorldName::new(format!("c{source}")).map_err(|e| anyhow!("controller id c{source}: {e}"))?;
    Ok(world.controller_token(&id))
}

impl Rig {
    fn open(common: &Common, transport: TransportKind, link: Option<ZenohLink>, source: u32) -> Result<Rig> {
        let world = common.world()?;
        let timeout = common.timeout_or(5.0);
        match transport {
            TransportKind::Zenoh => {
                let mut link = match link {
                    Some(l) => l,
                    None => common.open_zenoh()?,
                };
                let (tx, poses) = inbox(1024);
                link.subscribe_key(world.key(Topic::Poses), &tx)?;
                let input = link.input_publisher(Topic::Actuator, timeout)?;
                let token = link
                    .session()
                    .liveliness()
                    .declare_token(controller_token(&world, source)?)
                    .wait()
                    .map_err(|e| anyhow!("zenoh: cannot declare the controller's liveliness token: {e}"))?;
                Ok(Rig::Zenoh { link, poses, input, _token: token })
            }
            TransportKind::Iceoryx2 => {
                let control = IoxControl::open_as(&world, &controller_token(&world, source)?, timeout)?;
                let name = pivotsim_link::iox::service_name(&world, Topic::Poses)?;
                let service = pivotsim_link::iox::open_service(control.node(), &name)?;
                let poses = service
                    .subscriber_builder()
                    .buffer_size(msgs::IOX_SUBSCRIBER_BUFFER)
                    .create()
                    .map_err(|e| anyhow!("iceoryx2: cannot subscribe to {name}: {e:?}"))?;
                let inputs = IoxInputs::open(&world)?;
                wait_iox_subscriber(&inputs, timeout)?;
                Ok(Rig::Iox { control, poses, inputs, _poses_service: service })
            }
        }
    }

    fn request(&mut self, req: &msgs::ControlRequest, timeout: Duration) -> Result<msgs::ControlReply> {
        match self {
            Rig::Zenoh { link, .. } => link.control(req, timeout),
            Rig::Iox { control, .. } => control.request(req, timeout),
        }
    }

    fn send_input(&mut self, bytes: &[u8]) -> Result<()> {
        match self {
            Rig::Zenoh { input, .. } => {
                input.put(bytes.to_vec()).wait().map_err(|e| anyhow!("zenoh: put: {e}"))
            }
            Rig::Iox { inputs, .. } => match inputs.send(bytes)? {
                0 => bail!("iceoryx2: nobody subscribes to the cmd service (did the server stop?)"),
                _ => Ok(()),
            },
        }
    }

    /// Reads pose frames until the one of state `seq` (decoded into `frame`); older ones (a paused
    /// world's re-sends) are skipped, malformed ones counted in `malformed`.
    fn pose(
        &mut self,
        seq: u64,
        timeout: Duration,
        frame: &mut msgs::PoseFrame,
        malformed: &mut u64,
    ) -> Result<()> {
        let start = Instant::now();
        let deadline = start + timeout;
        let mut take = |bytes: &[u8]| -> Result<bool> {
            let Ok(view) = msgs::PoseFrameView::parse(bytes) else {
                *malformed += 1;
                return Ok(false);
            };
            let got = view.sequence();
            if got > seq {
                bail!(
                    "pose frame {got} arrived while waiting for {seq}: is another controller stepping the world?"
                );
            }
            if got < seq {
                return Ok(false);
            }
            frame.decode_into(bytes).map_err(|e| anyhow!("pose frame {seq}: {e}"))?;
            Ok(true)
        };
        loop {
            let now = Instant::now();
            if now >= deadline || interrupted() {
                bail!("no pose frame with sequence {seq} within {:.1} s", timeout.as_secs_f64());
            }
            match self {
                Rig::Zenoh { poses, .. } => {
                    if let Some(r) = poses.recv_timeout(deadline - now)
                        && take(&r.bytes)?
                    {
                        return Ok(());
                    }
                }
                Rig::Iox { poses, .. } => match poses.receive() {
                    Ok(Some(sample)) => {
                        if take(sample.payload())? {
                            return Ok(());
                        }
                    }
                    Ok(None) if now - start < SPIN => std::thread::yield_now(),
                    Ok(None) => std::thread::sleep(NAP),
                    Err(e) => bail!("iceoryx2: poses: {e:?}"),
                },
            }
        }
    }
}

fn ok_status(reply: msgs::ControlReply, what: &str) -> Result<msgs::ServerStatus> {
    match reply.outcome {
        msgs::ControlOutcome::Ok(s) => Ok(s),
        msgs::ControlOutcome::Error(f) => {
            let code = serde_json::to_value(f.code).ok().and_then(|v| v.as_str().map(String::from));
            bail!("{what}: the server refused ({}): {}", code.as_deref().unwrap_or("?"), f.message)
        }
    }
}

/// What a run measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Round trips completed.
    pub steps: u64,
    /// Wall time of those round trips (s).
    pub wall_s: f64,
    /// Round trip latencies after the warm-up (µs), sorted.
    pub latencies_us: Vec<f64>,
    /// Sequence of the first and last stepped state.
    pub sequences: (u64, u64),
    /// Simulation time at the end (s).
    pub sim_time: f64,
    /// Measured coordinate and last command at the end.
    pub measured: f64,
    /// Last command sent.
    pub command: f64,
    /// Island solves of all steps.
    pub island_solves: u64,
    /// Of them, solves that did not end converged.
    pub not_converged: u64,
    /// Largest relative residual of an island solve.
    pub max_residual_rel: f64,
    /// Malformed pose frames skipped.
    pub malformed: u64,
}

/// Runs `lockstep`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let timeout = common.timeout_or(5.0);
    let link = match args.transport {
        TransportKind::Zenoh => Some(common.open_zenoh()?),
        TransportKind::Iceoryx2 => None,
    };
    let scene = match &link {
        Some(l) => Some(l.scene(timeout)?),
        None => scene_best_effort(common, None, timeout.min(Duration::from_secs(1))),
    };
    let plan = Plan::resolve(args, scene.as_ref())?;
    let source = random_u32();
    let mut rig = Rig::open(common, args.transport, link, source)?;
    let summary = closed_loop(&mut rig, &plan, args, source, timeout)?;
    if args.resume {
        let req = msgs::ControlRequest { id: fresh_id(), command: msgs::ControlCommand::Resume };
        ok_status(rig.request(&req, timeout)?, "resume")?;
    }
    print_summary(&summary, &plan, args);
    Ok(ExitCode::SUCCESS)
}

/// Pauses the world, then runs the loop: command, step 1, read that step's pose.
fn closed_loop(rig: &mut Rig, plan: &Plan, args: &Args, source: u32, timeout: Duration) -> Result<Summary> {
    let mut id = fresh_id();
    let pause = msgs::ControlRequest { id, command: msgs::ControlCommand::Pause };
    let paused = ok_status(rig.request(&pause, timeout)?, "pause")?;
    let mut frame = msgs::PoseFrame { sequence: 0, sim_time: 0.0, wall_time_ns: 0, bodies: Vec::new() };
    let mut malformed = 0;
    rig.pose(paused.sequence, timeout, &mut frame, &mut malformed).context("the paused state's pose")?;
    let measure = |frame: &msgs::PoseFrame| -> Result<f64> {
        let b = frame.bodies.iter().find(|b| b.id == plan.body);
        b.map(|b| args.measure.of(b)).ok_or_else(|| anyhow!("the pose frame has no body {}", plan.body))
    };
    let mut measured = measure(&frame)?;
    let base = now_ns();
    let mut buf = Vec::with_capacity(128);
    let mut latencies = Vec::with_capacity(args.steps.min(1_000_000) as usize);
    let (mut last, mut command) = (paused.sequence, 0.0);
    let (mut island_solves, mut not_converged, mut max_residual) = (0u64, 0u64, 0.0f64);
    let mut sim_time = paused.sim_time;
    let limit = secs(args.max_seconds);
    let start = Instant::now();
    let mut done = 0;
    while done < args.steps && start.elapsed() < limit && !interrupted() {
        let t0 = Instant::now();
        command = plan.command(args, measured);
        let input = msgs::InputCommand::Actuator(msgs::ActuatorCommand {
            sequence: base + done,
            source_id: source,
            mode: plan.mode,
            actuator: plan.actuator,
            value: command,
        });
        input.encode(&mut buf).map_err(|e| anyhow!("input: {e}"))?;
        rig.send_input(&buf)?;
        id += 1;
        let step = msgs::ControlRequest { id, command: msgs::ControlCommand::Step { count: 1 } };
        let reply = rig.request(&step, timeout)?;
        if reply.id != id {
            bail!("reply id {} to request {id}", reply.id);
        }
        let s = ok_status(reply, "step")?;
        let report = s.steps.ok_or_else(|| anyhow!("the step reply carries no steps report"))?;
        if s.sequence != last + 1 || report.count != 1 {
            bail!(
                "step from sequence {last} gave sequence {} ({} step(s)): is another client stepping the world?",
                s.sequence,
                report.count
            );
        }
        last = s.sequence;
        sim_time = s.sim_time;
        island_solves += u64::from(report.island_solves);
        not_converged += u64::from(report.not_converged);
        max_residual = max_residual.max(report.max_residual_rel);
        rig.pose(s.sequence, timeout, &mut frame, &mut malformed)?;
        measured = measure(&frame)?;
        done += 1;
        if done > args.warmup {
            latencies.push(t0.elapsed().as_secs_f64() * 1e6);
        }
        if args.every > 0 && done % args.every == 0 && !args.json {
            println!(
                "step {done:>7}  seq {last}  t {sim_time:.4} s  {} {:?} {measured:+.5}  command {command:+.4}",
                plan.body_name, args.measure
            );
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    latencies.sort_by(f64::total_cmp);
    Ok(Summary {
        steps: done,
        wall_s,
        latencies_us: latencies,
        sequences: (paused.sequence + 1, last),
        sim_time,
        measured,
        command,
        island_solves,
        not_converged,
        max_residual_rel: max_residual,
        malformed,
    })
}

fn print_summary(s: &Summary, plan: &Plan, args: &Args) {
    let rate = s.steps as f64 / s.wall_s.max(1e-9);
    let (p50, p99, max) = (
        percentile(&s.latencies_us, 0.5),
        percentile(&s.latencies_us, 0.99),
        s.latencies_us.last().copied().unwrap_or(f64::NAN),
    );
    let transport = match args.transport {
        TransportKind::Zenoh => "zenoh",
        TransportKind::Iceoryx2 => "iceoryx2",
    };
    if args.json {
        let v = serde_json::json!({
            "transport": transport,
            "steps": s.steps,
            "wall_s": s.wall_s,
            "round_trips_per_s": rate,
            "latency_us": { "p50": p50, "p99": p99, "max": max, "samples": s.latencies_us.len() },
            "first_sequence": s.sequences.0,
            "last_sequence": s.sequences.1,
            "sim_time": s.sim_time,
            "actuator": plan.actuator.as_str(),
            "body": plan.body_name,
            "measured": s.measured,
            "target": args.target,
            "command": s.command,
            "island_solves": s.island_solves,
            "not_converged": s.not_converged,
            "max_residual_rel": s.max_residual_rel,
            "malformed_poses": s.malformed,
        });
        println!("{v}");
        return;
    }
    println!(
        "lockstep over {transport}: {} round trips in {:.3} s = {rate:.0} /s; round trip p50 {p50:.0} µs, p99 {p99:.0} µs, max {max:.0} µs ({} after {} warm-up)",
        s.steps,
        s.wall_s,
        s.latencies_us.len(),
        args.warmup.min(s.steps)
    );
    println!(
        "states {}..={} (consecutive), sim time {:.4} s; {} {:?} {:+.5} (target {:+.5}), last command {:+.4} to {}",
        s.sequences.0,
        s.sequences.1,
        s.sim_time,
        plan.body_name,
        args.measure,
        s.measured,
        args.target,
        s.command,
        plan.actuator.as_str()
    );
    println!(
        "steps: {} taken  island solves {}  not converged {}  max residual {:.3e}",
        s.steps, s.island_solves, s.not_converged, s.max_residual_rel
    );
    if s.malformed > 0 {
        println!("malformed pose frames skipped: {}", s.malformed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(q: [f64; 4]) -> msgs::BodyPose {
        msgs::BodyPose {
            id: 0,
            flags: 0,
            position: [1.0, 2.0, 3.0],
            orientation: q,
            linear_velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
        }
    }

    #[test]
    fn twist_angles_about_the_world_axes() {
        // A rotation by a about y: q = (0, sin a/2, 0, cos a/2); past π it wraps.
        for a in [-3.0, -1.0, 0.0, 0.5, 1.5, 3.1] {
            let q = [0.0, (a / 2.0f64).sin(), 0.0, (a / 2.0f64).cos()];
            assert!((Measure::Pitch.of(&pose(q)) - a).abs() < 1e-12, "{a}");
            assert!(Measure::Roll.of(&pose(q)).abs() < 1e-12);
        }
        let q = [0.0, 0.0, (2.0f64).sin(), (2.0f64).cos()]; // 4 rad about z
        assert!((Measure::Yaw.of(&pose(q)) - (4.0 - std::f64::consts::TAU)).abs() < 1e-12);
        assert_eq!(Measure::Z.of(&pose([0.0, 0.0, 0.0, 1.0])), 3.0);
    }

    #[test]
    fn the_command_is_proportional_clamped_and_finite() {
        use clap::Parser;
        #[derive(Debug, Parser)]
        struct T {
            #[command(flatten)]
            a: Args,
        }
        let t = T::parse_from(["t", "--target", "0.5", "--gain", "2", "--measure", "pitch"]);
        let mut plan = Plan {
            actuator: msgs::ActuatorName::new("a").unwrap(),
            mode: msgs::ActuatorMode::Velocity,
            limits: None,
            body: 0,
            body_name: "b".into(),
        };
        assert_eq!(plan.command(&t.a, 0.25), 0.5);
        // Angles: the short way round.
        assert!((plan.command(&t.a, 0.5 + std::f64::consts::TAU) - 0.0).abs() < 1e-12);
        plan.limits = Some([-0.1, 0.1]);
        // Errors of 1.5 rad either way (within ±π, so not wrapped): 2 · 1.5 clamped.
        assert_eq!(plan.command(&t.a, -1.0), 0.1);
        assert_eq!(plan.command(&t.a, 2.0), -0.1);
        assert_eq!(plan.command(&t.a, f64::NAN), 0.0);
    }
}
