//! pivotsim in Foxglove's terms: the channels (topics and schemas) shared by the live view
//! (`foxglove`) and the recording (`record`), the scene's shapes as scene entities, the per-step
//! transforms, the signals and events frames as JSON.

pub mod frames;
pub mod front;
pub mod scene;
pub mod signals;
pub mod topics;

/// The root frame every body's transform hangs from.
pub const WORLD_FRAME: &str = "world";

/// Which clock stamps messages (`--clock` of `foxglove` and `record`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Clock {
    /// Simulation time, ns from the scene's start (what `/clock` carries on the ROS 2 path).
    Sim,
    /// Wall time, ns since the UNIX epoch.
    Wall,
}

impl Clock {
    /// The stamp of a frame at simulation time `sim_time` taken at wall time `wall_ns`.
    pub fn stamp(self, sim_time: f64, wall_ns: u64) -> u64 {
        match self {
            Clock::Sim => frames::sim_ns(sim_time),
            Clock::Wall => wall_ns,
        }
    }
}
