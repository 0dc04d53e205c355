//! What the load test reads and reports: the server's `/metrics` (Prometheus text) parsed
//! into the counters it needs, the server process's memory and CPU time from `/proc`, and
//! the figures of one run as JSON and as a markdown table.

use serde::Serialize;
use std::collections::BTreeMap;

/// The server's counters the load test reads from `/metrics`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Metrics {
    /// Observation and status payloads that arrived (`rf_inputs_received_total`).
    pub received: u64,
    pub observations_accepted: u64,
    /// Rejections by `kind/reason`.
    pub rejected: BTreeMap<String, u64>,
    pub states_published: u64,
    /// `rf_obs_to_state_latency_seconds`: (upper bound s, cumulative count) per bucket.
    pub latency_buckets: Vec<(f64, u64)>,
    pub latency_count: u64,
    pub latency_sum_s: f64,
    /// Inputs waiting for the fusion (`rf_intake_queued`).
    pub intake_queued: u64,
    /// Robots the server keeps a row for (series of `rf_robot_online`).
    pub robots_tracked: u64,
}

fn label<'a>(labels: &'a str, name: &str) -> Option<&'a str> {
    let start = labels.find(&format!("{name}=\""))? + name.len() + 2;
    let rest = &labels[start..];
    Some(&rest[..rest.find('"')?])
}

impl Metrics {
    /// Parses the Prometheus text exposition; unknown families are skipped.
    pub fn parse(text: &str) -> Metrics {
        let mut m = Metrics::default();
        for line in text.lines().filter(|l| !l.starts_with('#')) {
            let Some((key, value)) = line.rsplit_once(' ') else {
                continue;
            };
            let Ok(v) = value.parse::<f64>() else {
                continue;
            };
            let (name, labels) = key.split_once('{').unwrap_or((key, ""));
            match name {
                "rf_inputs_received_total" => m.received = v as u64,
                "rf_observations_accepted_total" => m.observations_accepted = v as u64,
                "rf_states_published_total" => m.states_published = v as u64,
                "rf_messages_rejected_total" => {
                    let kind = label(labels, "kind").unwrap_or("?");
                    let reason = label(labels, "reason").unwrap_or("?");
                    m.rejected.insert(format!("{kind}/{reason}"), v as u64);
                }
                "rf_obs_to_state_latency_seconds_bucket" => {
                    if let Some(le) = label(labels, "le").and_then(|b| b.parse::<f64>().ok()) {
                        m.latency_buckets.push((le, v as u64));
                    }
                }
                "rf_obs_to_state_latency_seconds_count" => m.latency_count = v as u64,
                "rf_obs_to_state_latency_seconds_sum" => m.latency_sum_s = v,
                "rf_intake_queued" => m.intake_queued = v as u64,
                "rf_robot_online" => m.robots_tracked += 1,
                _ => {}
            }
        }
        m
    }

    pub fn rejected_total(&self) -> u64 {
        self.rejected.values().sum()
    }

    /// The smallest bucket bound below which at least `q` of the latencies fall (`None`
    /// when there are none, or when they lie beyond the last finite bound).
    pub fn latency_bound(&self, q: f64) -> Option<f64> {
        let need = (q * self.latency_count as f64).ceil() as u64;
        if self.latency_count == 0 {
            return None;
        }
        self.latency_buckets
            .iter()
            .find(|(_, cum)| *cum >= need)
            .map(|(b, _)| *b)
    }

    /// The latency histogram of what happened since `earlier`.
    pub fn latency_since(&self, earlier: &Metrics) -> Metrics {
        let buckets = self
            .latency_buckets
            .iter()
            .map(|(b, c)| {
                let before = earlier
                    .latency_buckets
                    .iter()
                    .find(|(eb, _)| eb == b)
                    .map_or(0, |(_, ec)| *ec);
                (*b, c.saturating_sub(before))
            })
            .collect();
        Metrics {
            latency_buckets: buckets,
            latency_count: self.latency_count.saturating_sub(earlier.latency_count),
            latency_sum_s: self.latency_sum_s - earlier.latency_sum_s,
            ..Metrics::default()
        }
    }
}

/// A field of `/proc/PID/status` in kB (`VmRSS:`, `VmHWM:`).
pub fn proc_status_kb(pid: u32, field: &str) -> Option<u64> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix(field))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// User plus system CPU time of a process, seconds (100 ticks a second).
pub fn proc_cpu_s(pid: u32) -> Option<f64> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after = text.rsplit_once(')')?.1;
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// The figures of one load run.
#[derive(Debug, Clone, Serialize)]
pub struct LoadReport {
    pub robots: usize,
    pub cameras: usize,
    pub hz: f64,
    pub seconds: f64,
    /// Zenoh sessions the robots used (one each unless asked otherwise).
    pub sessions: usize,
    /// A secured network: TLS with mutual authentication and the roster's access control.
    pub tls: bool,
    /// Wall time of the publishing, seconds.
    pub publish_s: f64,
    pub sent: u64,
    /// Puts that returned an error (not counted as sent).
    pub put_errors: u64,
    pub received: u64,
    pub accepted: u64,
    /// Rejections by `kind/reason`.
    pub rejected: BTreeMap<String, u64>,
    pub states_published: u64,
    pub states_per_s: f64,
    /// States published in each whole second of the load.
    pub states_each_s: Vec<u64>,
    /// The most inputs seen waiting in the server's intake queue (sampled once a second).
    pub intake_queued_max: u64,
    /// From the last send to the server's last new arrival, once nothing more arrives and
    /// its intake queue is empty (polled every 10 ms): the server is back to fusing what
    /// arrives as it arrives.
    pub recovery_s: Option<f64>,
    /// Robots the server keeps a row for, at the run's midpoint and at its end.
    pub robots_tracked_mid: u64,
    pub robots_tracked_end: u64,
    pub latency_p50_s: Option<f64>,
    pub latency_p99_s: Option<f64>,
    pub latency_mean_s: Option<f64>,
    /// p99 over the second half of the run alone (a growing backlog shows here).
    pub latency_p99_second_half_s: Option<f64>,
    pub latency_samples: u64,
    pub rss_idle_kb: u64,
    pub rss_peak_kb: u64,
    pub rss_end_kb: u64,
    /// Resident set at the run's midpoint, and its change from there to the end.
    pub rss_mid_kb: u64,
    pub rss_growth_second_half_kb: i64,
    /// Sampled once a second while the robots publish.
    pub rss_samples_kb: Vec<u64>,
    pub server_cpu_s: f64,
    /// Server CPU time over the publishing wall time (1 = one core busy).
    pub server_cpu_share: f64,
    pub cores: usize,
}

fn ms(v: Option<f64>) -> String {
    v.map_or("–".into(), |s| format!("{:.1} ms", s * 1000.0))
}

fn mb(kb: u64) -> String {
    format!("{:.1} MB", kb as f64 / 1024.0)
}

impl LoadReport {
    pub fn rejected_total(&self) -> u64 {
        self.rejected.values().sum()
    }

    /// The fewest states published in a whole second of the load.
    pub fn states_min_per_s(&self) -> Option<u64> {
        self.states_each_s.iter().copied().min()
    }

    /// Every observation sent was received and then accepted or rejected, none were
    /// rejected, and none failed to send.
    pub fn nothing_lost(&self) -> bool {
        self.put_errors == 0
            && self.sent == self.received
            && self.received == self.accepted + self.rejected_total()
            && self.rejected_total() == 0
    }

    /// The markdown table, preceded by the command and the machine.
    pub fn markdown(&self, command: &str) -> String {
        let rejected = if self.rejected.is_empty() {
            "0".to_string()
        } else {
            self.rejected
                .iter()
                .map(|(k, n)| format!("{n} {k}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let expected = (self.robots * self.cameras) as f64 * self.hz * self.seconds;
        let rows = [
            (
                "load".to_string(),
                format!(
                    "{} robots × {} cameras × {} Hz for {} s = {} observations/s ({} Zenoh sessions, a liveliness token each{})",
                    self.robots,
                    self.cameras,
                    self.hz,
                    self.seconds,
                    (self.robots * self.cameras) as f64 * self.hz,
                    self.sessions,
                    if self.tls {
                        "; TLS with mutual authentication, a certificate per robot, the roster's access control"
                    } else {
                        "; plain TCP"
                    }
                ),
            ),
            (
                "observations sent".into(),
                format!(
                    "{} of {expected:.0} scheduled in {:.1} s ({} put errors)",
                    self.sent, self.publish_s, self.put_errors
                ),
            ),
            (
                "received by the server".into(),
                format!(
                    "{} ({} not received)",
                    self.received,
                    self.sent.saturating_sub(self.received)
                ),
            ),
            ("accepted".into(), self.accepted.to_string()),
            ("rejected".into(), rejected),
            (
                "in = processed".into(),
                if self.nothing_lost() {
                    "yes: sent = received = accepted, nothing rejected".into()
                } else {
                    format!(
                        "**no**: sent {}, received {}, accepted {} + rejected {}",
                        self.sent,
                        self.received,
                        self.accepted,
                        self.rejected_total()
                    )
                },
            ),
            (
                "arrival → published state (server histogram, bucket bounds)".into(),
                format!(
                    "p50 ≤ {}, p99 ≤ {}, mean {} ({} observations); second half p99 ≤ {}",
                    ms(self.latency_p50_s),
                    ms(self.latency_p99_s),
                    ms(self.latency_mean_s),
                    self.latency_samples,
                    ms(self.latency_p99_second_half_s)
                ),
            ),
            (
                "states published".into(),
                format!(
                    "{} ({:.1}/s while loaded; the slowest whole second {})",
                    self.states_published,
                    self.states_per_s,
                    self.states_min_per_s()
                        .map_or("–".to_string(), |n| format!("{n}/s"))
                ),
            ),
            (
                "intake queue".into(),
                format!(
                    "at most {} waiting (sampled once a second); every backlog worked off {} after the last send",
                    self.intake_queued_max,
                    self.recovery_s
                        .map_or("**not within 10 s**".to_string(), |s| format!("{:.2} s", s))
                ),
            ),
            (
                "robots the server tracks".into(),
                format!(
                    "{} at the midpoint, {} at the end",
                    self.robots_tracked_mid, self.robots_tracked_end
                ),
            ),
            (
                "server resident memory".into(),
                format!(
                    "idle {}, peak {} (VmHWM), end {}; {:+.1} MB over the second half",
                    mb(self.rss_idle_kb),
                    mb(self.rss_peak_kb),
                    mb(self.rss_end_kb),
                    self.rss_growth_second_half_kb as f64 / 1024.0
                ),
            ),
            (
                "server CPU".into(),
                format!(
                    "{:.1} s in {:.1} s = {:.0} % of one core",
                    self.server_cpu_s,
                    self.publish_s,
                    self.server_cpu_share * 100.0
                ),
            ),
        ];
        let mut out = format!(
            "Produced by `{command}`.\n\nMeasured on {} cores shared with other work; the robots and the server run on the same machine.\n\n| measure | result |\n|---|---|\n",
            self.cores
        );
        for (k, v) in rows {
            out.push_str(&format!("| {k} | {v} |\n"));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
# HELP rf_inputs_received x
# TYPE rf_inputs_received counter
rf_inputs_received_total 12
rf_observations_accepted_total 10
rf_states_published_total 7
rf_messages_rejected_total{kind=\"observation\",reason=\"rate_limited\"} 2
rf_obs_to_state_latency_seconds_bucket{le=\"0.01\"} 5
rf_obs_to_state_latency_seconds_bucket{le=\"0.025\"} 9
rf_obs_to_state_latency_seconds_bucket{le=\"0.05\"} 10
rf_obs_to_state_latency_seconds_bucket{le=\"+Inf\"} 10
rf_obs_to_state_latency_seconds_sum 0.15
rf_obs_to_state_latency_seconds_count 10
rf_intake_queued 3
rf_robot_online{robot=\"miro1\"} 1
rf_robot_online{robot=\"miro2\"} 0
# EOF
";

    #[test]
    fn reads_the_counters_and_the_histogram() {
        let m = Metrics::parse(TEXT);
        assert_eq!((m.received, m.observations_accepted), (12, 10));
        assert_eq!(m.states_published, 7);
        assert_eq!((m.intake_queued, m.robots_tracked), (3, 2));
        assert_eq!(m.rejected.get("observation/rate_limited"), Some(&2));
        assert_eq!(m.rejected_total(), 2);
        assert_eq!(m.latency_bound(0.5), Some(0.01));
        assert_eq!(m.latency_bound(0.9), Some(0.025));
        assert_eq!(m.latency_bound(0.99), Some(0.05));
        let later = Metrics::parse(
            &TEXT
                .replace("} 10\n", "} 14\n")
                .replace("count 10", "count 14"),
        );
        let d = later.latency_since(&m);
        assert_eq!(d.latency_count, 4);
        assert_eq!(d.latency_bound(0.5), Some(0.05));
    }
}
