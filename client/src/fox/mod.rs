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
