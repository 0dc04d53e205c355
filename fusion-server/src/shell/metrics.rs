//! The server's counters and their exposition in the OpenMetrics text format, encoded by
//! `prometheus-client`: at each scrape a [`Snapshot`] of the engine's and the shell's
//! counters is taken and handed to the encoder as a collector.

use crate::engine::Engine;
use crate::shell::views::ViewCounts;
use prometheus_client::collector::Collector;
use prometheus_client::encoding::{
    DescriptorEncoder, EncodeMetric, MetricEncoder, NoLabelSet, text::encode,
};
use prometheus_client::metrics::MetricType;
use prometheus_client::metrics::counter::ConstCounter;
use prometheus_client::metrics::gauge::ConstGauge;
use prometheus_client::registry::Registry;
use proto::Stamp;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Upper bounds of the latency histogram buckets (seconds).
pub const LATENCY_BUCKETS_S: [f64; 12] = [
    1e-4, 2.5e-4, 5e-4, 1e-3, 2.5e-3, 5e-3, 0.01, 0.025, 0.05, 0.1, 0.25, 1.0,
];

/// A fixed-bucket histogram, Prometheus style (cumulative on output).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Histogram {
    counts: [u64; LATENCY_BUCKETS_S.len()],
    count: u64,
    sum: f64,
}

impl Histogram {
    pub fn observe(&mut self, v: f64) {
        if !v.is_finite() {
            return;
        }
        if let Some(i) = LATENCY_BUCKETS_S.iter().position(|b| v <= *b) {
            self.counts[i] += 1;
        }
        self.count += 1;
        self.sum += v;
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    /// The smallest bucket bound below which at least `q` of the samples fall.
    pub fn quantile_bound(&self, q: f64) -> Option<f64> {
        let need = (q * self.count as f64).ceil() as u64;
        let mut seen = 0;
        for (c, b) in self.counts.iter().zip(LATENCY_BUCKETS_S) {
            seen += c;
            if seen >= need && self.count > 0 {
                return Some(b);
            }
        }
        None
    }
}

impl EncodeMetric for Histogram {
    fn encode(&self, mut encoder: MetricEncoder) -> Result<(), std::fmt::Error> {
        // Per-bucket counts (the encoder sums them), the overflow in +Inf.
        let within: u64 = self.counts.iter().sum();
        let buckets: Vec<(f64, u64)> = LATENCY_BUCKETS_S
            .iter()
            .copied()
            .zip(self.counts.iter().copied())
            .chain(std::iter::once((f64::MAX, self.count - within)))
            .collect();
        encoder.encode_histogram::<NoLabelSet>(self.sum, self.count, &buckets, None)
    }

    fn metric_type(&self) -> MetricType {
        MetricType::Histogram
    }
}

/// What the I/O shell counts (the engine counts what it decides).
#[derive(Debug, Default)]
pub struct ShellStats {
    /// Observation and status payloads that arrived (whatever became of them).
    pub inputs_received: AtomicU64,
    /// Inputs waiting in the intake queue for the engine.
    pub intake_queued: AtomicU64,
    pub states_published: AtomicU64,
    pub ws_clients: AtomicU64,
    pub ws_frames_sent: AtomicU64,
    /// Frames a slow WebSocket client never got because newer ones replaced them.
    pub ws_frames_dropped: AtomicU64,
    pub queries_answered: AtomicU64,
    pub queries_failed: AtomicU64,
    pub recorded: AtomicU64,
    pub record_dropped: AtomicU64,
    /// Payload bytes waiting in the match log's queue.
    pub record_queue_bytes: AtomicU64,
    /// Rejected inputs left out of the match log.
    pub record_skipped_rejected: AtomicU64,
    /// How the match log's recording stood when /metrics was last asked.
    pub recording: Mutex<Option<crate::matchlog::record::RecordingHealth>>,
    /// Seconds from an observation's arrival to the publication of a state that includes it.
    pub obs_to_state_s: Mutex<Histogram>,
    /// This server stands by: a live server of its prefix has a smaller id and publishes
    /// the ball (see `shell::standby`).
    pub standby: std::sync::atomic::AtomicBool,
    /// Live-stream clients dropped because a frame could not be sent in time.
    pub ws_send_timeouts: AtomicU64,
    /// Foxglove WebSocket clients connected, messages sent, skipped (a client behind),
    /// clients dropped for a send that took too long, refused (too many), bad requests.
    pub foxglove_clients: AtomicU64,
    pub foxglove_sent: AtomicU64,
    pub foxglove_dropped: AtomicU64,
    pub foxglove_send_timeouts: AtomicU64,
    pub foxglove_refused: AtomicU64,
    pub foxglove_bad_requests: AtomicU64,
    /// The HTTP listener's connections and deadlines.
    pub http: std::sync::Arc<crate::shell::http::guard::GuardStats>,
}

impl ShellStats {
    pub fn latency(&self) -> Histogram {
        self.obs_to_state_s
            .lock()
            .map(|h| h.clone())
            .unwrap_or_default()
    }
}

/// One metric family's description. Counters are named without the `_total` that the
/// encoder adds to their samples.
#[derive(Debug, Clone, Copy)]
struct Family {
    name: &'static str,
    counter: bool,
    help: &'static str,
}

impl Family {
    fn new(name: &'static str, kind: &str, help: &'static str) -> Family {
        let counter = kind == "counter";
        let name = if counter {
            name.strip_suffix("_total").unwrap_or(name)
        } else {
            name
        };
        Family {
            name,
            counter,
            help,
        }
    }

    fn metric_type(&self) -> MetricType {
        if self.counter {
            MetricType::Counter
        } else {
            MetricType::Gauge
        }
    }

    /// One sample of the family into `encoder`.
    fn sample(&self, encoder: MetricEncoder, v: Value) -> Result<(), std::fmt::Error> {
        match (self.counter, v) {
            (true, Value::Count(n)) => ConstCounter::new(n).encode(encoder),
            (true, Value::Real(x)) => ConstCounter::new(x).encode(encoder),
            (false, Value::Count(n)) => {
                ConstGauge::new(i64::try_from(n).unwrap_or(i64::MAX)).encode(encoder)
            }
            (false, Value::Real(x)) => ConstGauge::new(x).encode(encoder),
        }
    }
}

/// A sample's value: counts are written as integers.
#[derive(Debug, Clone, Copy)]
enum Value {
    Count(u64),
    Real(f64),
}

/// What one scrape shows: the counters and gauges read at `now`.
#[derive(Debug)]
struct Snapshot {
    simple: Vec<(Family, Value)>,
    rejected: Vec<((String, String), u64)>,
    per_robot: Vec<(Family, Vec<(String, Value)>)>,
    /// The match log's recording, when the server records one.
    recording: Option<crate::matchlog::record::RecordingHealth>,
    active: Value,
    clock_suspect: Value,
    latency: Histogram,
}

impl Collector for Snapshot {
    fn encode(&self, mut encoder: DescriptorEncoder) -> Result<(), std::fmt::Error> {
        for (f, v) in &self.simple {
            f.sample(
                encoder.encode_descriptor(f.name, f.help, None, f.metric_type())?,
                *v,
            )?;
        }
        let rejected = Family::new(
            "rf_messages_rejected_total",
            "counter",
            "Inbound messages rejected, by message kind and reason.",
        );
        let mut family =
            encoder.encode_descriptor(rejected.name, rejected.help, None, MetricType::Counter)?;
        for ((kind, reason), n) in &self.rejected {
            let labels = [("kind", kind.as_str()), ("reason", reason.as_str())];
            ConstCounter::new(*n).encode(family.encode_family(&labels)?)?;
        }
        for (f, rows) in &self.per_robot {
            let mut family = encoder.encode_descriptor(f.name, f.help, None, f.metric_type())?;
            for (robot, v) in rows {
                f.sample(family.encode_family(&[("robot", robot.as_str())])?, *v)?;
            }
        }
        let active = Family::new(
            "rf_server_active",
            "gauge",
            "1 while this server publishes the ball; 0 while it stands by for a server of the same prefix with a smaller id.",
        );
        let suspect = Family::new(
            "rf_robots_clock_suspect",
            "gauge",
            "Robots whose estimated clock offset exceeds the warning threshold.",
        );
        if let Some(r) = &self.recording {
            let errors = Family::new(
                "rf_record_errors_total",
                "counter",
                "Writes and flushes of the match log that failed, by cause (disk_full, permission, io): each stops the recording until a new file can be written.",
            );
            let mut family =
                encoder.encode_descriptor(errors.name, errors.help, None, MetricType::Counter)?;
            for (cause, n) in &r.errors {
                ConstCounter::new(*n).encode(family.encode_family(&[("cause", *cause)])?)?;
            }
            for (f, v) in [
                (
                    Family::new(
                        "rf_record_stopped",
                        "gauge",
                        "1 while a failing file or disk keeps the match log from recording (the server serves on; recording resumes into a new file when writes succeed).",
                    ),
                    u64::from(r.stopped),
                ),
                (
                    Family::new(
                        "rf_record_failed_total",
                        "counter",
                        "Messages the match log's writer could not write: while the recording was stopped, in a failed write, or refused for themselves.",
                    ),
                    r.failed,
                ),
                (
                    Family::new(
                        "rf_record_resumed_total",
                        "counter",
                        "Times the match log resumed into a new file after it had stopped.",
                    ),
                    r.resumed,
                ),
            ] {
                f.sample(
                    encoder.encode_descriptor(f.name, f.help, None, f.metric_type())?,
                    Value::Count(v),
                )?;
            }
        }
        for (f, v) in [(active, self.active), (suspect, self.clock_suspect)] {
            f.sample(
                encoder.encode_descriptor(f.name, f.help, None, f.metric_type())?,
                v,
            )?;
        }
        self.latency.encode(encoder.encode_descriptor(
            "rf_obs_to_state_latency_seconds",
            "From an observation's arrival to the publication of a state that includes it.",
            None,
            MetricType::Histogram,
        )?)
    }
}

/// The OpenMetrics text exposition of the engine's and the shell's counters at `now`.
pub fn render(engine: &Engine, shell: &ShellStats, views: &ViewCounts, now: Stamp) -> String {
    let mut registry = Registry::default();
    registry.register_collector(Box::new(snapshot(engine, shell, now)));
    registry.register_collector(Box::new(views_snapshot(engine, views, now)));
    let mut out = String::with_capacity(8192);
    // Writing into a String cannot fail.
    let _ = encode(&mut out, &registry);
    out
}

fn snapshot(engine: &Engine, shell: &ShellStats, now: Stamp) -> Snapshot {
    let c = engine.counters();
    let core = engine.fusion().counters();
    let h = &shell.http;
    let simple: [(&str, &str, &str, u64); 39] = [
        (
            "rf_inputs_received_total",
            "counter",
            "Observation and status payloads that arrived, whatever became of them (each is then accepted or rejected).",
            shell.inputs_received.load(Relaxed),
        ),
        (
            "rf_observations_accepted_total",
            "counter",
            "Observations used by the fusion.",
            c.observations_accepted,
        ),
        (
            "rf_statuses_accepted_total",
            "counter",
            "Robot status messages accepted.",
            c.statuses_accepted,
        ),
        (
            "rf_observations_clock_corrected_total",
            "counter",
            "Accepted observations whose capture stamps were corrected by their robot's estimated clock offset.",
            c.observations_clock_corrected,
        ),
        (
            "rf_robots_evicted_total",
            "counter",
            "Robots not yet established forgotten to make room for a newcomer, the robot table being full.",
            c.robots_evicted,
        ),
        (
            "rf_clock_jumps_total",
            "counter",
            "Robot clock jumps caught (the robot's offset estimate restarted).",
            c.clock_jumps,
        ),
        (
            "rf_observations_reordered_total",
            "counter",
            "Observations that arrived out of capture order and were slotted in.",
            core.reordered,
        ),
        (
            "rf_observations_outside_walls_total",
            "counter",
            "Accepted observations beyond a wall, ignored by the tracker.",
            core.outside_walls,
        ),
        (
            "rf_observations_held_total",
            "counter",
            "Observations that went to hypotheses other than the estimate (awaiting promotion, or phantoms).",
            core.held_in_hypotheses,
        ),
        (
            "rf_kicks_inferred_total",
            "counter",
            "Kicks of the ball estimate inferred from runs of surprising sightings.",
            core.kicks_inferred,
        ),
        (
            "rf_bounces_seen_total",
            "counter",
            "Wall bounces the ball estimate went through: foreseen by its flight, or found at a wall where surprising sightings would otherwise have been a kick.",
            core.bounces_seen,
        ),
        (
            "rf_misses_in_view_total",
            "counter",
            "Frames whose camera footprint held a ball hypothesis the frame did not see (negative information).",
            core.misses_in_view,
        ),
        (
            "rf_footprints_rejected_total",
            "counter",
            "Camera footprints of robot statuses refused (fewer than 3 corners, no area, beyond reach, the whole pitch).",
            core.footprints_rejected,
        ),
        (
            "rf_robot_slots_reused_total",
            "counter",
            "New robot ids that took the fusion's place of one quiet for 30 s, its table of 1024 being full (a flood of made-up ids).",
            core.robot_slots_reused,
        ),
        (
            "rf_forecasts_scored_total",
            "counter",
            "Points of the ball estimate's own forecasts scored against the sightings that came when they were due (the path's covariance is calibrated on them).",
            core.forecasts_scored,
        ),
        (
            "rf_forecasts_outside_95_total",
            "counter",
            "Scored forecast points whose sighting fell outside the served 95 % region (about 5 % of rf_forecasts_scored_total when the path's covariance is honest).",
            core.forecasts_outside_95,
        ),
        (
            "rf_intake_queued",
            "gauge",
            "Observations and statuses received and waiting for the fusion (bounded; the oldest are dropped as queue_full).",
            shell.intake_queued.load(Relaxed),
        ),
        (
            "rf_states_published_total",
            "counter",
            "Ball states published.",
            shell.states_published.load(Relaxed),
        ),
        (
            "rf_ws_clients",
            "gauge",
            "Connected WebSocket stream clients.",
            shell.ws_clients.load(Relaxed),
        ),
        (
            "rf_ws_frames_sent_total",
            "counter",
            "Frames sent to WebSocket clients.",
            shell.ws_frames_sent.load(Relaxed),
        ),
        (
            "rf_ws_frames_dropped_total",
            "counter",
            "Frames skipped for slow WebSocket clients.",
            shell.ws_frames_dropped.load(Relaxed),
        ),
        (
            "rf_ws_send_timeouts_total",
            "counter",
            "WebSocket clients dropped because a frame could not be sent in time (the frames they missed count as dropped).",
            shell.ws_send_timeouts.load(Relaxed),
        ),
        (
            "rf_foxglove_clients",
            "gauge",
            "Connected Foxglove WebSocket clients (serve --foxglove).",
            shell.foxglove_clients.load(Relaxed),
        ),
        (
            "rf_foxglove_messages_sent_total",
            "counter",
            "Messages sent to Foxglove WebSocket clients.",
            shell.foxglove_sent.load(Relaxed),
        ),
        (
            "rf_foxglove_messages_dropped_total",
            "counter",
            "Messages Foxglove WebSocket clients skipped, having fallen behind the bounded queue.",
            shell.foxglove_dropped.load(Relaxed),
        ),
        (
            "rf_foxglove_send_timeouts_total",
            "counter",
            "Foxglove WebSocket clients dropped because a message could not be sent in time.",
            shell.foxglove_send_timeouts.load(Relaxed),
        ),
        (
            "rf_foxglove_clients_refused_total",
            "counter",
            "Foxglove WebSocket connections refused because the most clients were connected.",
            shell.foxglove_refused.load(Relaxed),
        ),
        (
            "rf_foxglove_bad_requests_total",
            "counter",
            "Requests from Foxglove WebSocket clients that could not be read.",
            shell.foxglove_bad_requests.load(Relaxed),
        ),
        (
            "rf_http_connections",
            "gauge",
            "Open HTTP connections (WebSocket streams included).",
            h.open.load(Relaxed),
        ),
        (
            "rf_http_connections_refused_total",
            "counter",
            "HTTP connections closed at once because the connection cap was reached.",
            h.refused.load(Relaxed),
        ),
        (
            "rf_http_idle_evicted_total",
            "counter",
            "Idle HTTP connections closed to make room for a new one, the connection cap being reached.",
            h.idle_evicted.load(Relaxed),
        ),
        (
            "rf_http_request_timeouts_total",
            "counter",
            "HTTP connections closed because a request was not complete in time.",
            h.request_timeouts.load(Relaxed),
        ),
        (
            "rf_http_idle_timeouts_total",
            "counter",
            "HTTP connections closed because nothing moved on them for the idle timeout.",
            h.idle_timeouts.load(Relaxed),
        ),
        (
            "rf_queries_answered_total",
            "counter",
            "Prediction and intercept queries answered.",
            shell.queries_answered.load(Relaxed),
        ),
        (
            "rf_queries_failed_total",
            "counter",
            "Queries answered with an error.",
            shell.queries_failed.load(Relaxed),
        ),
        (
            "rf_record_messages_total",
            "counter",
            "Messages written to the match log.",
            shell.recorded.load(Relaxed),
        ),
        (
            "rf_record_dropped_total",
            "counter",
            "Messages the match log could not keep up with.",
            shell.record_dropped.load(Relaxed),
        ),
        (
            "rf_record_queue_bytes",
            "gauge",
            "Payload bytes waiting in the match log's queue (bounded; beyond it records are dropped).",
            shell.record_queue_bytes.load(Relaxed),
        ),
        (
            "rf_record_skipped_rejected_total",
            "counter",
            "Rejected inputs left out of the match log (they are counted by reason instead).",
            shell.record_skipped_rejected.load(Relaxed),
        ),
    ];
    let simple = simple
        .into_iter()
        .map(|(name, kind, help, v)| (Family::new(name, kind, help), Value::Count(v)))
        .collect();
    let rejected = c
        .rejected
        .iter()
        .map(|((kind, reason), n)| ((kind.to_string(), reason.to_string()), *n))
        .collect();

    let robots = engine.robots(now);
    let per_robot: [(&str, &str, &str); 7] = [
        (
            "rf_robot_online",
            "gauge",
            "1 while the robot's liveliness token is present.",
        ),
        (
            "rf_robot_obs_rate_hz",
            "gauge",
            "Observations per second accepted from the robot.",
        ),
        (
            "rf_robot_observations_rejected_total",
            "counter",
            "Observations from the robot that were rejected.",
        ),
        (
            "rf_robot_covariance_scale",
            "gauge",
            "Factor applied to the covariance the robot reports (1 = honest).",
        ),
        (
            "rf_robot_outlier_rate",
            "gauge",
            "Share of the robot's reports the others did not confirm.",
        ),
        (
            "rf_robot_clock_offset_seconds",
            "gauge",
            "Estimated server clock minus the robot's clock (smallest recent arrival minus capture, less the robots' common latency floor).",
        ),
        (
            "rf_robot_clock_correction_seconds",
            "gauge",
            "Seconds added to the robot's capture stamps before they are fused (0: not corrected).",
        ),
    ];
    let per_robot = per_robot
        .iter()
        .enumerate()
        .map(|(k, (name, kind, help))| {
            let rows = robots
                .iter()
                .filter_map(|r| {
                    let v = match k {
                        0 => Some(Value::Count(u64::from(r.online))),
                        1 => Some(Value::Real(r.obs_rate_hz)),
                        2 => Some(Value::Count(r.observations_rejected)),
                        3 => r.covariance_scale.map(Value::Real),
                        4 => r.outlier_rate.map(Value::Real),
                        5 => r.clock_offset_s.map(Value::Real),
                        _ => r.clock_offset_s.map(|_| Value::Real(r.clock_correction_s)),
                    };
                    v.map(|v| (r.robot_id.clone(), v))
                })
                .collect();
            (Family::new(name, kind, help), rows)
        })
        .collect();
    let recording = shell
        .recording
        .lock()
        .map(|r| r.clone())
        .unwrap_or_default();
    Snapshot {
        simple,
        rejected,
        per_robot,
        recording,
        active: Value::Count(u64::from(!shell.standby.load(Relaxed))),
        clock_suspect: Value::Count(robots.iter().filter(|r| r.clock_suspect).count() as u64),
        latency: shell.latency(),
    }
}

/// The camera views and each robot camera's perception, as the robots report it.
#[derive(Debug)]
struct ViewsSnapshot {
    counts: ViewCounts,
    /// (robot, camera, the camera's counters).
    cameras: Vec<(String, &'static str, proto::CameraPerception)>,
}

fn views_snapshot(engine: &Engine, views: &ViewCounts, now: Stamp) -> ViewsSnapshot {
    let cameras = engine
        .robots(now)
        .into_iter()
        .filter_map(|r| r.status.map(|s| (r.robot_id, s.cameras)))
        .flat_map(|(robot, cams)| {
            cams.into_iter()
                .map(move |c| (robot.clone(), proto::camera_chunk(c.camera), c))
        })
        .collect();
    ViewsSnapshot {
        counts: views.clone(),
        cameras,
    }
}

impl Collector for ViewsSnapshot {
    fn encode(&self, mut encoder: DescriptorEncoder) -> Result<(), std::fmt::Error> {
        let c = &self.counts;
        for (name, kind, help, v) in [
            (
                "rf_camera_views_received_total",
                "counter",
                "Camera views kept (the newest of each camera is served to the page).",
                c.accepted,
            ),
            (
                "rf_camera_views_kept",
                "gauge",
                "Cameras whose newest view the server holds.",
                c.kept,
            ),
        ] {
            let f = Family::new(name, kind, help);
            f.sample(
                encoder.encode_descriptor(f.name, f.help, None, f.metric_type())?,
                Value::Count(v),
            )?;
        }
        let refused = Family::new(
            "rf_camera_views_refused_total",
            "counter",
            "Camera views refused, by reason (too_large, bad_key, rate_limited, decode, wrong_robot, wrong_camera, stale, or a validation reason such as not_jpeg).",
        );
        let mut family =
            encoder.encode_descriptor(refused.name, refused.help, None, MetricType::Counter)?;
        for (reason, n) in &c.refused {
            ConstCounter::new(*n).encode(family.encode_family(&[("reason", *reason)])?)?;
        }
        type Pick = fn(&proto::CameraPerception) -> Value;
        let per_camera: [(&str, &str, &str, Pick); 7] = [
            (
                "rf_robot_camera_frames_total",
                "counter",
                "Frames the robot's camera pipeline processed, as the robot reports it.",
                |c| Value::Count(c.frames),
            ),
            (
                "rf_robot_camera_candidates_total",
                "counter",
                "Candidates the robot's classifier scored in the camera's frames.",
                |c| Value::Count(c.candidates),
            ),
            (
                "rf_robot_camera_balls_total",
                "counter",
                "Balls the robot published from the camera.",
                |c| Value::Count(c.balls),
            ),
            (
                "rf_robot_camera_frames_per_second",
                "gauge",
                "Frames a second over the robot's last status interval.",
                |c| Value::Real(c.frames_per_s),
            ),
            (
                "rf_robot_camera_candidates_per_frame",
                "gauge",
                "Candidates per frame over the robot's last status interval.",
                |c| Value::Real(c.candidates_per_frame),
            ),
            (
                "rf_robot_camera_balls_per_second",
                "gauge",
                "Balls published a second over the robot's last status interval.",
                |c| Value::Real(c.balls_per_s),
            ),
            (
                "rf_robot_camera_detector_seconds",
                "gauge",
                "The robot's median pipeline time per frame over its last status interval.",
                |c| Value::Real(c.detector_ms / 1000.0),
            ),
        ];
        for (name, kind, help, pick) in per_camera {
            let f = Family::new(name, kind, help);
            let mut family = encoder.encode_descriptor(f.name, f.help, None, f.metric_type())?;
            for (robot, camera, c) in &self.cameras {
                let labels = [("robot", robot.as_str()), ("camera", *camera)];
                f.sample(family.encode_family(&labels)?, pick(c))?;
            }
        }
        let f = Family::new(
            "rf_robot_camera_rejections_total",
            "counter",
            "Candidates the robot rejected in the camera's frames, by reason, as the robot reports it.",
        );
        let mut family = encoder.encode_descriptor(f.name, f.help, None, f.metric_type())?;
        for (robot, camera, c) in &self.cameras {
            for (reason, n) in &c.rejections {
                let labels = [
                    ("robot", robot.as_str()),
                    ("camera", *camera),
                    ("reason", reason.as_str()),
                ];
                ConstCounter::new(*n).encode(family.encode_family(&labels)?)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_buckets_and_quantiles() {
        let mut h = Histogram::default();
        for v in [5e-5, 3e-4, 3e-4, 2e-3, f64::NAN, 5.0] {
            h.observe(v);
        }
        assert_eq!(h.count(), 5);
        assert_eq!(h.quantile_bound(0.2), Some(1e-4));
        assert_eq!(h.quantile_bound(0.6), Some(5e-4));
        assert_eq!(h.quantile_bound(1.0), None, "5 s is beyond the last bucket");
        let mut registry = Registry::default();
        registry.register("x", "A histogram", h);
        let mut s = String::new();
        encode(&mut s, &registry).expect("a String takes any text");
        assert!(s.contains("x_bucket{le=\"0.0005\"} 3"), "{s}");
        assert!(s.contains("x_bucket{le=\"+Inf\"} 5"), "{s}");
        assert!(s.contains("x_count 5"), "{s}");
    }

    #[test]
    fn the_exposition_keeps_the_sample_names_and_is_openmetrics() {
        use crate::engine::EngineConfig;
        let engine = Engine::new(EngineConfig::default());
        let shell = ShellStats::default();
        shell.inputs_received.store(7, Relaxed);
        shell.ws_clients.store(2, Relaxed);
        let mut engine = engine;
        let now = Stamp(1_700_000_000_000_000_000);
        let status = proto::RobotStatus {
            version: proto::VERSION,
            robot_id: "miro1".into(),
            stamp: now,
            pose: proto::Pose2::default(),
            pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-3],
            head: proto::HeadJoints::default(),
            fps: 15.0,
            timings: vec![],
            footprints: vec![],
            cameras: vec![proto::CameraPerception {
                camera: proto::Camera::Right,
                frames: 40,
                candidates: 90,
                balls: 30,
                rejections: [("low_probability".to_string(), 55)].into_iter().collect(),
                frames_per_s: 15.0,
                candidates_per_frame: 2.25,
                balls_per_s: 11.0,
                detector_ms: 6.5,
            }],
        };
        assert!(
            engine
                .status(Some("miro1"), &proto::encode(&status), now)
                .is_ok()
        );
        let views = ViewCounts {
            accepted: 12,
            refused: [("not_jpeg", 3)].into_iter().collect(),
            kept: 2,
        };
        let text = render(&engine, &shell, &views, now);
        for line in [
            "rf_camera_views_received_total 12",
            "rf_camera_views_kept 2",
            "rf_camera_views_refused_total{reason=\"not_jpeg\"} 3",
            "rf_robot_camera_frames_total{robot=\"miro1\",camera=\"right\"} 40",
            "rf_robot_camera_candidates_per_frame{robot=\"miro1\",camera=\"right\"} 2.25",
            "rf_robot_camera_rejections_total{robot=\"miro1\",camera=\"right\",reason=\"low_probability\"} 55",
            "# TYPE rf_inputs_received counter",
            "rf_inputs_received_total 7",
            "# TYPE rf_ws_clients gauge",
            "rf_ws_clients 2",
            "rf_server_active 1",
            "rf_obs_to_state_latency_seconds_count 0",
            "# EOF",
        ] {
            assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
        }
    }
}
