//! The options every command takes ([`Common`]), and what the transports need of them
//! ([`net::Server`]: Zenoh endpoints, world name, timeout).

use std::time::Duration;

use anyhow::{Context, Result};
use pivotsim_msgs::WorldName;

use crate::net;
use crate::stop::secs;

/// Options every command takes.
#[derive(Debug, Clone, clap::Args)]
pub struct Common {
    /// World name: the `<world>` of every key and service.
    #[arg(long, global = true, default_value = "default", value_name = "NAME")]
    pub world: String,
    /// Zenoh endpoint of the server (repeatable).
    #[arg(long, global = true, default_value = "tcp/127.0.0.1:7447", value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Zenoh endpoint to listen on (repeatable; none by default: the client only connects).
    #[arg(long, global = true, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// A Zenoh configuration file (JSON5): credentials for a server with access control
    /// (`deploy/zenoh/`), routers; `--connect`/`--listen` are added to it.
    #[arg(long, global = true, value_name = "FILE")]
    pub zenoh_config: Option<std::path::PathBuf>,
    /// Seconds to wait for the server: connecting, replies, and (for watch, ping, record, send)
    /// the longest silence before giving up. Default 5 s for one-shot commands and ping; watch and
    /// record wait for frames indefinitely unless given.
    #[arg(long, global = true, value_name = "SECONDS")]
    pub timeout: Option<f64>,
}

impl Common {
    /// The world name, checked.
    pub fn world(&self) -> Result<WorldName> {
        WorldName::new(self.world.clone()).with_context(|| format!("world name {:?}", self.world))
    }

    /// Zenoh endpoints.
    pub fn zenoh(&self) -> net::ZenohOptions {
        net::ZenohOptions {
            connect: self.connect.clone(),
            listen: self.listen.clone(),
            config_file: self.zenoh_config.clone(),
        }
    }

    /// The `--timeout`, or `default`.
    pub fn timeout_or(&self, default: f64) -> Duration {
        secs(self.timeout.unwrap_or(default))
    }

    /// What the transports need: endpoints, world, and the connect timeout (default 5 s).
    pub fn server(&self) -> Result<net::Server> {
        Ok(net::Server { zenoh: self.zenoh(), world: self.world()?, timeout: self.timeout_or(5.0) })
    }

    /// Opens a Zenoh session to the server.
    pub fn open_zenoh(&self) -> Result<net::ZenohLink> {
        self.server()?.open_zenoh()
    }
}
