//! A token bucket: the rate limit of viewers' messages and of remote workers' samples.

use std::time::{Duration, Instant};

/// A token bucket: `burst` tokens, refilled at `rate` per second.
pub(crate) struct Bucket {
    tokens: f64,
    burst: f64,
    rate: f64,
    last: Instant,
}

impl Bucket {
    pub(crate) fn new(burst: f64, rate: f64) -> Self {
        // Guard against a zero or negative configuration: it would never refill.
        let rate = rate.max(1e-3);
        let burst = burst.max(1.0);
        Self {
            tokens: burst,
            burst,
            rate,
            last: Instant::now(),
        }
    }

    fn refill(&mut self) {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.tokens = (self.tokens + dt * self.rate).min(self.burst);
        self.last = now;
    }

    /// Takes a token if there is one.
    pub(crate) fn take(&mut self) -> bool {
        self.refill();
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }

    /// Takes a token on credit; returns how long to wait until the balance is back to zero.
    pub(crate) fn take_or_wait(&mut self) -> Duration {
        self.take_n_or_wait(1.0)
    }

    /// Takes `n` tokens on credit; returns how long to wait until the balance is back to
    /// zero (a remote worker's batch costs its samples and light paths).
    pub(crate) fn take_n_or_wait(&mut self, n: f64) -> Duration {
        self.refill();
        self.tokens -= n;
        if self.tokens >= 0.0 {
            Duration::ZERO
        } else {
            Duration::from_secs_f64(-self.tokens / self.rate)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_allow_a_burst_then_the_rate() {
        let mut b = Bucket::new(3.0, 10.0);
        assert!(b.take() && b.take() && b.take());
        assert!(!b.take());
        let mut r = Bucket::new(2.0, 100.0);
        assert_eq!(r.take_or_wait(), Duration::ZERO);
        assert_eq!(r.take_or_wait(), Duration::ZERO);
        let w = r.take_or_wait();
        assert!(
            w > Duration::from_millis(5) && w <= Duration::from_millis(10),
            "{w:?}"
        );
    }
}
