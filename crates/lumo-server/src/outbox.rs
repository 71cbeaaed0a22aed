//! A viewer's bounded send queue. The server pushes without ever waiting; the viewer's socket
//! task pops. Every kind of message is bounded, so a viewer that stops reading costs a fixed
//! amount of memory and never delays anyone else:
//!
//! - sample batches and frames (data) are dropped oldest first beyond a byte and a count budget,
//!   and the queue only ever holds data of one epoch: data of an older epoch is discarded as a
//!   whole (O(discarded)) when a newer epoch starts;
//! - stats, broadcast cameras, parameters and finish events keep only the newest queued one;
//! - error replies beyond a few queued are dropped;
//! - what must arrive once each (the hello, a camera this viewer asked for) counts against a
//!   control budget, and a viewer over it is closed: it stopped reading while asking for more.

use std::collections::VecDeque;
use std::sync::Mutex;

use axum::body::Bytes;
use tokio::sync::{watch, Notify};

/// Data messages a queue holds at most, whatever their size (tiny batches add up in count,
/// not bytes).
pub const MAX_DATA_MESSAGES: usize = 1024;
/// Error replies queued at most; further ones are dropped until the viewer reads.
pub const MAX_QUEUED_ERRORS: usize = 16;
/// Control messages queued at most (next to the byte budget).
pub const MAX_CONTROL_MESSAGES: usize = 1024;
/// Default bytes of control messages a viewer may have queued before it is closed.
pub const DEFAULT_CONTROL_BYTES: usize = 64 << 10;
/// WebSocket close code for a viewer closed for breaking the rules (RFC 6455: policy
/// violation).
pub const CLOSE_POLICY: u16 = 1008;
/// WebSocket close code for a viewer refused because the server is full (RFC 6455: try again
/// later).
pub const CLOSE_TRY_LATER: u16 = 1013;

/// A message of which only the newest queued one matters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// A camera another viewer asked for (or one this viewer no longer waits for).
    Camera,
    /// Integrator and mode.
    Params,
    /// A render finished.
    Finish,
}

/// What a queued message is, for the dropping and coalescing rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Must arrive, once, in order (the hello; a camera this viewer asked for): counts against
    /// the control budget.
    Control,
    /// Replaces the older queued message of the same slot; the newest goes to the back, so
    /// slots keep the order they were pushed in.
    Latest(Slot),
    /// An error reply: dropped when [`MAX_QUEUED_ERRORS`] are queued.
    Error,
    /// Replaces an older stats message still queued, in its place.
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

/// What the socket task should do next.
#[derive(Clone, Debug, PartialEq)]
pub enum Next {
    /// Send this binary message.
    Send(Bytes),
    /// Send a close frame with this code and reason, then stop.
    Close(u16, String),
}

#[derive(Clone, Debug, PartialEq)]
enum State {
    Open,
    /// A close frame is waiting to be sent; nothing else will be.
    Closing(u16, String),
    Closed,
}

struct Inner {
    /// Order stamp of the next message: pop sends the lowest stamp of the three queues.
    seq: u64,
    /// Control, slot and error messages, in push order (a short queue: every kind in it is
    /// bounded by count).
    control: VecDeque<(u64, Outgoing)>,
    control_bytes: usize,
    /// The one queued stats message.
    stats: Option<(u64, Outgoing)>,
    /// Data of a single epoch, oldest first.
    data: VecDeque<(u64, Outgoing)>,
    data_bytes: usize,
    errors: usize,
    dropped: u64,
    errors_dropped: u64,
    state: State,
}

impl Inner {
    fn clear(&mut self) {
        self.control.clear();
        self.control_bytes = 0;
        self.stats = None;
        self.data.clear();
        self.data_bytes = 0;
        self.errors = 0;
    }

    /// Discards all data when it belongs to an epoch other than `epoch`: the queue holds one
    /// epoch only, so checking the newest message suffices and the cost is what is freed.
    fn purge(&mut self, epoch: u32) {
        if self
            .data
            .back()
            .is_some_and(|(_, m)| m.kind != Kind::Data(epoch))
        {
            self.data.clear();
            self.data_bytes = 0;
        }
    }

    fn remove_control(&mut self, i: usize) -> Option<Outgoing> {
        let (_, m) = self.control.remove(i)?;
        self.control_bytes -= m.bytes.len();
        if m.kind == Kind::Error {
            self.errors -= 1;
        }
        Some(m)
    }

    fn pop_control(&mut self) -> Option<Outgoing> {
        self.remove_control(0)
    }
}

/// The queue.
pub struct Outbox {
    inner: Mutex<Inner>,
    notify: Notify,
    /// True once closing or closed; the viewer's reading task watches it.
    closed_tx: watch::Sender<bool>,
    capacity: usize,
    control_capacity: usize,
}

impl Outbox {
    /// A queue holding at most `capacity` bytes of data messages and
    /// [`DEFAULT_CONTROL_BYTES`] of control messages.
    pub fn new(capacity: usize) -> Self {
        Self::with_budgets(capacity, DEFAULT_CONTROL_BYTES)
    }

    /// A queue holding at most `capacity` bytes of data and `control_capacity` bytes of
    /// control messages (more closes it).
    pub fn with_budgets(capacity: usize, control_capacity: usize) -> Self {
        Self {
            inner: Mutex::new(Inner {
                seq: 0,
                control: VecDeque::new(),
                control_bytes: 0,
                stats: None,
                data: VecDeque::new(),
                data_bytes: 0,
                errors: 0,
                dropped: 0,
                errors_dropped: 0,
                state: State::Open,
            }),
            notify: Notify::new(),
            closed_tx: watch::channel(false).0,
            capacity,
            control_capacity,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queues `msg` without blocking, dropping or coalescing old messages as its kind allows.
    /// Closes the queue (with a close frame) when the control budget is exceeded.
    pub fn push(&self, msg: Outgoing) {
        {
            let mut q = self.lock();
            if q.state != State::Open {
                return;
            }
            let seq = q.seq;
            q.seq += 1;
            let len = msg.bytes.len();
            match msg.kind {
                Kind::Stats => {
                    if let Some((_, old)) = &mut q.stats {
                        *old = msg;
                        return;
                    }
                    q.stats = Some((seq, msg));
                }
                Kind::Data(epoch) => {
                    q.purge(epoch);
                    if len > self.capacity {
                        q.dropped += 1;
                        return;
                    }
                    while q.data_bytes + len > self.capacity || q.data.len() >= MAX_DATA_MESSAGES {
                        let Some((_, old)) = q.data.pop_front() else {
                            break;
                        };
                        q.data_bytes -= old.bytes.len();
                        q.dropped += 1;
                    }
                    q.data_bytes += len;
                    q.data.push_back((seq, msg));
                }
                Kind::Error => {
                    if q.errors >= MAX_QUEUED_ERRORS {
                        q.errors_dropped += 1;
                        return;
                    }
                    q.errors += 1;
                    q.control_bytes += len;
                    q.control.push_back((seq, msg));
                }
                Kind::Latest(slot) => {
                    // At most one per slot is queued, so the scan is over a few entries.
                    if let Some(i) = q
                        .control
                        .iter()
                        .position(|(_, m)| m.kind == Kind::Latest(slot))
                    {
                        q.remove_control(i);
                    }
                    q.control_bytes += len;
                    q.control.push_back((seq, msg));
                }
                Kind::Control => {
                    q.control_bytes += len;
                    q.control.push_back((seq, msg));
                }
            }
            if q.control_bytes > self.control_capacity || q.control.len() > MAX_CONTROL_MESSAGES {
                let reason = format!(
                    "viewer not reading: {} control messages, {} bytes queued (budget \
                     {MAX_CONTROL_MESSAGES}, {} bytes)",
                    q.control.len(),
                    q.control_bytes,
                    self.control_capacity
                );
                drop(q);
                self.close_with(CLOSE_POLICY, &reason);
                return;
            }
        }
        self.notify.notify_one();
    }

    /// Removes queued data of epochs other than `epoch` (called when a new render starts).
    pub fn purge_except(&self, epoch: u32) {
        self.lock().purge(epoch);
    }

    /// Takes the next message, waiting for one; None once closed (after the close frame, if
    /// one was asked for).
    pub async fn pop(&self) -> Option<Next> {
        loop {
            {
                let mut q = self.lock();
                match std::mem::replace(&mut q.state, State::Closed) {
                    State::Closed => return None,
                    State::Closing(code, reason) => return Some(Next::Close(code, reason)),
                    State::Open => q.state = State::Open,
                }
                let c = q.control.front().map(|(s, _)| *s);
                let s = q.stats.as_ref().map(|(s, _)| *s);
                let d = q.data.front().map(|(s, _)| *s);
                let first = [c, s, d].into_iter().flatten().min();
                if first.is_some() && first == c {
                    if let Some(m) = q.pop_control() {
                        return Some(Next::Send(m.bytes));
                    }
                }
                if first.is_some() && first == s {
                    return q.stats.take().map(|(_, m)| Next::Send(m.bytes));
                }
                if let Some((_, m)) = q.data.pop_front() {
                    q.data_bytes -= m.bytes.len();
                    return Some(Next::Send(m.bytes));
                }
            }
            // notify_one stores a permit when nobody waits, so a push between the check above
            // and this await is not lost.
            self.notify.notified().await;
        }
    }

    /// Closes the queue: pending and future messages are discarded, `pop` returns None. A
    /// close frame already asked for by [`Outbox::close_with`] is still handed out first.
    pub fn close(&self) {
        {
            let mut q = self.lock();
            q.clear();
            if q.state == State::Open {
                q.state = State::Closed;
            }
        }
        self.closed_tx.send_replace(true);
        self.notify.notify_one();
    }

    /// Discards everything queued and makes `pop` hand out one close frame, then None.
    pub fn close_with(&self, code: u16, reason: &str) {
        {
            let mut q = self.lock();
            q.clear();
            if q.state == State::Open {
                q.state = State::Closing(code, truncate(reason, 120).to_string());
            }
        }
        self.closed_tx.send_replace(true);
        self.notify.notify_one();
    }

    /// Resolves once the queue is closing or closed.
    pub async fn closed(&self) {
        let mut rx = self.closed_tx.subscribe();
        // The sender lives as long as self, so wait_for only ends when the flag is set.
        let _ = rx.wait_for(|c| *c).await;
    }

    /// True once closing or closed.
    pub fn is_closed(&self) -> bool {
        *self.closed_tx.borrow()
    }

    /// Data messages dropped so far.
    pub fn dropped(&self) -> u64 {
        self.lock().dropped
    }

    /// Error replies dropped so far because too many were queued.
    pub fn errors_dropped(&self) -> u64 {
        self.lock().errors_dropped
    }

    /// Bytes queued (data, control and stats).
    pub fn queued_bytes(&self) -> usize {
        let q = self.lock();
        q.data_bytes + q.control_bytes + q.stats.as_ref().map_or(0, |(_, m)| m.bytes.len())
    }

    /// Sizes of the queue, for tests and tools.
    pub fn report(&self) -> QueueReport {
        let q = self.lock();
        QueueReport {
            data_bytes: q.data_bytes,
            data_messages: q.data.len(),
            control_bytes: q.control_bytes,
            control_messages: q.control.len(),
        }
    }

    /// The data budget in bytes.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// The control budget in bytes.
    pub fn control_capacity(&self) -> usize {
        self.control_capacity
    }
}

/// How full a queue is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QueueReport {
    /// Bytes of data queued.
    pub data_bytes: usize,
    /// Data messages queued.
    pub data_messages: usize,
    /// Bytes of control, slot and error messages queued.
    pub control_bytes: usize,
    /// Control, slot and error messages queued.
    pub control_messages: usize,
}

fn truncate(s: &str, max: usize) -> &str {
    if s.len() <= max {
        return s;
    }
    let mut end = max;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s[..end]
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

    fn msg(kind: Kind, b: &'static [u8]) -> Outgoing {
        Outgoing {
            kind,
            bytes: Bytes::from_static(b),
        }
    }

    fn drain(q: &Outbox) -> Vec<Next> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .expect("runtime");
        rt.block_on(async {
            let mut v = vec![];
            while q.queued_bytes() > 0 || q.is_closed() {
                match q.pop().await {
                    Some(n) => v.push(n),
                    None => break,
                }
            }
            v
        })
    }

    fn sent(v: &[u8]) -> Next {
        Next::Send(Bytes::copy_from_slice(v))
    }

    #[test]
    fn drops_oldest_data_and_keeps_control() {
        let q = Outbox::new(100);
        q.push(msg(Kind::Control, b"hello"));
        for _ in 0..5 {
            q.push(data(1, 40));
        }
        assert_eq!(q.report().data_bytes, 80);
        assert_eq!(q.dropped(), 3);
        q.push(msg(Kind::Stats, b"s1"));
        q.push(msg(Kind::Stats, b"s22"));
        // A new epoch's data purges the old epoch's.
        q.push(data(2, 10));
        assert_eq!(
            drain(&q),
            vec![sent(b"hello"), sent(b"s22"), sent(&[2u8; 10])]
        );
        q.close();
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .expect("runtime");
        assert!(rt.block_on(q.pop()).is_none());
    }

    #[test]
    fn slots_keep_the_newest_in_push_order_and_errors_are_capped() {
        let q = Outbox::new(1 << 20);
        q.push(msg(Kind::Latest(Slot::Params), b"p1"));
        q.push(msg(Kind::Latest(Slot::Camera), b"c1"));
        q.push(data(1, 3));
        q.push(msg(Kind::Latest(Slot::Params), b"p2"));
        q.push(msg(Kind::Latest(Slot::Camera), b"c2"));
        q.push(msg(Kind::Control, b"own"));
        for _ in 0..100 {
            q.push(msg(Kind::Error, b"e"));
        }
        assert_eq!(q.errors_dropped(), 100 - MAX_QUEUED_ERRORS as u64);
        let mut want = vec![sent(&[1u8; 3]), sent(b"p2"), sent(b"c2"), sent(b"own")];
        want.extend(std::iter::repeat_n(sent(b"e"), MAX_QUEUED_ERRORS));
        assert_eq!(drain(&q), want);
    }

    #[test]
    fn control_over_budget_closes_with_a_frame_and_memory_stays_bounded() {
        let q = Outbox::with_budgets(1000, 200);
        for _ in 0..100_000 {
            q.push(msg(Kind::Control, b"0123456789"));
            q.push(msg(Kind::Error, b"error"));
            q.push(msg(Kind::Latest(Slot::Finish), b"finish"));
            q.push(data(7, 10));
            assert!(q.queued_bytes() <= 1000 + 200);
        }
        assert!(q.is_closed());
        let got = drain(&q);
        assert_eq!(got.len(), 1);
        assert!(matches!(&got[0], Next::Close(CLOSE_POLICY, r) if r.contains("not reading")));
        // Closing after close_with keeps the frame; then nothing.
        q.close();
        assert!(drain(&q).is_empty());
    }

    #[test]
    fn data_count_is_capped_and_restarts_free_old_epochs_at_once() {
        let q = Outbox::new(usize::MAX / 2);
        for i in 0..(MAX_DATA_MESSAGES * 3) {
            q.push(data(1, 1 + i % 2));
        }
        assert_eq!(q.report().data_messages, MAX_DATA_MESSAGES);
        q.purge_except(2);
        assert_eq!(q.report(), QueueReport::default());
        // Many restarts interleaved with data never leave more than one epoch queued.
        for e in 0..10_000u32 {
            q.push(data(e, 5));
            q.push(data(e, 5));
            q.purge_except(e + 1);
            assert_eq!(q.report().data_messages, 0);
        }
    }
}
