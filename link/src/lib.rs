//! Transport plumbing written once for the server, the console (`pivotsim-client`) and the ROS 2
//! bridge: what "the same settings on both sides" means in code.
//!
//! | module | what | feature |
//! |---|---|---|
//! | [`inbox`](mod@inbox) | a bounded hand-over from transport threads and callbacks to one loop: a full inbox drops and counts, it never blocks the transport | — |
//! | [`clock`](mod@clock) | the wall clock the frames carry (ns since the UNIX epoch) | — |
//! | `zenoh_config` | the Zenoh configuration of a peer on given endpoints, multicast scouting off unless asked, or a configuration file | `zenoh` |
//! | `iox` | iceoryx2 nodes and a world's byte services with the server's settings (safe overflow, subscriber buffer [`pivotsim_msgs::IOX_SUBSCRIBER_BUFFER`]) | `iceoryx2` |
//!
//! Key expressions and service names themselves are the wire spec's and live in `pivotsim-msgs`
//! ([`pivotsim_msgs::WorldName::key`], [`pivotsim_msgs::WorldName::iox_service`]).

pub mod clock;
pub mod inbox;
#[cfg(feature = "iceoryx2")]
pub mod iox;
#[cfg(feature = "zenoh")]
pub mod zenoh_config;

pub use clock::wall_ns;
pub use inbox::{Inbox, InboxSender, inbox};
