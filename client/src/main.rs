//! `pivotsim-client`: the operator console. Its subcommands (watch, drive, send, scene, control,
//! record, ping) arrive with the server issue; today it only reports what it knows.

use clap::Parser;

/// Operator console and probes for the pivotsim server.
#[derive(Debug, Parser)]
#[command(version, about)]
struct Cli {}

fn main() -> anyhow::Result<()> {
    let _cli = Cli::parse();
    eprintln!(
        "pivotsim-client {}: no transport yet (the server issue adds watch/drive/send/record/ping); solver variants: {}",
        env!("CARGO_PKG_VERSION"),
        pivotsim_msgs::SOLVER_VARIANTS.join(", ")
    );
    Ok(())
}
