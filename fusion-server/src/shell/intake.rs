//! Between Zenoh and the engine: each sample is stamped with the clock the moment it is
//! received and queued for one worker thread that feeds the engine. Lateness is then
//! judged on the arrival stamp, so a burst that takes the engine a while to work through
//! does not turn valid observations into `too_late`; and the Zenoh receive path never
//! waits for the engine's lock (what it refuses is counted by the worker).
//!
//! The queue is bounded by count and by bytes. When it is full the *oldest* waiting input
//! is dropped to make room (counted as a rejection with reason `queue_full`): under
//! overload the engine works on what is freshest, and the backlog, hence the latency,
//! stays bounded; when the load stops, what is queued is worked off at once.
//!
//! A robot's inputs over its rate limit (the engine's `[limits]`, the same token bucket)
//! are refused here, before they are copied, queued or decoded: a flooding robot costs
//! the fusion nothing. Robots with a history (an input accepted, or a liveliness token)
//! queue apart from the rest: ids nobody has heard of get a small share of the queue ([`UNPROVEN_CAPACITY`]) and
//! are dropped first when it is full, so that a flood of made-up ids cannot push out the
//! observations of robots that have been fusing.

use crate::engine::RateBuckets;
use crate::shell::live::Live;
use proto::Stamp;
use std::collections::{HashSet, VecDeque};
use std::sync::atomic::Ordering::Relaxed;
use std::sync::{Arc, Condvar, Mutex};

/// Samples the queue holds.
pub const QUEUE_CAPACITY: usize = 16_384;
/// Of those, samples of robots without a history.
pub const UNPROVEN_CAPACITY: usize = QUEUE_CAPACITY / 16;
/// Payload bytes the queue holds.
pub const QUEUE_MAX_BYTES: u64 = 32 << 20;
/// Robot ids with a history, and rate buckets, the queue remembers; beyond, it starts
/// over (robots prove themselves again with their next accepted input, buckets start full
/// as the engine's do for a new robot).
const KNOWN_CAPACITY: usize = 4096;

/// The per-robot rate limit (messages a second, burst).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Limit {
    rate_hz: f64,
    burst: f64,
}

impl Default for Limit {
    fn default() -> Self {
        Limit {
            rate_hz: f64::INFINITY,
            burst: f64::INFINITY,
        }
    }
}

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
    limit: Limit,
}

/// Inputs refused on the receive path and not yet counted: (kind, reason, the robot when
/// the reason is its own, how many).
type Refused = Vec<(InputKind, &'static str, Option<String>, u64)>;

#[derive(Debug, Default)]
struct QueueState {
    /// Inputs of robots with a history, and of the rest, each in arrival order.
    proven: VecDeque<Input>,
    unproven: VecDeque<Input>,
    bytes: u64,
    closed: bool,
    /// Robot ids (key chunks) with a history.
    known: HashSet<String>,
    /// Each robot's rate bucket.
    buckets: RateBuckets<KNOWN_CAPACITY>,
    refused: Refused,
}

impl QueueState {
    fn len(&self) -> usize {
        self.proven.len() + self.unproven.len()
    }

    fn full_for(&self, bytes: u64) -> bool {
        self.len() >= QUEUE_CAPACITY || self.bytes + bytes > QUEUE_MAX_BYTES
    }

    fn refuse(&mut self, kind: InputKind, reason: &'static str, robot: Option<&str>) {
        match self
            .refused
            .iter_mut()
            .find(|(k, r, id, _)| *k == kind && *r == reason && id.as_deref() == robot)
        {
            Some((_, _, _, n)) => *n += 1,
            None => self
                .refused
                .push((kind, reason, robot.map(str::to_string), 1)),
        }
    }

    /// Takes a token from `robot`'s bucket at `now`.
    fn within_rate(&mut self, robot: &str, now: Stamp, limit: Limit) -> bool {
        limit.rate_hz.is_infinite() || self.buckets.take(robot, now, limit.rate_hz, limit.burst)
    }

    /// Drops the front of `unproven` (else of `proven`) for room.
    fn drop_oldest(&mut self, proven_too: bool) -> bool {
        let old = match self.unproven.pop_front() {
            Some(old) => old,
            None if proven_too => match self.proven.pop_front() {
                Some(old) => old,
                None => return false,
            },
            None => return false,
        };
        self.bytes -= old.payload.len() as u64;
        self.refuse(old.kind, "queue_full", None);
        true
    }
}

/// What the worker takes from the queue: the oldest input (if any), the inputs left
/// waiting, and the refusals to count.
struct Work {
    input: Option<Input>,
    left: usize,
    refused: Refused,
}

impl Queue {
    /// Queues `input` of robot `robot` (refused when over the robot's rate), first dropping
    /// the oldest inputs that leave no room (those of robots without a history first); the
    /// inputs now queued. A closed queue drops `input` itself.
    fn push(&self, robot: &str, input: Input) -> usize {
        let mut q = self.state.lock().unwrap_or_else(|p| p.into_inner());
        if q.closed {
            q.refuse(input.kind, "queue_full", None);
            let queued = q.len();
            drop(q);
            self.ready.notify_one();
            return queued;
        }
        if !q.within_rate(robot, input.received, self.limit) {
            q.refuse(input.kind, "rate_limited", Some(robot));
            let queued = q.len();
            drop(q);
            // The worker counts it.
            self.ready.notify_one();
            return queued;
        }
        let bytes = input.payload.len() as u64;
        let proven = q.known.contains(robot);
        if proven {
            while q.full_for(bytes) && q.drop_oldest(true) {}
        } else {
            while (q.unproven.len() >= UNPROVEN_CAPACITY || q.full_for(bytes))
                && q.drop_oldest(false)
            {}
        }
        if q.full_for(bytes) {
            // Full of robots with a history: a newcomer's input waits for no one.
            q.refuse(input.kind, "queue_full", None);
        } else {
            q.bytes += bytes;
            if proven {
                q.proven.push_back(input);
            } else {
                q.unproven.push_back(input);
            }
        }
        let queued = q.len();
        drop(q);
        self.ready.notify_one();
        queued
    }

    /// Counts an input refused on the receive path (by the worker, soon).
    fn refuse(&self, kind: InputKind, reason: &'static str) {
        self.state
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .refuse(kind, reason, None);
        self.ready.notify_one();
    }

    /// Robot `robot` has a history: its inputs queue with the proven from now on.
    fn know(&self, robot: &str) {
        let mut q = self.state.lock().unwrap_or_else(|p| p.into_inner());
        if q.known.len() >= KNOWN_CAPACITY {
            q.known.clear();
        }
        q.known.insert(robot.to_string());
    }

    /// The oldest input (of either kind of robot) and what there is to count, waiting for
    /// either; `None` once closed with nothing left.
    fn pop(&self) -> Option<Work> {
        let mut q = self.state.lock().unwrap_or_else(|p| p.into_inner());
        loop {
            let from_unproven = match (q.proven.front(), q.unproven.front()) {
                (Some(p), Some(u)) => Some(u.received < p.received),
                (Some(_), None) => Some(false),
                (None, Some(_)) => Some(true),
                (None, None) => None,
            };
            let input = match from_unproven {
                Some(true) => q.unproven.pop_front(),
                Some(false) => q.proven.pop_front(),
                None => None,
            };
            if let Some(i) = &input {
                q.bytes -= i.payload.len() as u64;
            }
            let refused = std::mem::take(&mut q.refused);
            if input.is_some() || !refused.is_empty() {
                return Some(Work {
                    input,
                    left: q.len(),
                    refused,
                });
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
        let (max_bytes, limit) = live.with_engine(|e| {
            let c = e.config();
            let limit = Limit {
                rate_hz: c.admission.rate_limit_hz,
                burst: c.admission.rate_burst,
            };
            ((c.max_observation_bytes, c.max_status_bytes), limit)
        });
        let queue = Arc::new(Queue {
            limit,
            ..Queue::default()
        });
        let (l, q) = (live.clone(), queue.clone());
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
            self.queue.refuse(kind, "too_large");
            return;
        }
        let input = Input {
            kind,
            key: key.to_string(),
            payload: payload.to_vec(),
            received,
        };
        let robot = self.live.keys.robot_chunk_of(key).unwrap_or(key);
        let queued = self.queue.push(robot, input);
        self.live.stats.intake_queued.store(queued as u64, Relaxed);
    }

    /// A robot's liveliness token under `key` appeared: the robot has a history.
    pub fn liveliness(&self, key: &str) {
        if let Some(robot) = self.live.keys.robot_chunk_of(key) {
            self.queue.know(robot);
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
    // The robots this worker has told the queue about (a copy, so that it asks the queue's
    // lock only for news).
    let mut known: HashSet<String> = HashSet::new();
    while let Some(Work {
        input,
        left,
        refused,
    }) = queue.pop()
    {
        live.stats.intake_queued.store(left as u64, Relaxed);
        for (kind, reason, robot, n) in refused {
            live.count_refused_inputs(kind.label(), reason, robot.as_deref(), n);
        }
        let Some(input) = input else { continue };
        let accepted = match input.kind {
            InputKind::Observation => {
                live.on_observation_at(&input.key, &input.payload, input.received)
            }
            InputKind::Status => live.on_status_at(&input.key, &input.payload, input.received),
        };
        if accepted {
            let robot = live.keys.robot_chunk_of(&input.key).unwrap_or(&input.key);
            if !known.contains(robot) {
                if known.len() >= KNOWN_CAPACITY {
                    known.clear();
                }
                known.insert(robot.to_string());
                queue.know(robot);
            }
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
        q.know("miro1");
        for seq in 0..QUEUE_CAPACITY + 5 {
            let queued = q.push("miro1", input(seq));
            assert_eq!(queued, (seq + 1).min(QUEUE_CAPACITY));
        }
        let first = q.pop().expect("work");
        assert_eq!(first.input.map(|i| i.key), Some("k5".to_string()));
        assert_eq!(first.left, QUEUE_CAPACITY - 1);
        assert_eq!(
            first.refused,
            vec![(InputKind::Observation, "queue_full", None, 5)]
        );
        q.close();
        let rest = std::iter::from_fn(|| q.pop()).count();
        assert_eq!(rest, QUEUE_CAPACITY - 1);
        // Closed: nothing more is taken, and what was refused is still counted.
        q.push("miro1", input(0));
        let last = q.pop().expect("the refusal");
        assert!(last.input.is_none());
        assert_eq!(
            last.refused,
            vec![(InputKind::Observation, "queue_full", None, 1)]
        );
    }

    /// A flood of made-up ids fills only their share of the queue and is dropped first:
    /// the inputs of robots with a history all stay, in arrival order with the rest.
    #[test]
    fn made_up_ids_take_only_their_share_and_go_first() {
        let q = Queue::default();
        let input = |key: &str, at: u64| Input {
            kind: InputKind::Observation,
            key: key.to_string(),
            payload: vec![0; 10],
            received: Stamp(at),
        };
        q.know("honest");
        let mut at = 0;
        for k in 0..QUEUE_CAPACITY * 2 {
            at += 1;
            q.push(&format!("fake{k}"), input("fake", at));
            if k % 4 == 0 {
                at += 1;
                q.push("honest", input("honest", at));
            }
        }
        let honest = QUEUE_CAPACITY * 2 / 4;
        {
            let s = q.state.lock().expect("queue");
            assert_eq!(s.unproven.len(), UNPROVEN_CAPACITY);
            assert_eq!(s.proven.len(), honest);
        }
        // Full of honest inputs now: the made-up ids' go first, then a newcomer is refused.
        for _ in 0..QUEUE_CAPACITY {
            at += 1;
            q.push("honest", input("honest", at));
        }
        at += 1;
        q.push("newcomer", input("newcomer", at));
        q.close();
        let mut last = 0;
        let (mut kinds, mut refused) = (std::collections::BTreeMap::new(), 0);
        while let Some(w) = q.pop() {
            refused += w.refused.iter().map(|r| r.3).sum::<u64>();
            if let Some(i) = w.input {
                assert!(i.received.0 > last, "in arrival order");
                last = i.received.0;
                *kinds.entry(i.key).or_insert(0) += 1;
            }
        }
        assert_eq!(kinds.get("fake"), None, "{kinds:?}");
        assert_eq!(kinds.get("honest"), Some(&QUEUE_CAPACITY));
        assert_eq!(kinds.get("newcomer"), None);
        let sent = QUEUE_CAPACITY * 2 + honest + QUEUE_CAPACITY + 1;
        assert_eq!(refused as usize, sent - QUEUE_CAPACITY);
    }

    /// A robot over its rate is refused on the receive path, counted against it, and
    /// leaves the others' inputs alone.
    #[test]
    fn a_robot_over_its_rate_is_refused_before_it_is_queued() {
        let q = Queue {
            limit: Limit {
                rate_hz: 10.0,
                burst: 5.0,
            },
            ..Queue::default()
        };
        let input = |key: &str, at_s: f64| Input {
            kind: InputKind::Observation,
            key: key.to_string(),
            payload: vec![0; 10],
            received: Stamp((at_s * 1e9) as u64 + 1_000_000_000),
        };
        // One second: the flooder sends 100, the other 10.
        for k in 0..100 {
            q.push("flood", input("flood", k as f64 / 100.0));
            if k % 10 == 0 {
                q.push("calm", input("calm", k as f64 / 100.0));
            }
        }
        q.close();
        let (mut flood, mut calm, mut limited) = (0, 0, Vec::new());
        while let Some(w) = q.pop() {
            limited.extend(w.refused);
            match w.input.map(|i| i.key).as_deref() {
                Some("flood") => flood += 1,
                Some("calm") => calm += 1,
                _ => {}
            }
        }
        // The burst of 5 and about 10 a second after it.
        assert!((14..=16).contains(&flood), "{flood}");
        assert_eq!(calm, 10);
        assert_eq!(
            limited,
            vec![(
                InputKind::Observation,
                "rate_limited",
                Some("flood".to_string()),
                100 - flood
            )]
        );
    }
}
