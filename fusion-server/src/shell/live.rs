//! The live server's shared state: the engine behind a lock, the clock, the counters, the
//! live stream and the match log. Zenoh callbacks, the publisher task and HTTP handlers all
//! go through here; nothing in it blocks on the network, and nothing in it publishes: the
//! publisher task (`shell::serve`) asks for a [`Publication`] and sends it. Each state is
//! serialised once: the wire payload and the view, which the live stream and
//! `GET /api/state` share.

use crate::clock::Clock;
use crate::engine::{Engine, EngineEvent, RecentObs, RobotView};
use crate::matchlog::{LogKind, MatchLog};
use crate::query::{BallQuery, QueryError, QueryReply};
use crate::scene::{Scene, SceneRecord};
use crate::shell::foxglove_hub::FoxgloveHub;
use crate::shell::history::BallHistory;
use crate::shell::metrics::ShellStats;
use crate::shell::replay_control::{ReplayControl, ReplayStatus};
use crate::shell::views::ViewHub;
use proto::{BallState, KeySpace, Pitch, Stamp};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Debug;
use std::sync::atomic::Ordering::Relaxed;
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};
use tokio::sync::broadcast;

/// The body of `GET /api/state` and of each live-stream frame.
#[derive(Debug, Clone, Serialize)]
pub struct StateView<'a> {
    /// Server clock when the view was taken.
    pub stamp: Stamp,
    pub ball: Option<BallState>,
    pub robots: Vec<RobotView>,
    pub pitch: &'a Pitch,
    /// Observations received in the last [`RECENT_WINDOW_S`] seconds, accepted or
    /// rejected with the reason, oldest first.
    pub observations: Vec<RecentObs>,
    /// Rejected inputs so far, by `kind/reason`.
    pub rejected: BTreeMap<String, u64>,
    /// Where the replay stands, when the server replays a match log.
    pub replay: Option<ReplayStatus>,
    /// How the match log's recording stands, when the server records one.
    pub recording: Option<crate::matchlog::record::RecordingHealth>,
}

/// The kind a scene message is logged as.
fn scene_kind(r: &SceneRecord) -> LogKind {
    if r.schema == crate::scene::TRANSFORMS_SCHEMA {
        LogKind::Transforms
    } else {
        LogKind::Scene
    }
}

/// How far back the view's observations go.
pub const RECENT_WINDOW_S: f64 = 2.0;

/// Who may use the control endpoints (`POST /api/replay/…`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum ControlAccess {
    /// Requests from this machine only (loopback addresses).
    #[default]
    LoopbackOnly,
    /// Requests with `Authorization: Bearer TOKEN`, from anywhere.
    Token(String),
}

/// One state to publish: the wire payload (none before the ball is first seen) and, on
/// the regular ticks, the view the live stream and `GET /api/state` serve.
#[derive(Debug, Clone, Default)]
pub struct Publication {
    pub payload: Option<Vec<u8>>,
    pub view: Option<Arc<str>>,
}

#[derive(Debug)]
struct Inner {
    engine: Engine,
    /// Arrival stamps of observations applied since the last published state.
    unpublished: Vec<Stamp>,
    /// When the match is next drawn for the log and Foxglove.
    scene: Scene,
}

/// Rejections are logged at most this often, all reasons together (they are always
/// counted, by reason, in the metrics).
const REJECT_LOG_EVERY: Duration = Duration::from_secs(5);
/// At most this many engine events (clock corrections and jumps, robots evicted) are
/// logged a second; the rest are counted in /metrics only (a flood's events would
/// otherwise cost more than the fusion).
const EVENT_LOGS_PER_S: u32 = 10;

#[derive(Debug)]
pub struct Live {
    inner: Mutex<Inner>,
    pub keys: KeySpace,
    /// `{prefix}/ball/state`, the topic states are logged under.
    state_key: String,
    pub clock: Arc<dyn Clock>,
    pub stats: ShellStats,
    /// One frame per published state; slow readers lose the oldest frames.
    pub stream: broadcast::Sender<Arc<str>>,
    /// Publish a state right after accepted observations (the publisher task is woken).
    pub publish_on_update: bool,
    /// Wakes the publisher task after an accepted observation, with `publish_on_update`.
    pub updated: tokio::sync::Notify,

    /// The last published view and when it was made; served while younger than
    /// `view_max_age`.
    last_view: Mutex<Option<(Instant, Arc<str>)>>,
    view_max_age: OnceLock<Duration>,
    log: Option<Arc<dyn MatchLog>>,
    last_reject_log: Mutex<Option<Instant>>,
    /// The second the event lines are counted in, and how many were logged in it.
    event_logs: Mutex<(Option<Instant>, u32)>,
    /// The replay's control, when the server replays a match log.
    replay: OnceLock<Arc<ReplayControl>>,
    control_access: OnceLock<ControlAccess>,
    ws_send_timeout: OnceLock<Duration>,
    /// The Foxglove WebSocket's channels and queue, when it is served.
    foxglove: OnceLock<Arc<FoxgloveHub>>,
    /// The robots' camera views.
    pub views: ViewHub,
    /// The ball over the last half minute, for a page that opens.
    history: Mutex<BallHistory>,
}

impl Live {
    pub fn new(
        engine: Engine,
        keys: KeySpace,
        clock: Arc<dyn Clock>,
        stream_buffer: usize,
        publish_on_update: bool,
        log: Option<Arc<dyn MatchLog>>,
    ) -> Self {
        let (stream, _) = broadcast::channel(stream_buffer.max(1));
        let keys_for_views = keys.clone();
        Live {
            inner: Mutex::new(Inner {
                engine,
                unpublished: Vec::new(),
                scene: Scene::new(),
            }),
            state_key: keys.ball_state(),
            keys,
            clock,
            stats: ShellStats::default(),
            stream,
            publish_on_update,
            updated: tokio::sync::Notify::new(),

            last_view: Mutex::new(None),
            view_max_age: OnceLock::new(),
            log,
            last_reject_log: Mutex::new(None),
            event_logs: Mutex::new((None, 0)),
            replay: OnceLock::new(),
            control_access: OnceLock::new(),
            ws_send_timeout: OnceLock::new(),
            foxglove: OnceLock::new(),
            views: ViewHub::new(keys_for_views),
            history: Mutex::new(BallHistory::default()),
        }
    }

    /// Starts handing messages to Foxglove clients (once; `shell::foxglove`).
    pub fn enable_foxglove(&self, name: &str) -> Arc<FoxgloveHub> {
        self.foxglove
            .get_or_init(|| Arc::new(FoxgloveHub::new(name)))
            .clone()
    }

    pub fn foxglove(&self) -> Option<Arc<FoxgloveHub>> {
        self.foxglove.get().cloned()
    }

    /// Hands the replay's control over (once): the control endpoints and the stream's
    /// `replay` field come alive.
    pub fn set_replay(&self, control: Arc<ReplayControl>) {
        if self.replay.set(control).is_err() {
            tracing::warn!("the replay control was already set");
        }
    }

    /// `GET /api/state` serves the last published view while it is younger than `age`
    /// (set once, by the publisher task, to a little more than its tick).
    pub fn set_view_max_age(&self, age: Duration) {
        let _ = self.view_max_age.set(age);
    }

    /// Whether this server publishes the ball (see `shell::standby`).
    pub fn is_active(&self) -> bool {
        !self.stats.standby.load(Relaxed)
    }

    pub fn set_active(&self, active: bool) {
        self.stats.standby.store(!active, Relaxed);
    }

    pub fn replay(&self) -> Option<&Arc<ReplayControl>> {
        self.replay.get()
    }

    /// Sets who may use the control endpoints (once; loopback only unless set).
    pub fn set_control_access(&self, access: ControlAccess) {
        if self.control_access.set(access).is_err() {
            tracing::warn!("the control access was already set");
        }
    }

    /// Sets how long a live-stream frame may take to send before its client is dropped
    /// (once; 5 s unless set).
    pub fn set_ws_send_timeout(&self, limit: Duration) {
        if self.ws_send_timeout.set(limit).is_err() {
            tracing::warn!("the stream's send timeout was already set");
        }
    }

    pub fn ws_send_timeout(&self) -> Duration {
        self.ws_send_timeout
            .get()
            .copied()
            .unwrap_or(Duration::from_secs(5))
    }

    pub fn control_access(&self) -> &ControlAccess {
        static DEFAULT: ControlAccess = ControlAccess::LoopbackOnly;
        self.control_access.get().unwrap_or(&DEFAULT)
    }

    /// Replaces the engine (a replay moved in time), keeping which robots are online: that
    /// follows their liveliness tokens, not the log.
    pub fn replace_engine(&self, mut engine: Engine) {
        let now = self.clock.now();
        let mut inner = self.lock();
        for id in inner.engine.online_robots() {
            engine.liveliness(&id, true, now).ok();
        }
        inner.engine = engine;
        inner.unpublished.clear();
    }

    fn view<'a>(&self, inner: &'a Inner, now: Stamp, ball: Option<BallState>) -> StateView<'a> {
        StateView {
            stamp: now,
            ball,
            robots: inner.engine.robots(now),
            pitch: inner.engine.pitch(),
            observations: inner.engine.recent_observations(now, RECENT_WINDOW_S),
            rejected: inner.engine.rejected_by_reason(),
            replay: self.replay.get().map(|r| r.status()),
            recording: self.log.as_ref().and_then(|l| l.health()),
        }
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panic elsewhere must not take the server down with it: the engine is still usable.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Runs `f` on the engine under the lock.
    pub fn with_engine<T>(&self, f: impl FnOnce(&Engine) -> T) -> T {
        f(&self.lock().engine)
    }

    /// Logs an engine event, at most [`EVENT_LOGS_PER_S`] a second.
    fn log_event(&self, e: &EngineEvent) {
        let mut budget = self.event_logs.lock().unwrap_or_else(|p| p.into_inner());
        let (since, used) = &mut *budget;
        if since.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) {
            (*since, *used) = (Some(Instant::now()), 0);
        }
        *used += 1;
        if *used > EVENT_LOGS_PER_S {
            if *used == EVENT_LOGS_PER_S + 1 {
                tracing::warn!("more robot events this second: counted in /metrics, not logged");
            }
            return;
        }
        match e {
            EngineEvent::ClockCorrected {
                correction_s: 0.0, ..
            } => tracing::info!("{e}"),
            _ => tracing::warn!("{e}"),
        }
    }

    fn log_rejection(&self, what: &str, key: &str, e: &dyn std::fmt::Display) {
        let mut last = self
            .last_reject_log
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if last.is_none_or(|t| t.elapsed() >= REJECT_LOG_EVERY) {
            *last = Some(Instant::now());
            tracing::warn!(
                "rejected {what} on {key}: {e} (further rejections are counted in /metrics)"
            );
        }
    }

    /// The robot chunk of a robot's key as it came (the whole key when it is not under
    /// `{prefix}/robots/`, which the engine then refuses as not an id).
    fn key_robot<'k>(&self, key: &'k str) -> Option<&'k str> {
        Some(self.keys.robot_chunk_of(key).unwrap_or(key))
    }

    /// Hands an accepted input to the match log and the Foxglove clients. A rejected one is
    /// only counted: whoever sends junk must not be able to fill the disk with it.
    fn record(&self, kind: LogKind, key: &str, now: Stamp, payload: &[u8], accepted: bool) {
        if accepted && let Some(hub) = self.foxglove.get() {
            hub.publish(kind, key, now, payload);
        }
        let Some(log) = &self.log else { return };
        if accepted {
            log.log(kind, key, now, payload);
        } else {
            self.stats.record_skipped_rejected.fetch_add(1, Relaxed);
        }
    }

    /// Counts a rejection decided in the shell (an oversized query), with the engine's.
    pub fn count_rejection(&self, kind: &'static str, reason: &'static str) {
        self.lock().engine.count_rejection(kind, reason);
    }

    /// Counts `n` inputs of `robot` (when known) refused in the shell for one reason before
    /// the engine saw them (oversized, over the robot's rate, or the intake queue full):
    /// rejections, and inputs left out of the match log.
    pub fn count_refused_inputs(
        &self,
        kind: &'static str,
        reason: &'static str,
        robot: Option<&str>,
        n: u64,
    ) {
        self.stats.inputs_received.fetch_add(n, Relaxed);
        if self.log.is_some() {
            self.stats.record_skipped_rejected.fetch_add(n, Relaxed);
        }
        self.lock().engine.count_rejections(kind, reason, robot, n);
    }

    /// An observation payload arrived on `key` just now.
    pub fn on_observation(&self, key: &str, payload: &[u8]) {
        self.on_observation_at(key, payload, self.clock.now());
    }

    /// An observation payload that arrived on `key` at `now` (the clock read when it was
    /// received, before any queue or lock: a backlog must not make it look late).
    /// Says whether it was accepted.
    pub fn on_observation_at(&self, key: &str, payload: &[u8], now: Stamp) -> bool {
        self.stats.inputs_received.fetch_add(1, Relaxed);
        let robot = self.key_robot(key);
        let mut inner = self.lock();
        let result = inner.engine.observation(robot, payload, now);
        self.record(LogKind::Observation, key, now, payload, result.is_ok());
        for e in inner.engine.take_events() {
            self.log_event(&e);
        }
        match result {
            Ok(_) => {
                inner.unpublished.push(now);
                drop(inner);
                if self.publish_on_update {
                    self.updated.notify_one();
                }
                true
            }
            Err(e) => {
                drop(inner);
                self.log_rejection("observation", key, &e);
                false
            }
        }
    }

    /// A status payload arrived on `key` just now.
    pub fn on_status(&self, key: &str, payload: &[u8]) {
        self.on_status_at(key, payload, self.clock.now());
    }

    /// A status payload that arrived on `key` at `now`.
    /// Says whether it was accepted.
    pub fn on_status_at(&self, key: &str, payload: &[u8], now: Stamp) -> bool {
        self.stats.inputs_received.fetch_add(1, Relaxed);
        let robot = self.key_robot(key);
        let mut inner = self.lock();
        let result = inner.engine.status(robot, payload, now);
        self.record(LogKind::Status, key, now, payload, result.is_ok());
        drop(inner);
        match result {
            Ok(_) => true,
            Err(e) => {
                self.log_rejection("status", key, &e);
                false
            }
        }
    }

    /// A camera view payload arrived on `key` just now; whether it was kept.
    pub fn on_view(&self, key: &str, payload: &[u8]) -> bool {
        let now = self.clock.now();
        self.views
            .on_view(key, payload, now, self.log.as_ref(), self.foxglove.get())
    }

    /// A robot liveliness token under `key` appeared or went away.
    pub fn on_liveliness(&self, key: &str, alive: bool) {
        // A chunk that is not an id is refused and counted by the engine.
        let robot = self.keys.robot_chunk_of(key).unwrap_or(key);
        let now = self.clock.now();
        let result = self.lock().engine.liveliness(robot, alive, now);
        match result {
            Ok(()) => tracing::info!(
                "robot {robot} is {}",
                if alive { "online" } else { "offline" }
            ),
            Err(e) => self.log_rejection("liveliness", key, &e),
        }
    }

    /// The state to publish now, serialised once: its wire payload (logged, and its
    /// observations' latency measured) and, when `with_view`, the view for the live stream
    /// and `GET /api/state`.
    pub fn publication(&self, with_view: bool) -> Publication {
        let mut inner = self.lock();
        let now = self.clock.now();
        let state = inner.engine.ball_state(now);
        let payload = state.as_ref().map(proto::encode);
        let arrivals = if payload.is_some() {
            std::mem::take(&mut inner.unpublished)
        } else {
            Vec::new()
        };
        // Logged under the lock: every input applied after this state is logged after it,
        // so a replay of the log recomputes exactly this state.
        if let (Some(p), Some(log)) = (&payload, &self.log) {
            log.log(LogKind::BallState, &self.state_key, now, p);
        }
        let hub = self.foxglove.get();
        // The scene only when someone keeps or watches it.
        let scene = if self.log.is_some() || hub.is_some_and(|h| h.watched()) {
            let Inner { engine, scene, .. } = &mut *inner;
            scene.tick(engine, now, state.as_ref())
        } else {
            Vec::new()
        };
        if let Some(log) = &self.log {
            for r in &scene {
                log.log(scene_kind(r), r.topic, r.log_time, &r.payload);
            }
        }
        if let Ok(mut h) = self.history.lock() {
            h.push(now, state.as_ref());
        }
        // The view only for watchers: nobody else needs it made at every tick.
        let view = (with_view && self.stream.receiver_count() > 0).then(|| {
            let view = self.view(&inner, now, state);
            Arc::<str>::from(serde_json::to_string(&view).unwrap_or_default())
        });
        drop(inner);
        if let Some(hub) = hub {
            if let Some(p) = &payload {
                hub.publish(LogKind::BallState, &self.state_key, now, p);
            }
            for r in &scene {
                hub.publish(scene_kind(r), r.topic, r.log_time, &r.payload);
            }
        }
        if payload.is_some() {
            if let Ok(mut h) = self.stats.obs_to_state_s.lock() {
                for a in arrivals {
                    h.observe(now.secs_since(a));
                }
            }
            self.stats.states_published.fetch_add(1, Relaxed);
        }
        if let Some(v) = &view
            && let Ok(mut last) = self.last_view.lock()
        {
            *last = Some((Instant::now(), v.clone()));
        }
        Publication { payload, view }
    }

    /// Sends a frame to the live stream (never waits for readers).
    pub fn broadcast(&self, frame: Arc<str>) {
        // No receivers is not an error: nobody is watching.
        let _ = self.stream.send(frame);
    }

    /// The view `GET /api/state` serves: the last one made (for the live stream or for an
    /// earlier request) while it is fresh, less than about a tick old; else one taken now,
    /// kept for the requests that follow. However many ask, the view is serialised at most
    /// about once a tick.
    pub fn current_view(&self) -> Arc<str> {
        let Some(max_age) = self.view_max_age.get() else {
            return Arc::from(self.view_json());
        };
        let mut last = self.last_view.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((made, view)) = last.as_ref()
            && made.elapsed() <= *max_age
        {
            return view.clone();
        }
        let view: Arc<str> = Arc::from(self.view_json());
        *last = Some((Instant::now(), view.clone()));
        view
    }

    /// The view taken now.
    pub fn view_json(&self) -> String {
        let inner = self.lock();
        let now = self.clock.now();
        let view = self.view(&inner, now, inner.engine.ball_state(now));
        serde_json::to_string(&view).unwrap_or_default()
    }

    /// The ball over the last half minute of match time (`GET /api/history`).
    pub fn history_json(&self) -> String {
        let samples = self.history.lock().map(|h| h.samples()).unwrap_or_default();
        serde_json::json!({ "stamp": self.clock.now(), "samples": samples }).to_string()
    }

    pub fn robots_json(&self) -> String {
        let inner = self.lock();
        serde_json::to_string(&inner.engine.robots(self.clock.now())).unwrap_or_default()
    }

    /// Answers a query now, counting the outcome.
    pub fn query(&self, q: &BallQuery) -> Result<QueryReply, QueryError> {
        let r = {
            let inner = self.lock();
            inner.engine.query(q, self.clock.now())
        };
        let counter = if r.is_ok() {
            &self.stats.queries_answered
        } else {
            &self.stats.queries_failed
        };
        counter.fetch_add(1, Relaxed);
        r
    }

    /// Prometheus text exposition.
    pub fn metrics_text(&self) -> String {
        if let Some(log) = &self.log {
            let (written, dropped) = log.counts();
            self.stats.recorded.store(written, Relaxed);
            self.stats.record_dropped.store(dropped, Relaxed);
            self.stats
                .record_queue_bytes
                .store(log.queued_bytes(), Relaxed);
            *self
                .stats
                .recording
                .lock()
                .unwrap_or_else(|p| p.into_inner()) = log.health();
        }
        let views = self.views.counts();
        let inner = self.lock();
        crate::shell::metrics::render(&inner.engine, &self.stats, &views, self.clock.now())
    }
}
