//! The live view's front door: a WebSocket relay in front of the Foxglove SDK's server.
//!
//! The SDK (0.30) negotiates only `foxglove.sdk.v1` and `foxglove.sdk.v1.1` and answers any other
//! offer with HTTP 400 ("Missing expected sec-websocket-protocol header"). `foxglove.websocket.v1`
//! — the ws-protocol name that the `@foxglove/ws-protocol` npm client, roslibjs-foxglove and
//! Lichtblick releases before their `sdk.v1` support offer — is the same protocol under its older
//! name, and the SDK cannot be configured to accept it. So the SDK's server listens on an
//! ephemeral loopback port and this relay owns the view's address: it accepts a client offering
//! any of the three names, answers with the one it picked, opens a connection to the SDK with the
//! SDK's name for the same protocol (`foxglove.websocket.v1` → `foxglove.sdk.v1`), and relays
//! WebSocket messages both ways unchanged. A client offering none of them is refused with a 400
//! that names the subprotocols to offer.
//!
//! The relay also makes the view's losses visible. Message data (opcode `0x01`) towards a client
//! goes through a bounded queue ([`QUEUE`] messages per client); when a slow client lets it fill,
//! the newest message is dropped and counted against its topic (the relay follows `advertise`
//! from the server and `subscribe` from the client to know which topic a subscription id is).
//! Control messages (JSON text, other opcodes) are never dropped.

use std::collections::{BTreeMap, HashMap};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};

use anyhow::{Context as _, Result};
use futures_util::{SinkExt, StreamExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::handshake::server::{ErrorResponse, Request, Response};
use tokio_tungstenite::tungstenite::http::{HeaderValue, StatusCode};
use tokio_tungstenite::tungstenite::{self, Message};

/// The ws-protocol specification's name of the protocol.
pub const WEBSOCKET_V1: &str = "foxglove.websocket.v1";
/// The Foxglove SDK's name of the same protocol.
pub const SDK_V1: &str = "foxglove.sdk.v1";
/// The SDK's v1 with connection-scoped schema tables.
pub const SDK_V1_1: &str = "foxglove.sdk.v1.1";

/// Message data queued towards one client before the newest is dropped (the SDK's own default
/// backlog).
pub const QUEUE: usize = 1024;

/// The subprotocol answered to a client that offered `offered` (comma-separated values of its
/// `Sec-WebSocket-Protocol` headers), and the one asked of the SDK; `None` when it offered none of
/// the three. Preference: `foxglove.sdk.v1.1`, `foxglove.sdk.v1`, `foxglove.websocket.v1`,
/// whatever the client's order (the SDK's rule).
pub fn select<'a>(offered: impl IntoIterator<Item = &'a str>) -> Option<(&'static str, &'static str)> {
    let offered: Vec<&str> = offered.into_iter().map(str::trim).collect();
    [(SDK_V1_1, SDK_V1_1), (SDK_V1, SDK_V1), (WEBSOCKET_V1, SDK_V1)]
        .into_iter()
        .find(|(name, _)| offered.contains(name))
}

/// The refusal's text.
pub fn refusal(offered: &str) -> String {
    format!(
        "pivotsim foxglove view: offer the WebSocket subprotocol `{WEBSOCKET_V1}` or `{SDK_V1}` \
         (Sec-WebSocket-Protocol header); offered: {:?}",
        offered
    )
}

/// Per topic: message data relayed to clients and dropped because a client's queue was full.
#[derive(Debug, Default)]
pub struct Delivery {
    topics: Mutex<BTreeMap<String, (u64, u64)>>,
    clients: Mutex<u64>,
}

impl Delivery {
    fn count(&self, topic: &str, dropped: bool) {
        let mut t = self.topics.lock().unwrap_or_else(|e| e.into_inner());
        let e = t.entry(topic.to_string()).or_default();
        if dropped {
            e.1 += 1;
        } else {
            e.0 += 1;
        }
    }

    /// (topic, relayed, dropped), by topic.
    pub fn snapshot(&self) -> Vec<(String, u64, u64)> {
        let t = self.topics.lock().unwrap_or_else(|e| e.into_inner());
        t.iter().map(|(k, &(s, d))| (k.clone(), s, d)).collect()
    }

    /// Clients connected so far.
    pub fn clients(&self) -> u64 {
        *self.clients.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The relay: its address, its counts, its runtime (stopped when dropped).
pub struct Front {
    addr: SocketAddr,
    delivery: Arc<Delivery>,
    runtime: Option<tokio::runtime::Runtime>,
}

impl std::fmt::Debug for Front {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Front").field("addr", &self.addr).finish()
    }
}

impl Front {
    /// Listens on `host:port` and relays every client to the SDK's server at `upstream`.
    pub fn start(host: &str, port: u16, upstream: SocketAddr) -> Result<Front> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("fox-front")
            .enable_all()
            .build()
            .context("foxglove front: tokio runtime")?;
        let listener = runtime
            .block_on(TcpListener::bind((host, port)))
            .with_context(|| format!("foxglove: cannot listen on {host}:{port}"))?;
        let addr = listener.local_addr()?;
        let delivery = Arc::new(Delivery::default());
        runtime.spawn(accept(listener, upstream, delivery.clone()));
        Ok(Front { addr, delivery, runtime: Some(runtime) })
    }

    /// The address clients connect to.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// What was relayed and dropped.
    pub fn delivery(&self) -> &Arc<Delivery> {
        &self.delivery
    }
}

impl Drop for Front {
    fn drop(&mut self) {
        if let Some(r) = self.runtime.take() {
            r.shutdown_background();
        }
    }
}

async fn accept(listener: TcpListener, upstream: SocketAddr, delivery: Arc<Delivery>) {
    loop {
        let Ok((stream, peer)) = listener.accept().await else { continue };
        let delivery = delivery.clone();
        tokio::spawn(async move {
            if let Err(e) = relay(stream, upstream, delivery).await {
                eprintln!("pivotsim-client: viewer {peer}: {e:#}");
            }
        });
    }
}

/// The handshake with a client: the subprotocol answered and the one to ask of the SDK, or a 400.
// The error type is tungstenite's handshake callback's (`ErrorResponse` by value), not ours.
#[allow(clippy::result_large_err)]
fn handshake(req: &Request, res: Response) -> Result<(Response, &'static str), ErrorResponse> {
    let values: Vec<&str> =
        req.headers().get_all("sec-websocket-protocol").iter().filter_map(|v| v.to_str().ok()).collect();
    let offered = values.join(", ");
    match select(offered.split(',')) {
        Some((answer, upstream)) => {
            let mut res = res;
            res.headers_mut().insert("sec-websocket-protocol", HeaderValue::from_static(answer));
            Ok((res, upstream))
        }
        None => {
            let mut refuse = ErrorResponse::new(Some(refusal(&offered)));
            *refuse.status_mut() = StatusCode::BAD_REQUEST;
            Err(refuse)
        }
    }
}

/// Which topic a subscription of this connection is.
#[derive(Debug, Default)]
struct Routes {
    channels: HashMap<u64, String>,
    subscriptions: HashMap<u32, u64>,
}

impl Routes {
    fn topic(&self, sub: u32) -> String {
        self.subscriptions
            .get(&sub)
            .and_then(|c| self.channels.get(c))
            .cloned()
            .unwrap_or_else(|| format!("(subscription {sub})"))
    }

    /// Follows the server's `advertise`.
    fn server_text(&mut self, text: &str) {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(text) else { return };
        if v["op"] == "advertise"
            && let Some(chs) = v["channels"].as_array()
        {
            for c in chs {
                if let (Some(id), Some(topic)) = (c["id"].as_u64(), c["topic"].as_str()) {
                    self.channels.insert(id, topic.to_string());
                }
            }
        }
    }

    /// Follows the client's `subscribe`.
    fn client_text(&mut self, text: &str) {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(text) else { return };
        if v["op"] == "subscribe"
            && let Some(subs) = v["subscriptions"].as_array()
        {
            for s in subs {
                if let (Some(id), Some(ch)) = (s["id"].as_u64(), s["channelId"].as_u64()) {
                    self.subscriptions.insert(id as u32, ch);
                }
            }
        }
    }
}

/// The subscription id of a message-data frame (opcode `0x01`, then the id as u32 LE).
fn message_data_subscription(b: &[u8]) -> Option<u32> {
    match b {
        [1, a, b, c, d, ..] => Some(u32::from_le_bytes([*a, *b, *c, *d])),
        _ => None,
    }
}

// The handshake closure returns tungstenite's `ErrorResponse` by value (its callback's type).
#[allow(clippy::result_large_err)]
async fn relay(stream: TcpStream, upstream: SocketAddr, delivery: Arc<Delivery>) -> Result<()> {
    let mut asked = SDK_V1;
    let down = tokio_tungstenite::accept_hdr_async(stream, |req: &Request, res: Response| {
        let (res, up) = handshake(req, res)?;
        asked = up;
        Ok(res)
    })
    .await
    .context("handshake")?;
    *delivery.clients.lock().unwrap_or_else(|e| e.into_inner()) += 1;
    let mut req = format!("ws://{upstream}").into_client_request()?;
    req.headers_mut().insert("sec-websocket-protocol", HeaderValue::from_static(asked));
    let tcp = TcpStream::connect(upstream).await.context("the SDK's server")?;
    let (up, _) = tokio_tungstenite::client_async(req, tcp).await.context("the SDK's handshake")?;
    let (mut down_tx, mut down_rx) = down.split();
    let (mut up_tx, mut up_rx) = up.split();
    let routes = Arc::new(Mutex::new(Routes::default()));
    let (queue_tx, mut queue_rx) = mpsc::channel::<Message>(QUEUE);

    // SDK → queue: message data is dropped (and counted) when the queue is full.
    let r = routes.clone();
    let from_sdk = async move {
        while let Some(m) = up_rx.next().await {
            let m = m?;
            let close = matches!(m, Message::Close(_));
            let sub = match &m {
                Message::Binary(b) => message_data_subscription(b),
                Message::Text(t) => {
                    r.lock().unwrap_or_else(|e| e.into_inner()).server_text(t.as_str());
                    None
                }
                _ => None,
            };
            match sub {
                Some(sub) => {
                    let topic = r.lock().unwrap_or_else(|e| e.into_inner()).topic(sub);
                    match queue_tx.try_send(m) {
                        Ok(()) => delivery.count(&topic, false),
                        Err(mpsc::error::TrySendError::Full(_)) => delivery.count(&topic, true),
                        Err(mpsc::error::TrySendError::Closed(_)) => break,
                    }
                }
                None => {
                    if queue_tx.send(m).await.is_err() {
                        break;
                    }
                }
            }
            if close {
                break;
            }
        }
        Ok::<(), tungstenite::Error>(())
    };
    // Queue → client.
    let to_client = async move {
        while let Some(m) = queue_rx.recv().await {
            down_tx.send(m).await?;
        }
        Ok::<(), tungstenite::Error>(())
    };
    // Client → SDK, unchanged.
    let from_client = async move {
        while let Some(m) = down_rx.next().await {
            let m = m?;
            if let Message::Text(t) = &m {
                routes.lock().unwrap_or_else(|e| e.into_inner()).client_text(t.as_str());
            }
            let close = matches!(m, Message::Close(_));
            up_tx.send(m).await?;
            if close {
                break;
            }
        }
        Ok::<(), tungstenite::Error>(())
    };
    let r = tokio::select! {
        r = from_sdk => r,
        r = to_client => r,
        r = from_client => r,
    };
    match r {
        Ok(())
        | Err(
            tungstenite::Error::ConnectionClosed
            | tungstenite::Error::AlreadyClosed
            | tungstenite::Error::Protocol(tungstenite::error::ProtocolError::ResetWithoutClosingHandshake),
        ) => Ok(()),
        Err(e) => Err(e.into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_of_v1_is_accepted_and_the_sdk_is_asked_its_own() {
        assert_eq!(select([WEBSOCKET_V1]), Some((WEBSOCKET_V1, SDK_V1)));
        assert_eq!(select([" foxglove.websocket.v1 "]), Some((WEBSOCKET_V1, SDK_V1)));
        assert_eq!(select([WEBSOCKET_V1, SDK_V1]), Some((SDK_V1, SDK_V1)));
        assert_eq!(select([SDK_V1, SDK_V1_1]), Some((SDK_V1_1, SDK_V1_1)));
        assert_eq!(select(["foxglove.sdk.v1.10", "foxglove.websocket.v2", ""]), None);
        assert!(refusal("x").contains(WEBSOCKET_V1));
    }

    #[test]
    fn message_data_names_its_subscription() {
        assert_eq!(message_data_subscription(&[1, 7, 0, 0, 0, 9, 9]), Some(7));
        assert_eq!(message_data_subscription(&[1, 7, 0]), None);
        assert_eq!(message_data_subscription(&[2, 7, 0, 0, 0]), None);
        let mut r = Routes::default();
        r.server_text(r#"{"op":"advertise","channels":[{"id":3,"topic":"/tf"}]}"#);
        r.client_text(r#"{"op":"subscribe","subscriptions":[{"id":7,"channelId":3}]}"#);
        assert_eq!(r.topic(7), "/tf");
        assert_eq!(r.topic(8), "(subscription 8)");
    }
}
