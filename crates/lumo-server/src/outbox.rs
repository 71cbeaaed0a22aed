//! A viewer's bounded send queue. The server pushes without ever waiting; the viewer's socket
//! task pops. When a viewer reads too slowly the oldest sample batches are dropped, stats are
//! coalesced into the newest, and a new epoch (camera or parameters) purges data of old ones,
//! so a stalled or vanished viewer costs bounded memory and never delays anyone else.

use std::collections::VecDeque;
use std::sync::Mutex;

use axum::body::Bytes;
use tokio::sync::Notify;

/// What a queued message is, for the dropping and coalescing rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Must arrive (hello, camera, params, finish, error).
    Control,
    /// Replaces an older stats message still queued.
    Stats,
    /// Sample batch or frame of an epoch: droppable, oldest first.
    Data(u32),
}

/// One queued message.
#[derive(Clone, Debug)]
pub struct Outgoing {
    /// Its kind.
    pub kind: Kind,
    /// The encoded message.
    pub bytes: Bytes,
}

#[derive(Default)]
struct Inner {
    queue: VecDeque<Outgoing>,
    bytes: usize,
    dropped: u64,
    closed: bool,
}

fn purge(q: &mut Inner, epoch: u32) {
    let mut freed = 0;
    q.queue.retain(|m| match m.kind {
        Kind::Data(e) if e != epoch => {
            freed += m.bytes.len();
            false
        }
        _ => true,
    });
    q.bytes -= freed;
}

/// The queue.
pub struct Outbox {
    inner: Mutex<Inner>,
    notify: Notify,
    capacity: usize,
}

impl Outbox {
    /// A queue holding at most `capacity` bytes of data messages.
    pub fn new(capacity: usize) -> Self {
        Self {
            inner: Mutex::new(Inner::default()),
            notify: Notify::new(),
            capacity,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queues `msg` without blocking, dropping old data if needed.
    pub fn push(&self, msg: Outgoing) {
        {
            let mut q = self.lock();
            if q.closed {
                return;
            }
            match msg.kind {
                Kind::Stats => {
                    if let Some(old) = q.queue.iter_mut().find(|m| m.kind == Kind::Stats) {
                        let delta = msg.bytes.len() as isize - old.bytes.len() as isize;
                        *old = msg;
                        q.bytes = (q.bytes as isize + delta) as usize;
                        return;
                    }
                }
                Kind::Data(epoch) => {
                    while q.bytes + msg.bytes.len() > self.capacity {
                        let Some(i) = q.queue.iter().position(|m| matches!(m.kind, Kind::Data(_)))
                        else {
                            break;
                        };
                        if let Some(old) = q.queue.remove(i) {
                            q.bytes -= old.bytes.len();
                            q.dropped += 1;
                        }
                    }
                    if q.bytes + msg.bytes.len() > self.capacity {
                        q.dropped += 1;
                        return;
                    }
                    // Data of an older epoch is useless once a newer one arrives.
                    purge(&mut q, epoch);
                }
                Kind::Control => {}
            }
            q.bytes += msg.bytes.len();
            q.queue.push_back(msg);
        }
        self.notify.notify_one();
    }

    /// Removes queued data of epochs other than `epoch` (called when a new render starts).
    pub fn purge_except(&self, epoch: u32) {
        purge(&mut self.lock(), epoch);
    }

    /// Takes the next message, waiting for one; None once closed.
    pub async fn pop(&self) -> Option<Outgoing> {
        loop {
            {
                let mut q = self.lock();
                if q.closed {
                    return None;
                }
                if let Some(m) = q.queue.pop_front() {
                    q.bytes -= m.bytes.len();
                    return Some(m);
                }
            }
            // notify_one stores a permit when nobody waits, so a push between the check above
            // and this await is not lost.
            self.notify.notified().await;
        }
    }

    /// Closes the queue: pending and future messages are discarded, `pop` returns None.
    pub fn close(&self) {
        {
            let mut q = self.lock();
            q.closed = true;
            q.queue.clear();
            q.bytes = 0;
        }
        self.notify.notify_one();
    }

    /// Data messages dropped so far.
    pub fn dropped(&self) -> u64 {
        self.lock().dropped
    }

    /// Bytes queued.
    pub fn queued_bytes(&self) -> usize {
        self.lock().bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(epoch: u32, n: usize) -> Outgoing {
        Outgoing {
            kind: Kind::Data(epoch),
            bytes: Bytes::from(vec![epoch as u8; n]),
        }
    }

    #[test]
    fn drops_oldest_data_and_keeps_control() {
        let q = Outbox::new(100);
        q.push(Outgoing {
            kind: Kind::Control,
            bytes: Bytes::from_static(b"hello"),
        });
        for _ in 0..5 {
            q.push(data(1, 40));
        }
        assert!(q.queued_bytes() <= 100 + 5);
        assert_eq!(q.dropped(), 3);
        q.push(Outgoing {
            kind: Kind::Stats,
            bytes: Bytes::from_static(b"s1"),
        });
        q.push(Outgoing {
            kind: Kind::Stats,
            bytes: Bytes::from_static(b"s22"),
        });
        // A new epoch's data purges the old epoch's.
        q.push(data(2, 10));
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .expect("runtime");
        let got: Vec<Vec<u8>> = rt.block_on(async {
            let mut v = vec![];
            while q.queued_bytes() > 0 {
                v.push(q.pop().await.expect("open").bytes.to_vec());
            }
            v
        });
        assert_eq!(got, vec![b"hello".to_vec(), b"s22".to_vec(), vec![2u8; 10]]);
        q.close();
        assert!(rt.block_on(q.pop()).is_none());
    }
}
