//! Temporary files of a test process: a scene (or any text) written where a server or a binary can
//! read it, and scratch directories, named after the process so that concurrent runs never meet.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

/// `pivotsim-PID-name` in the system's temporary directory (nothing is created).
pub fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("pivotsim-{}-{name}", std::process::id()))
}

/// Writes `text` to [`temp_path`]`(name)` and returns the path. The file is replaced whole (written
/// aside, then renamed), so tests of one process may write the same scene while others read it.
pub fn temp_file(name: &str, text: &str) -> PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let path = temp_path(name);
    let aside = temp_path(&format!("{name}.{}.part", NEXT.fetch_add(1, Ordering::Relaxed)));
    std::fs::write(&aside, text).unwrap_or_else(|e| panic!("{}: {e}", aside.display()));
    std::fs::rename(&aside, &path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    path
}

/// An empty directory at [`temp_path`]`(name)` (emptied if it was there), for a test's outputs.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = temp_path(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    dir
}
