//! Snapshots: a scene's complete state in a versioned file, from which a run continues bit for bit
//! as if it had never stopped (README "Rig control").
//!
//! **What is in one.** The scene it belongs to — its name, its source, the text it was built from
//! with every override applied, and that text's SHA-256 — and the scene's state
//! ([`SceneState`]): the world's ([`WorldState`](crate::dynamics::WorldState): poses, velocities,
//! joints enabled and their motors, warm starts of every row, the narrow phase's manifolds), the
//! actuators' commands and faults, the script's position and ramps, the faults with when they
//! fired, the signals' debouncers and counters; and, when the runner keeps one, the instability
//! watchdog's ledger. Everything else a step reads is either the scene's model, rebuilt from the
//! text, or recomputed within the step from the above (module docs of `dynamics/world/state.rs`,
//! `scene/state.rs`, `signals/state.rs` say part by part why).
//!
//! **File format** (version [`SNAPSHOT_FORMAT`]): the 8 bytes `PIVSNAP\0`, the format version as a
//! little-endian `u32`, then the [`Snapshot`] in postcard (serde's compact binary encoding: `f64`
//! bit for bit, integers as varints, sequences length-prefixed). A file of another format version,
//! not starting with the magic, cut short or with bytes after the value is refused with a
//! [`SnapshotError`]; so is a snapshot restored into another scene (its text's hash differs).
//! Equal states encode to equal bytes (maps are written sorted).
//!
//! **Bit-exact.** A restored run repeats the uninterrupted run's every pose and every solver
//! statistic but wall times, on the same build, CPU feature set and solver variant, with the same
//! inputs at the same steps (`tests/snapshot.rs` checks every shipped scene). A wall-clock solve
//! budget (`--max-solve-us`) makes any run depend on the machine's load, restored or not.

use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use thiserror::Error;

use crate::dynamics::{Watchdog, WorldStateError};
use crate::scene::{self, Scene, SceneError, SceneState, SceneStateError};

/// The file format version this build writes and reads.
pub const SNAPSHOT_FORMAT: u32 = 1;

/// The first bytes of a snapshot file.
pub const MAGIC: [u8; 8] = *b"PIVSNAP\0";

/// Largest snapshot file read (bytes): far above any scene's state (the crane's is ~0.3 MB).
pub const MAX_SNAPSHOT_BYTES: u64 = 256 << 20;

/// The scene a snapshot belongs to.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SceneRef {
    /// `[scene] name`.
    pub name: String,
    /// Where it was loaded from (path or `builtin:<name>`).
    pub source: String,
    /// SHA-256 of `text`, hex.
    pub digest: String,
    /// The text it was built from, overrides applied.
    pub text: String,
}

impl SceneRef {
    /// The reference of a loaded scene.
    pub fn of(scene: &Scene) -> Self {
        SceneRef {
            name: scene.name.clone(),
            source: scene.source.clone(),
            digest: digest(&scene.text),
            text: scene.text.clone(),
        }
    }
}

/// SHA-256 of a scene text, hex.
pub fn digest(text: &str) -> String {
    Sha256::digest(text.as_bytes()).iter().map(|b| format!("{b:02x}")).collect()
}

/// A snapshot (module doc).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Snapshot {
    /// The build that wrote it (`pivotsim-server <version>`, target): informative; a restore on
    /// another build is allowed but need not repeat the original run bit for bit.
    pub build: String,
    /// The scene.
    pub scene: SceneRef,
    /// Its state.
    pub state: SceneState,
    /// The instability watchdog's ledger, when the runner keeps one.
    pub watchdog: Option<Watchdog>,
    /// Whether an operator drove the actuators (the server's inputs) rather than the scene's
    /// script; a headless run's snapshot says `false`. A replay from a keyframe restores it; a
    /// `restore` request and `run --from` hand control to the script, as after a load.
    pub operator: bool,
}

/// Why a snapshot could not be taken, read or restored.
#[derive(Debug, Error)]
pub enum SnapshotError {
    /// Reading or writing the file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// The file is larger than [`MAX_SNAPSHOT_BYTES`].
    #[error("{bytes} bytes is more than a snapshot may have ({MAX_SNAPSHOT_BYTES})")]
    TooLarge {
        /// Its size.
        bytes: u64,
    },
    /// The bytes do not start with [`MAGIC`].
    #[error("not a pivotsim snapshot (no PIVSNAP header)")]
    NotASnapshot,
    /// Another format version.
    #[error("snapshot format {found}, this build reads format {SNAPSHOT_FORMAT}")]
    Format {
        /// The file's version.
        found: u32,
    },
    /// The bytes after the header do not decode (cut short, damaged, trailing bytes).
    #[error("damaged snapshot: {0}")]
    Corrupt(String),
    /// The snapshot is of another scene (or of the same scene with other overrides).
    #[error(
        "the snapshot is of scene `{snapshot}` ({snapshot_digest:.12}…), not of `{scene}` ({scene_digest:.12}…)"
    )]
    OtherScene {
        /// The snapshot's scene name.
        snapshot: String,
        /// Its text's digest.
        snapshot_digest: String,
        /// The scene it was restored into.
        scene: String,
        /// That scene's digest.
        scene_digest: String,
    },
    /// The state did not encode (a bug: every part is plain data).
    #[error("the snapshot did not encode: {0}")]
    Encode(String),
    /// The scene text the snapshot carries does not build.
    #[error("the snapshot's scene does not build: {0}")]
    Scene(#[from] Box<SceneError>),
    /// The state could not be taken.
    #[error(transparent)]
    Capture(#[from] WorldStateError),
    /// The state does not fit the scene (a damaged snapshot whose digest still matches).
    #[error(transparent)]
    State(#[from] SceneStateError),
}

impl Snapshot {
    /// The snapshot of `scene` now, with the runner's `watchdog` if it keeps one.
    pub fn capture(scene: &Scene, watchdog: Option<&Watchdog>) -> Result<Self, SnapshotError> {
        Ok(Snapshot {
            build: format!("pivotsim-server {} {}", env!("CARGO_PKG_VERSION"), std::env::consts::ARCH),
            scene: SceneRef::of(scene),
            state: scene.state()?,
            watchdog: watchdog.cloned(),
            operator: false,
        })
    }

    /// Simulation time of the state (s).
    pub fn time(&self) -> f64 {
        self.state.world.time()
    }

    /// Steps the world had taken.
    pub fn steps(&self) -> u64 {
        self.state.world.steps()
    }

    /// Restores the state into `scene`, which must be the snapshot's scene (same text, overrides
    /// applied); on an error `scene` is unchanged.
    pub fn restore_into(&self, scene: &mut Scene) -> Result<(), SnapshotError> {
        let d = digest(&scene.text);
        if d != self.scene.digest {
            return Err(SnapshotError::OtherScene {
                snapshot: self.scene.name.clone(),
                snapshot_digest: self.scene.digest.clone(),
                scene: scene.name.clone(),
                scene_digest: d,
            });
        }
        scene.restore_state(&self.state)?;
        Ok(())
    }

    /// Builds the snapshot's scene from the text it carries and restores the state into it.
    pub fn to_scene(&self) -> Result<Scene, SnapshotError> {
        if digest(&self.scene.text) != self.scene.digest {
            return Err(SnapshotError::Corrupt("the scene text does not match its digest".into()));
        }
        let mut scene = scene::load_str(&self.scene.source, &self.scene.text).map_err(Box::new)?;
        self.restore_into(&mut scene)?;
        Ok(scene)
    }

    /// The file's bytes (module doc).
    pub fn to_bytes(&self) -> Result<Vec<u8>, SnapshotError> {
        let mut out = Vec::with_capacity(1 << 16);
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&SNAPSHOT_FORMAT.to_le_bytes());
        postcard::to_extend(self, out).map_err(|e| SnapshotError::Encode(e.to_string()))
    }

    /// Reads a snapshot from its bytes (module doc).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, SnapshotError> {
        let rest = bytes.strip_prefix(&MAGIC[..]).ok_or(SnapshotError::NotASnapshot)?;
        let (version, body) = rest.split_first_chunk::<4>().ok_or(SnapshotError::NotASnapshot)?;
        let found = u32::from_le_bytes(*version);
        if found != SNAPSHOT_FORMAT {
            return Err(SnapshotError::Format { found });
        }
        let (snap, trailing) =
            postcard::take_from_bytes::<Snapshot>(body).map_err(|e| SnapshotError::Corrupt(e.to_string()))?;
        if !trailing.is_empty() {
            return Err(SnapshotError::Corrupt(format!("{} bytes after the snapshot", trailing.len())));
        }
        Ok(snap)
    }

    /// Writes the file (through a temporary file renamed into place: a reader never sees half a
    /// snapshot).
    pub fn write(&self, path: &Path) -> Result<(), SnapshotError> {
        let io = |source| SnapshotError::Io { path: path.display().to_string(), source };
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".part");
        std::fs::write(&tmp, self.to_bytes()?).map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    }

    /// Reads a file (at most [`MAX_SNAPSHOT_BYTES`]).
    pub fn read(path: &Path) -> Result<Self, SnapshotError> {
        use std::io::Read;
        let io = |source| SnapshotError::Io { path: path.display().to_string(), source };
        let file = std::fs::File::open(path).map_err(io)?;
        let mut bytes = Vec::new();
        file.take(MAX_SNAPSHOT_BYTES + 1).read_to_end(&mut bytes).map_err(io)?;
        if bytes.len() as u64 > MAX_SNAPSHOT_BYTES {
            return Err(SnapshotError::TooLarge { bytes: bytes.len() as u64 });
        }
        Self::from_bytes(&bytes)
    }
}
