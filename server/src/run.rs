//! The headless runner behind `pivotsim-server run`: a scene driven by its script as fast as
//! possible, with a progress bar, per-step statistics and poses as CSV, island problems dumped in
//! the MLCP file format, and a summary (text or one JSON object).
//!
//! Definitions used in the summary (per step unless said otherwise):
//! - *solve time*: the sum over islands of the solver's wall time ([`IslandStats::solve_us`]);
//!   mean and 99th percentile over steps; the same of the solving thread's CPU time
//!   ([`IslandStats::solve_cpu_us`]) leaves out the time other processes of the machine ran
//!   meanwhile (a compile beside a benchmark), not a virtual machine's steal time, which the guest
//!   counts as running;
//! - *mass ratio* of an island: largest over smallest body mass among its dynamic bodies (paper
//!   Table 2); the summary reports the largest over the run;
//! - *tight fraction*: tight rows over rows of an island (the share of variables at a bound);
//! - *joint error*: [`World::max_joint_error`] after the step (anchor separation across locked
//!   directions), the largest over the run;
//! - *finite*: no step ever failed on a NaN/Inf state or problem (the run stops at the first);
//! - *stable*: finite, and the instability watchdog ([`Watchdog`], `dynamics/watchdog.rs`) never
//!   fired: the world never gained energy beyond its initial energy and its inputs' work by the
//!   scene's margin, and no body outran the scene's speed bound. `instability` says what fired
//!   first, `unstable_steps` in how many steps.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use thiserror::Error;

use crate::dynamics::{IslandStats, MAX_SHADOWS, Watchdog, World};
use crate::scene::{Scene, SceneStepError};
use crate::snapshot::{Snapshot, SnapshotError};
use crate::solver::{SolveStatus, Variant, io};

/// What to run and what to write.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Simulated seconds (default: the scene's duration).
    pub duration: Option<f64>,
    /// Solver variant for every island (default: the scene's).
    pub variant: Option<Variant>,
    /// Per-step, per-island statistics CSV.
    pub stats: Option<PathBuf>,
    /// Per-step body poses CSV.
    pub poses: Option<PathBuf>,
    /// Directory for island MLCP dumps.
    pub dump_mlcp: Option<PathBuf>,
    /// Dump every N-th step (≥ 1).
    pub every: usize,
    /// With `dump_mlcp`: instead of every N-th step, keep the N hardest island solves of the run
    /// (those that did not converge first, then by pivot steps, then by solve time) and write them
    /// at the end, each with the warm start the simulation gave it (`*-hardNN-step*-island*.txt`).
    pub dump_hard: usize,
    /// Variants that also solve every island problem, answers discarded (paired timing and
    /// agreement, [`World::set_shadow_variants`]; at most [`MAX_SHADOWS`]).
    pub shadow: Vec<Variant>,
    /// Show a progress bar on a terminal.
    pub progress: bool,
    /// Write a snapshot (`snapshot/`) when the world reaches this time (`--snapshot-at`,
    /// `--snapshot`).
    pub snapshot: Option<SnapshotAt>,
    /// The watchdog's ledger to go on from (a run from a snapshot, `--from`), instead of a new
    /// watchdog started at the first step's state.
    pub watchdog: Option<Watchdog>,
}

/// Where and when a run writes a snapshot.
#[derive(Debug, Clone, PartialEq)]
pub struct SnapshotAt {
    /// Simulation time (s), rounded to the nearest step; within the run.
    pub time: f64,
    /// The file.
    pub path: PathBuf,
}

/// The run's summary (`--json` prints it as one object).
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct RunSummary {
    /// Scene name.
    pub scene: String,
    /// Solver variant.
    pub variant: String,
    /// Steps taken.
    pub steps: u64,
    /// Simulated time (s).
    pub sim_time_s: f64,
    /// Wall time of the stepping loop (s), writers included.
    pub wall_s: f64,
    /// Simulated over wall time.
    pub realtime_factor: f64,
    /// Largest island (rows).
    pub max_island_rows: usize,
    /// Largest island (bodies).
    pub max_island_bodies: usize,
    /// Most islands with rows in one step.
    pub max_islands: usize,
    /// Solver threads of the world (`World::set_threads`; 1: serial).
    pub threads: usize,
    /// Island solves of the run that ran on the solver threads (a step's islands concurrently).
    pub parallel_solves: u64,
    /// Largest body-mass ratio within an island.
    pub max_mass_ratio: f64,
    /// Mean solve time per step (µs).
    pub mean_solve_us: f64,
    /// 99th-percentile solve time per step (µs).
    pub p99_solve_us: f64,
    /// Largest solve time of a step (µs).
    pub max_solve_us: f64,
    /// 99th-percentile solve CPU time per step (µs): the solving thread's CPU time.
    pub p99_solve_cpu_us: f64,
    /// Largest solve CPU time of a step (µs).
    pub max_solve_cpu_us: f64,
    /// Mean wall time per step, everything included (µs).
    pub mean_step_us: f64,
    /// Mean pivot steps per island solve.
    pub mean_pivot_steps: f64,
    /// Most pivot steps of one island solve.
    pub max_pivot_steps: usize,
    /// Largest tight fraction of an island.
    pub max_tight_fraction: f64,
    /// Mean tight fraction of the largest island per step.
    pub mean_tight_fraction: f64,
    /// Largest joint anchor error after a step (m).
    pub max_joint_error_m: f64,
    /// Largest speed of a dynamic body (m/s): an explosion shows here while everything is finite.
    pub max_body_speed_mps: f64,
    /// Largest relative natural-map residual of an island solve.
    pub max_residual_rel: f64,
    /// Island solves by outcome: converged, inexact, max_steps, other.
    pub solves_converged: u64,
    /// Solves that ended inexact (residual at the precision floor).
    pub solves_inexact: u64,
    /// Solves that hit the pivot-step cap.
    pub solves_max_steps: u64,
    /// Solves with any other status.
    pub solves_other: u64,
    /// No NaN/Inf ever appeared.
    pub finite: bool,
    /// Finite and the instability watchdog never fired.
    pub stable: bool,
    /// What the watchdog found first (energy gain or speed), if it fired.
    pub instability: Option<String>,
    /// Steps the watchdog flagged.
    pub unstable_steps: u64,
    /// Why the run stopped early, if it did.
    pub error: Option<String>,
    /// Island problems written by `--dump-mlcp`.
    pub dumped: usize,
    /// Mean wall time of one island solve (µs), islands with rows.
    pub mean_island_solve_us: f64,
    /// Largest wall time of one island solve (µs).
    pub max_island_solve_us: f64,
    /// Island solves in which a safeguard (projected Newton, Murty, semismooth Newton, the interior
    /// point method) ran.
    pub solves_fallback: u64,
    /// Island solves stopped by the time budget (`max_solve_us`).
    pub solves_budget: u64,
    /// The shadow variants' paired numbers (`--shadow`), in the order given.
    pub shadow: Vec<ShadowSummary>,
}

/// A shadow variant over the run: the same island problems as the run's own variant, solved
/// within microseconds of it (`dynamics/shadow.rs`), so that the speed-up is a paired one.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct ShadowSummary {
    /// The shadow variant.
    pub variant: String,
    /// Its solve time per step, all islands: mean over every step (µs).
    pub mean_solve_us: f64,
    /// The same over the steps with tight rows in the run's own answer (µs; the paper's Table 3).
    pub mean_tight_us: f64,
    /// The run's own variant on the same steps: mean over every step (µs).
    pub own_mean_solve_us: f64,
    /// And over the steps with tight rows (µs).
    pub own_mean_tight_us: f64,
    /// Shadow time over own time, summed over every step: how many times faster the run's own
    /// variant solved the same problems.
    pub speedup: f64,
    /// The same over the steps with tight rows.
    pub speedup_tight: f64,
    /// Shadow solves that did not converge.
    pub not_converged: u64,
    /// Largest `‖λ_shadow − λ‖∞ / ‖λ‖∞` over the islands that both converged on.
    pub max_deviation: f64,
}

/// Why a run could not start or write its outputs.
#[derive(Debug, Error)]
pub enum RunError {
    /// An output file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// A CSV writer.
    #[error("{path}: {source}")]
    Csv {
        /// The file.
        path: String,
        /// The cause.
        source: csv::Error,
    },
    /// A bad option.
    #[error("{0}")]
    Option(String),
    /// Writing the snapshot.
    #[error("snapshot: {0}")]
    Snapshot(#[from] SnapshotError),
}

#[derive(Serialize)]
struct StatsRow<'a> {
    step: u64,
    time: f64,
    island: usize,
    bodies: usize,
    rows: usize,
    nnz: usize,
    mass_ratio: f64,
    variant: &'a str,
    status: &'a str,
    pivot_steps: usize,
    tight: usize,
    solve_us: f64,
    assemble_us: f64,
    residual: f64,
    residual_rel: f64,
    max_violation: f64,
}

#[derive(Serialize)]
struct PoseRow<'a> {
    step: u64,
    time: f64,
    body: &'a str,
    x: f64,
    y: f64,
    z: f64,
    qw: f64,
    qx: f64,
    qy: f64,
    qz: f64,
}

fn csv_writer(path: &Path) -> Result<csv::Writer<BufWriter<File>>, RunError> {
    let f = File::create(path).map_err(|source| RunError::Io { path: path.display().to_string(), source })?;
    Ok(csv::Writer::from_writer(BufWriter::new(f)))
}

/// Largest over smallest mass of island `k`'s dynamic bodies.
pub fn island_mass_ratio(world: &World, k: usize) -> f64 {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for &b in world.islands().bodies(k) {
        let m = world.bodies()[b].mass();
        lo = lo.min(m);
        hi = hi.max(m);
    }
    if lo.is_finite() && lo > 0.0 { hi / lo } else { 1.0 }
}

/// Per-step accumulators of a shadow's summary: (own, shadow) time sums over every step and over
/// the steps with tight rows.
#[derive(Default, Clone, Copy)]
struct ShadowAcc {
    all: (f64, f64),
    tight: (f64, f64),
    not_converged: u64,
    max_deviation: f64,
}

/// Per-step accumulators of the summary.
#[derive(Default)]
struct Acc {
    shadow: [ShadowAcc; MAX_SHADOWS],
    tight_steps: u64,
    solve_us: Vec<f64>,
    solve_cpu_us: Vec<f64>,
    step_us: f64,
    pivots: u64,
    solves: u64,
    island_us: f64,
    tight_largest: f64,
}

/// Runs `scene` under its script for the options' duration and returns the summary; a step that
/// fails (non-finite state) ends the run with `finite = false` and the error in the summary.
pub fn run_scene(scene: &mut Scene, opts: &RunOptions) -> Result<RunSummary, RunError> {
    run_scene_observed(scene, opts, |_| {})
}

/// [`run_scene`] with `on_step` called on the world after every step (tests record trajectories
/// with it).
pub fn run_scene_observed(
    scene: &mut Scene,
    opts: &RunOptions,
    mut on_step: impl FnMut(&World),
) -> Result<RunSummary, RunError> {
    let steps = prepare(scene, opts)?;
    let snapshot_step = snapshot_step(scene, opts, steps)?;
    let mut out = Outputs::open(opts)?;
    let bar = progress_bar(opts.progress, steps, &scene.name);
    let mut sum = RunSummary::start(&scene.name, scene.world.settings().solver.variant.name());
    sum.shadow = opts
        .shadow
        .iter()
        .map(|v| ShadowSummary { variant: v.name().into(), ..Default::default() })
        .collect();
    let mut hard = HardSolves::new(if opts.dump_mlcp.is_some() { opts.dump_hard } else { 0 });
    let parallel_before = scene.world.parallel_solves();
    let mut acc = Acc {
        solve_us: Vec::with_capacity(steps as usize),
        solve_cpu_us: Vec::with_capacity(steps as usize),
        ..Acc::default()
    };
    let mut watchdog = opts.watchdog.clone().unwrap_or_else(|| Watchdog::new(&scene.world, scene.watchdog));
    let every = opts.every.max(1);
    let start = Instant::now();
    let tick = (steps / 200).max(1);
    for n in 0..steps {
        let dump = opts.dump_mlcp.is_some() && hard.keep == 0 && n % every as u64 == 0;
        scene.world.set_capture_problems(dump || hard.keep > 0);
        let t0 = Instant::now();
        if let Err(e) = scene.step() {
            // A step refuses to commit a non-finite state or problem; a refused actuator is not a
            // NaN.
            sum.finite = matches!(e, SceneStepError::Control(_));
            sum.error = Some(e.to_string());
            break;
        }
        acc.step_us += t0.elapsed().as_secs_f64() * 1e6;
        let world = &scene.world;
        record_step(world, &mut sum, &mut acc);
        if let Some(i) = watchdog.check(world)
            && watchdog.count() == 1
        {
            bar.suspend(|| eprintln!("warning: {}: unstable: {i}", scene.name));
        }
        on_step(world);
        out.write_step(world, &scene.name, dump, &mut sum)?;
        if let Some((at, path)) = snapshot_step
            && world.steps() == at
        {
            Snapshot::capture(scene, Some(&watchdog))?.write(path)?;
        }
        hard.offer(world);
        if n % tick == 0 {
            bar.set_position(n + 1);
        }
    }
    scene.world.set_capture_problems(false);
    if let Some(dir) = &opts.dump_mlcp {
        sum.dumped += hard.write(dir, &scene.name)?;
    }
    bar.finish_and_clear();
    out.flush()?;
    sum.finish(acc, &watchdog, start.elapsed().as_secs_f64(), scene.world.time());
    sum.threads = scene.world.threads();
    sum.parallel_solves = scene.world.parallel_solves() - parallel_before;
    Ok(sum)
}

/// Applies the options' solver variant to the scene and returns the number of steps to run.
fn prepare(scene: &mut Scene, opts: &RunOptions) -> Result<u64, RunError> {
    if let Some(v) = opts.variant {
        let mut s = *scene.world.settings();
        s.solver.variant = v;
        scene.world.set_settings(s).map_err(|e| RunError::Option(e.to_string()))?;
    }
    scene.world.set_shadow_variants(&opts.shadow).map_err(|e| RunError::Option(e.to_string()))?;
    let h = scene.world.settings().timestep;
    let duration = opts.duration.unwrap_or(scene.duration);
    if !(duration.is_finite() && duration > 0.0) {
        return Err(RunError::Option(format!("duration {duration} must be a finite number > 0")));
    }
    Ok((duration / h).round() as u64)
}

/// The world step count after which the options' snapshot is written: `--snapshot-at` rounded to
/// the nearest step, which must fall within the run's `steps` from the world's present step.
fn snapshot_step<'a>(
    scene: &Scene,
    opts: &'a RunOptions,
    steps: u64,
) -> Result<Option<(u64, &'a Path)>, RunError> {
    let Some(at) = &opts.snapshot else { return Ok(None) };
    let (h, now) = (scene.world.settings().timestep, scene.world.steps());
    let step = (at.time / h).round();
    let (first, last) = (now + 1, now + steps);
    if !(at.time.is_finite() && step >= first as f64 && step <= last as f64) {
        return Err(RunError::Option(format!(
            "--snapshot-at {} is outside the run ({:.4} s to {:.4} s)",
            at.time,
            first as f64 * h,
            last as f64 * h
        )));
    }
    Ok(Some((step as u64, at.path.as_path())))
}

/// A progress bar over `steps` labelled `name` (hidden unless `show`).
fn progress_bar(show: bool, steps: u64, name: &str) -> ProgressBar {
    let bar = if show { ProgressBar::new(steps) } else { ProgressBar::hidden() };
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} steps, {per_sec}, eta {eta}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_message(name.to_string());
    bar
}

impl RunSummary {
    /// The summary before the first step: nothing counted yet, finite and stable.
    fn start(scene: &str, variant: &str) -> Self {
        RunSummary {
            scene: scene.to_string(),
            variant: variant.to_string(),
            max_mass_ratio: 1.0,
            finite: true,
            stable: true,
            ..RunSummary::default()
        }
    }

    /// The totals and means after the last step: `wall_s` of the stepping loop, `sim_time_s` the
    /// world's time.
    fn finish(&mut self, mut acc: Acc, watchdog: &Watchdog, wall_s: f64, sim_time_s: f64) {
        self.wall_s = wall_s;
        self.unstable_steps = watchdog.count();
        self.instability = watchdog.first().map(ToString::to_string);
        self.stable = self.finite && self.instability.is_none();
        self.steps = acc.solve_us.len() as u64;
        self.sim_time_s = sim_time_s;
        self.realtime_factor = if self.wall_s > 0.0 { self.sim_time_s / self.wall_s } else { 0.0 };
        let n = acc.solve_us.len().max(1) as f64;
        self.mean_solve_us = acc.solve_us.iter().sum::<f64>() / n;
        self.mean_step_us = acc.step_us / n;
        self.mean_pivot_steps = acc.pivots as f64 / acc.solves.max(1) as f64;
        self.mean_island_solve_us = acc.island_us / acc.solves.max(1) as f64;
        self.mean_tight_fraction = acc.tight_largest / n;
        (self.p99_solve_us, self.max_solve_us) = p99_and_max(&mut acc.solve_us);
        (self.p99_solve_cpu_us, self.max_solve_cpu_us) = p99_and_max(&mut acc.solve_cpu_us);
        let nt = acc.tight_steps.max(1) as f64;
        let ratio = |(own, sh): (f64, f64)| if own > 0.0 { sh / own } else { 0.0 };
        for (out, a) in self.shadow.iter_mut().zip(&acc.shadow) {
            out.mean_solve_us = a.all.1 / n;
            out.own_mean_solve_us = a.all.0 / n;
            out.mean_tight_us = a.tight.1 / nt;
            out.own_mean_tight_us = a.tight.0 / nt;
            out.speedup = ratio(a.all);
            out.speedup_tight = ratio(a.tight);
            out.not_converged = a.not_converged;
            out.max_deviation = a.max_deviation;
        }
    }
}

/// The 99th percentile and the largest of `v` (sorted in place; zeros when empty).
fn p99_and_max(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    match v.last() {
        Some(&max) => {
            let i = ((v.len() as f64 * 0.99).ceil() as usize).clamp(1, v.len()) - 1;
            (v[i], max)
        }
        None => (0.0, 0.0),
    }
}

/// A CSV file being written, with its path for errors.
type CsvOut = (csv::Writer<BufWriter<File>>, String);

/// The run's per-step outputs: statistics and poses CSV, island problems dumped every N-th step.
struct Outputs<'a> {
    stats: Option<CsvOut>,
    poses: Option<CsvOut>,
    dump_mlcp: Option<&'a Path>,
}

impl<'a> Outputs<'a> {
    /// Creates the files and the dump directory the options name.
    fn open(opts: &'a RunOptions) -> Result<Self, RunError> {
        let open = |p: &Option<PathBuf>| {
            p.as_deref().map(|p| Ok::<_, RunError>((csv_writer(p)?, p.display().to_string()))).transpose()
        };
        let (stats, poses) = (open(&opts.stats)?, open(&opts.poses)?);
        if let Some(dir) = &opts.dump_mlcp {
            std::fs::create_dir_all(dir)
                .map_err(|source| RunError::Io { path: dir.display().to_string(), source })?;
        }
        Ok(Outputs { stats, poses, dump_mlcp: opts.dump_mlcp.as_deref() })
    }

    /// Writes the step just taken: a stats row per island, a pose row per dynamic body, and with
    /// `dump` the island problems (counted in `sum.dumped`).
    fn write_step(
        &mut self,
        world: &World,
        scene: &str,
        dump: bool,
        sum: &mut RunSummary,
    ) -> Result<(), RunError> {
        let (step, time) = (world.steps(), world.time());
        if let Some((w, path)) = self.stats.as_mut() {
            for s in world.island_stats() {
                let row = StatsRow {
                    step,
                    time,
                    island: s.island,
                    bodies: s.bodies,
                    rows: s.rows,
                    nnz: s.nnz,
                    mass_ratio: island_mass_ratio(world, s.island),
                    variant: s.variant.name(),
                    status: s.status.name(),
                    pivot_steps: s.pivot_steps,
                    tight: s.tight,
                    solve_us: s.solve_us,
                    assemble_us: s.assemble_us,
                    residual: s.residual,
                    residual_rel: s.residual_rel,
                    max_violation: s.max_violation,
                };
                w.serialize(row).map_err(|source| RunError::Csv { path: path.clone(), source })?;
            }
        }
        if let Some((w, path)) = self.poses.as_mut() {
            for b in world.bodies().iter().filter(|b| b.is_dynamic()) {
                let (x, q) = (b.position(), b.orientation());
                let row = PoseRow {
                    step,
                    time,
                    body: b.name(),
                    x: x.x,
                    y: x.y,
                    z: x.z,
                    qw: q.w,
                    qx: q.i,
                    qy: q.j,
                    qz: q.k,
                };
                w.serialize(row).map_err(|source| RunError::Csv { path: path.clone(), source })?;
            }
        }
        if let (true, Some(dir)) = (dump, self.dump_mlcp) {
            for (p, s) in world.captured_problems().iter().zip(world.island_stats()) {
                let path = dir.join(format!("{scene}-step{step:06}-island{}.txt", s.island));
                write_problem(&path, p)?;
                sum.dumped += 1;
            }
        }
        Ok(())
    }

    /// Flushes the CSV files.
    fn flush(&mut self) -> Result<(), RunError> {
        for (w, path) in [self.stats.as_mut(), self.poses.as_mut()].into_iter().flatten() {
            w.flush().map_err(|source| RunError::Io { path: path.clone(), source })?;
        }
        Ok(())
    }
}

fn record_step(world: &World, sum: &mut RunSummary, acc: &mut Acc) {
    let stats = world.island_stats();
    let (mut solve, mut solve_cpu) = (0.0, 0.0);
    let mut largest: Option<&IslandStats> = None;
    for s in stats {
        solve += s.solve_us;
        solve_cpu += s.solve_cpu_us;
        sum.max_island_rows = sum.max_island_rows.max(s.rows);
        sum.max_island_bodies = sum.max_island_bodies.max(s.bodies);
        sum.max_mass_ratio = sum.max_mass_ratio.max(island_mass_ratio(world, s.island));
        sum.max_pivot_steps = sum.max_pivot_steps.max(s.pivot_steps);
        sum.max_residual_rel = sum.max_residual_rel.max(s.residual_rel);
        if s.rows > 0 {
            sum.max_tight_fraction = sum.max_tight_fraction.max(s.tight as f64 / s.rows as f64);
        }
        if largest.is_none_or(|l| s.rows > l.rows) {
            largest = Some(s);
        }
        acc.pivots += s.pivot_steps as u64;
        acc.solves += 1;
        acc.island_us += s.solve_us;
        sum.max_island_solve_us = sum.max_island_solve_us.max(s.solve_us);
        sum.solves_fallback += s.fallback as u64;
        match s.status {
            SolveStatus::Converged => sum.solves_converged += 1,
            SolveStatus::Inexact => sum.solves_inexact += 1,
            SolveStatus::MaxSteps => sum.solves_max_steps += 1,
            SolveStatus::Budget => sum.solves_budget += 1,
            _ => sum.solves_other += 1,
        }
    }
    if let Some(l) = largest.filter(|l| l.rows > 0) {
        acc.tight_largest += l.tight as f64 / l.rows as f64;
    }
    record_shadows(stats, acc, sum.shadow.len());
    sum.max_islands = sum.max_islands.max(stats.len());
    sum.max_joint_error_m = sum.max_joint_error_m.max(world.max_joint_error());
    for b in world.bodies().iter().filter(|b| b.is_dynamic()) {
        sum.max_body_speed_mps = sum.max_body_speed_mps.max(b.linvel().norm());
    }
    acc.solve_us.push(solve);
    acc.solve_cpu_us.push(solve_cpu);
}

/// Adds the step's shadow solves (the first `n` slots) to their accumulators.
fn record_shadows(stats: &[IslandStats], acc: &mut Acc, n: usize) {
    let tight = stats.iter().any(|s| s.tight > 0);
    acc.tight_steps += tight as u64;
    for (i, a) in acc.shadow.iter_mut().enumerate().take(n) {
        let (mut own, mut sh) = (0.0, 0.0);
        for s in stats {
            let x = &s.shadow[i];
            own += s.solve_us;
            sh += x.solve_us;
            if x.status != SolveStatus::Converged {
                a.not_converged += 1;
            } else if s.status == SolveStatus::Converged {
                a.max_deviation = a.max_deviation.max(x.deviation);
            }
        }
        a.all = (a.all.0 + own, a.all.1 + sh);
        if tight {
            a.tight = (a.tight.0 + own, a.tight.1 + sh);
        }
    }
}

/// How hard a solve was: (did not converge, pivot steps, solve time).
type Hardness = (bool, usize, f64);

/// One kept solve: its hardness, step, island and problem.
type HardSolve = (Hardness, u64, usize, crate::solver::Mlcp);

/// The hardest island solves of a run, kept for `--dump-hard` (allocates: offline use only).
struct HardSolves {
    keep: usize,
    /// Hardest first.
    kept: Vec<HardSolve>,
}

impl HardSolves {
    fn new(keep: usize) -> Self {
        HardSolves { keep, kept: Vec::new() }
    }

    /// Offers the islands of the step just taken (their problems were captured).
    fn offer(&mut self, world: &World) {
        if self.keep == 0 {
            return;
        }
        for (p, s) in world.captured_problems().iter().zip(world.island_stats()) {
            let key = (s.status != SolveStatus::Converged, s.pivot_steps, s.solve_us);
            let harder = |a: &Hardness, b: &Hardness| (a.0, a.1).cmp(&(b.0, b.1)).then(a.2.total_cmp(&b.2));
            if self.kept.len() == self.keep
                && self.kept.last().is_some_and(|l| harder(&key, &l.0) != std::cmp::Ordering::Greater)
            {
                continue;
            }
            let at = self.kept.partition_point(|k| harder(&k.0, &key) == std::cmp::Ordering::Greater);
            self.kept.insert(at, (key, world.steps(), s.island, p.clone()));
            self.kept.truncate(self.keep);
        }
    }

    /// Writes the kept problems; returns how many.
    fn write(&self, dir: &Path, scene: &str) -> Result<usize, RunError> {
        for (rank, (_, step, island, p)) in self.kept.iter().enumerate() {
            let path = dir.join(format!("{scene}-hard{rank:02}-step{step:06}-island{island}.txt"));
            write_problem(&path, p)?;
        }
        Ok(self.kept.len())
    }
}

fn write_problem(path: &Path, p: &crate::solver::Mlcp) -> Result<(), RunError> {
    let err = |source| RunError::Io { path: path.display().to_string(), source };
    let mut out = BufWriter::new(File::create(path).map_err(err)?);
    io::write_mlcp(p, &mut out).and_then(|()| out.flush()).map_err(err)
}

/// The summary as text lines.
pub fn summary_text(s: &RunSummary) -> String {
    format!(
        "scene {} ({}): {} steps, {:.2} s simulated in {:.3} s wall (real-time factor {:.1})\n\
         islands: up to {} with rows; largest {} rows, {} bodies; mass ratio up to {:.3e}; {} solver thread(s), {} solves parallel\n\
         solve per step: mean {:.1} µs, p99 {:.1} µs, max {:.1} µs (CPU time: p99 {:.1} µs, max {:.1} µs); step mean {:.1} µs\n\
         pivots per solve: mean {:.2}, max {}; tight fraction max {:.3}, mean (largest island) {:.3}\n\
         solves: {} converged, {} inexact, {} at the step cap, {} other; max relative residual {:.2e}\n\
         joint error max {:.3e} m; body speed max {:.3} m/s; finite: {}; stable: {}{}{}{}",
        s.scene,
        s.variant,
        s.steps,
        s.sim_time_s,
        s.wall_s,
        s.realtime_factor,
        s.max_islands,
        s.max_island_rows,
        s.max_island_bodies,
        s.max_mass_ratio,
        s.threads,
        s.parallel_solves,
        s.mean_solve_us,
        s.p99_solve_us,
        s.max_solve_us,
        s.p99_solve_cpu_us,
        s.max_solve_cpu_us,
        s.mean_step_us,
        s.mean_pivot_steps,
        s.max_pivot_steps,
        s.max_tight_fraction,
        s.mean_tight_fraction,
        s.solves_converged,
        s.solves_inexact,
        s.solves_max_steps,
        s.solves_other,
        s.max_residual_rel,
        s.max_joint_error_m,
        s.max_body_speed_mps,
        s.finite,
        s.stable,
        s.instability
            .as_deref()
            .map(|e| format!("\nunstable ({} steps flagged): {e}", s.unstable_steps))
            .unwrap_or_default(),
        s.error.as_deref().map(|e| format!("\nstopped early: {e}")).unwrap_or_default(),
        if s.dumped > 0 { format!("\nMLCP files written: {}", s.dumped) } else { String::new() },
    ) + &s
        .shadow
        .iter()
        .map(|x| {
            format!(
                "\nshadow {}: {:.1} µs per step, {} {:.1} on the same problems (speed-up of {} {:.2}×); \
                 steps with tight rows {:.1} against {:.1} ({:.2}×); {} not converged; deviation max {:.1e}",
                x.variant,
                x.mean_solve_us,
                s.variant,
                x.own_mean_solve_us,
                s.variant,
                x.speedup,
                x.mean_tight_us,
                x.own_mean_tight_us,
                x.speedup_tight,
                x.not_converged,
                x.max_deviation
            )
        })
        .collect::<String>()
}
