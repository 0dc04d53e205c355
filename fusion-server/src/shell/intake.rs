//! Between Zenoh and the engine: each sample is stamped with the clock the moment it is
//! received and queued for one worker thread that feeds the engine. Lateness is then
//! judged on the arrival stamp, so a burst that takes the engine a while to work through
//! does not turn valid observations into `too_late`; and the Zenoh receive path never
//! waits for the engine's lock.
//!
//! The queue is bounded by count and by bytes; what does not fit is dropped and counted
//! as a rejection with reason `queue_full`.

use crate::shell::live::Live;
use proto::Stamp;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex};

/// Samples the queue holds.
pub const QUEUE_CAPACITY: usize = 16_384;
/// Payload bytes the queue holds.
pub const QUEUE_MAX_BYTES: u64 = 32 << 20;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    Observation,
    Status,
}

impl InputKind {
    fn label(self) -> &'static str {
        match self {
            InputKind::Observation => "observation",
            InputKind::Status => "status",
        }
    }
}

#[derive(Debug)]
struct Input {
    kind: InputKind,
    key: String,
    payload: Vec<u8>,
    received: Stamp,
}

/// The receiving end's handle: cheap to call from Zenoh callbacks.
#[derive(Debug)]
pub struct Intake {
    tx: Mutex<Option<SyncSender<Input>>>,
    live: Arc<Live>,
    queued_bytes: Arc<AtomicU64>,
    worker: Mutex<Option<std::thread::JoinHandle<()>>>,
    /// The engine's caps on (observation, status) payloads.
    max_bytes: (usize, usize),
}

impl Intake {
    /// Starts the worker thread feeding `live`.
    pub fn start(live: Arc<Live>) -> std::io::Result<Arc<Intake>> {
        let (tx, rx) = sync_channel(QUEUE_CAPACITY);
        let queued_bytes = Arc::new(AtomicU64::new(0));
        let (l, q) = (live.clone(), queued_bytes.clone());
        let max_bytes = live.with_engine(|e| {
            let c = e.config();
            (c.max_observation_bytes, c.max_status_bytes)
        });
        let worker = std::thread::Builder::new()
            .name("intake".into())
            .spawn(move || work(&l, &rx, &q))?;
        Ok(Arc::new(Intake {
            tx: Mutex::new(Some(tx)),
            live,
            queued_bytes,
            worker: Mutex::new(Some(worker)),
            max_bytes,
        }))
    }

    /// A sample arrived now on `key`: stamped, then copied and queued (or dropped and
    /// counted). A payload over its cap is counted as `too_large` here, never copied.
    pub fn receive(&self, kind: InputKind, key: &str, payload: &[u8]) {
        let received = self.live.clock.now();
        let cap = match kind {
            InputKind::Observation => self.max_bytes.0,
            InputKind::Status => self.max_bytes.1,
        };
        if payload.len() > cap {
            self.live.count_refused_input(kind.label(), "too_large");
            return;
        }
        let payload = payload.to_vec();
        let bytes = payload.len() as u64;
        let before = self.queued_bytes.fetch_add(bytes, Relaxed);
        let input = Input {
            kind,
            key: key.to_string(),
            payload,
            received,
        };
        let sent = before + bytes <= QUEUE_MAX_BYTES
            && match self.tx.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
                Some(tx) => match tx.try_send(input) {
                    Ok(()) => true,
                    Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => false,
                },
                None => false,
            };
        if !sent {
            self.queued_bytes.fetch_sub(bytes, Relaxed);
            self.live.count_refused_input(kind.label(), "queue_full");
        }
    }

    /// Closes the queue and waits for the worker to finish what is queued.
    pub fn stop(&self) {
        self.tx.lock().unwrap_or_else(|p| p.into_inner()).take();
        if let Some(w) = self.worker.lock().unwrap_or_else(|p| p.into_inner()).take()
            && w.join().is_err()
        {
            tracing::warn!("the intake worker panicked");
        }
    }
}

fn work(live: &Live, rx: &Receiver<Input>, queued_bytes: &AtomicU64) {
    while let Ok(input) = rx.recv() {
        queued_bytes.fetch_sub(input.payload.len() as u64, Relaxed);
        match input.kind {
            InputKind::Observation => {
                live.on_observation_at(&input.key, &input.payload, input.received)
            }
            InputKind::Status => live.on_status_at(&input.key, &input.payload, input.received),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::Clock;
    use crate::shell::serve::{ServeConfig, shared};
    use proto::test_support::observation;
    use std::sync::atomic::AtomicU64;
    use std::sync::mpsc::channel;

    #[derive(Debug)]
    struct ManualClock(AtomicU64);

    impl Clock for ManualClock {
        fn now(&self) -> Stamp {
            Stamp(self.0.load(Relaxed))
        }
    }

    fn obs(seq: u64, stamp: Stamp) -> Vec<u8> {
        proto::encode(&observation("miro1", seq, stamp, [0.5, 0.1]))
    }

    /// Observations received on time are judged on their arrival, however long the engine
    /// takes to get to them: here it is busy for two seconds (well past the late window).
    #[test]
    fn a_backlog_does_not_make_observations_late() -> anyhow::Result<()> {
        let t0 = Stamp(1_800_000_000_000_000_000);
        let clock = Arc::new(ManualClock(AtomicU64::new(t0.0)));
        let live = shared(&ServeConfig::default(), clock.clone(), None)?;
        let intake = Intake::start(live.clone())?;
        let (locked_tx, locked_rx) = channel();
        let (release_tx, release_rx) = channel::<()>();
        let l = live.clone();
        let busy = std::thread::spawn(move || {
            l.with_engine(|_| {
                locked_tx.send(()).ok();
                release_rx.recv().ok();
            })
        });
        locked_rx.recv()?;
        let n = 100_u64;
        for seq in 0..n {
            let now = t0.offset_secs(seq as f64 * 1e-3);
            clock.0.store(now.0, Relaxed);
            intake.receive(
                InputKind::Observation,
                "rf/robots/miro1/obs",
                &obs(seq, now),
            );
        }
        clock.0.store(t0.offset_secs(2.0).0, Relaxed);
        release_tx.send(())?;
        busy.join()
            .map_err(|_| anyhow::anyhow!("the busy thread panicked"))?;
        intake.stop();
        let (accepted, late) = live.with_engine(|e| {
            let late = e.rejected_by_reason().get("observation/too_late").copied();
            (e.counters().observations_accepted, late)
        });
        assert_eq!((accepted, late), (n, None));
        Ok(())
    }
}
