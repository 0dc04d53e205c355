//! What `bench_edges` measures of a server process at its edges, and its markdown table:
//! made-up robot ids before honest ones, idle sockets under a low open-files limit, a
//! thousand concurrent state requests, and hundreds of live-stream viewers.

use serde::Serialize;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// A burst of made-up ids, then honest robots.
#[derive(Debug, Clone, Serialize)]
pub struct Burst {
    pub made_up_ids: usize,
    pub burst_s: f64,
    pub honest_robots: usize,
    /// What the honest robots sent in their first second, and of it what was accepted
    /// (read 0.3 s after they stopped).
    pub honest_sent: u64,
    pub honest_accepted: u64,
    /// Honest observations refused as `too_many_robots`.
    pub too_many_robots: u64,
}

impl Burst {
    pub fn share(&self) -> f64 {
        self.honest_accepted as f64 / (self.honest_sent as f64).max(1.0)
    }
}

/// Idle connections to the HTTP port of a server under a low open-files limit.
#[derive(Debug, Clone, Serialize)]
pub struct FdLimit {
    pub open_files: u32,
    /// Idle connections tried, and those the kernel accepted.
    pub idle_tried: usize,
    pub idle_connected: usize,
    /// `GET /api/state` afterwards: answered, and in how long.
    pub state_answered: bool,
    pub state_s: Option<f64>,
    /// A new robot's first second of observations, and what of it was accepted.
    pub robot_sent: u64,
    pub robot_accepted: u64,
    /// Idle connections the server closed to make room (`rf_http_idle_evicted_total`).
    pub idle_evicted: u64,
}

/// Concurrent `GET /api/state`.
#[derive(Debug, Clone, Serialize)]
pub struct Gets {
    pub requests: usize,
    pub answered: usize,
    pub p50_s: Option<f64>,
    pub p99_s: Option<f64>,
    pub max_s: Option<f64>,
}

/// `n` threads, released together, each open a connection to `addr` and `GET
/// /api/state` (`Connection: close`); the time from its connect to the whole 200 answer.
pub fn concurrent_gets(addr: &str, n: usize) -> std::io::Result<Gets> {
    let barrier = std::sync::Arc::new(std::sync::Barrier::new(n));
    let threads = (0..n)
        .map(|_| {
            let (addr, barrier) = (addr.to_string(), barrier.clone());
            std::thread::Builder::new()
                .stack_size(64 << 10)
                .spawn(move || {
                    barrier.wait();
                    let t0 = Instant::now();
                    let mut c = std::net::TcpStream::connect(&addr).ok()?;
                    c.set_read_timeout(Some(Duration::from_secs(20))).ok()?;
                    c.write_all(b"GET /api/state HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
                        .ok()?;
                    let mut answer = Vec::new();
                    c.read_to_end(&mut answer).ok()?;
                    answer
                        .starts_with(b"HTTP/1.1 200")
                        .then(|| t0.elapsed().as_secs_f64())
                })
        })
        .collect::<std::io::Result<Vec<_>>>()?;
    let mut times: Vec<f64> = threads
        .into_iter()
        .filter_map(|t| t.join().ok().flatten())
        .collect();
    times.sort_by(f64::total_cmp);
    let at = |q: f64| {
        (!times.is_empty()).then(|| times[((q * times.len() as f64) as usize).min(times.len() - 1)])
    };
    Ok(Gets {
        requests: n,
        answered: times.len(),
        p50_s: at(0.5),
        p99_s: at(0.99),
        max_s: times.last().copied(),
    })
}

/// Live-stream viewers.
#[derive(Debug, Clone, Serialize)]
pub struct Viewers {
    pub viewers: usize,
    /// How many of them the server counted as connected.
    pub served: u64,
    pub seconds: f64,
    /// Frames a second the slowest viewer and the median viewer got.
    pub min_hz: f64,
    pub median_hz: f64,
    /// The server's resident memory before the viewers came, and its peak (VmHWM).
    pub rss_before_kb: u64,
    pub rss_peak_kb: u64,
    /// Frames the server skipped for viewers behind (`rf_ws_frames_dropped_total`).
    pub frames_dropped: u64,
}

/// One `bench_edges` run.
#[derive(Debug, Clone, Serialize)]
pub struct EdgesReport {
    pub cores: usize,
    pub burst: Burst,
    pub fd_limit: FdLimit,
    pub gets: Gets,
    pub viewers: Viewers,
}

fn ms(v: Option<f64>) -> String {
    v.map_or("–".into(), |s| format!("{:.1} ms", s * 1000.0))
}

fn mark(met: bool) -> &'static str {
    if met { "met" } else { "**not met**" }
}

/// The state rate the viewers are served at (the server's default).
pub const STATE_HZ: f64 = 30.0;

impl EdgesReport {
    pub fn markdown(&self, command: &str) -> String {
        let mut out = format!(
            "Produced by `{command}`: a `fusion-server serve --open` process per row, on {} cores shared with the clients.\n\n| measure | result | target | |\n|---|---|---|---|\n",
            self.cores
        );
        let b = &self.burst;
        out.push_str(&format!(
            "| {} made-up robot ids in {:.1} s, then {} honest robots (a liveliness token each, 2 cameras × 30 Hz) for 1 s | {} of {} accepted ({:.1} %), {} refused as `too_many_robots` | ≥ 95 % accepted within 1 s | {} |\n",
            b.made_up_ids,
            b.burst_s,
            b.honest_robots,
            b.honest_accepted,
            b.honest_sent,
            100.0 * b.share(),
            b.too_many_robots,
            mark(b.share() >= 0.95)
        ));
        let f = &self.fd_limit;
        out.push_str(&format!(
            "| `ulimit -n {}`, {} idle connections to the HTTP port ({} connected), then `GET /api/state` and a new robot for 1 s | state {}, robot {} of {} accepted, {} idle connections closed to make room | the state answers, the robot's observations accepted | {} |\n",
            f.open_files,
            f.idle_tried,
            f.idle_connected,
            if f.state_answered {
                format!("answered in {}", ms(f.state_s))
            } else {
                "**not answered**".into()
            },
            f.robot_accepted,
            f.robot_sent,
            f.idle_evicted,
            mark(f.state_answered && f.robot_sent > 0 && f.robot_accepted * 100 >= 95 * f.robot_sent)
        ));
        let g = &self.gets;
        out.push_str(&format!(
            "| {} concurrent `GET /api/state` (a connection each) | {} answered; p50 {}, p99 {}, max {} | all answered, p99 ≤ 1 s | {} |\n",
            g.requests,
            g.answered,
            ms(g.p50_s),
            ms(g.p99_s),
            ms(g.max_s),
            mark(g.answered == g.requests && g.p99_s.is_some_and(|p| p <= 1.0))
        ));
        let v = &self.viewers;
        out.push_str(&format!(
            "| {} live-stream viewers (`/api/stream`) for {:.0} s | {} served; frames each: slowest {:.1}/s, median {:.1}/s; {} frames skipped; server memory {:.1} MB before, peak {:.1} MB | each at the state rate ({STATE_HZ:.0} Hz), memory bounded | {} |\n",
            v.viewers,
            v.seconds,
            v.served,
            v.min_hz,
            v.median_hz,
            v.frames_dropped,
            v.rss_before_kb as f64 / 1024.0,
            v.rss_peak_kb as f64 / 1024.0,
            mark(v.served == v.viewers as u64 && v.min_hz >= 0.95 * STATE_HZ && v.rss_peak_kb < 200 * 1024)
        ));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report() -> EdgesReport {
        EdgesReport {
            cores: 2,
            burst: Burst {
                made_up_ids: 300,
                burst_s: 0.3,
                honest_robots: 5,
                honest_sent: 300,
                honest_accepted: 290,
                too_many_robots: 0,
            },
            fd_limit: FdLimit {
                open_files: 256,
                idle_tried: 300,
                idle_connected: 300,
                state_answered: true,
                state_s: Some(0.002),
                robot_sent: 60,
                robot_accepted: 60,
                idle_evicted: 3,
            },
            gets: Gets {
                requests: 1000,
                answered: 1000,
                p50_s: Some(0.1),
                p99_s: Some(0.5),
                max_s: Some(0.6),
            },
            viewers: Viewers {
                viewers: 200,
                served: 200,
                seconds: 10.0,
                min_hz: 29.5,
                median_hz: 30.0,
                rss_before_kb: 20_000,
                rss_peak_kb: 40_000,
                frames_dropped: 0,
            },
        }
    }

    #[test]
    fn each_row_is_marked_against_its_target() {
        let mut r = report();
        let table = r.markdown("bench_edges");
        assert_eq!(table.matches("| met |").count(), 4, "{table}");
        assert!(table.contains("290 of 300 accepted (96.7 %)"));
        r.burst.honest_accepted = 200;
        r.gets.answered = 999;
        r.viewers.min_hz = 20.0;
        r.fd_limit.state_answered = false;
        let table = r.markdown("bench_edges");
        assert_eq!(table.matches("**not met**").count(), 4, "{table}");
    }
}
