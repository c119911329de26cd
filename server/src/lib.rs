//! pivotsim server library: the solver (paper §3) and, as the project grows, the dynamics, the scene
//! loader and the transports. The binary `pivotsim-server` is a thin CLI over this library.

pub mod dynamics;
pub mod fault_matrix;
pub mod run;
pub mod scene;
pub mod serve;
pub mod signals;
pub mod snapshot;
pub mod solver;
