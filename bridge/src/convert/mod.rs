//! pivotsim frames → ROS messages, and `sensor_msgs/Joy` → a pivotsim joystick frame. Pure
//! functions and small state (no DDS, no Zenoh): unit-tested here, used by the bridge loop.

use std::collections::HashMap;

use pivotsim_msgs as msgs;

use crate::ros_msgs::*;

mod diagnostics;
mod joy;
mod markers;
mod signals;
#[cfg(test)]
mod tests;
mod tf;

pub use diagnostics::*;
pub use joy::*;
pub use markers::*;
pub use signals::*;
pub use tf::*;

/// Which clock stamps `/tf`, `/pivotsim/pose_array` and the diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StampSource {
    /// Simulation time (as on `/clock`; ROS nodes run with `use_sim_time:=true`).
    #[default]
    Sim,
    /// The server's wall clock at the end of the step (the pose frame's `wall_time_ns`).
    Wall,
}

impl StampSource {
    /// The stamp of a pose frame.
    pub fn stamp(self, sim_time: f64, wall_time_ns: u64) -> Time {
        match self {
            StampSource::Sim => Time::from_secs_f64(sim_time),
            StampSource::Wall => Time::from_nanos(wall_time_ns.min(i64::MAX as u64) as i64),
        }
    }
}

/// What the bridge knows of the served scene: body names and kinds by id, and its markers.
#[derive(Debug, Clone)]
pub struct SceneInfo {
    /// The description as received.
    pub description: msgs::SceneDescription,
    names: HashMap<u32, usize>,
}

impl SceneInfo {
    /// Indexes a description.
    pub fn new(description: msgs::SceneDescription) -> SceneInfo {
        let names = description.bodies.iter().enumerate().map(|(i, b)| (b.id, i)).collect();
        SceneInfo { description, names }
    }

    /// The body with this id.
    pub fn body(&self, id: u32) -> Option<&msgs::BodyInfo> {
        self.names.get(&id).map(|&i| &self.description.bodies[i])
    }

    /// Whether a pose frame's bodies are exactly this scene's (same ids, same count).
    pub fn matches(&self, frame: &msgs::PoseFrame) -> bool {
        frame.bodies.len() == self.description.bodies.len()
            && frame.bodies.iter().all(|b| self.names.contains_key(&b.id))
    }
}
