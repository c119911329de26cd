//! A bounded inbox: transports (Zenoh callbacks, iceoryx2 polling threads) offer items, one loop
//! takes them. Offering never blocks: when the inbox is full (or its receiver is gone) the item is
//! handed back to the caller and counted as dropped, so a burst of frames can never stall a
//! transport thread or grow memory without bound.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::time::Duration;

/// The offering side, cloned into callbacks and threads.
pub struct InboxSender<T> {
    tx: SyncSender<T>,
    dropped: Arc<AtomicU64>,
}

impl<T> Clone for InboxSender<T> {
    fn clone(&self) -> Self {
        InboxSender { tx: self.tx.clone(), dropped: self.dropped.clone() }
    }
}

impl<T> std::fmt::Debug for InboxSender<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("InboxSender").field("dropped", &self.dropped.load(Ordering::Relaxed)).finish()
    }
}

impl<T> InboxSender<T> {
    /// Offers an item; a full or closed inbox hands it back (and counts a drop).
    pub fn offer(&self, item: T) -> Result<(), T> {
        match self.tx.try_send(item) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(item) | TrySendError::Disconnected(item)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
                Err(item)
            }
        }
    }
}

/// The taking side.
pub struct Inbox<T> {
    rx: Receiver<T>,
    dropped: Arc<AtomicU64>,
}

impl<T> std::fmt::Debug for Inbox<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Inbox").field("dropped", &self.dropped()).finish()
    }
}

impl<T> Inbox<T> {
    /// The next item, waiting at most `timeout` (`None` on timeout or when every sender is gone).
    pub fn recv_timeout(&self, timeout: Duration) -> Option<T> {
        self.rx.recv_timeout(timeout).ok()
    }

    /// An item if one is waiting.
    pub fn try_recv(&self) -> Option<T> {
        self.rx.try_recv().ok()
    }

    /// Items dropped so far because the inbox was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

/// A bounded inbox of `capacity` items (at least 1).
pub fn inbox<T>(capacity: usize) -> (InboxSender<T>, Inbox<T>) {
    let (tx, rx) = sync_channel(capacity.max(1));
    let dropped = Arc::new(AtomicU64::new(0));
    (InboxSender { tx, dropped: dropped.clone() }, Inbox { rx, dropped })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_inbox_hands_the_item_back_and_counts_it() {
        let (tx, rx) = inbox::<u32>(2);
        assert_eq!(tx.offer(1), Ok(()));
        assert_eq!(tx.clone().offer(2), Ok(()));
        assert_eq!(tx.offer(3), Err(3));
        assert_eq!(rx.dropped(), 1);
        assert_eq!(rx.try_recv(), Some(1));
        assert_eq!(rx.recv_timeout(Duration::from_millis(1)), Some(2));
        assert_eq!(rx.try_recv(), None);
        drop(rx);
        assert_eq!(tx.offer(4), Err(4));
    }
}
