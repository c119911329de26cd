//! Binaries run as a user runs them, with a hard time limit and captured output.

use std::io::Read;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A free TCP port on 127.0.0.1 (bound, read, released).
pub fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind 127.0.0.1:0");
    l.local_addr().expect("a local address").port()
}

/// `tcp/127.0.0.1:<free port>`.
pub fn free_endpoint() -> String {
    format!("tcp/127.0.0.1:{}", free_port())
}

/// What a run printed.
#[derive(Debug, Clone)]
pub struct Output {
    /// Exit code (`None`: killed by a signal).
    pub code: Option<i32>,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
}

impl Output {
    /// Panics with both streams unless the exit code is 0.
    pub fn ok(self) -> Output {
        assert_eq!(self.code, Some(0), "run failed\nstdout:\n{}\nstderr:\n{}", self.stdout, self.stderr);
        self
    }

    /// Whether the run panicked (Rust's exit code 101, or a panic message).
    pub fn panicked(&self) -> bool {
        self.code == Some(101) || self.stderr.contains("panicked at")
    }
}

/// A running binary; killed when dropped.
#[derive(Debug)]
pub struct Running {
    child: Child,
    out: Option<JoinHandle<String>>,
    err: Arc<Mutex<String>>,
    err_thread: Option<JoinHandle<()>>,
    started: Instant,
    limit: Duration,
}

/// Starts `bin` with `args` (stdin closed, stdout and stderr captured).
pub fn spawn(bin: &str, args: &[String], limit: Duration) -> Running {
    let mut child = Command::new(bin)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {bin}: {e}"));
    let mut so = child.stdout.take().expect("piped stdout");
    let mut se = child.stderr.take().expect("piped stderr");
    let out = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = so.read_to_string(&mut s);
        s
    });
    let err = Arc::new(Mutex::new(String::new()));
    let e = err.clone();
    let err_thread = std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        loop {
            match se.read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(n) => e.lock().expect("stderr buffer").push_str(&String::from_utf8_lossy(&buf[..n])),
            }
        }
    });
    Running { child, out: Some(out), err, err_thread: Some(err_thread), started: Instant::now(), limit }
}

impl Running {
    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// What it wrote on stderr so far.
    pub fn stderr_so_far(&self) -> String {
        self.err.lock().expect("stderr buffer").clone()
    }

    /// Waits until it wrote `text` on stderr (panics past `limit`).
    pub fn wait_for_stderr(&self, text: &str, limit: Duration) {
        let t = Instant::now();
        while !self.err.lock().expect("stderr buffer").contains(text) {
            assert!(t.elapsed() < limit, "no {text:?} on stderr within {limit:?}: {}", self.stderr_so_far());
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Sends a signal (`INT`, `TERM`, `KILL`) to it.
    pub fn signal(&self, name: &str) {
        let ok = Command::new("kill").args([format!("-{name}"), self.child.id().to_string()]).status();
        assert!(ok.is_ok_and(|s| s.success()), "kill -{name}");
    }

    /// Sends SIGINT (Ctrl-C).
    pub fn interrupt(&self) {
        self.signal("INT");
    }

    /// Waits for the exit; `Err` with what it printed (after killing it) when it outlives its
    /// time limit.
    pub fn wait_limited(mut self) -> Result<Output, Output> {
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Ok(self.collect(status.code()));
            }
            if self.started.elapsed() > self.limit {
                let _ = self.child.kill();
                let _ = self.child.wait();
                return Err(self.collect(None));
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Waits for the exit; kills it and panics past the time limit.
    pub fn wait(self) -> Output {
        let limit = self.limit;
        match self.wait_limited() {
            Ok(o) => o,
            Err(o) => panic!("did not finish within {limit:?}\nstdout:\n{}\nstderr:\n{}", o.stdout, o.stderr),
        }
    }

    fn collect(&mut self, code: Option<i32>) -> Output {
        let stdout = self.out.take().and_then(|t| t.join().ok()).unwrap_or_default();
        if let Some(t) = self.err_thread.take() {
            let _ = t.join();
        }
        Output { code, stdout, stderr: self.stderr_so_far() }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Runs `bin` with `args` to completion within `limit` (panics past it).
pub fn run(bin: &str, args: &[String], limit: Duration) -> Output {
    spawn(bin, args, limit).wait()
}

/// Runs `bin` once per row of `cases` (each row: the arguments, with one hostile value in it) and
/// asserts that no run panics (exit code 101 or a panic message). A refused value is fine — that
/// is the point — and so is a run that does its job; a run still going at `limit` (a value that is
/// accepted and means "keep running") is stopped there and counts as not panicking. The failures
/// of all rows are reported together.
pub fn assert_no_panic(bin: &str, cases: &[Vec<&str>], limit: Duration) {
    let mut failures = Vec::new();
    for case in cases {
        let args: Vec<String> = case.iter().map(|s| s.to_string()).collect();
        let o = match spawn(bin, &args, limit).wait_limited() {
            Ok(o) | Err(o) => o,
        };
        if o.panicked() {
            failures.push(format!("{case:?}: panicked (exit {:?})\n{}", o.code, o.stderr));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} hostile runs panicked:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
