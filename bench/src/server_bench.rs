//! The server benchmark's results and their markdown table (see the `bench_server` binary).

use serde::Serialize;
use sim::quantile;

#[derive(Debug, Clone, Serialize)]
pub struct Throughput {
    pub sent: u64,
    pub received: u64,
    pub secs: f64,
    pub payload_bytes: usize,
    /// Through the server: observations that arrived out of capture order (each re-fuses
    /// the late window after it), and those whose stamps were clock-corrected.
    pub reordered: u64,
    pub clock_corrected: u64,
}

impl Throughput {
    pub fn per_s(&self) -> f64 {
        self.received as f64 / self.secs.max(1e-9)
    }
    pub fn lost(&self) -> u64 {
        self.sent.saturating_sub(self.received)
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Latency {
    pub rate_hz: f64,
    pub sent: usize,
    pub matched: usize,
    pub p50_s: Option<f64>,
    pub p99_s: Option<f64>,
    pub max_s: Option<f64>,
}

impl Latency {
    pub fn of(rate_hz: f64, sent: usize, lat_s: Vec<f64>) -> Self {
        Latency {
            rate_hz,
            sent,
            matched: lat_s.len(),
            p50_s: quantile(&lat_s, 0.5),
            p99_s: quantile(&lat_s, 0.99),
            max_s: lat_s.iter().copied().reduce(f64::max),
        }
    }
}

/// The per-robot limit at work: a robot flooding beside one within the limit.
#[derive(Debug, Clone, Serialize)]
pub struct Limiter {
    pub seconds: f64,
    pub limit_hz: f64,
    pub burst: f64,
    pub flood_sent: u64,
    pub flood_accepted: u64,
    pub rate_limited: u64,
    pub honest_sent: u64,
    pub honest_accepted: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ReplaySpeed {
    pub match_s: f64,
    pub robots: usize,
    pub observations: u64,
    pub states: u64,
    pub messages: usize,
    /// Reading the observation log.
    pub read_s: f64,
    /// Re-fusing its observations with states at 30 Hz (`replay FILE`).
    pub fuse_s: f64,
    /// The same, writing the re-fused log (`replay FILE --out DIR`).
    pub write_s: f64,
    /// The ground-truth log read, re-fused, its run rebuilt and scored as the evaluation does.
    pub full_s: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Memory {
    pub robots: usize,
    pub seconds: f64,
    pub published: u64,
    pub rss_idle_kb: u64,
    pub rss_kb: u64,
    pub hwm_kb: u64,
    /// CPU seconds per wall second of the server process.
    pub cpu_share: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub cores: usize,
    pub raw: Throughput,
    pub server: Throughput,
    /// A bare Zenoh round trip (publish, echo from a callback, receive): the ceiling.
    pub raw_latency: Latency,
    pub latency: Latency,
    pub limiter: Limiter,
    /// The per-robot limit of the throughput run (raised far above the default for it).
    pub throughput_limit_hz: f64,
    /// Observations the throughput run's sender keeps at most ahead of the server.
    pub throughput_window: u64,
    /// Robots sharing the latency run's observations.
    pub latency_robots: usize,
    pub replay: ReplaySpeed,
    pub memory: Memory,
}

fn ms(v: Option<f64>) -> String {
    v.map(|s| format!("{:.3} ms", s * 1e3))
        .unwrap_or_else(|| "-".into())
}

fn mark(ok: bool) -> &'static str {
    if ok { "met" } else { "missed" }
}

impl Report {
    pub fn markdown(&self) -> String {
        let r = &self.replay;
        let m = &self.memory;
        let l = &self.latency;
        let read_fuse_x = r.match_s / (r.read_s + r.fuse_s).max(1e-9);
        let write_x = r.match_s / (r.read_s + r.write_s).max(1e-9);
        let full_x = r.match_s / r.full_s.max(1e-9);
        let rss_mb = m.hwm_kb as f64 / 1024.0;
        let mut out = String::new();
        out.push_str(&format!(
            "Measured on {} cores.\n\n| measure | result | target | |\n|---|---|---|---|\n",
            self.cores
        ));
        out.push_str(&format!(
            "| raw Zenoh loopback ({} B payloads, one session to another) | {:.0} msg/s ({} of {} received) | ceiling | |\n",
            self.raw.payload_bytes,
            self.raw.per_s(),
            self.raw.received,
            self.raw.sent
        ));
        let ratio = self.server.per_s() / self.raw.per_s().max(1e-9);
        out.push_str(&format!(
            "| observations through Zenoh into the server (10 robots, their rate limit raised to {:.0e}/s for this row; the sender at most {} observations ahead of the server) | {:.0} obs/s, {} lost of {} ({:.0} % of raw Zenoh; {} out of capture order, {} clock-corrected) | ≥ 100 000 obs/s without loss | {} |\n",
            self.throughput_limit_hz,
            self.throughput_window,
            self.server.per_s(),
            self.server.lost(),
            self.server.sent,
            100.0 * ratio,
            self.server.reordered,
            self.server.clock_corrected,
            mark(self.server.per_s() >= 100_000.0 && self.server.lost() == 0)
        ));
        let rl = &self.raw_latency;
        out.push_str(&format!(
            "| raw Zenoh round trip at {:.0} msg/s (publish, echo from a callback, receive) | p50 {}, p99 {}, max {} | ceiling | |\n",
            rl.rate_hz,
            ms(rl.p50_s),
            ms(rl.p99_s),
            ms(rl.max_s)
        ));
        let within = |p: f64| p <= 1e-3 && rl.p99_s.is_some_and(|r| p <= 2.0 * r);
        out.push_str(&format!(
            "| publish → state latency at {:.0} obs/s from {} robots in turn, each under the per-robot limit (states on update; {} of {} matched) | p50 {}, p99 {}, max {} | p99 ≤ 1 ms and ≤ 2 × the raw round trip's | {} |\n",
            l.rate_hz,
            self.latency_robots,
            l.matched,
            l.sent,
            ms(l.p50_s),
            ms(l.p99_s),
            ms(l.max_s),
            mark(l.p99_s.is_some_and(within))
        ));
        let f = &self.limiter;
        let allowed = f.burst + f.limit_hz * f.seconds;
        out.push_str(&format!(
            "| the per-robot limit ({:.0}/s, burst {:.0}): one robot flooding for {:.1} s beside one at 100 obs/s | flooder: {} sent, {} accepted (the limit allows {:.0}), {} refused as `rate_limited`; the other: {} of {} accepted | the other robot unaffected | {} |\n",
            f.limit_hz,
            f.burst,
            f.seconds,
            f.flood_sent,
            f.flood_accepted,
            allowed,
            f.rate_limited,
            f.honest_accepted,
            f.honest_sent,
            mark(f.honest_accepted == f.honest_sent && f.flood_accepted as f64 <= allowed + 1.0)
        ));
        out.push_str(&format!(
            "| offline replay of a {:.0} s, {}-robot match log ({} observations; states at 30 Hz), `replay --no-log`: read + re-fuse | {:.3} s + {:.3} s = {:.0}× real time | ≥ 2 000× | {} |\n",
            r.match_s,
            r.robots,
            r.observations,
            r.read_s,
            r.fuse_s,
            read_fuse_x,
            mark(read_fuse_x >= 2000.0)
        ));
        out.push_str(&format!(
            "| the same, writing the re-fused log ({} states), `replay` | {:.3} s = {:.0}× real time | | |\n",
            r.states,
            r.read_s + r.write_s,
            write_x
        ));
        out.push_str(&format!(
            "| the same match with ground truth ({} messages), `replay --no-log` and `score_log`: read, re-fuse, score | {:.3} s = {:.0}× real time | | |\n",
            r.messages,
            r.full_s,
            full_x
        ));
        out.push_str(&format!(
            "| server resident memory, {} robots for {:.0} s ({} observations) | peak {:.1} MB (idle {:.1} MB), CPU {:.0} % of a core | ≤ 50 MB | {} |\n",
            m.robots,
            m.seconds,
            m.published,
            rss_mb,
            m.rss_idle_kb as f64 / 1024.0,
            100.0 * m.cpu_share,
            mark(rss_mb <= 50.0)
        ));
        out
    }
}
