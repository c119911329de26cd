//! `pivotsim-server`: the CLI over the pivotsim library.
//!
//! Subcommands: `serve` (the default: a scene in real time over Zenoh and iceoryx2), `run` (a
//! scene headless, as fast as possible), `scenes` (the built-in scenes), `solve` (one MLCP file),
//! `pattern` (sparsity plots) and `bench-solver` (every variant on generated problems and the
//! repository's test problems). What each does beyond the library lives in `cli/`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use pivotsim_server::scene::SceneOverride;
use pivotsim_server::solver::{OrderingKind, Variant};

mod cli;

use cli::values;

/// Exact-contact multibody physics server (block principal pivoting with Cholesky downdates).
#[derive(Debug, Parser)]
#[command(version, about, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Without a subcommand: `serve` with these options.
    #[command(flatten)]
    serve: cli::serve::ServeArgs,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Serve a scene in real time over Zenoh and iceoryx2 (the default command).
    Serve(cli::serve::ServeArgs),
    /// Replay a recorded session (`pivotsim-client record`) bit for bit: served like a live
    /// server, or checked (`--check`); `--from T`, `--branch T` (README "Rig control").
    Replay(cli::replay::ReplayArgs),
    /// Run a scene headless under its script, as fast as possible, and print a summary.
    Run {
        /// A built-in scene name (see `scenes`) or a scene file path.
        #[arg(long, required_unless_present = "from", conflicts_with = "from")]
        scene: Option<String>,
        /// Go on from this snapshot (`--snapshot`, or the server's `snapshot` request) instead of
        /// a scene's start: the scene is the one the snapshot carries, the run repeats the
        /// uninterrupted run bit for bit (README "Rig control").
        #[arg(long, value_name = "FILE", conflicts_with = "set")]
        from: Option<PathBuf>,
        /// Write a snapshot of the complete state when the world reaches this time (s; rounded to
        /// a step within the run). Needs --snapshot.
        #[arg(long, value_name = "T", requires = "snapshot", allow_negative_numbers = true)]
        snapshot_at: Option<f64>,
        /// The snapshot file --snapshot-at writes.
        #[arg(long, value_name = "FILE", requires = "snapshot_at")]
        snapshot: Option<PathBuf>,
        /// Simulated seconds, a finite number > 0 up to 1e6 (default: the scene's duration; from a
        /// snapshot, what is left of it).
        #[arg(long, allow_negative_numbers = true, value_parser = values::run_seconds)]
        duration: Option<f64>,
        /// Solver variant for every island (default: the scene's).
        #[arg(long)]
        variant: Option<Variant>,
        /// Solver threads: a step's islands solved concurrently, bit-identical to one thread
        /// (1 ..= 256; default: the cores present; 1: every island in turn on the main thread).
        #[arg(long, value_parser = cli::values::threads)]
        threads: Option<usize>,
        /// Write per-step, per-island solver statistics here (CSV).
        #[arg(long)]
        stats: Option<PathBuf>,
        /// Write per-step body poses here (CSV).
        #[arg(long)]
        poses: Option<PathBuf>,
        /// Dump island problems in the MLCP file format into this directory.
        #[arg(long)]
        dump_mlcp: Option<PathBuf>,
        /// With --dump-mlcp: every N-th step (N ≥ 1).
        #[arg(long, allow_negative_numbers = true, default_value_t = 60, value_parser = clap::value_parser!(u32).range(1..))]
        every: u32,
        /// With --dump-mlcp: instead of every N-th step, the N hardest island solves of the run
        /// (not converged first, then most pivot steps, then slowest), with their warm starts.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=100_000))]
        dump_hard: u32,
        /// Also solve every island problem with this variant (repeatable, up to 3), answers
        /// discarded: the summary gives the paired speed-up of the run's own variant over it on the
        /// same problems and how far its answers deviate.
        #[arg(long)]
        shadow: Vec<Variant>,
        /// Print the summary as one JSON object.
        #[arg(long)]
        json: bool,
        /// Override a scene setting (repeatable): `contact_compliance=1e-10`, `max_pivot_steps=35`,
        /// `body.hook.mass=70` (scenes/README.md, "Overriding settings").
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<SceneOverride>,
    },
    /// List the built-in scenes.
    Scenes,
    /// Plot the sparsity pattern of an MLCP file's matrix before and after reordering, and its
    /// envelope factor (paper Fig. 5 and 6), as one SVG.
    Pattern {
        /// The problem file.
        file: PathBuf,
        /// Output SVG.
        #[arg(long, default_value = "pattern.svg")]
        out: PathBuf,
        /// Reordering: natural, cm, rcm.
        #[arg(long, default_value = "rcm")]
        ordering: OrderingKind,
    },
    /// Solve one MLCP file (format: docs/MLCP_FORMAT.md) and print its statistics.
    Solve(cli::solve::SolveArgs),
    /// Benchmark every solver variant: kernel crossover, paper Fig. 4, generated contact-like
    /// problems and the repository's test problems (server/tests/data); writes bench.md,
    /// bench.json and SVG plots.
    BenchSolver {
        /// Output directory (default: bench-out/).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Smaller sizes and fewer repeats (about a minute).
        #[arg(long)]
        quick: bool,
        /// Scan this directory for *.txt MLCP files instead of server/tests/data (run from the
        /// repository root).
        #[arg(long)]
        data: Option<PathBuf>,
        /// Run only the generated-island sweep over this many islands (every exact variant in
        /// rotation, cold and warm; `sweep.json` in the output directory).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
        sweep: Option<u32>,
        /// Run only the hardest-solves stage: each shipped scene's 7 hardest warm solves (dumped
        /// by a run as shipped, or read from `--data DIR/<scene>/`), timed with every exact variant
        /// beside ODE's column of issue 31 (`hard.md`, `hard.json`, `hard.svg`).
        #[arg(long, conflicts_with = "sweep")]
        hard: bool,
        /// With --hard: solves per file and variant, the median taken (1 to 1,000).
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1_000))]
        repeats: u32,
    },
    /// The speed/accuracy report: every paper scene with every variant, the paper's Tables 2–4 and
    /// Fig. 3, 5/6, 7 beside its numbers, residual against time for PGS and block pivoting, warm
    /// starts, and the extremes of compliance and mass ratio (README.md, report.json, steps.csv,
    /// SVG figures)
    Report {
        /// Output directory (default: report-out/).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Shorter runs and fewer points (a few minutes instead of about twenty).
        #[arg(long)]
        quick: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Solve(args)) => cli::solve::solve(&args),
        Some(Command::Run {
            scene,
            from,
            snapshot_at,
            snapshot,
            duration,
            variant,
            threads,
            stats,
            poses,
            dump_mlcp,
            every,
            dump_hard,
            shadow,
            json,
            set,
        }) => {
            let threads = threads.unwrap_or_else(cli::values::default_threads);
            let opts = pivotsim_server::run::RunOptions {
                duration,
                variant,
                stats,
                poses,
                dump_mlcp,
                every: every as usize,
                dump_hard: dump_hard as usize,
                shadow,
                progress: !json,
                snapshot: snapshot_at
                    .zip(snapshot)
                    .map(|(time, path)| pivotsim_server::run::SnapshotAt { time, path }),
                watchdog: None,
            };
            match (scene, from) {
                (_, Some(file)) => cli::run::run(cli::run::Start::Snapshot(file), &set, opts, threads, json),
                (Some(scene), None) => {
                    cli::run::run(cli::run::Start::Scene(scene), &set, opts, threads, json)
                }
                (None, None) => Err(anyhow::anyhow!("give --scene or --from")),
            }
        }
        Some(Command::Scenes) => {
            cli::run::scenes();
            Ok(())
        }
        Some(Command::Pattern { file, out, ordering }) => cli::pattern::pattern(&file, &out, ordering),
        Some(Command::BenchSolver { out, quick, data, sweep, hard, repeats }) => {
            let cfg = cli::bench::BenchConfig::new(out, quick, data);
            match sweep {
                Some(n) => cli::bench::sweep::run(n as usize, &cfg.out).map(|_| ()),
                None if hard => {
                    cli::bench::hard::run(&cfg.out, cfg.data.as_deref(), repeats as usize).map(|_| ())
                }
                None => cli::bench::run(&cfg).map(|_| ()),
            }
        }
        Some(Command::Report { out, quick }) => {
            let cfg = cli::report::ReportConfig {
                out: out.unwrap_or_else(|| PathBuf::from("report-out")),
                quick,
                tiny: false,
            };
            cli::report::run(&cfg).map(|_| ())
        }
        Some(Command::Serve(args)) => cli::serve::serve(args),
        Some(Command::Replay(args)) => cli::replay::replay(args),
        None => cli::serve::serve(cli.serve),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
