//! The Zenoh configuration of every pivotsim process: a peer on the given endpoints with multicast
//! scouting off unless asked (so nothing leaves the given endpoints), or a configuration file
//! (JSON5) for routers and multi-host rigs, with the given endpoints added.
//!
//! The server listens (default `tcp/127.0.0.1:7447`); the console and the bridge listen on nothing
//! and connect to the server.

use std::path::PathBuf;

/// Endpoints and options of a session.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ZenohEndpoints {
    /// Endpoints to listen on (none: listen nowhere, unless the file says so).
    pub listen: Vec<String>,
    /// Endpoints to connect to (routers, the server, other peers).
    pub connect: Vec<String>,
    /// A Zenoh configuration file; `listen` and `connect` are added when not empty.
    pub config_file: Option<PathBuf>,
    /// Turn multicast scouting on (off by default; with a file, the file decides unless this is set).
    pub multicast_scouting: bool,
}

/// A configuration that Zenoh refused (a bad file, a bad endpoint).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("zenoh configuration: {0}")]
pub struct ConfigError(pub String);

impl ZenohEndpoints {
    /// A peer that connects to `connect` and listens nowhere (the console, the bridge).
    pub fn client(connect: Vec<String>) -> ZenohEndpoints {
        ZenohEndpoints { connect, ..ZenohEndpoints::default() }
    }

    /// The Zenoh configuration of these endpoints.
    pub fn config(&self) -> Result<zenoh::Config, ConfigError> {
        let err = |what: &str, e: &dyn std::fmt::Display| ConfigError(format!("{what}: {e}"));
        let mut c = match &self.config_file {
            Some(p) => zenoh::Config::from_file(p).map_err(|e| err(&p.display().to_string(), &e))?,
            None => zenoh::Config::default(),
        };
        let mut set = |key: &str, value: String| c.insert_json5(key, &value).map_err(|e| err(key, &e));
        let list = |v: &[String]| serde_json::to_string(v).unwrap_or_else(|_| "[]".into());
        let file = self.config_file.is_some();
        if !file {
            set("mode", "\"peer\"".into())?;
        }
        if !file || !self.listen.is_empty() {
            set("listen/endpoints", list(&self.listen))?;
        }
        if !file || !self.connect.is_empty() {
            set("connect/endpoints", list(&self.connect))?;
        }
        if !file || self.multicast_scouting {
            set("scouting/multicast/enabled", self.multicast_scouting.to_string())?;
        }
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_client_peer_listens_nowhere_and_does_not_scout() {
        let c = ZenohEndpoints::client(vec!["tcp/127.0.0.1:7447".into()]).config().unwrap();
        assert_eq!(c.get_json("mode").unwrap(), "\"peer\"");
        assert_eq!(c.get_json("listen/endpoints").unwrap().replace(' ', ""), "[]");
        assert!(c.get_json("connect/endpoints").unwrap().contains("tcp/127.0.0.1:7447"));
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "false");
    }

    #[test]
    fn a_bad_endpoint_or_file_is_an_error() {
        let bad = ZenohEndpoints { listen: vec!["nonsense".into()], ..Default::default() };
        assert!(bad.config().is_err());
        let missing =
            ZenohEndpoints { config_file: Some("/nonexistent/z.json5".into()), ..Default::default() };
        assert!(missing.config().is_err());
    }
}
