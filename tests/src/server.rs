//! A real server in-process on loopback, and a Zenoh client session connected to it.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_server::serve::{ServeConfig, ServeError, ServeReport, ZenohOptions, run};
use zenoh::Wait;

use crate::free_endpoint;

/// How long a server may take to listen.
const START_LIMIT: Duration = Duration::from_secs(20);

/// Starts tried on fresh ports before a test gives up.
const START_TRIES: usize = 3;

/// A world name unique to this test process and `tag`.
pub fn world_name(tag: &str) -> String {
    format!("t{}-{tag}", std::process::id())
}

/// A server running on a thread; stopped and joined on drop.
#[derive(Debug)]
pub struct Server {
    /// `tcp/127.0.0.1:PORT` (empty when Zenoh is off).
    pub endpoint: String,
    /// World name.
    pub world: msgs::WorldName,
    shutdown: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<ServeReport, ServeError>>>,
}

impl Server {
    /// Serves `scene` (a built-in name or a file) as a world named after `tag`, over Zenoh on a
    /// free loopback port and iceoryx2; returns once Zenoh listens.
    pub fn start(scene: &str, tag: &str) -> Server {
        Server::start_with(scene, tag, |_| {})
    }

    /// Same, with changes to the configuration (`config.zenoh = None` for iceoryx2 only, …). A free
    /// port can be taken by another test's Zenoh listener before the server binds it; then the
    /// server stops at once and the start is retried on a fresh port (at most `START_TRIES`).
    pub fn start_with(scene: &str, tag: &str, f: impl Fn(&mut ServeConfig)) -> Server {
        let mut last = String::new();
        for _ in 0..START_TRIES {
            let mut config = ServeConfig {
                scene: scene.to_string(),
                world: world_name(tag),
                zenoh: Some(ZenohOptions { listen: vec![free_endpoint()], ..ZenohOptions::default() }),
                iceoryx2: true,
                ..ServeConfig::default()
            };
            f(&mut config);
            match Server::try_spawn(config) {
                Ok(server) => return server,
                Err(e) => last = e,
            }
        }
        panic!("the server did not start in {START_TRIES} tries: {last}");
    }

    /// Runs `config` on a thread; returns once its Zenoh endpoint (if any) accepts connections.
    pub fn spawn(config: ServeConfig) -> Server {
        Server::try_spawn(config).unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Server::spawn`], with the reason as an error when the server stops during its start
    /// (e.g. its port was taken: something else then answers the connection check, so the thread
    /// is checked once more after it).
    fn try_spawn(config: ServeConfig) -> Result<Server, String> {
        let endpoint = config.zenoh.as_ref().and_then(|z| z.listen.first().cloned()).unwrap_or_default();
        let world = msgs::WorldName::new(config.world.clone()).expect("a valid world name");
        let shutdown = Arc::new(AtomicBool::new(false));
        let stop = shutdown.clone();
        let thread = std::thread::spawn(move || run(&config, stop));
        let stopped = |thread: JoinHandle<Result<ServeReport, ServeError>>| {
            let r = thread.join().expect("the server thread");
            format!("the server stopped during its start: {r:?}")
        };
        let port = endpoint.rsplit(':').next().and_then(|p| p.parse::<u16>().ok());
        let deadline = Instant::now() + START_LIMIT;
        if let Some(port) = port {
            while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
                assert!(Instant::now() < deadline, "the server did not listen on {port}");
                if thread.is_finished() {
                    return Err(stopped(thread));
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        // iceoryx2 and the queryables are up right after.
        std::thread::sleep(Duration::from_millis(100));
        if thread.is_finished() {
            return Err(stopped(thread));
        }
        Ok(Server { endpoint, world, shutdown, thread: Some(thread) })
    }

    /// The key (= iceoryx2 service name for poses and stats) of `topic` in this world.
    pub fn key(&self, topic: msgs::Topic) -> String {
        self.world.key(topic)
    }

    /// The client options that reach this server: `--connect EP --world W`.
    pub fn client_args(&self) -> Vec<String> {
        vec!["--connect".into(), self.endpoint.clone(), "--world".into(), self.world.to_string()]
    }

    /// A Zenoh client session (a peer listening nowhere, no scouting) connected to this server,
    /// returned once the scene queryable answers (panics after 10 s).
    pub fn session(&self) -> zenoh::Session {
        self.connect().0
    }

    /// [`Server::session`] with the scene description its queryable answered.
    pub fn connect(&self) -> (zenoh::Session, msgs::SceneDescription) {
        let c = pivotsim_link::zenoh_config::ZenohEndpoints::client(vec![self.endpoint.clone()])
            .config()
            .expect("a client configuration");
        let s = zenoh::open(c).wait().expect("a client session");
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if let Some(description) = self.scene(&s) {
                return (s, description);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        panic!("the server did not answer its scene queryable within 10 s");
    }

    /// The scene description over `session`, if the server answers within about half a second.
    pub fn scene(&self, session: &zenoh::Session) -> Option<msgs::SceneDescription> {
        let replies =
            session.get(self.key(msgs::Topic::Scene)).timeout(Duration::from_millis(500)).wait().ok()?;
        let reply = replies.recv_timeout(Duration::from_millis(600)).ok()??;
        let bytes = reply.result().ok()?.payload().to_bytes().into_owned();
        msgs::SceneDescription::decode(&bytes).ok()
    }

    /// Sends a control request with `id` over `session` and returns the reply (panics after 3 s).
    pub fn control(
        &self,
        session: &zenoh::Session,
        id: u64,
        command: msgs::ControlCommand,
    ) -> msgs::ControlReply {
        let mut buf = Vec::new();
        msgs::ControlRequest { id, command }.encode(&mut buf).expect("an encodable request");
        self.control_bytes(session, buf)
    }

    /// Sends raw control request bytes (valid or not) and returns the reply (panics after 3 s).
    pub fn control_bytes(&self, session: &zenoh::Session, bytes: Vec<u8>) -> msgs::ControlReply {
        let replies = session
            .get(self.key(msgs::Topic::Control))
            .payload(bytes)
            .timeout(Duration::from_secs(2))
            .wait()
            .expect("a control query");
        let reply = replies.recv_timeout(Duration::from_secs(3)).ok().flatten().expect("a control reply");
        let payload = reply.result().expect("a reply sample").payload().to_bytes().into_owned();
        msgs::ControlReply::decode(&payload).expect("a decodable reply")
    }

    /// Stops the server and returns its report.
    pub fn stop(mut self) -> ServeReport {
        self.shutdown.store(true, Ordering::Relaxed);
        let t = self.thread.take().expect("a running server");
        t.join().expect("the server thread").expect("the server ran")
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
