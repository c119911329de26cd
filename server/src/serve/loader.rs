//! Scene loading that cannot hurt the world: what `load_scene` and `reset` may read, and reading
//! it off the step thread.
//!
//! **What may be loaded** ([`LoadPolicy`]). A built-in scene by name; the start scene (the file
//! named on the server's command line, which its operator chose); or a file inside one of the
//! server's scene directories (`serve --scene-dir DIR`, repeatable; none by default). A relative
//! path is looked up in each scene directory in the order given, then against the server's working
//! directory; every candidate is resolved to its canonical path (symbolic links and `..` followed)
//! and must lie inside a scene directory, so neither `../` nor a link leads out. Anything else is
//! refused with [`LoadError::Refused`] (the control reply code `load_refused`) before a byte of it
//! is read:
//!
//! - a path outside the scene directories (also every path when there are none);
//! - a file that is not a regular file — a FIFO, a device such as `/dev/zero`, a directory, a
//!   socket: the file is opened non-blocking (so a FIFO without a writer cannot stall the loader)
//!   and its type is taken from the open descriptor, not from the path, so a file swapped between a
//!   check and the open is still caught;
//! - a file larger than the size bound (`--max-scene-bytes`, [`DEFAULT_MAX_SCENE_BYTES`] = 1 MiB):
//!   the length from the descriptor is checked first, and the read stops at the bound plus one
//!   byte, so a file that grows while it is read is refused too, never read past the bound.
//!
//! **No echo.** A file inside the scene directories that is not a scene (not UTF-8 text, not TOML,
//! or TOML without a `[scene]` table) is refused as `not a scene file`, with at most a line number:
//! the parser's message, which may quote the offending text, is only given for files that declare
//! a `[scene]` table, i.e. for scene files with a mistake in them.
//!
//! **Off the step thread.** [`LoadJob::run`] resolves, reads and builds; it owns everything it
//! needs and is `Send`, so the server's loop hands it to a loader thread ([`Loader`]) and keeps
//! stepping (or stays paused) until the built scene comes back, then swaps it in at a step boundary
//! ([`super::Engine::finish_load`]) and replies. One load at a time: a second request while one is
//! under way is answered `busy`.

use std::fs::OpenOptions;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::thread::JoinHandle;
use std::time::Duration;

use pivotsim_msgs as msgs;
use thiserror::Error;

use crate::scene::{self, BUILTIN, Scene, SceneError, SceneOverride, builtin};

/// Largest scene file read by default (1 MiB; the largest shipped scene is about 20 KiB).
pub const DEFAULT_MAX_SCENE_BYTES: u64 = 1 << 20;

/// Where scenes may come from and how large they may be (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct LoadPolicy {
    /// Canonical scene directories.
    dirs: Vec<PathBuf>,
    /// Size bound (bytes).
    max_bytes: u64,
    /// The start scene's reference, as given on the command line, when it is a file.
    trusted: Option<String>,
    /// Test hook: the loader waits this long before it reads (slow storage).
    delay: Option<Duration>,
}

impl Default for LoadPolicy {
    /// Built-in scenes only, 1 MiB.
    fn default() -> Self {
        LoadPolicy { dirs: Vec::new(), max_bytes: DEFAULT_MAX_SCENE_BYTES, trusted: None, delay: None }
    }
}

/// A scene directory that cannot serve as one.
#[derive(Debug, Error)]
pub enum PolicyError {
    /// The directory does not exist or cannot be resolved.
    #[error("scene directory {dir}: {source}")]
    Dir {
        /// As given.
        dir: String,
        /// Why.
        source: std::io::Error,
    },
    /// Not a directory.
    #[error("scene directory {dir}: not a directory")]
    NotADir {
        /// As given.
        dir: String,
    },
    /// A size bound of 0.
    #[error("--max-scene-bytes must be at least 1")]
    ZeroBound,
}

impl LoadPolicy {
    /// The policy of these scene directories (each must exist) and size bound.
    pub fn new(dirs: &[PathBuf], max_bytes: u64) -> Result<LoadPolicy, PolicyError> {
        if max_bytes == 0 {
            return Err(PolicyError::ZeroBound);
        }
        let mut canonical = Vec::with_capacity(dirs.len());
        for d in dirs {
            let dir = d.display().to_string();
            let c = d.canonicalize().map_err(|source| PolicyError::Dir { dir: dir.clone(), source })?;
            if !c.is_dir() {
                return Err(PolicyError::NotADir { dir });
            }
            canonical.push(c);
        }
        Ok(LoadPolicy { dirs: canonical, max_bytes, trusted: None, delay: None })
    }

    /// Trusts `scene_ref`, the start scene named on the command line (no-op for a built-in name).
    pub fn trust_start_scene(&mut self, scene_ref: &str) {
        if builtin(scene_ref).is_none() {
            self.trusted = Some(scene_ref.to_string());
        }
    }

    /// Test hook: every load waits `delay` before it reads (slow storage).
    pub fn with_delay(mut self, delay: Option<Duration>) -> LoadPolicy {
        self.delay = delay;
        self
    }

    /// The size bound (bytes).
    pub fn max_bytes(&self) -> u64 {
        self.max_bytes
    }

    /// The canonical scene directories.
    pub fn dirs(&self) -> &[PathBuf] {
        &self.dirs
    }

    /// Where `scene_ref` is read from, or why it is refused (nothing is opened).
    pub fn resolve(&self, scene_ref: &str) -> Result<Source, LoadError> {
        if let Some(b) = builtin(scene_ref) {
            return Ok(Source::Builtin(b));
        }
        if self.trusted.as_deref() == Some(scene_ref) {
            return Ok(Source::File(PathBuf::from(scene_ref)));
        }
        let p = Path::new(scene_ref);
        let mut candidates: Vec<PathBuf> = Vec::new();
        if p.is_absolute() {
            candidates.push(p.to_path_buf());
        } else {
            candidates.extend(self.dirs.iter().map(|d| d.join(p)));
            candidates.push(p.to_path_buf());
        }
        let mut outside = false;
        for c in candidates {
            // `canonicalize` only reads directory entries and links, never the file itself.
            let Ok(c) = c.canonicalize() else { continue };
            if self.dirs.iter().any(|d| c.starts_with(d)) {
                return Ok(Source::File(c));
            }
            outside = true;
        }
        if outside {
            return Err(LoadError::Refused {
                scene: scene_ref.to_string(),
                reason: if self.dirs.is_empty() { Refusal::NoSceneDirs } else { Refusal::OutsideSceneDirs },
            });
        }
        Err(LoadError::Unknown {
            name: scene_ref.to_string(),
            known: BUILTIN.iter().map(|b| b.name).collect::<Vec<_>>().join(", "),
            dirs: self.dirs.len(),
        })
    }

    /// Reads a file of this policy's: regular, at most the bound, UTF-8 (module doc).
    pub fn read(&self, path: &Path, scene_ref: &str) -> Result<String, LoadError> {
        let refused = |reason| LoadError::Refused { scene: scene_ref.to_string(), reason };
        let io = |e: std::io::Error| LoadError::Io { scene: scene_ref.to_string(), kind: e.kind() };
        let file = open_nonblocking(path).map_err(io)?;
        let meta = file.metadata().map_err(io)?;
        let ty = meta.file_type();
        if !ty.is_file() {
            return Err(refused(Refusal::NotRegular { kind: file_kind(&ty) }));
        }
        let max = self.max_bytes;
        if meta.len() > max {
            return Err(refused(Refusal::TooLarge { bytes: meta.len(), max }));
        }
        let mut bytes = Vec::with_capacity(meta.len() as usize);
        file.take(max + 1).read_to_end(&mut bytes).map_err(io)?;
        if bytes.len() as u64 > max {
            return Err(refused(Refusal::TooLarge { bytes: bytes.len() as u64, max }));
        }
        String::from_utf8(bytes).map_err(|_| refused(Refusal::NotAScene { line: None }))
    }
}

/// Opens `path` for reading without blocking on a FIFO that has no writer.
fn open_nonblocking(path: &Path) -> std::io::Result<std::fs::File> {
    let mut o = OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    o.open(path)
}

/// What kind of non-regular file this is, for the refusal.
fn file_kind(ty: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ty.is_fifo() {
            return "a FIFO";
        }
        if ty.is_char_device() || ty.is_block_device() {
            return "a device";
        }
        if ty.is_socket() {
            return "a socket";
        }
    }
    if ty.is_dir() { "a directory" } else { "not a regular file" }
}

/// Where a scene is read from.
#[derive(Debug, Clone)]
pub enum Source {
    /// A built-in scene.
    Builtin(&'static scene::BuiltinScene),
    /// A file (canonical, or the trusted start scene's path as given).
    File(PathBuf),
}

/// Why a scene was refused before it was read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Refusal {
    /// The server has no scene directories: only built-in scenes and the start scene load.
    NoSceneDirs,
    /// The path resolves outside every scene directory.
    OutsideSceneDirs,
    /// Not a regular file.
    NotRegular {
        /// `a FIFO`, `a device`, `a directory`, `a socket`.
        kind: &'static str,
    },
    /// Larger than the bound.
    TooLarge {
        /// Its size (or what was read before the read stopped).
        bytes: u64,
        /// The bound.
        max: u64,
    },
    /// Inside the scene directories but not a scene: not UTF-8, not TOML, or no `[scene]` table.
    NotAScene {
        /// The line of a TOML syntax error, when that is the reason.
        line: Option<usize>,
    },
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::NoSceneDirs => f.write_str(
                "the server loads built-in scenes only (start it with --scene-dir DIR to allow files from DIR)",
            ),
            Refusal::OutsideSceneDirs => f.write_str("outside the server's scene directories (--scene-dir)"),
            Refusal::NotRegular { kind } => write!(f, "{kind}, not a regular file"),
            Refusal::TooLarge { bytes, max } => {
                write!(f, "larger than the server's bound of {max} bytes ({bytes} bytes; --max-scene-bytes)")
            }
            Refusal::NotAScene { line: Some(l) } => write!(f, "not a scene file (not TOML: line {l})"),
            Refusal::NotAScene { line: None } => {
                f.write_str("not a scene file (not UTF-8 TOML text with a [scene] table)")
            }
        }
    }
}

/// Why a load failed.
#[derive(Debug, Error)]
pub enum LoadError {
    /// Neither a built-in scene nor a file in the scene directories.
    #[error(
        "no built-in scene `{name}` and no such file in the server's {dirs} scene director{} (built-in: {known})",
        if *dirs == 1 { "y" } else { "ies" }
    )]
    Unknown {
        /// As asked.
        name: String,
        /// The built-in names.
        known: String,
        /// How many scene directories were searched.
        dirs: usize,
    },
    /// Refused before it was read (module doc).
    #[error("scene `{scene}` refused: {reason}")]
    Refused {
        /// As asked.
        scene: String,
        /// Why.
        reason: Refusal,
    },
    /// The file could not be read.
    #[error("scene `{scene}`: cannot read it ({kind})")]
    Io {
        /// As asked.
        scene: String,
        /// The I/O error's kind (its message could name other paths).
        kind: std::io::ErrorKind,
    },
    /// A scene file that does not build (located).
    #[error(transparent)]
    Scene(#[from] SceneError),
}

impl LoadError {
    /// The control reply code of this failure.
    pub fn code(&self) -> msgs::ControlErrorCode {
        match self {
            LoadError::Unknown { .. } => msgs::ControlErrorCode::UnknownScene,
            LoadError::Refused { .. } => msgs::ControlErrorCode::LoadRefused,
            LoadError::Io { .. } | LoadError::Scene(_) => msgs::ControlErrorCode::SceneLoadFailed,
        }
    }
}

/// Refuses text that is not a scene without quoting it: only a file with a `[scene]` table gets
/// the parser's (possibly quoting) messages.
fn check_is_scene(text: &str, scene_ref: &str) -> Result<(), LoadError> {
    let refused =
        |line| LoadError::Refused { scene: scene_ref.to_string(), reason: Refusal::NotAScene { line } };
    match text.parse::<toml::Table>() {
        Ok(t) if t.get("scene").is_some_and(|s| s.is_table()) => Ok(()),
        Ok(_) => Err(refused(None)),
        // A scene file with a syntax error: its own messages are the user's to see.
        Err(_) if text.lines().any(|l| l.trim_start().starts_with("[scene]")) => Ok(()),
        Err(e) => {
            let line = e.span().map(|s| text[..s.start.min(text.len())].lines().count().max(1));
            Err(refused(line))
        }
    }
}

/// One `load_scene` or `reset`: everything needed to resolve, read and build the scene on any
/// thread.
#[derive(Debug)]
pub struct LoadJob {
    /// The control request's id.
    pub id: u64,
    /// The scene as asked.
    pub scene_ref: String,
    policy: Arc<LoadPolicy>,
    overrides: Vec<SceneOverride>,
}

/// A finished [`LoadJob`].
#[derive(Debug)]
pub struct Loaded {
    /// The control request's id.
    pub id: u64,
    /// The scene as asked.
    pub scene_ref: String,
    /// The built scene, or why not.
    pub result: Result<Scene, LoadError>,
}

impl LoadJob {
    /// A job for request `id`.
    pub fn new(id: u64, scene_ref: &str, policy: Arc<LoadPolicy>, overrides: Vec<SceneOverride>) -> LoadJob {
        LoadJob { id, scene_ref: scene_ref.to_string(), policy, overrides }
    }

    /// Resolves, reads and builds (module doc).
    pub fn run(self) -> Loaded {
        let result = self.build();
        Loaded { id: self.id, scene_ref: self.scene_ref, result }
    }

    fn build(&self) -> Result<Scene, LoadError> {
        let source = self.policy.resolve(&self.scene_ref)?;
        if let Some(d) = self.policy.delay {
            std::thread::sleep(d);
        }
        let (file, text) = match &source {
            Source::Builtin(b) => (format!("builtin:{}", b.name), b.text.to_string()),
            Source::File(p) => {
                let text = self.policy.read(p, &self.scene_ref)?;
                check_is_scene(&text, &self.scene_ref)?;
                (p.display().to_string(), text)
            }
        };
        Ok(scene::load_str_with(&file, &text, &self.overrides)?)
    }
}

/// Sends the encoded reply of a control request (a transport's).
pub type ReplyFn = Box<dyn FnOnce(Vec<u8>) + Send>;

/// The loader thread: runs one [`LoadJob`] at a time and hands back the built scene with the
/// reply of the request that asked for it.
pub struct Loader {
    jobs: Option<Sender<LoadJob>>,
    done: Receiver<Loaded>,
    reply: Option<(u64, ReplyFn)>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Loader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Loader").field("busy", &self.is_busy()).finish()
    }
}

impl Loader {
    /// Starts the thread.
    pub fn spawn() -> std::io::Result<Loader> {
        let (jobs, rx) = channel::<LoadJob>();
        let (tx, done) = channel::<Loaded>();
        let thread = std::thread::Builder::new().name("scene-loader".into()).spawn(move || {
            for job in rx {
                if tx.send(job.run()).is_err() {
                    return;
                }
            }
        })?;
        Ok(Loader { jobs: Some(jobs), done, reply: None, thread: Some(thread) })
    }

    /// Whether a job is under way.
    pub fn is_busy(&self) -> bool {
        self.reply.is_some()
    }

    /// Hands `job` to the thread, keeping `reply` until it is done; gives both back when a job is
    /// already under way (or the thread ended).
    pub fn submit(&mut self, job: LoadJob, reply: ReplyFn) -> Result<(), (LoadJob, ReplyFn)> {
        if self.is_busy() {
            return Err((job, reply));
        }
        let Some(tx) = &self.jobs else { return Err((job, reply)) };
        let id = job.id;
        if let Err(e) = tx.send(job) {
            return Err((e.0, reply));
        }
        self.reply = Some((id, reply));
        Ok(())
    }

    /// The finished job and its request's reply, if the job is done (never waits).
    pub fn finished(&mut self) -> Option<(Loaded, ReplyFn)> {
        if !self.is_busy() {
            return None;
        }
        match self.done.try_recv() {
            Ok(l) => self.reply.take().map(|(_, r)| (l, r)),
            Err(TryRecvError::Empty) => None,
            // The thread died (a panic while building): answer instead of waiting forever.
            Err(TryRecvError::Disconnected) => {
                self.jobs = None;
                let (id, r) = self.reply.take()?;
                r(super::Engine::error_reply(
                    id,
                    msgs::ControlErrorCode::Internal,
                    "the scene loader stopped",
                ));
                None
            }
        }
    }
}

impl Drop for Loader {
    /// Closes the job channel and waits for an idle thread; a load still reading is not waited
    /// for (its thread ends with the process).
    fn drop(&mut self) {
        drop(self.jobs.take());
        if let Some(t) = self.thread.take()
            && !self.is_busy()
        {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("pivotsim-loader-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn builtins_resolve_without_scene_dirs_and_paths_are_refused() {
        let p = LoadPolicy::default();
        assert!(matches!(p.resolve("crane"), Ok(Source::Builtin(b)) if b.name == "crane"));
        let e = p.resolve("/etc/hostname").unwrap_err();
        assert!(matches!(e, LoadError::Refused { reason: Refusal::NoSceneDirs, .. }), "{e}");
        assert_eq!(e.code(), msgs::ControlErrorCode::LoadRefused);
        let e = p.resolve("no-such-scene").unwrap_err();
        assert_eq!(e.code(), msgs::ControlErrorCode::UnknownScene);
    }

    #[test]
    fn dot_dot_and_links_do_not_lead_out_of_a_scene_dir() {
        let d = dir("dotdot");
        let inside = d.join("scenes");
        std::fs::create_dir_all(&inside).unwrap();
        std::fs::write(d.join("secret.toml"), "[scene]\nname = \"x\"\n").unwrap();
        std::fs::write(inside.join("ok.toml"), "[scene]\nname = \"x\"\n").unwrap();
        let p = LoadPolicy::new(std::slice::from_ref(&inside), 1024).unwrap();
        assert!(matches!(p.resolve("ok.toml"), Ok(Source::File(_))));
        let up = inside.join("../secret.toml");
        let e = p.resolve(up.to_str().unwrap()).unwrap_err();
        assert!(matches!(e, LoadError::Refused { reason: Refusal::OutsideSceneDirs, .. }), "{e}");
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("secret.toml"), inside.join("link.toml")).unwrap();
            let e = p.resolve("link.toml").unwrap_err();
            assert!(matches!(e, LoadError::Refused { reason: Refusal::OutsideSceneDirs, .. }), "{e}");
        }
    }

    #[test]
    fn a_file_over_the_bound_is_refused_and_not_a_scene_is_not_quoted() {
        let d = dir("bound");
        std::fs::write(d.join("big.toml"), vec![b'#'; 2048]).unwrap();
        std::fs::write(d.join("notes.toml"), "password = \"hunter2\"\n").unwrap();
        std::fs::write(d.join("junk.toml"), "hunter2 hunter2 = = =\n").unwrap();
        let p = Arc::new(LoadPolicy::new(std::slice::from_ref(&d), 1024).unwrap());
        let run = |s: &str| LoadJob::new(1, s, p.clone(), Vec::new()).run().result.unwrap_err();
        let e = run("big.toml");
        assert!(matches!(e, LoadError::Refused { reason: Refusal::TooLarge { bytes: 2048, max: 1024 }, .. }));
        for f in ["notes.toml", "junk.toml"] {
            let e = run(f);
            assert_eq!(e.code(), msgs::ControlErrorCode::LoadRefused, "{e}");
            assert!(!e.to_string().contains("hunter2"), "the contents are echoed: {e}");
        }
    }
}
