//! Between Zenoh and the engine: each sample is stamped with the clock the moment it is
//! received and queued for one worker thread that feeds the engine. Lateness is then
//! judged on the arrival stamp, so a burst that takes the engine a while to work through
//! does not turn valid observations into `too_late`; and the Zenoh receive path never
//! waits for the engine's lock.
//!
//! The queue is bounded by count and by bytes. When it is full the *oldest* waiting input
//! is dropped to make room (counted as a rejection with reason `queue_full`): under
//! overload the engine works on what is freshest, and the backlog, hence the latency,
//! stays bounded; when the load stops, what is queued is worked off at once.

use crate::shell::live::Live;
use proto::Stamp;
use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex};

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

/// The queue between the receiving threads and the worker.
#[derive(Debug, Default)]
struct Queue {
    state: Mutex<QueueState>,
    ready: Condvar,
}

#[derive(Debug, Default)]
struct QueueState {
    inputs: VecDeque<Input>,
    bytes: u64,
    closed: bool,
}

impl Queue {
    /// Queues `input`, first dropping the oldest inputs that leave no room; the kinds of
    /// those dropped. A closed queue drops `input` itself.
    fn push(&self, input: Input) -> Vec<InputKind> {
        let mut q = self.state.lock().unwrap_or_else(|p| p.into_inner());
        if q.closed {
            return vec![input.kind];
        }
        let bytes = input.payload.len() as u64;
        let mut dropped = Vec::new();
        while !q.inputs.is_empty()
            && (q.inputs.len() >= QUEUE_CAPACITY || q.bytes + bytes > QUEUE_MAX_BYTES)
        {
            if let Some(old) = q.inputs.pop_front() {
                q.bytes -= old.payload.len() as u64;
                dropped.push(old.kind);
            }
        }
        q.bytes += bytes;
        q.inputs.push_back(input);
        drop(q);
        self.ready.notify_one();
        dropped
    }

    /// The oldest input, waiting for one; `None` once closed and empty.
    fn pop(&self) -> Option<Input> {
        let mut q = self.state.lock().unwrap_or_else(|p| p.into_inner());
        loop {
            if let Some(input) = q.inputs.pop_front() {
                q.bytes -= input.payload.len() as u64;
                return Some(input);
            }
            if q.closed {
                return None;
            }
            q = self.ready.wait(q).unwrap_or_else(|p| p.into_inner());
        }
    }

    fn close(&self) {
        self.state.lock().unwrap_or_else(|p| p.into_inner()).closed = true;
        self.ready.notify_all();
    }
}

/// The receiving end's handle: cheap to call from Zenoh callbacks.
#[derive(Debug)]
pub struct Intake {
    queue: Arc<Queue>,
    live: Arc<Live>,
    worker: Mutex<Option<std::thread::JoinHandle<()>>>,
    /// The engine's caps on (observation, status) payloads.
    max_bytes: (usize, usize),
}

impl Intake {
    /// Starts the worker thread feeding `live`.
    pub fn start(live: Arc<Live>) -> std::io::Result<Arc<Intake>> {
        let queue = Arc::new(Queue::default());
        let (l, q) = (live.clone(), queue.clone());
        let max_bytes = live.with_engine(|e| {
            let c = e.config();
            (c.max_observation_bytes, c.max_status_bytes)
        });
        let worker = std::thread::Builder::new()
            .name("intake".into())
            .spawn(move || work(&l, &q))?;
        Ok(Arc::new(Intake {
            queue,
            live,
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
        let input = Input {
            kind,
            key: key.to_string(),
            payload: payload.to_vec(),
            received,
        };
        for old in self.queue.push(input) {
            self.live.count_refused_input(old.label(), "queue_full");
        }
    }

    /// Closes the queue and waits for the worker to finish what is queued.
    pub fn stop(&self) {
        self.queue.close();
        if let Some(w) = self.worker.lock().unwrap_or_else(|p| p.into_inner()).take()
            && w.join().is_err()
        {
            tracing::warn!("the intake worker panicked");
        }
    }
}

fn work(live: &Live, queue: &Queue) {
    while let Some(input) = queue.pop() {
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
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
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

    /// A full queue drops its oldest inputs, not the newest, and the worker then gets the
    /// newest ones in order.
    #[test]
    fn a_full_queue_drops_the_oldest() {
        let q = Queue::default();
        let input = |seq: usize| Input {
            kind: InputKind::Observation,
            key: format!("k{seq}"),
            payload: vec![0; 10],
            received: Stamp(seq as u64),
        };
        let mut dropped = 0;
        for seq in 0..QUEUE_CAPACITY + 5 {
            dropped += q.push(input(seq)).len();
        }
        assert_eq!(dropped, 5);
        assert_eq!(q.pop().map(|i| i.key), Some("k5".to_string()));
        q.close();
        let rest = std::iter::from_fn(|| q.pop()).count();
        assert_eq!(rest, QUEUE_CAPACITY - 1);
        // Closed: nothing more is taken.
        assert_eq!(q.push(input(0)).len(), 1);
    }
}
