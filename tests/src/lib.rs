//! The one test harness of pivotsim, used by the tests of every crate:
//!
//! | module | what |
//! |---|---|
//! | `server` (feature `live`) | a real server in-process: Zenoh on a free loopback port (multicast scouting off), iceoryx2, a world name unique to the test; a Zenoh client session connected to it |
//! | [`process`] | a binary run with a hard time limit, its output captured; a table of hostile flag values run against a binary (no panic); free loopback ports |
//! | [`files`] | temporary files and directories of the test process: a scene written where a server can read it |
//! | [`layout`] | Foxglove layouts: their topics, plot message paths and frames, resolved against messages as JSON |
//!
//! The tests that span crates live in `tests/tests/`; the tests of one binary live beside it and
//! use this harness (`env!("CARGO_BIN_EXE_…")` names a binary only inside its own package).
//! Every wait is bounded in time, and everything stays on 127.0.0.1.

pub mod files;
pub mod layout;
pub mod process;
#[cfg(feature = "live")]
pub mod server;

pub use files::{temp_dir, temp_file, temp_path};
pub use process::{Output, Running, assert_no_panic, free_endpoint, free_port, run, spawn};
#[cfg(feature = "live")]
pub use server::Server;
