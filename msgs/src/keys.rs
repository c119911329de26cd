//! Zenoh key expressions and iceoryx2 service names.
//!
//! Every name is `pivotsim/<world>/<topic>`, the same string on both transports:
//!
//! | topic | suffix | how | frame kind |
//! |---|---|---|---|
//! | [`Topic::Poses`] | `poses` | server publishes | pose frame `0x0001` |
//! | [`Topic::Stats`] | `stats` | server publishes | solver stats `0x0002` |
//! | [`Topic::Signals`] | `signals` | server publishes | signals `0x0003` |
//! | [`Topic::Events`] | `events` | server publishes | events `0x0004` |
//! | [`Topic::Joystick`] | `cmd/joystick` | server subscribes | joystick `0x0010` |
//! | [`Topic::Winch`] | `cmd/winch` | server subscribes | winch `0x0011` |
//! | [`Topic::Boom`] | `cmd/boom` | server subscribes | boom `0x0012` |
//! | [`Topic::Actuator`] | `cmd/actuator` | server subscribes | actuator `0x0013` |
//! | [`Topic::Scene`] | `scene` | queryable | query: no payload; reply: scene description `0x0102` |
//! | [`Topic::Control`] | `control` | queryable | query: control request `0x0100`; reply: control reply `0x0101` |
//!
//! A world name is 1 to 64 bytes of `[A-Za-z0-9_-]`, so a key never contains the Zenoh wildcard or
//! separator characters and stays far below iceoryx2's service-name limit. On Zenoh the server may
//! subscribe to all inputs at once with [`inputs_wildcard`] (`pivotsim/<world>/cmd/**`); iceoryx2
//! has no wildcards, so every input goes to the one service `pivotsim/<world>/cmd`
//! ([`WorldName::iox_service`]), where the frame's header says what it is.

use std::fmt;

/// First segment of every key.
pub const KEY_PREFIX: &str = "pivotsim";
/// Longest world name, in bytes.
pub const MAX_WORLD_NAME_LEN: usize = 64;
/// World name used when none is given.
pub const DEFAULT_WORLD: &str = "default";
/// Last segment of the Zenoh liveliness token of a world's server ([`WorldName::server_token`]).
pub const SERVER_TOKEN: &str = "server";
/// The segment under which lockstep controllers hold their liveliness tokens
/// (`pivotsim/<world>/controller/<id>`).
pub const CONTROLLER_TOKENS: &str = "controller";
/// Last segment of the one iceoryx2 service that carries every input frame.
pub const IOX_INPUT_SERVICE: &str = "cmd";
/// Samples a subscriber of the server's iceoryx2 services buffers: the server creates them with
/// this, and a client that creates them first must ask for the same.
pub const IOX_SUBSCRIBER_BUFFER: usize = 16;

/// Why a world name or key expression is not valid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum KeyError {
    /// Empty world name.
    #[error("empty world name")]
    EmptyWorld,
    /// World name above [`MAX_WORLD_NAME_LEN`] bytes.
    #[error("world name of {len} bytes (at most {MAX_WORLD_NAME_LEN})")]
    WorldTooLong {
        /// Length in bytes.
        len: usize,
    },
    /// A byte outside `[A-Za-z0-9_-]`.
    #[error("byte 0x{byte:02x} at {index} is not allowed in a world name")]
    WorldChar {
        /// Byte offset.
        index: usize,
        /// The byte.
        byte: u8,
    },
    /// A key that does not start with `pivotsim/`.
    #[error("key {key:?} is not under {KEY_PREFIX}/")]
    NotPivotsim {
        /// The key.
        key: String,
    },
    /// A key whose topic part is not one of [`Topic::ALL`].
    #[error("unknown topic {topic:?}")]
    UnknownTopic {
        /// The part after the world name.
        topic: String,
    },
}

/// A validated world name.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct WorldName(String);

impl WorldName {
    /// Checks `name` (1..=64 bytes of `[A-Za-z0-9_-]`).
    pub fn new(name: impl Into<String>) -> Result<WorldName, KeyError> {
        let name = name.into();
        let b = name.as_bytes();
        if b.is_empty() {
            return Err(KeyError::EmptyWorld);
        }
        if b.len() > MAX_WORLD_NAME_LEN {
            return Err(KeyError::WorldTooLong { len: b.len() });
        }
        if let Some(index) = b.iter().position(|&c| !(c.is_ascii_alphanumeric() || c == b'_' || c == b'-')) {
            return Err(KeyError::WorldChar { index, byte: b[index] });
        }
        Ok(WorldName(name))
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// Key expression (= iceoryx2 service name) of `topic` in this world.
    pub fn key(&self, topic: Topic) -> String {
        let mut s = String::new();
        self.write_key(topic, &mut s);
        s
    }

    /// The iceoryx2 service that carries `topic` in this world: the key for poses and stats, the
    /// one input service `pivotsim/<world>/cmd` for every input topic, and `None` for the
    /// queryables (Zenoh only).
    pub fn iox_service(&self, topic: Topic) -> Option<String> {
        match topic {
            Topic::Poses | Topic::Stats | Topic::Signals | Topic::Events => Some(self.key(topic)),
            Topic::Joystick | Topic::Winch | Topic::Boom | Topic::Actuator => {
                Some(format!("{KEY_PREFIX}/{}/{IOX_INPUT_SERVICE}", self.0))
            }
            Topic::Scene | Topic::Control | Topic::Applied | Topic::Keyframes => None,
        }
    }

    /// The Zenoh liveliness token a server holds while it serves this world
    /// (`pivotsim/<world>/server`): a second server of the same world sees it and refuses to
    /// start, and clients may watch it to know whether a server is up.
    pub fn server_token(&self) -> String {
        format!("{KEY_PREFIX}/{}/{SERVER_TOKEN}", self.0)
    }

    /// The liveliness token of the lockstep controller `id` (`pivotsim/<world>/controller/<id>`;
    /// `id` follows the world-name rules): the server watches these and acts when the last one
    /// goes away (`serve --on-controller-lost`).
    pub fn controller_token(&self, id: &WorldName) -> String {
        format!("{KEY_PREFIX}/{}/{CONTROLLER_TOKENS}/{}", self.0, id.0)
    }

    /// The key expression of every controller token of this world.
    pub fn controller_tokens(&self) -> String {
        format!("{KEY_PREFIX}/{}/{CONTROLLER_TOKENS}/*", self.0)
    }

    /// Clears `out` and writes the key of `topic` into it (no allocation once `out` has grown).
    pub fn write_key(&self, topic: Topic, out: &mut String) {
        out.clear();
        out.push_str(KEY_PREFIX);
        out.push('/');
        out.push_str(&self.0);
        out.push('/');
        out.push_str(topic.suffix());
    }
}

impl fmt::Display for WorldName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::str::FromStr for WorldName {
    type Err = KeyError;

    fn from_str(s: &str) -> Result<Self, KeyError> {
        WorldName::new(s)
    }
}

impl Default for WorldName {
    fn default() -> Self {
        WorldName(DEFAULT_WORLD.to_owned())
    }
}

/// What travels under a key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Topic {
    /// Pose frames, published every step.
    Poses,
    /// Solver stats, published every step.
    Stats,
    /// Sensor channels and contact states, published every step.
    Signals,
    /// Threshold crossings and faults, published at the steps that have them.
    Events,
    /// What changed the world before a step (inputs, world-acting control requests, deadman
    /// trips), published at the steps that had any.
    Applied,
    /// Snapshots of the state, every few seconds and at each new scene state.
    Keyframes,
    /// Joystick inputs.
    Joystick,
    /// Winch commands.
    Winch,
    /// Boom commands.
    Boom,
    /// Generic actuator commands.
    Actuator,
    /// Scene description queryable.
    Scene,
    /// Control queryable.
    Control,
}

impl Topic {
    /// Every topic.
    pub const ALL: [Topic; 12] = [
        Topic::Poses,
        Topic::Stats,
        Topic::Signals,
        Topic::Events,
        Topic::Applied,
        Topic::Keyframes,
        Topic::Joystick,
        Topic::Winch,
        Topic::Boom,
        Topic::Actuator,
        Topic::Scene,
        Topic::Control,
    ];

    /// The topic inputs of the server.
    pub const INPUTS: [Topic; 4] = [Topic::Joystick, Topic::Winch, Topic::Boom, Topic::Actuator];

    /// Part of the key after `pivotsim/<world>/`.
    pub fn suffix(self) -> &'static str {
        match self {
            Topic::Poses => "poses",
            Topic::Stats => "stats",
            Topic::Signals => "signals",
            Topic::Events => "events",
            Topic::Applied => "applied",
            Topic::Keyframes => "keyframes",
            Topic::Joystick => "cmd/joystick",
            Topic::Winch => "cmd/winch",
            Topic::Boom => "cmd/boom",
            Topic::Actuator => "cmd/actuator",
            Topic::Scene => "scene",
            Topic::Control => "control",
        }
    }

    /// Whether the topic is a queryable (request/reply) rather than publish/subscribe.
    pub fn is_queryable(self) -> bool {
        matches!(self, Topic::Scene | Topic::Control)
    }

    /// Kind of the frames sent to this key: published frames, or the query payload (`None` for
    /// `scene`, whose query carries no payload).
    pub fn kind(self) -> Option<crate::Kind> {
        use crate::Kind;
        Some(match self {
            Topic::Poses => Kind::PoseFrame,
            Topic::Stats => Kind::SolverStats,
            Topic::Signals => Kind::Signals,
            Topic::Events => Kind::Events,
            Topic::Applied => Kind::Applied,
            Topic::Keyframes => Kind::Keyframe,
            Topic::Joystick => Kind::Joystick,
            Topic::Winch => Kind::Winch,
            Topic::Boom => Kind::Boom,
            Topic::Actuator => Kind::Actuator,
            Topic::Scene => return None,
            Topic::Control => Kind::ControlRequest,
        })
    }

    /// Kind of the reply of a queryable.
    pub fn reply_kind(self) -> Option<crate::Kind> {
        match self {
            Topic::Scene => Some(crate::Kind::SceneDescription),
            Topic::Control => Some(crate::Kind::ControlReply),
            _ => None,
        }
    }

    /// The topic of a key suffix.
    pub fn from_suffix(s: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|t| t.suffix() == s)
    }
}

/// `pivotsim/<world>/cmd/**`: every input topic of a world, for one Zenoh subscriber.
pub fn inputs_wildcard(world: &WorldName) -> String {
    format!("{KEY_PREFIX}/{world}/cmd/**")
}

/// Splits a concrete key `pivotsim/<world>/<topic>` into its world and topic.
pub fn parse_key(key: &str) -> Result<(WorldName, Topic), KeyError> {
    let not = || KeyError::NotPivotsim { key: key.to_owned() };
    let rest = key.strip_prefix(KEY_PREFIX).and_then(|r| r.strip_prefix('/')).ok_or_else(not)?;
    let (world, topic) = rest.split_once('/').ok_or_else(not)?;
    let world = WorldName::new(world)?;
    let topic =
        Topic::from_suffix(topic).ok_or_else(|| KeyError::UnknownTopic { topic: topic.to_owned() })?;
    Ok((world, topic))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iceoryx2_services_are_the_documented_strings() {
        let w = WorldName::new("crane-1").unwrap();
        assert_eq!(w.iox_service(Topic::Poses).as_deref(), Some("pivotsim/crane-1/poses"));
        assert_eq!(w.iox_service(Topic::Stats).as_deref(), Some("pivotsim/crane-1/stats"));
        for t in Topic::INPUTS {
            assert_eq!(w.iox_service(t).as_deref(), Some("pivotsim/crane-1/cmd"));
        }
        assert_eq!(w.iox_service(Topic::Scene), None);
        assert_eq!(w.iox_service(Topic::Control), None);
    }

    #[test]
    fn keys_are_the_documented_strings() {
        let w = WorldName::new("crane-1").unwrap();
        let keys: Vec<String> = Topic::ALL.iter().map(|&t| w.key(t)).collect();
        assert_eq!(
            keys,
            [
                "pivotsim/crane-1/poses",
                "pivotsim/crane-1/stats",
                "pivotsim/crane-1/signals",
                "pivotsim/crane-1/events",
                "pivotsim/crane-1/applied",
                "pivotsim/crane-1/keyframes",
                "pivotsim/crane-1/cmd/joystick",
                "pivotsim/crane-1/cmd/winch",
                "pivotsim/crane-1/cmd/boom",
                "pivotsim/crane-1/cmd/actuator",
                "pivotsim/crane-1/scene",
                "pivotsim/crane-1/control",
            ]
        );
        assert_eq!(inputs_wildcard(&w), "pivotsim/crane-1/cmd/**");
        for t in Topic::ALL {
            assert_eq!(parse_key(&w.key(t)), Ok((w.clone(), t)));
            assert_eq!(t.is_queryable(), t.reply_kind().is_some());
        }
        for t in Topic::INPUTS {
            assert!(t.suffix().starts_with("cmd/"));
        }
    }

    #[test]
    fn world_names_are_checked() {
        assert_eq!(WorldName::new(""), Err(KeyError::EmptyWorld));
        assert_eq!(WorldName::new("a".repeat(65)), Err(KeyError::WorldTooLong { len: 65 }));
        assert!(WorldName::new("A_z-09".repeat(10)).is_ok());
        for bad in ["a/b", "a*", "a b", "$x", "é", "a?", "a#"] {
            assert!(matches!(WorldName::new(bad), Err(KeyError::WorldChar { .. })), "{bad}");
        }
        assert_eq!(WorldName::default().as_str(), "default");
        assert!(matches!(parse_key("other/w/poses"), Err(KeyError::NotPivotsim { .. })));
        assert!(matches!(parse_key("pivotsim/w"), Err(KeyError::NotPivotsim { .. })));
        assert!(matches!(parse_key("pivotsim/w/cmd/fly"), Err(KeyError::UnknownTopic { .. })));
        assert!(matches!(parse_key("pivotsim/w*/poses"), Err(KeyError::WorldChar { .. })));
    }
}
