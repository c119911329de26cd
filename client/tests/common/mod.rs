//! Test harness: a real server in-process (Zenoh on a free loopback port, iceoryx2 on a world
//! name unique to the test) and the client binary run against it with a hard time limit.

#![allow(dead_code)]

use std::io::Read;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use pivotsim_server::serve::{ServeConfig, ZenohOptions, run};

/// The client binary.
pub const CLIENT: &str = env!("CARGO_BIN_EXE_pivotsim-client");

/// The test scene: a winch drum and a position-driven slider, no gravity.
pub const DRUM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/scenes/drum.toml");

/// A free TCP port on 127.0.0.1 (bound, read, released).
pub fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind 127.0.0.1:0");
    l.local_addr().unwrap().port()
}

/// A server running on a thread; stopped and joined on drop.
pub struct Server {
    /// `tcp/127.0.0.1:PORT`.
    pub endpoint: String,
    /// World name.
    pub world: String,
    shutdown: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    /// Starts `scene` as a world named after `tag` and this process; waits until Zenoh listens.
    pub fn start(scene: &str, tag: &str) -> Server {
        Server::start_with(scene, tag, |_| {})
    }

    /// Same, with changes to the configuration.
    pub fn start_with(scene: &str, tag: &str, f: impl FnOnce(&mut ServeConfig)) -> Server {
        let port = free_port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let world = format!("ct-{tag}-{}", std::process::id());
        let mut config = ServeConfig {
            scene: scene.to_string(),
            world: world.clone(),
            zenoh: Some(ZenohOptions { listen: vec![endpoint.clone()], ..ZenohOptions::default() }),
            iceoryx2: true,
            ..ServeConfig::default()
        };
        f(&mut config);
        let shutdown = Arc::new(AtomicBool::new(false));
        let stop = shutdown.clone();
        let thread = std::thread::spawn(move || {
            run(&config, stop).expect("server runs");
        });
        let deadline = Instant::now() + Duration::from_secs(20);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(Instant::now() < deadline, "server did not listen on {port}");
            assert!(!thread.is_finished(), "server thread ended");
            std::thread::sleep(Duration::from_millis(20));
        }
        // iceoryx2 opens right after Zenoh.
        std::thread::sleep(Duration::from_millis(100));
        Server { endpoint, world, shutdown, thread: Some(thread) }
    }

    /// Client arguments that reach this server.
    pub fn args(&self) -> Vec<String> {
        vec!["--connect".into(), self.endpoint.clone(), "--world".into(), self.world.clone()]
    }

    /// Runs the client with `args` after the connection options; panics past `limit`.
    pub fn client(&self, args: &[&str], limit: Duration) -> Output {
        let mut all = self.args();
        all.extend(args.iter().map(|s| s.to_string()));
        run_client(&all, limit)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.shutdown.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// What a client run printed.
#[derive(Debug)]
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
        assert_eq!(self.code, Some(0), "client failed\nstdout:\n{}\nstderr:\n{}", self.stdout, self.stderr);
        self
    }
}

/// A running client.
pub struct Running {
    child: std::process::Child,
    out: JoinHandle<String>,
    err: Arc<Mutex<String>>,
    err_thread: JoinHandle<()>,
    started: Instant,
    limit: Duration,
}

/// Starts the client with `args`.
pub fn spawn_client(args: &[String], limit: Duration) -> Running {
    let mut child = Command::new(CLIENT)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the client");
    let mut so = child.stdout.take().unwrap();
    let mut se = child.stderr.take().unwrap();
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
                Ok(n) => e.lock().unwrap().push_str(&String::from_utf8_lossy(&buf[..n])),
            }
        }
    });
    Running { child, out, err, err_thread, started: Instant::now(), limit }
}

impl Running {
    /// Waits until the client wrote `text` on stderr (panics past `limit`).
    pub fn wait_for_stderr(&self, text: &str, limit: Duration) {
        let t = Instant::now();
        while !self.err.lock().unwrap().contains(text) {
            assert!(
                t.elapsed() < limit,
                "no {text:?} on stderr within {limit:?}: {}",
                self.err.lock().unwrap()
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Sends SIGINT (Ctrl-C) to the client.
    pub fn interrupt(&self) {
        let ok = Command::new("kill").args(["-INT", &self.child.id().to_string()]).status().expect("kill");
        assert!(ok.success());
    }

    /// Waits for the exit; kills the client and panics past the time limit.
    pub fn wait(mut self) -> Output {
        loop {
            if let Some(status) = self.child.try_wait().expect("wait") {
                let stdout = self.out.join().unwrap();
                let _ = self.err_thread.join();
                let stderr = self.err.lock().unwrap().clone();
                return Output { code: status.code(), stdout, stderr };
            }
            if self.started.elapsed() > self.limit {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!(
                    "client did not finish within {:?}\nstdout:\n{}\nstderr:\n{}",
                    self.limit,
                    self.out.join().unwrap(),
                    self.err.lock().unwrap()
                );
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

/// Runs the client to completion within `limit`.
pub fn run_client(args: &[String], limit: Duration) -> Output {
    spawn_client(args, limit).wait()
}

/// The `key=value` field of a plain `watch` line.
pub fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace().find_map(|w| w.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
}
