//! Where the server reads time: passed in, never read inside the pure layers.

use proto::Stamp;
use std::fmt::Debug;
use std::time::{SystemTime, UNIX_EPOCH};

/// Where the shell reads time. Live: the system clock. Replay: a clock running through a
/// recorded match, possibly faster than real time, paused or moved
/// ([`crate::shell::replay_control::ReplayClock`]).
pub trait Clock: Send + Sync + Debug {
    fn now(&self) -> Stamp;
}

#[derive(Debug, Clone, Copy, Default)]
pub struct SystemClock;

impl Clock for SystemClock {
    fn now(&self) -> Stamp {
        let ns = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        Stamp(u64::try_from(ns).unwrap_or(u64::MAX))
    }
}
