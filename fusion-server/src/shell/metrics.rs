//! The server's counters and the Prometheus text exposition of them.

use crate::engine::Engine;
use proto::Stamp;
use std::fmt::Write;
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

    fn render(&self, out: &mut String, name: &str) {
        let mut cum = 0;
        for (c, b) in self.counts.iter().zip(LATENCY_BUCKETS_S) {
            cum += c;
            let _ = writeln!(out, "{name}_bucket{{le=\"{b}\"}} {cum}");
        }
        let _ = writeln!(out, "{name}_bucket{{le=\"+Inf\"}} {}", self.count);
        let _ = writeln!(out, "{name}_sum {}", self.sum);
        let _ = writeln!(out, "{name}_count {}", self.count);
    }
}

/// What the I/O shell counts (the engine counts what it decides).
#[derive(Debug, Default)]
pub struct ShellStats {
    /// Observation and status payloads that arrived (whatever became of them).
    pub inputs_received: AtomicU64,
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
    /// Seconds from an observation's arrival to the publication of a state that includes it.
    pub obs_to_state_s: Mutex<Histogram>,
    /// This server stands by: a live server of its prefix has a smaller id and publishes
    /// the ball (see `shell::standby`).
    pub standby: std::sync::atomic::AtomicBool,
    /// Live-stream clients dropped because a frame could not be sent in time.
    pub ws_send_timeouts: AtomicU64,
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

fn family(out: &mut String, name: &str, kind: &str, help: &str) {
    let _ = writeln!(out, "# HELP {name} {help}");
    let _ = writeln!(out, "# TYPE {name} {kind}");
}

fn escape(label: &str) -> String {
    label
        .replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// The Prometheus text exposition of the engine's and the shell's counters at `now`.
pub fn render(engine: &Engine, shell: &ShellStats, now: Stamp) -> String {
    let mut out = String::with_capacity(4096);
    let c = engine.counters();
    let core = engine.fusion().counters();
    let h = &shell.http;
    let simple: [(&str, &str, &str, u64); 27] = [
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
            "Kicks inferred from runs of surprising sightings.",
            core.kicks_inferred,
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
    for (name, kind, help, v) in simple {
        family(&mut out, name, kind, help);
        let _ = writeln!(out, "{name} {v}");
    }
    family(
        &mut out,
        "rf_messages_rejected_total",
        "counter",
        "Inbound messages rejected, by message kind and reason.",
    );
    for ((kind, reason), n) in &c.rejected {
        let _ = writeln!(
            out,
            "rf_messages_rejected_total{{kind=\"{kind}\",reason=\"{reason}\"}} {n}"
        );
    }

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
    for (k, (name, kind, help)) in per_robot.iter().enumerate() {
        family(&mut out, name, kind, help);
        for r in &robots {
            let v = match k {
                0 => Some(f64::from(u8::from(r.online))),
                1 => Some(r.obs_rate_hz),
                2 => Some(r.observations_rejected as f64),
                3 => r.covariance_scale,
                4 => r.outlier_rate,
                5 => r.clock_offset_s,
                _ => r.clock_offset_s.map(|_| r.clock_correction_s),
            };
            if let Some(v) = v {
                let _ = writeln!(out, "{name}{{robot=\"{}\"}} {v}", escape(&r.robot_id));
            }
        }
    }

    let name = "rf_server_active";
    family(
        &mut out,
        name,
        "gauge",
        "1 while this server publishes the ball; 0 while it stands by for a server of the same prefix with a smaller id.",
    );
    let _ = writeln!(out, "{name} {}", u8::from(!shell.standby.load(Relaxed)));

    let name = "rf_robots_clock_suspect";
    family(
        &mut out,
        name,
        "gauge",
        "Robots whose estimated clock offset exceeds the warning threshold.",
    );
    let suspect = robots.iter().filter(|r| r.clock_suspect).count();
    let _ = writeln!(out, "{name} {suspect}");

    let name = "rf_obs_to_state_latency_seconds";
    family(
        &mut out,
        name,
        "histogram",
        "From an observation's arrival to the publication of a state that includes it.",
    );
    shell.latency().render(&mut out, name);
    out
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
        let mut s = String::new();
        h.render(&mut s, "x");
        assert!(s.contains("x_bucket{le=\"0.0005\"} 3"), "{s}");
        assert!(s.contains("x_bucket{le=\"+Inf\"} 5"), "{s}");
    }

    #[test]
    fn labels_are_escaped() {
        assert_eq!(escape("a\"b\\c"), "a\\\"b\\\\c");
    }
}
