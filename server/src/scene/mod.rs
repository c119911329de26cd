//! Scene files: the human-editable description of a machine and its world (TOML, specified in
//! `scenes/README.md`), loaded into a [`World`] with its named actuators ([`Controls`]), default
//! joystick mapping ([`JoystickMap`]) and scripted operator timeline ([`Script`]).
//!
//! | file | concept |
//! |---|---|
//! | `format.rs` | the file's syntax as serde types (unknown fields refused) |
//! | `build/` | checks and builds, one file per stage (settings, bodies, joints, items, actuators): repeats, references, inertia from shapes, errors with locations |
//! | `terrain.rs` | terrain shape types (heightfield, stairs, hills, trimesh) and the material table |
//! | `controls.rs` | actuators, joystick mapping, timeline |
//! | `signals.rs` | `[[sensor]]`, `[[event]]`, `[[fault]]` → the scene's signals and faults |
//! | `faults.rs` | faults (rope break, hose burst, brake fade, sticking valve, sensor dropout), scripted and live |
//! | `builtin.rs` | the scenes shipped in `scenes/`, embedded in the binary |
//! | `overrides.rs` | `--set KEY=VALUE`: settings overridden on the command line |
//!
//! Loading is all or nothing: the world is built in a local and handed out only when every table
//! passed, so a bad scene never half-loads. Every error names the file, line and column of the
//! offending table or value and the field ([`SceneError`]).
//!
//! ```
//! let mut scene = pivotsim_server::scene::load_str("inline", r#"
//!     [scene]
//!     name = "drop"
//!     [[body]]
//!     name = "ball"
//!     mass = 1.0
//!     position = [0, 0, 2]
//!     [[body.shape]]
//!     type = "ball"
//!     radius = 0.1
//! "#)?;
//! scene.step()?;
//! assert!(scene.world.body_id("ball").is_some());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod build;
mod builtin;
mod checks;
mod controls;
mod faults;
mod format;
mod overrides;
mod signals;
mod state;
mod terrain;

use std::fmt;
use std::path::Path;

use thiserror::Error;

pub use builtin::{BUILTIN, BuiltinScene, builtin};
pub use controls::{
    Actuator, ActuatorFault, ActuatorKind, ActuatorTarget, AxisMode, ButtonAction, Controls, InputError,
    JoyAxis, JoyButton, JoystickError, JoystickMap, Neutral, RampProfile, SceneEvent, Script, ScriptEntry,
};
pub use faults::{Fault, FaultAction, FaultError, FaultRequest, FaultTrigger, Faults, MAX_FAULTS};
pub use overrides::{OverrideError, SceneOverride};
pub use signals::DEFAULT_TOUCH;
pub use state::{ActuatorState, SceneState, SceneStateError};

use crate::dynamics::{ControlError, ModelError, StepError, WatchdogSettings, World};
use crate::signals::{Event, EventKind, EventName, Signals};

/// A place in a scene file (1-based line and column).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// File path or `builtin:<name>`.
    pub file: String,
    /// Line.
    pub line: usize,
    /// Column (bytes).
    pub column: usize,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// Why a scene did not load.
#[derive(Debug, Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: cannot read the scene: {source}")]
    Io {
        /// The path.
        file: String,
        /// The cause.
        source: std::io::Error,
    },
    /// TOML syntax, a wrong type, an unknown or missing field.
    #[error("{at}: {message}")]
    Syntax {
        /// Where.
        at: Location,
        /// What the parser said.
        message: String,
    },
    /// A value that parses but means nothing (a missing body, a bad number, a conflict).
    #[error("{at}: `{field}`: {message}")]
    Invalid {
        /// Where (the table holding the field).
        at: Location,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The dynamics refused an item.
    #[error("{at}: `{item}`: {source}")]
    Model {
        /// Where.
        at: Location,
        /// The item's name.
        item: String,
        /// The dynamics' typed error.
        source: Box<ModelError>,
    },
    /// A `--set KEY=VALUE` override that names nothing in the scene.
    #[error("{file}: --set {source}")]
    Override {
        /// The scene.
        file: String,
        /// What is wrong with the override.
        source: OverrideError,
    },
    /// Neither a built-in scene nor a readable file.
    #[error("no built-in scene `{name}` and no such file (built-in: {known})")]
    Unknown {
        /// What was asked for.
        name: String,
        /// The built-in names.
        known: String,
    },
}

impl SceneError {
    /// The location, when the error has one.
    pub fn location(&self) -> Option<&Location> {
        match self {
            SceneError::Syntax { at, .. } | SceneError::Invalid { at, .. } | SceneError::Model { at, .. } => {
                Some(at)
            }
            _ => None,
        }
    }
}

/// Why a scene's step failed.
#[derive(Debug, Error)]
pub enum SceneStepError {
    /// An actuator or event was refused by the world.
    #[error(transparent)]
    Control(#[from] ControlError),
    /// The step failed.
    #[error(transparent)]
    Step(#[from] StepError),
}

/// A loaded scene: the world, its inputs and its timeline.
#[derive(Debug)]
pub struct Scene {
    /// Name (`[scene] name`).
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Where it came from (path or `builtin:<name>`).
    pub source: String,
    /// The text it was built from, overrides applied: what a snapshot names it by (`snapshot/`).
    pub text: String,
    /// Default run length (s).
    pub duration: f64,
    /// The world.
    pub world: World,
    /// Named actuators.
    pub controls: Controls,
    /// Scripted operator timeline.
    pub script: Script,
    /// Default joystick mapping.
    pub joystick: JoystickMap,
    /// Bounds of the instability watchdog (`[scene] max_speed`, `energy_margin`).
    pub watchdog: WatchdogSettings,
    /// Sensors and threshold events (`[[sensor]]`, `[[event]]`), evaluated after every step.
    pub signals: Signals,
    /// Faults, declared (`[[fault]]`) and requested ([`Scene::request_fault`]).
    pub faults: Faults,
    /// How many of `faults` the file declared (a reset keeps these).
    pub declared_faults: usize,
    /// Shapes drawn but not collided (a `[[cable]]`'s segment capsules): body, shape, pose in the
    /// body frame. Display only: the world never sees them.
    pub visuals: Vec<(crate::dynamics::BodyId, crate::dynamics::Shape, nalgebra::Isometry3<f64>)>,
}

impl Scene {
    /// One step driven by the script: fires the timeline entries due now, applies the actuators,
    /// steps the world.
    pub fn step(&mut self) -> Result<(), SceneStepError> {
        let t = self.world.time();
        self.script.advance(t, &mut self.controls, &mut self.world)?;
        self.step_manual()
    }

    /// One step without the script (an operator drives the actuators): the faults due, the
    /// actuators, the world's step, then the signals, tension-triggered faults and thresholds.
    pub fn step_manual(&mut self) -> Result<(), SceneStepError> {
        let h = self.world.settings().timestep;
        self.signals.begin_events();
        let t = self.world.time();
        self.faults.before_step(t, &mut self.world, &mut self.controls, &mut self.signals)?;
        self.controls.apply(&mut self.world, h)?;
        self.world.step()?;
        self.signals.evaluate(&self.world);
        let t = self.world.time();
        self.faults.after_step(t, &mut self.world, &mut self.controls, &mut self.signals)?;
        self.signals.check_thresholds(t);
        Ok(())
    }

    /// A live fault request (an instructor station): checked against the scene and queued to fire
    /// at the next step (or when its tension limit is reached). A refused request is counted as a
    /// `FaultRejected` event and returned as a typed error.
    pub fn request_fault(&mut self, req: &FaultRequest) -> Result<(), FaultError> {
        let result = Faults::resolve(req, &self.world, &self.controls, &self.signals, None)
            .and_then(|f| self.faults.push(f, &mut self.signals));
        if result.is_err() {
            let time = self.world.time();
            let name = EventName::new(&req.target);
            self.signals.queue_event(Event {
                kind: EventKind::FaultRejected,
                name,
                time,
                value: 0.0,
                level: 0.0,
            });
        }
        result
    }
}

/// Loads a scene from text; `file` labels error locations.
pub fn load_str(file: &str, text: &str) -> Result<Scene, SceneError> {
    build::build(file, text)
}

/// Loads a scene from text with settings overridden (`--set KEY=VALUE`, see [`SceneOverride`]);
/// `file` labels error locations.
pub fn load_str_with(file: &str, text: &str, overrides: &[SceneOverride]) -> Result<Scene, SceneError> {
    let text = overrides::apply(text, overrides)
        .map_err(|source| SceneError::Override { file: file.to_string(), source })?;
    load_str(file, &text)
}

/// Loads a scene file.
pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|source| SceneError::Io { file: file.clone(), source })?;
    load_str(&file, &text)
}

/// Loads a built-in scene by name, or else a file by path.
pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
    load_with(name_or_path, &[])
}

/// Loads a built-in scene by name, or else a file by path, with settings overridden
/// (`--set KEY=VALUE`, see [`SceneOverride`]); the overridden values pass the same checks as
/// values written in the file.
pub fn load_with(name_or_path: &str, overrides: &[SceneOverride]) -> Result<Scene, SceneError> {
    let with = |file: String, text: &str| load_str_with(&file, text, overrides);
    if let Some(b) = builtin(name_or_path) {
        return with(format!("builtin:{}", b.name), b.text);
    }
    let path = Path::new(name_or_path);
    if path.exists() {
        let file = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|source| SceneError::Io { file: file.clone(), source })?;
        return with(file, &text);
    }
    Err(SceneError::Unknown {
        name: name_or_path.to_string(),
        known: BUILTIN.iter().map(|b| b.name).collect::<Vec<_>>().join(", "),
    })
}
