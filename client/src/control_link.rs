//! Control requests over either transport: the Zenoh `control` queryable ([`ZenohLink::control`])
//! or the iceoryx2 request-response service `pivotsim/<world>/control` ([`IoxControl`]), the same
//! request and reply frames on both (`msgs/README.md`, "Keys and service names").
//!
//! Over iceoryx2 a request is one request sample and its reply one response; the client waits for
//! it by polling — spinning (yielding the CPU) for the first [`SPIN`], then sleeping [`NAP`]
//! between polls — so a lockstep round trip costs the server's step and two shared-memory hops,
//! not a sleep. A server that drops the request without answering (it stopped) ends the wait at
//! once; a server that died waits out the timeout.

use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use iceoryx2::port::client::Client;
use iceoryx2::prelude::*;
use pivotsim_link::iox as link;
use pivotsim_msgs as msgs;

use crate::net::{TransportKind, ZenohLink};

/// How long the client spins on a pending reply before it sleeps between polls.
pub const SPIN: Duration = Duration::from_micros(300);
/// The sleep between polls after [`SPIN`].
pub const NAP: Duration = Duration::from_micros(20);

/// The iceoryx2 client of a world's control service.
pub struct IoxControl {
    client: Client<ipc::Service, [u8], (), [u8], ()>,
    _service: link::ControlService,
    buf: Vec<u8>,
    // Declared last: dropped after the port and the service.
    node: Node<ipc::Service>,
}

impl std::fmt::Debug for IoxControl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IoxControl")
    }
}

impl IoxControl {
    /// Opens (or creates) the world's control service and a client port, then waits at most
    /// `timeout` for a server (the pivotsim server of the world on this host) to serve it.
    pub fn open(world: &msgs::WorldName, timeout: Duration) -> Result<IoxControl> {
        IoxControl::open_as(world, "pivotsim-client", timeout)
    }

    /// [`IoxControl::open`] with a node named `node_name`: a lockstep controller names its node
    /// with its controller token (`pivotsim/<world>/controller/<id>`), by which the server tells
    /// that it is there and when it goes.
    pub fn open_as(world: &msgs::WorldName, node_name: &str, timeout: Duration) -> Result<IoxControl> {
        let node = link::node(node_name)?;
        let service = link::open_control_service(&node, &link::control_service_name(world))?;
        let client = service
            .client_builder()
            .initial_max_slice_len(link::CONTROL_REQUEST_BYTES)
            .create()
            .map_err(|e| anyhow!("iceoryx2: cannot create a control client: {e:?}"))?;
        let deadline = Instant::now() + timeout;
        while service.dynamic_config().number_of_servers() == 0 {
            if Instant::now() >= deadline || crate::stop::interrupted() {
                bail!(
                    "iceoryx2: nobody serves {} (no server for world `{world}` on this host?)",
                    link::control_service_name(world)
                );
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        Ok(IoxControl { client, _service: service, buf: Vec::with_capacity(256), node })
    }

    /// The node (for further ports of the same process).
    pub fn node(&self) -> &Node<ipc::Service> {
        &self.node
    }

    /// Sends `req` and waits at most `timeout` for its reply.
    pub fn request(&mut self, req: &msgs::ControlRequest, timeout: Duration) -> Result<msgs::ControlReply> {
        req.encode(&mut self.buf).context("control request")?;
        let sample = self
            .client
            .loan_slice_uninit(self.buf.len())
            .map_err(|e| anyhow!("iceoryx2: control request: {e:?}"))?;
        let pending = sample
            .write_from_slice(&self.buf)
            .send()
            .map_err(|e| anyhow!("iceoryx2: control request: {e:?}"))?;
        let start = Instant::now();
        let deadline = start + timeout;
        loop {
            match pending.receive() {
                Ok(Some(response)) => {
                    return msgs::ControlReply::decode(response.payload())
                        .context("the control reply does not decode");
                }
                Ok(None) => {}
                Err(e) => bail!("iceoryx2: control reply: {e:?}"),
            }
            if !pending.is_connected() {
                // The reply may have landed between the two calls.
                if let Ok(Some(response)) = pending.receive() {
                    return msgs::ControlReply::decode(response.payload())
                        .context("the control reply does not decode");
                }
                bail!("iceoryx2: the server dropped the control request without a reply (did it stop?)");
            }
            let now = Instant::now();
            if now >= deadline || crate::stop::interrupted() {
                bail!("iceoryx2: no control reply within {:.1} s", timeout.as_secs_f64());
            }
            if now - start < SPIN {
                std::thread::yield_now();
            } else {
                std::thread::sleep(NAP);
            }
        }
    }
}

/// Where control requests go.
#[derive(Debug)]
pub enum ControlLink {
    /// The `control` queryable.
    Zenoh(ZenohLink),
    /// The `control` request-response service.
    Iox(IoxControl),
}

impl ControlLink {
    /// Opens the transport's control link to the world's server.
    pub fn open(common: &crate::common::Common, transport: TransportKind) -> Result<ControlLink> {
        Ok(match transport {
            TransportKind::Zenoh => ControlLink::Zenoh(common.open_zenoh()?),
            TransportKind::Iceoryx2 => {
                ControlLink::Iox(IoxControl::open(&common.world()?, common.timeout_or(5.0))?)
            }
        })
    }

    /// Sends `req` and returns the reply, waiting at most `timeout`.
    pub fn request(&mut self, req: &msgs::ControlRequest, timeout: Duration) -> Result<msgs::ControlReply> {
        match self {
            ControlLink::Zenoh(l) => l.control(req, timeout),
            ControlLink::Iox(c) => c.request(req, timeout),
        }
    }
}
