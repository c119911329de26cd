//! The client's side of the one test harness (`pivotsim-tests`): the client binary run against an
//! in-process server with a hard time limit.

#![allow(dead_code)]

use std::time::Duration;

// Each test file uses a part of this module.
#[allow(unused_imports)]
pub use pivotsim_tests::{Output, Running, Server, free_port};

/// The client binary.
pub const CLIENT: &str = env!("CARGO_BIN_EXE_pivotsim-client");

/// The test scene: a winch drum and a position-driven slider, no gravity.
pub const DRUM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/scenes/drum.toml");

/// The client run against a harness server.
pub trait ClientOf {
    /// Client arguments that reach this server.
    fn args(&self) -> Vec<String>;
    /// Runs the client with `args` after the connection options; panics past `limit`.
    fn client(&self, args: &[&str], limit: Duration) -> Output;
}

impl ClientOf for Server {
    fn args(&self) -> Vec<String> {
        self.client_args()
    }

    fn client(&self, args: &[&str], limit: Duration) -> Output {
        let mut all = self.client_args();
        all.extend(args.iter().map(|s| s.to_string()));
        run_client(&all, limit)
    }
}

/// Starts the client with `args`.
pub fn spawn_client(args: &[String], limit: Duration) -> Running {
    pivotsim_tests::spawn(CLIENT, args, limit)
}

/// Runs the client to completion within `limit`.
pub fn run_client(args: &[String], limit: Duration) -> Output {
    pivotsim_tests::run(CLIENT, args, limit)
}

/// The `key=value` field of a plain `watch` line.
pub fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace().find_map(|w| w.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
}
