//! Wire types of pivotsim (plain data, no nalgebra, nothing of the server).
//!
//! The message set (pose frames, solver statistics, operator inputs, control requests, scene
//! description) is specified by the server issue; until it lands this crate only names the solver
//! variants as they travel on the wire, so that every side spells them the same way.

/// Solver variant names as they appear on the wire, in the CLI and in reports.
pub const SOLVER_VARIANTS: [&str; 7] =
    ["full", "downdate", "skyline", "skyline-refactor", "incremental", "auto", "pgs"];
