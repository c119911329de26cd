//! Zenoh transport: a peer session (listening on `tcp/127.0.0.1:7447` by default, multicast
//! scouting off unless asked), publishers `pivotsim/<world>/poses` and `…/stats` (congestion
//! control *drop*, express: a slow subscriber loses frames, it never slows the loop), one
//! subscriber on `…/cmd/**` for every input topic, and the queryables `…/scene` (the encoded
//! description) and `…/control` (requests answered by the loop thread).

use std::sync::{Arc, RwLock};

use pivotsim_msgs as msgs;
use zenoh::Wait;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::query::Queryable;

use super::{ErrorThrottle, Inbound, InboxSender, ServeError, Transport, ZenohOptions};

fn err(e: impl std::fmt::Display) -> ServeError {
    ServeError::Transport { transport: "zenoh", message: e.to_string() }
}

/// A Zenoh configuration from the options: peer mode on the given endpoints (module doc).
pub fn config(opts: &ZenohOptions) -> Result<zenoh::Config, ServeError> {
    let mut c = match &opts.config_file {
        Some(p) => zenoh::Config::from_file(p).map_err(err)?,
        None => {
            let mut c = zenoh::Config::default();
            c.insert_json5("mode", "\"peer\"").map_err(err)?;
            c
        }
    };
    let json = |v: &[String]| serde_json::to_string(v).expect("strings serialize");
    if opts.config_file.is_none() || !opts.listen.is_empty() {
        c.insert_json5("listen/endpoints", &json(&opts.listen)).map_err(err)?;
    }
    if !opts.connect.is_empty() {
        c.insert_json5("connect/endpoints", &json(&opts.connect)).map_err(err)?;
    }
    if opts.config_file.is_none() || opts.multicast_scouting {
        let on = if opts.multicast_scouting { "true" } else { "false" };
        c.insert_json5("scouting/multicast/enabled", on).map_err(err)?;
    }
    Ok(c)
}

/// The server's Zenoh side.
pub struct ZenohTransport {
    session: zenoh::Session,
    poses: Publisher<'static>,
    stats: Publisher<'static>,
    _inputs: Subscriber<()>,
    _scene: Queryable<()>,
    _control: Queryable<()>,
    description: Arc<RwLock<Vec<u8>>>,
    throttle: ErrorThrottle,
}

impl std::fmt::Debug for ZenohTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohTransport").field("zid", &self.session.zid()).finish()
    }
}

impl ZenohTransport {
    /// Opens the session and declares everything for `world`.
    pub fn open(
        opts: &ZenohOptions,
        world: &msgs::WorldName,
        inbox: InboxSender,
        description: &[u8],
    ) -> Result<ZenohTransport, ServeError> {
        let session = zenoh::open(config(opts)?).wait().map_err(err)?;
        let publisher = |topic: msgs::Topic| {
            session
                .declare_publisher(world.key(topic))
                .congestion_control(CongestionControl::Drop)
                .express(true)
                .wait()
                .map_err(err)
        };
        let poses = publisher(msgs::Topic::Poses)?;
        let stats = publisher(msgs::Topic::Stats)?;
        let tx = inbox.clone();
        let inputs = session
            .declare_subscriber(msgs::inputs_wildcard(world))
            .callback(move |sample| {
                let topic = msgs::parse_key(sample.key_expr().as_str()).ok().map(|(_, t)| t);
                let bytes = sample.payload().to_bytes().into_owned();
                match topic {
                    // A key under cmd/ that is no input topic: the loop counts it as a version
                    // mismatch (a frame that does not belong on its key).
                    Some(t) if msgs::Topic::INPUTS.contains(&t) => {
                        tx.offer(Inbound::Input { topic: Some(t), bytes });
                    }
                    _ => {
                        tx.offer(Inbound::Input { topic: Some(msgs::Topic::Scene), bytes });
                    }
                }
            })
            .wait()
            .map_err(err)?;
        let description = Arc::new(RwLock::new(description.to_vec()));
        let desc = description.clone();
        let scene_key = world.key(msgs::Topic::Scene);
        let scene = session
            .declare_queryable(scene_key.clone())
            .callback(move |q| {
                let bytes = desc.read().map(|d| d.clone()).unwrap_or_default();
                let _ = q.reply(scene_key.clone(), bytes).wait();
            })
            .wait()
            .map_err(err)?;
        let control_key = world.key(msgs::Topic::Control);
        let control = session
            .declare_queryable(control_key.clone())
            .callback(move |q| {
                let bytes = q.payload().map(|p| p.to_bytes().into_owned()).unwrap_or_default();
                let key = control_key.clone();
                inbox.offer(Inbound::Control {
                    bytes,
                    reply: Box::new(move |r| {
                        let _ = q.reply(key, r).wait();
                    }),
                });
            })
            .wait()
            .map_err(err)?;
        Ok(ZenohTransport {
            session,
            poses,
            stats,
            _inputs: inputs,
            _scene: scene,
            _control: control,
            description,
            throttle: ErrorThrottle::default(),
        })
    }
}

impl Transport for ZenohTransport {
    fn publish(&mut self, poses: &[u8], stats: &[u8]) {
        if let Err(e) = self.poses.put(poses.to_vec()).wait() {
            self.throttle.fail("zenoh poses", &e);
        }
        if let Err(e) = self.stats.put(stats.to_vec()).wait() {
            self.throttle.fail("zenoh stats", &e);
        }
    }

    fn set_description(&mut self, bytes: &[u8]) {
        if let Ok(mut d) = self.description.write() {
            d.clear();
            d.extend_from_slice(bytes);
        }
    }

    fn status(&mut self) -> String {
        let matched = self.poses.matching_status().wait().map(|m| m.matching()).unwrap_or(false);
        format!("zenoh: poses {}", if matched { "subscribed" } else { "no subscriber" })
    }
}
