//! A bounded inbox: transports (Zenoh callbacks, iceoryx2 polling threads) offer items, one loop
//! takes them. Offering never blocks: when the inbox is full (or its receiver is gone) the item is
//! handed back to the caller and counted as dropped, so a burst of frames can never stall a
//! transport thread or grow memory without bound.

use std::cell::RefCell;
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

/// The taking side (one thread: the loop).
pub struct Inbox<T> {
    rx: Receiver<T>,
    dropped: Arc<AtomicU64>,
    /// An item [`Inbox::wait`] took and the next take returns.
    held: RefCell<Option<T>>,
}

impl<T> std::fmt::Debug for Inbox<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Inbox").field("dropped", &self.dropped()).finish()
    }
}

impl<T> Inbox<T> {
    /// The next item, waiting at most `timeout` (`None` on timeout or when every sender is gone).
    pub fn recv_timeout(&self, timeout: Duration) -> Option<T> {
        self.held.borrow_mut().take().or_else(|| self.rx.recv_timeout(timeout).ok())
    }

    /// An item if one is waiting.
    pub fn try_recv(&self) -> Option<T> {
        self.held.borrow_mut().take().or_else(|| self.rx.try_recv().ok())
    }

    /// Waits at most `timeout` for an item without taking it (the next take returns it); whether
    /// one is waiting. A loop that sleeps between turns waits here, so an item wakes it at once.
    pub fn wait(&self, timeout: Duration) -> bool {
        let mut held = self.held.borrow_mut();
        if held.is_none() {
            *held = self.rx.recv_timeout(timeout).ok();
        }
        held.is_some()
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
    (InboxSender { tx, dropped: dropped.clone() }, Inbox { rx, dropped, held: RefCell::new(None) })
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

    #[test]
    fn waiting_keeps_the_item_for_the_next_take_in_order() {
        let (tx, rx) = inbox::<u32>(4);
        assert!(!rx.wait(Duration::from_millis(1)));
        let sender = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            tx.offer(7).unwrap();
            tx.offer(8).unwrap();
        });
        // Woken by the item, long before the timeout.
        let t0 = std::time::Instant::now();
        assert!(rx.wait(Duration::from_secs(10)));
        assert!(t0.elapsed() < Duration::from_secs(5));
        assert!(rx.wait(Duration::ZERO), "a held item is still waiting");
        sender.join().unwrap();
        assert_eq!(rx.try_recv(), Some(7));
        assert_eq!(rx.recv_timeout(Duration::from_millis(1)), Some(8));
        assert_eq!(rx.try_recv(), None);
    }
}
