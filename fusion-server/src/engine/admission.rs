//! Who may take room in the server's state: a token bucket per robot (a flood from one id
//! cannot crowd out the rest), the expiry of robots gone quiet, and, when the robot table
//! is full, room made by forgetting the least established robot (a burst of made-up ids
//! takes room only from each other, never from robots that are fusing).

use proto::Stamp;

/// A token bucket: `rate_hz` tokens a second, at most `burst` saved up. Time is passed in.
#[derive(Debug, Clone, PartialEq)]
pub struct TokenBucket {
    tokens: f64,
    at: Option<Stamp>,
}

impl TokenBucket {
    /// A full bucket.
    pub fn full(burst: f64) -> Self {
        TokenBucket {
            tokens: burst,
            at: None,
        }
    }

    /// Takes one token at `now` if there is one. A clock stepping back adds nothing, and
    /// the bucket fills on from the new time (a replay moved back in time must not wait
    /// for its clock to reach the old one before its robots may send again).
    pub fn take(&mut self, now: Stamp, rate_hz: f64, burst: f64) -> bool {
        if let Some(at) = self.at {
            let dt_s = now.secs_since(at).max(0.0);
            self.tokens = (self.tokens + dt_s * rate_hz).min(burst);
        }
        self.at = Some(now);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

/// A token bucket per robot id, for at most `CAPACITY` ids: beyond, it starts over (every
/// bucket full again), so made-up ids cannot take the server's memory.
#[derive(Debug, Clone, Default)]
pub struct RateBuckets<const CAPACITY: usize> {
    buckets: std::collections::HashMap<String, TokenBucket>,
}

impl<const CAPACITY: usize> RateBuckets<CAPACITY> {
    /// Takes a token from `robot`'s bucket at `now` (a new robot's starts full).
    pub fn take(&mut self, robot: &str, now: Stamp, rate_hz: f64, burst: f64) -> bool {
        if let Some(b) = self.buckets.get_mut(robot) {
            return b.take(now, rate_hz, burst);
        }
        if self.buckets.len() >= CAPACITY {
            self.buckets.clear();
        }
        let mut b = TokenBucket::full(burst);
        let ok = b.take(now, rate_hz, burst);
        self.buckets.insert(robot.to_string(), b);
        ok
    }

    /// Forgets every bucket.
    pub fn clear(&mut self) {
        self.buckets.clear();
    }
}

/// How robots are admitted and forgotten.
#[derive(Debug, Clone, PartialEq)]
pub struct AdmissionConfig {
    /// Messages (observations and statuses together) a robot may send per second on
    /// average; beyond it they are refused as `rate_limited`.
    pub rate_limit_hz: f64,
    /// Messages a robot may send at once above the average (a burst after a stall).
    pub rate_burst: f64,
    /// A robot heard of neither message nor liveliness change for this long is forgotten:
    /// at once when its token is gone, and when the table is full otherwise.
    pub robot_expiry_s: f64,
    /// Accepted messages (observations and statuses) after which a robot is established:
    /// when the table is full, only robots with fewer may be forgotten for a newcomer,
    /// those with the fewest first.
    pub established_messages: u64,
}

impl Default for AdmissionConfig {
    fn default() -> Self {
        AdmissionConfig {
            rate_limit_hz: 200.0,
            rate_burst: 200.0,
            robot_expiry_s: 10.0,
            established_messages: 20,
        }
    }
}

/// How often the table is swept for robots gone quiet.
pub const SWEEP_EVERY_S: f64 = 1.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bucket_gives_its_burst_then_its_rate() {
        let t0 = Stamp(1_800_000_000_000_000_000);
        let mut b = TokenBucket::full(5.0);
        let taken = (0..10).filter(|_| b.take(t0, 10.0, 5.0)).count();
        assert_eq!(taken, 5, "the burst");
        // One second later: ten more at 10 Hz, capped by the burst of five.
        let later = t0.offset_secs(1.0);
        let taken = (0..10).filter(|_| b.take(later, 10.0, 5.0)).count();
        assert_eq!(taken, 5);
        // 0.25 s on: two and a half tokens, two whole ones.
        let t = later.offset_secs(0.25);
        assert_eq!((0..10).filter(|_| b.take(t, 10.0, 5.0)).count(), 2);
        // A clock stepping back gives nothing...
        assert!(!b.take(t0, 10.0, 5.0));
        // ... and the bucket fills on from there: 0.2 s later, two tokens.
        let back = t0.offset_secs(0.2);
        assert_eq!((0..10).filter(|_| b.take(back, 10.0, 5.0)).count(), 2);
    }
}
