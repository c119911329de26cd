//! `watch`: the live view. On a terminal a table redrawn in place (at most 10 times a second):
//! step, sim time, step time, per-island solver rows, input health, and a few body poses by name.
//! Otherwise (or with `--plain`) one line per step; `--json` prints one JSON object per step.
//!
//! A step is printed once its pose frame and its stats frame (same sequence) have both arrived, or
//! when the next pose frame comes first.

use std::io::{IsTerminal, Write};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use pivotsim_msgs as msgs;
use pivotsim_msgs::Topic;

use crate::common::Common;
use crate::net::{Stream, TransportKind, now_ns};
use crate::stop::{interrupted, secs};
use crate::tojson::{pose_json, stats_json};
use crate::util::{FrameCounts, body_name, euler_zyx};

/// `watch` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Transport to receive on.
    #[arg(long, value_enum, default_value = "zenoh")]
    pub transport: TransportKind,
    /// Stop after this many steps.
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Bodies to show, by name or id (default: the first `--max-bodies` dynamic bodies; all with
    /// `--json`).
    #[arg(long, value_delimiter = ',', value_name = "NAME,…")]
    pub bodies: Vec<String>,
    /// Bodies shown by default.
    #[arg(long, default_value_t = 4, value_name = "N")]
    pub max_bodies: usize,
    /// One line per step even on a terminal.
    #[arg(long)]
    pub plain: bool,
    /// One JSON object per step (stats and poses).
    #[arg(long, conflicts_with = "plain")]
    pub json: bool,
    /// Show the sensor channels, contact states and events (topics `signals`, `events`) instead.
    #[arg(long)]
    pub signals: bool,
}

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Table,
    Plain,
    Json,
}

impl Mode {
    /// JSON when asked for, else a table on a terminal unless `--plain`, else plain lines.
    fn of(args: &Args) -> Mode {
        let stdout_tty = std::io::stdout().is_terminal();
        if args.json {
            Mode::Json
        } else if args.plain || !stdout_tty {
            Mode::Plain
        } else {
            Mode::Table
        }
    }
}

struct View {
    mode: Mode,
    scene: Option<msgs::SceneDescription>,
    selected: Vec<u32>,
    /// The body count and scene name `selected` was chosen for.
    selected_for: Option<(usize, Option<String>)>,
    /// When the scene description was last asked for again.
    scene_tried: Instant,
    explicit: Vec<String>,
    max_bodies: usize,
    counts: FrameCounts,
    dropped: u64,
    last_draw: Option<Instant>,
    world: String,
    transport: TransportKind,
}

impl View {
    /// A view with no body selected yet and nothing counted.
    fn new(mode: Mode, scene: Option<msgs::SceneDescription>, common: &Common, args: &Args) -> View {
        View {
            mode,
            scene,
            selected: Vec::new(),
            selected_for: None,
            scene_tried: Instant::now(),
            explicit: args.bodies.clone(),
            max_bodies: args.max_bodies,
            counts: FrameCounts::default(),
            dropped: 0,
            last_draw: None,
            world: common.world.clone(),
            transport: args.transport,
        }
    }

    /// Chooses the bodies shown once the first pose frame (or a new scene) is known.
    fn select(&mut self, v: &msgs::PoseFrameView<'_>) {
        let scene = self.scene.as_ref();
        self.selected = if !self.explicit.is_empty() {
            self.explicit
                .iter()
                .filter_map(|s| {
                    scene
                        .and_then(|sc| sc.bodies.iter().find(|b| &b.name == s).map(|b| b.id))
                        .or_else(|| s.parse().ok())
                })
                .collect()
        } else if self.mode == Mode::Json {
            v.bodies().map(|b| b.id).collect()
        } else {
            v.bodies()
                .filter(|b| match scene.and_then(|s| s.body(b.id)) {
                    Some(info) => info.kind == msgs::BodyKind::Dynamic,
                    None => b.flags & (msgs::BODY_STATIC | msgs::BODY_KINEMATIC) == 0,
                })
                .take(self.max_bodies)
                .map(|b| b.id)
                .collect()
        };
    }

    fn emit(&mut self, pose: &[u8], stats: Option<&msgs::SolverStats>, last: bool) -> Result<()> {
        let Ok(v) = msgs::PoseFrameView::parse(pose) else { return Ok(()) };
        let mut out = std::io::stdout().lock();
        match self.mode {
            Mode::Json => {
                let sel = &self.selected;
                let mut j = pose_json(&v, self.scene.as_ref(), |b| sel.contains(&b.id));
                j["stats"] = stats.map_or(serde_json::Value::Null, stats_json);
                writeln!(out, "{j}")?;
            }
            Mode::Plain => {
                let mut line = format!("seq={} t={:.4}", v.sequence(), v.sim_time());
                if let Some(s) = stats {
                    line.push_str(&format!(
                        " step_us={:.1} islands={} rows={} pivots={} tight={} solve_us={:.1} accepted={} rejected={} deadman={}",
                        s.step_wall_us,
                        s.islands.len(),
                        s.totals.rows,
                        s.totals.pivot_steps,
                        s.totals.tight,
                        s.totals.solve_us,
                        s.inputs.accepted,
                        s.inputs.rejected_total(),
                        if s.inputs.deadman_active { "active" } else { "off" },
                    ));
                }
                for id in &self.selected {
                    if let Some(b) = v.bodies().find(|b| b.id == *id) {
                        let p = b.position;
                        line.push_str(&format!(
                            " {}=({:.3},{:.3},{:.3})",
                            body_name(self.scene.as_ref(), *id),
                            p[0],
                            p[1],
                            p[2]
                        ));
                    }
                }
                writeln!(out, "{line}")?;
            }
            Mode::Table => {
                let due = self.last_draw.is_none_or(|t| t.elapsed() >= Duration::from_millis(100));
                if !(due || last) {
                    return Ok(());
                }
                self.last_draw = Some(Instant::now());
                let text = self.table(&v, stats);
                crossterm::queue!(out, crossterm::cursor::MoveTo(0, 0))?;
                for l in text.lines() {
                    crossterm::queue!(out, crossterm::style::Print(l))?;
                    crossterm::queue!(
                        out,
                        crossterm::terminal::Clear(crossterm::terminal::ClearType::UntilNewLine)
                    )?;
                    crossterm::queue!(out, crossterm::style::Print("\r\n"))?;
                }
                crossterm::queue!(
                    out,
                    crossterm::terminal::Clear(crossterm::terminal::ClearType::FromCursorDown)
                )?;
            }
        }
        out.flush()?;
        Ok(())
    }

    fn table(&self, v: &msgs::PoseFrameView<'_>, stats: Option<&msgs::SolverStats>) -> String {
        let mut t = String::new();
        let scene = self.scene.as_ref().map_or("?", |s| s.scene.as_str());
        let latency_us = now_ns().saturating_sub(v.wall_time_ns()) as f64 / 1e3;
        t.push_str(&format!(
            "pivotsim  world {}  scene {}  via {:?}   (Ctrl-C to stop)\n",
            self.world, scene, self.transport
        ));
        t.push_str(&format!(
            "step {:>9}   t = {:10.4} s   age {:8.1} µs\n",
            v.sequence(),
            v.sim_time(),
            latency_us
        ));
        match stats {
            None => t.push_str("(no stats yet)\n"),
            Some(s) => {
                push_step_lines(&mut t, s);
                push_island_table(&mut t, s);
            }
        }
        t.push('\n');
        self.push_body_table(&mut t, v);
        t.push_str(&format!(
            "\nframes {} ok, {} malformed (skipped), {} dropped\n",
            self.counts.ok, self.counts.malformed, self.dropped
        ));
        t
    }

    /// The table's rows of the selected bodies: position, Euler angles and speeds.
    fn push_body_table(&self, t: &mut String, v: &msgs::PoseFrameView<'_>) {
        t.push_str(&format!(
            "{:<16} {:>9} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8}\n",
            "body", "x m", "y m", "z m", "roll°", "pitch°", "yaw°", "|v| m/s", "|ω| r/s"
        ));
        for id in &self.selected {
            let Some(b) = v.bodies().find(|b| b.id == *id) else { continue };
            let e = euler_zyx(b.orientation).map(f64::to_degrees);
            let norm = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            let mut name = body_name(self.scene.as_ref(), *id);
            name.truncate(16);
            t.push_str(&format!(
                "{:<16} {:>9.3} {:>9.3} {:>9.3} {:>8.1} {:>8.1} {:>8.1} {:>8.3} {:>8.3}\n",
                name,
                b.position[0],
                b.position[1],
                b.position[2],
                e[0],
                e[1],
                e[2],
                norm(b.linear_velocity),
                norm(b.angular_velocity)
            ));
        }
    }

    /// Re-reads the scene description when the body count says the scene changed (at most every
    /// 2 s), and chooses the bodies shown again when the body count or the scene did change.
    fn follow_scene(
        &mut self,
        v: &msgs::PoseFrameView<'_>,
        common: &Common,
        stream: &Stream,
        scene_timeout: Duration,
    ) {
        if self.scene.as_ref().is_some_and(|s| s.bodies.len() != v.len())
            && self.scene_tried.elapsed() >= Duration::from_secs(2)
        {
            self.scene_tried = Instant::now();
            if let Some(s) = crate::util::scene_best_effort(common, stream.zenoh(), scene_timeout) {
                self.scene = Some(s);
            }
        }
        let key = (v.len(), self.scene.as_ref().map(|s| s.scene.clone()));
        if self.selected_for.as_ref() != Some(&key) {
            self.select(v);
            self.selected_for = Some(key);
        }
    }
}

/// The table's step line (wall time, solver totals) and input-health line.
fn push_step_lines(t: &mut String, s: &msgs::SolverStats) {
    t.push_str(&format!(
        "step wall {:9.1} µs   overruns {}   islands {}   rows {}   pivots {}   tight {}   solve {:.1} µs   max residual {:.2e}\n",
        s.step_wall_us,
        s.overruns,
        s.islands.len(),
        s.totals.rows,
        s.totals.pivot_steps,
        s.totals.tight,
        s.totals.solve_us,
        s.totals.residual_rel_max
    ));
    let rejected: Vec<String> = msgs::RejectReason::ALL
        .iter()
        .filter(|r| s.inputs.rejected_for(**r) > 0)
        .map(|r| format!("{} {}", r.name(), s.inputs.rejected_for(*r)))
        .collect();
    t.push_str(&format!(
        "inputs accepted {}   rejected {}{}   deadman trips {}{}\n",
        s.inputs.accepted,
        s.inputs.rejected_total(),
        if rejected.is_empty() { String::new() } else { format!(" ({})", rejected.join(", ")) },
        s.inputs.deadman_trips,
        if s.inputs.deadman_active { "   DEADMAN ACTIVE (actuators at neutral)" } else { "" }
    ));
    t.push('\n');
}

/// The table's per-island solver rows (the first ten).
fn push_island_table(t: &mut String, s: &msgs::SolverStats) {
    t.push_str(&format!(
        "{:>6} {:<16} {:<10} {:>6} {:>6} {:>6} {:>6} {:>6} {:>10} {:>9}\n",
        "island", "variant", "status", "rows", "bodies", "pivots", "tight", "iters", "solve µs", "residual"
    ));
    const MAX_ISLAND_ROWS: usize = 10;
    for (k, i) in s.islands.iter().take(MAX_ISLAND_ROWS).enumerate() {
        t.push_str(&format!(
            "{:>6} {:<16} {:<10} {:>6} {:>6} {:>6} {:>6} {:>6} {:>10.1} {:>9.1e}{}\n",
            k,
            i.variant.name(),
            i.status.name(),
            i.rows,
            i.bodies,
            i.pivot_steps,
            i.tight,
            i.iterations,
            i.solve_us,
            i.residual_rel,
            if i.fallback { "  fallback" } else { "" }
        ));
    }
    if s.islands.len() > MAX_ISLAND_ROWS {
        t.push_str(&format!("   … {} more islands\n", s.islands.len() - MAX_ISLAND_ROWS));
    }
}

/// Pose and stats frames paired into steps, and the steps shown.
#[derive(Default)]
struct Steps {
    /// The last pose frame (sequence, bytes), waiting for its stats.
    pending: Option<(u64, Vec<u8>)>,
    /// The last stats frame.
    stats: Option<msgs::SolverStats>,
    shown: u64,
    last_seq: Option<u64>,
    gaps: crate::util::SequenceGaps,
}

impl Steps {
    /// Whether `count` steps have been shown.
    fn done(&self, count: Option<u64>) -> bool {
        count.is_some_and(|c| self.shown >= c)
    }

    /// A pose frame of sequence `seq`: shows the pending step (it has no stats coming), then holds
    /// this one; `true` when that completed `count` (the frame is then not held).
    fn on_pose(&mut self, view: &mut View, seq: u64, bytes: Vec<u8>, count: Option<u64>) -> Result<bool> {
        if let Some((_, p)) = self.pending.take() {
            view.emit(&p, self.stats.as_ref(), false)?;
            self.shown += 1;
            if self.done(count) {
                return Ok(true);
            }
        }
        self.gaps.see(seq);
        if self.last_seq.is_some_and(|s| seq < s) {
            // Another server's stream (or a restarted server): sequences went back.
            self.stats = None;
        }
        self.last_seq = Some(seq);
        self.pending = Some((seq, bytes));
        Ok(false)
    }

    /// A stats frame: shows the pending step when the stats are its own.
    fn on_stats(&mut self, view: &mut View, s: msgs::SolverStats, count: Option<u64>) -> Result<()> {
        let matches = self.pending.as_ref().is_some_and(|(seq, _)| *seq == s.sequence);
        self.stats = Some(s);
        if matches && let Some((_, p)) = self.pending.take() {
            let last = count.is_some_and(|c| self.shown + 1 >= c);
            view.emit(&p, self.stats.as_ref(), last)?;
            self.shown += 1;
        }
        Ok(())
    }

    /// The closing line on stderr: steps shown, frames counted, and what was dropped where
    /// (`inbox_dropped` frames over the inbox).
    fn print_summary(&self, counts: &FrameCounts, inbox_dropped: u64) {
        eprintln!(
            "pivotsim-client: {} steps shown; {} frames ok, {} malformed (skipped), {} dropped \
             ({} steps never arrived, {} frames over the inbox)",
            self.shown,
            counts.ok,
            counts.malformed,
            inbox_dropped + self.gaps.skipped,
            self.gaps.skipped,
            inbox_dropped
        );
    }
}

/// Runs `watch`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    if args.signals {
        let view = crate::signals::View {
            transport: args.transport,
            count: args.count,
            duration: args.duration,
            plain: args.plain,
            json: args.json,
        };
        return crate::signals::run(common, &view);
    }
    let mode = Mode::of(args);
    let poll = Duration::from_micros(500);
    let stream =
        Stream::open(&common.server()?, args.transport, &[Topic::Poses, Topic::Stats], 1024, poll, None)?;
    let scene_timeout = common.timeout_or(2.0);
    let scene = crate::util::scene_best_effort(common, stream.zenoh(), scene_timeout);
    if scene.is_none() {
        eprintln!("pivotsim-client: no scene description (bodies shown by id)");
    }
    let mut view = View::new(mode, scene, common, args);
    if mode == Mode::Table {
        let mut out = std::io::stdout();
        crossterm::execute!(out, crossterm::terminal::Clear(crossterm::terminal::ClearType::All))?;
    }
    let idle = common.timeout.map(secs);
    let end = args.duration.map(|d| Instant::now() + secs(d));
    let mut last_frame = Instant::now();
    let mut steps = Steps::default();
    let mut outcome = Ok(());
    while !steps.done(args.count) {
        if interrupted() {
            break;
        }
        if end.is_some_and(|e| Instant::now() >= e) {
            break;
        }
        if let Some(idle) = idle
            && last_frame.elapsed() >= idle
        {
            outcome = Err(format!("no frames for {:.1} s", idle.as_secs_f64()));
            break;
        }
        let Some(r) = stream.inbox.recv_timeout(Duration::from_millis(50)) else { continue };
        view.dropped = stream.inbox.dropped() + steps.gaps.skipped;
        match r.topic {
            Some(Topic::Poses) => match msgs::PoseFrameView::parse(&r.bytes) {
                Ok(v) => {
                    view.counts.ok += 1;
                    last_frame = Instant::now();
                    // A new scene (load/reset): the description and the selection change.
                    view.follow_scene(&v, common, &stream, scene_timeout);
                    let seq = v.sequence();
                    if steps.on_pose(&mut view, seq, r.bytes, args.count)? {
                        break;
                    }
                }
                Err(_) => view.counts.malformed += 1,
            },
            Some(Topic::Stats) => match msgs::SolverStats::decode(&r.bytes) {
                Ok(s) => {
                    view.counts.ok += 1;
                    last_frame = Instant::now();
                    steps.on_stats(&mut view, s, args.count)?;
                }
                Err(_) => view.counts.malformed += 1,
            },
            _ => view.counts.malformed += 1,
        }
    }
    if !steps.done(args.count)
        && let Some((_, p)) = steps.pending.take()
    {
        view.emit(&p, steps.stats.as_ref(), true)?;
        steps.shown += 1;
    }
    steps.print_summary(&view.counts, stream.inbox.dropped());
    if let Err(e) = outcome {
        bail!("{e} on world `{}` via {:?}", common.world, args.transport);
    }
    Ok(ExitCode::SUCCESS)
}
