//! `pivotsim-server`: the CLI over the pivotsim library.
//!
//! Subcommands: `serve` (the default: a scene in real time over Zenoh and iceoryx2), `run` (a
//! scene headless, as fast as possible), `scenes` (the built-in scenes), `solve` (one MLCP file),
//! `pattern` (sparsity plots) and `bench-solver` (every variant on generated and shared problems).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use pivotsim_server::scene::SceneOverride;
use pivotsim_server::solver::{OrderingKind, Solver, SolverOptions, Variant, io};

/// Exact-contact multibody physics server (block principal pivoting with Cholesky downdates).
#[derive(Debug, Parser)]
#[command(version, about, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Without a subcommand: `serve` with these options.
    #[command(flatten)]
    serve: ServeArgs,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Serve a scene in real time over Zenoh and iceoryx2 (the default command).
    Serve(ServeArgs),
    /// Run a scene headless under its script, as fast as possible, and print a summary.
    Run {
        /// A built-in scene name (see `scenes`) or a scene file path.
        #[arg(long)]
        scene: String,
        /// Simulated seconds (default: the scene's duration).
        #[arg(long)]
        duration: Option<f64>,
        /// Solver variant for every island (default: the scene's).
        #[arg(long)]
        variant: Option<Variant>,
        /// Write per-step, per-island solver statistics here (CSV).
        #[arg(long)]
        stats: Option<PathBuf>,
        /// Write per-step body poses here (CSV).
        #[arg(long)]
        poses: Option<PathBuf>,
        /// Dump island problems in the MLCP file format into this directory.
        #[arg(long)]
        dump_mlcp: Option<PathBuf>,
        /// With --dump-mlcp: every N-th step.
        #[arg(long, default_value_t = 60)]
        every: usize,
        /// With --dump-mlcp: instead of every N-th step, the N hardest island solves of the run
        /// (not converged first, then most pivot steps, then slowest), with their warm starts.
        #[arg(long, default_value_t = 0)]
        dump_hard: usize,
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
    /// Solve one MLCP file (format: shared/MLCP_FORMAT.md) and print its statistics.
    Solve {
        /// The problem file.
        file: PathBuf,
        /// Solver variant: full, downdate, skyline, skyline-refactor, incremental, auto, pgs.
        #[arg(long, default_value = "auto")]
        variant: Variant,
        /// Cap on pivot steps (PGS: sweeps).
        #[arg(long, default_value_t = 35)]
        max_steps: usize,
        /// Reordering for the envelope variants: natural, cm, rcm.
        #[arg(long, default_value = "rcm")]
        ordering: OrderingKind,
        /// Relative natural-map residual to reach.
        #[arg(long, default_value_t = 1e-10)]
        tol: f64,
        /// Write λ here (one number per line, 17 significant digits).
        #[arg(long)]
        solution: Option<PathBuf>,
        /// Also measure the deletion error against a refactor from scratch (slower).
        #[arg(long)]
        deletion_error: bool,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Benchmark every solver variant: kernel crossover, paper Fig. 4, generated contact-like
    /// problems and the shared data files; writes bench.md, bench.json and SVG plots.
    BenchSolver {
        /// Output directory (default: bench-out/).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Smaller sizes and fewer repeats (about a minute).
        #[arg(long)]
        quick: bool,
        /// Scan this directory for *.txt MLCP files instead of the shared data directories.
        #[arg(long)]
        data: Option<PathBuf>,
    },
}

/// Options of `serve`.
#[derive(Debug, clap::Args)]
struct ServeArgs {
    /// A built-in scene name (see `scenes`) or a scene file path.
    #[arg(long, default_value = DEFAULT_SCENE)]
    scene: String,
    /// World name: keys are `pivotsim/<world>/...`.
    #[arg(long, default_value = pivotsim_msgs::DEFAULT_WORLD)]
    world: String,
    /// Zenoh endpoints to listen on (repeatable).
    #[arg(long, default_value = "tcp/127.0.0.1:7447")]
    listen: Vec<String>,
    /// Zenoh endpoints to connect to: routers or peers on other hosts (repeatable).
    #[arg(long)]
    connect: Vec<String>,
    /// A Zenoh configuration file (JSON5) for multi-host rigs and routers.
    #[arg(long)]
    zenoh_config: Option<PathBuf>,
    /// Turn Zenoh multicast scouting on (off by default: nothing leaves the given endpoints).
    #[arg(long)]
    multicast_scouting: bool,
    /// Do not start Zenoh.
    #[arg(long)]
    no_zenoh: bool,
    /// Do not start iceoryx2.
    #[arg(long)]
    no_iceoryx2: bool,
    /// Simulated seconds per wall second.
    #[arg(long, default_value_t = 1.0)]
    rtf: f64,
    /// Step as fast as possible instead of in real time.
    #[arg(long)]
    fast: bool,
    /// Deadman timeout in milliseconds.
    #[arg(long, default_value_t = 250)]
    deadman_ms: u64,
    /// Seconds between status lines (0: none; default 1 s on a terminal, none otherwise).
    #[arg(long)]
    status_interval: Option<f64>,
    /// Stop after this many steps.
    #[arg(long)]
    steps: Option<u64>,
    /// Start paused.
    #[arg(long)]
    paused: bool,
}

/// The scene `serve` runs when none is given.
const DEFAULT_SCENE: &str = "forklift";

fn serve(args: ServeArgs) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::Duration;
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,zenoh=warn".into()),
        )
        .with_writer(std::io::stderr)
        .try_init();
    let status_interval = match args.status_interval {
        Some(s) if s > 0.0 => Some(Duration::from_secs_f64(s)),
        Some(_) => None,
        None => std::io::stderr().is_terminal().then(|| Duration::from_secs(1)),
    };
    let config = pivotsim_server::serve::ServeConfig {
        scene: args.scene,
        world: args.world,
        realtime_factor: if args.fast { None } else { Some(args.rtf) },
        deadman: Duration::from_millis(args.deadman_ms),
        zenoh: (!args.no_zenoh).then_some(pivotsim_server::serve::ZenohOptions {
            listen: args.listen,
            connect: args.connect,
            config_file: args.zenoh_config,
            multicast_scouting: args.multicast_scouting,
        }),
        iceoryx2: !args.no_iceoryx2,
        status_interval,
        max_steps: args.steps,
        start_paused: args.paused,
    };
    let shutdown = Arc::new(AtomicBool::new(false));
    let flag = shutdown.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;
    let report = pivotsim_server::serve::run(&config, shutdown)?;
    println!(
        "{} steps, {:.2} s simulated in {:.2} s, {} overruns; inputs {} accepted, {} rejected, deadman trips {}",
        report.steps,
        report.sim_time,
        report.wall_s,
        report.overruns,
        report.inputs.accepted,
        report.inputs.rejected_total(),
        report.inputs.deadman_trips
    );
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Solve { file, variant, max_steps, ordering, tol, solution, deletion_error, json }) => {
            solve(&file, variant, max_steps, ordering, tol, solution, deletion_error, json)
        }
        Some(Command::Run {
            scene,
            duration,
            variant,
            stats,
            poses,
            dump_mlcp,
            every,
            dump_hard,
            json,
            set,
        }) => {
            let opts = pivotsim_server::run::RunOptions {
                duration,
                variant,
                stats,
                poses,
                dump_mlcp,
                every,
                dump_hard,
                progress: !json,
            };
            run(&scene, &set, &opts, json)
        }
        Some(Command::Scenes) => {
            for b in pivotsim_server::scene::BUILTIN {
                println!("{:<16} {}", b.name, b.summary);
            }
            Ok(())
        }
        Some(Command::Pattern { file, out, ordering }) => pattern(&file, &out, ordering),
        Some(Command::BenchSolver { out, quick, data }) => {
            let cfg = pivotsim_server::bench::BenchConfig::new(out, quick, data);
            pivotsim_server::bench::run(&cfg).map(|_| ())
        }
        Some(Command::Serve(args)) => serve(args),
        None => serve(cli.serve),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(
    scene: &str,
    overrides: &[SceneOverride],
    opts: &pivotsim_server::run::RunOptions,
    json: bool,
) -> anyhow::Result<()> {
    let mut sc = pivotsim_server::scene::load_with(scene, overrides)?;
    let summary = pivotsim_server::run::run_scene(&mut sc, opts)?;
    if json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!("{}", pivotsim_server::run::summary_text(&summary));
    }
    if !summary.finite {
        anyhow::bail!("the run stopped: {}", summary.error.as_deref().unwrap_or("non-finite state"));
    }
    Ok(())
}

fn pattern(file: &std::path::Path, out: &std::path::Path, ordering: OrderingKind) -> anyhow::Result<()> {
    let p = io::read_mlcp_file(file)?;
    let info = pivotsim_server::plot::sparsity_svg(out, p.a(), ordering)?;
    println!(
        "{}: m={} nnz={} bandwidth {}→{} envelope {}→{} factor {} stored / {} non-zero → {}",
        file.display(),
        info.m,
        info.nnz,
        info.bandwidth_before,
        info.bandwidth_after,
        info.envelope_before,
        info.envelope_after,
        info.factor_entries,
        info.factor_nonzeros,
        out.display()
    );
    Ok(())
}

fn solve(
    file: &std::path::Path,
    variant: Variant,
    max_steps: usize,
    ordering: OrderingKind,
    tol: f64,
    solution: Option<PathBuf>,
    deletion_error: bool,
    json: bool,
) -> anyhow::Result<()> {
    let p = io::read_mlcp_file(file)?;
    let mut opts = SolverOptions { variant, ordering, max_steps, tol_rel: tol, ..Default::default() };
    opts.pgs.max_iterations = max_steps;
    opts.pgs.tol_rel = tol;
    opts.measure_deletion_error = deletion_error;
    let mut solver = Solver::new(opts);
    let mut lambda = vec![0.0; p.n()];
    let st = solver.solve(&p, &mut lambda).clone();
    if let Some(out) = solution {
        let mut f = std::io::BufWriter::new(
            std::fs::File::create(&out).with_context(|| format!("cannot create {}", out.display()))?,
        );
        io::write_solution(&lambda, &mut f).with_context(|| format!("cannot write {}", out.display()))?;
    }
    if json {
        let v = serde_json::json!({
            "file": file.display().to_string(),
            "n": st.m,
            "nnz": st.nnz,
            "variant": st.variant.name(),
            "ordering": st.ordering.name(),
            "status": st.status.name(),
            "pivot_steps": st.pivot_steps,
            "iterations": st.iterations,
            "tight": st.tight,
            "tight_per_step": st.tight_per_step,
            "fallback": st.fallback,
            "murty_steps": st.murty_steps,
            "newton_steps": st.newton_steps,
            "proximal_iterations": st.proximal_iterations,
            "projected_newton_steps": st.projected_newton_steps,
            "friction_updates": st.friction_updates,
            "coupled_steps": st.coupled_steps,
            "outer_damped": st.outer_damped,
            "krylov_iterations": st.krylov_iterations,
            "residual": st.residual,
            "residual_rel": st.residual_rel,
            "time_us": st.total_us,
            "ordering_us": st.ordering_us,
            "factor_us": st.factor_us,
            "downdate_us": st.downdate_us,
            "solve_us": st.solve_us,
            "bandwidth": st.bandwidth_after,
            "bandwidth_before": st.bandwidth_before,
            "envelope": st.envelope_after,
            "envelope_before": st.envelope_before,
            "factor_entries": st.factor_entries,
            "deletions": st.deletions,
            "auto_choices": st.auto_choices,
            "regularized": st.regularized,
            "deletion_error": st.deletion_error,
            "deletion_error_abs": st.deletion_error_abs,
            "deletion_backward_error": st.deletion_backward_error,
        });
        println!("{v}");
    } else {
        println!(
            "{}: n={} variant={} status={} pivot_steps={} tight={} residual={:.3e} (rel {:.3e}) time={:.1} µs \
             [order {:.1}, factor {:.1}, downdate {:.1}, solve {:.1}] bandwidth {}→{} envelope {}→{} regularized={}",
            file.display(),
            st.m,
            st.variant,
            st.status.name(),
            if st.variant == Variant::Pgs { st.iterations } else { st.pivot_steps },
            st.tight,
            st.residual,
            st.residual_rel,
            st.total_us,
            st.ordering_us,
            st.factor_us,
            st.downdate_us,
            st.solve_us,
            st.bandwidth_before,
            st.bandwidth_after,
            st.envelope_before,
            st.envelope_after,
            st.regularized
        );
    }
    Ok(())
}
