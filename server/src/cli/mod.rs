//! The binary's command layer: what the subcommands of `pivotsim-server` do beyond the library
//! (progress bars, plots, reports). `anyhow`, `indicatif` and `plotters` stay here, out of the
//! library's API.
//!
//! | module | command |
//! |---|---|
//! | `bench/` | `bench-solver`: kernel crossover, paper Fig. 4, every variant on every problem |
//! | `pattern.rs` | `pattern`: sparsity plots of an MLCP file (paper Fig. 5 and 6) |
//! | `report/` | `report`: the speed/accuracy report (paper Tables 2–4, Fig. 3, 5/6, 7, the trade, extremes) |
//! | `replay.rs` | `replay`: a recorded session served again bit for bit, or checked |
//! | `run.rs` | `run` (a scene headless) and `scenes` |
//! | `serve.rs` | `serve`, the default: options, the start message, the final report |
//! | `solve.rs` | `solve`: one MLCP file, text or JSON (`SolveStats` as it serializes) |
//! | `values.rs` | parsers that turn hostile numeric values into clear errors |

pub mod bench;
pub mod pattern;
pub mod replay;
pub mod report;
pub mod run;
pub mod serve;
pub mod solve;
pub mod values;

/// Logs to stderr at `info` (Zenoh at `warn`) unless `RUST_LOG` says otherwise; for the commands
/// that serve (`serve`, `replay`). A second call does nothing.
pub fn init_tracing() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,zenoh=warn".into()),
        )
        .with_writer(std::io::stderr)
        // Colours only on a terminal: a log file or a pipe gets plain text.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
}
