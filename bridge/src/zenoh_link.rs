//! The bridge's Zenoh client: a peer session that connects to the server (no listening, no
//! multicast scouting), the latest pose, stats and signals frames (latest wins: a slow ROS side
//! skips frames, it never queues them), the events frames (rare, each one matters: a bounded
//! queue of [`EVENTS_QUEUE`], overflow counted), non-blocking scene queries, and the joystick
//! publisher.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use anyhow::anyhow;
use pivotsim_msgs as msgs;
use zenoh::Wait;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;

/// A client configuration: peer mode, connect to `connect`, listen nowhere, no multicast
/// scouting; or the given file with `connect` added (`pivotsim_link::zenoh_config`).
pub fn config(connect: &[String], file: Option<&Path>) -> anyhow::Result<zenoh::Config> {
    let e = pivotsim_link::zenoh_config::ZenohEndpoints {
        connect: connect.to_vec(),
        config_file: file.map(Path::to_path_buf),
        ..Default::default()
    };
    Ok(e.config()?)
}

/// At most this many events frames wait for the bridge loop; more are dropped and counted.
pub const EVENTS_QUEUE: usize = 64;

/// The newest frames from the server.
#[derive(Debug, Default)]
pub struct Latest {
    /// Newest pose frame not yet taken.
    pub poses: Option<Vec<u8>>,
    /// Newest stats frame not yet taken.
    pub stats: Option<Vec<u8>>,
    /// Newest scene description reply not yet taken.
    pub scene: Option<Vec<u8>>,
    /// Newest signals frame not yet taken.
    pub signals: Option<Vec<u8>>,
    /// Events frames not yet taken, oldest first (at most [`EVENTS_QUEUE`]).
    pub events: VecDeque<Vec<u8>>,
    /// When the last frame arrived.
    pub last_frame: Option<Instant>,
}

/// Shared between the Zenoh callbacks and the bridge loop.
#[derive(Debug, Default)]
pub struct Inbox {
    latest: Mutex<Latest>,
    ready: Condvar,
    /// Pose frames received.
    pub pose_frames: AtomicU64,
    /// Pose frames replaced before they were taken.
    pub pose_frames_skipped: AtomicU64,
    /// Signals frames received.
    pub signals_frames: AtomicU64,
    /// Signals frames replaced before they were taken.
    pub signals_frames_skipped: AtomicU64,
    /// Stats frames received.
    pub stats_frames: AtomicU64,
    /// Events frames received.
    pub events_frames: AtomicU64,
    /// Events frames dropped on a full queue.
    pub events_frames_dropped: AtomicU64,
}

impl Inbox {
    fn put(&self, f: impl FnOnce(&mut Latest)) {
        if let Ok(mut l) = self.latest.lock() {
            f(&mut l);
        }
        self.ready.notify_all();
    }

    /// A frame of `topic` arrived: the newest pose, stats or signals frame replaces the one not
    /// yet taken (counted as skipped for poses and signals); an events frame joins the queue, or
    /// is dropped and counted when [`EVENTS_QUEUE`] wait already. Other topics are ignored.
    pub fn receive(&self, topic: msgs::Topic, bytes: Vec<u8>) {
        let counter = match topic {
            msgs::Topic::Poses => &self.pose_frames,
            msgs::Topic::Signals => &self.signals_frames,
            msgs::Topic::Events => &self.events_frames,
            msgs::Topic::Stats => &self.stats_frames,
            _ => return,
        };
        counter.fetch_add(1, Ordering::Relaxed);
        let now = Instant::now();
        let lost = {
            let Ok(mut l) = self.latest.lock() else { return };
            let lost = match topic {
                msgs::Topic::Poses => l.poses.replace(bytes).is_some().then_some(&self.pose_frames_skipped),
                msgs::Topic::Signals => {
                    l.signals.replace(bytes).is_some().then_some(&self.signals_frames_skipped)
                }
                msgs::Topic::Stats => {
                    l.stats = Some(bytes);
                    None
                }
                _ if l.events.len() < EVENTS_QUEUE => {
                    l.events.push_back(bytes);
                    None
                }
                _ => Some(&self.events_frames_dropped),
            };
            if topic != msgs::Topic::Events {
                l.last_frame = Some(now);
            }
            lost
        };
        if let Some(c) = lost {
            c.fetch_add(1, Ordering::Relaxed);
        }
        self.ready.notify_all();
    }

    /// Waits up to `timeout` for something new, then takes everything new.
    pub fn take(&self, timeout: Duration) -> Latest {
        let Ok(mut l) = self.latest.lock() else { return Latest::default() };
        if l.poses.is_none()
            && l.stats.is_none()
            && l.scene.is_none()
            && l.signals.is_none()
            && l.events.is_empty()
        {
            l = match self.ready.wait_timeout(l, timeout) {
                Ok((l, _)) => l,
                Err(_) => return Latest::default(),
            };
        }
        Latest {
            poses: l.poses.take(),
            stats: l.stats.take(),
            scene: l.scene.take(),
            signals: l.signals.take(),
            events: std::mem::take(&mut l.events),
            last_frame: l.last_frame,
        }
    }
}

/// The bridge's Zenoh side.
pub struct ZenohLink {
    session: zenoh::Session,
    world: msgs::WorldName,
    /// What arrived.
    pub inbox: Arc<Inbox>,
    /// Poses, stats, signals and events, each feeding [`Inbox::receive`].
    _subscribers: [Subscriber<()>; 4],
    joystick: Publisher<'static>,
}

impl std::fmt::Debug for ZenohLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohLink").field("world", &self.world).finish()
    }
}

impl ZenohLink {
    /// Opens the session and subscribes to `world`'s poses, stats, signals and events.
    pub fn open(config: zenoh::Config, world: msgs::WorldName) -> anyhow::Result<ZenohLink> {
        let err = |e: zenoh::Error| anyhow!("zenoh: {e}");
        let session = zenoh::open(config).wait().map_err(err)?;
        let inbox = Arc::new(Inbox::default());
        let subscribe = |topic: msgs::Topic| {
            let i = inbox.clone();
            session
                .declare_subscriber(world.key(topic))
                .callback(move |s| i.receive(topic, s.payload().to_bytes().into_owned()))
                .wait()
                .map_err(err)
        };
        let subscribers = [
            subscribe(msgs::Topic::Poses)?,
            subscribe(msgs::Topic::Stats)?,
            subscribe(msgs::Topic::Signals)?,
            subscribe(msgs::Topic::Events)?,
        ];
        let joystick = session
            .declare_publisher(world.key(msgs::Topic::Joystick))
            .congestion_control(CongestionControl::Drop)
            .express(true)
            .wait()
            .map_err(err)?;
        Ok(ZenohLink { session, world, inbox, _subscribers: subscribers, joystick })
    }

    /// Asks the server for its scene description; the reply lands in the inbox (non-blocking).
    pub fn request_scene(&self) {
        let i = self.inbox.clone();
        let r = self
            .session
            .get(self.world.key(msgs::Topic::Scene))
            .timeout(Duration::from_secs(2))
            .callback(move |reply| {
                if let Ok(sample) = reply.result() {
                    let bytes = sample.payload().to_bytes().into_owned();
                    i.put(|l| l.scene = Some(bytes));
                }
            })
            .wait();
        if let Err(e) = r {
            tracing::warn!("scene query: {e}");
        }
    }

    /// Publishes one joystick frame (never blocks: dropped under congestion).
    pub fn put_joystick(&self, frame: &[u8]) -> anyhow::Result<()> {
        self.joystick.put(frame.to_vec()).wait().map_err(|e| anyhow!("zenoh put: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_newest_frame_wins_and_events_queue_to_their_bound() {
        let inbox = Inbox::default();
        inbox.receive(msgs::Topic::Poses, vec![1]);
        inbox.receive(msgs::Topic::Poses, vec![2]);
        inbox.receive(msgs::Topic::Stats, vec![3]);
        inbox.receive(msgs::Topic::Joystick, vec![9]); // not a topic the bridge reads
        for k in 0..EVENTS_QUEUE + 3 {
            inbox.receive(msgs::Topic::Events, vec![k as u8]);
        }
        let l = inbox.take(Duration::ZERO);
        assert_eq!((l.poses, l.stats, l.signals), (Some(vec![2]), Some(vec![3]), None));
        assert_eq!(l.events.len(), EVENTS_QUEUE);
        assert_eq!(l.events.front(), Some(&vec![0]), "the oldest kept, the overflow dropped");
        assert!(l.last_frame.is_some());
        let count = |c: &AtomicU64| c.load(Ordering::Relaxed);
        assert_eq!((count(&inbox.pose_frames), count(&inbox.pose_frames_skipped)), (2, 1));
        assert_eq!(count(&inbox.events_frames), EVENTS_QUEUE as u64 + 3);
        assert_eq!(count(&inbox.events_frames_dropped), 3);
        // Taken: nothing new until the next frame.
        let l = inbox.take(Duration::from_millis(1));
        assert!(l.poses.is_none() && l.events.is_empty());
    }
}
