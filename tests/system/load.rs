//! The load test, reduced: a real `fusion-server` process and 10 robots (a Zenoh session
//! and liveliness token each) × 2 cameras × 30 Hz for 3 s over loopback, on an open
//! network and on a secured one (TLS, a certificate per robot, the roster's access-control
//! list). Everything sent must be received and accepted, the latency and memory stay
//! within loose bounds.

mod support;

use bench::load::{self, LoadConfig};
use tools::progress::Progress;

#[tokio::test(flavor = "multi_thread")]
async fn ten_robots_lose_nothing() {
    ten_robots(false).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn ten_robots_lose_nothing_over_tls() {
    ten_robots(true).await;
}

async fn ten_robots(tls: bool) {
    let cfg = LoadConfig {
        robots: 10,
        cameras: 2,
        hz: 30.0,
        seconds: 3.0,
        // Senders that never drop: what is lost can only be the server's.
        block: true,
        tls,
        ..LoadConfig::default()
    };
    let progress = Progress::hidden(3);
    let r = load::run(&support::server_bin(), &cfg, &progress)
        .await
        .expect("the load run");
    assert_eq!(r.put_errors, 0);
    assert_eq!(r.sent, 10 * 2 * 30 * 3);
    assert_eq!(r.received, r.sent, "every observation sent arrives: {r:?}");
    assert_eq!(r.accepted, r.sent, "and is accepted: {r:?}");
    assert!(r.rejected.is_empty(), "no rejections: {:?}", r.rejected);
    assert!(r.nothing_lost());
    assert_eq!(r.tls, tls);
    // States at the default 30 Hz: an observation waits at most a period, plus the
    // machine's scheduling.
    let p99 = r.latency_p99_s.expect("latencies");
    assert!(p99 <= 0.25, "p99 {p99} s");
    assert!(r.states_published > 0);
    assert!(
        r.rss_peak_kb > 0 && r.rss_peak_kb < 200 * 1024,
        "peak {} kB",
        r.rss_peak_kb
    );
}

/// Overload, reduced for a test machine: 20 robots × 2 cameras × 300 Hz (each robot three
/// times its limit, 12 000 observations a second) for 3 s into the server. The state keeps
/// its rate, the excess is refused and counted, the intake queue empties soon after the
/// load stops, and memory stays bounded. The full overload (100 robots) is the load test's
/// `--overload` run.
#[tokio::test(flavor = "multi_thread")]
async fn overload_keeps_the_state_coming_and_recovers() {
    let cfg = LoadConfig {
        robots: 20,
        cameras: 2,
        hz: 300.0,
        seconds: 3.0,
        drain_s: 2.0,
        ..LoadConfig::default()
    };
    let progress = Progress::hidden(3);
    let r = load::run(&support::server_bin(), &cfg, &progress)
        .await
        .expect("the load run");
    assert!(r.sent > 1000, "{r:?}");
    assert!(
        r.rejected
            .get("observation/rate_limited")
            .copied()
            .unwrap_or(0)
            > 0,
        "beyond the per-robot limit: {:?}",
        r.rejected
    );
    // 30 states a second are published; a loaded test machine gets a loose floor.
    let slowest = r.states_min_per_s().expect("states counted each second");
    assert!(slowest >= 10, "states each second: {:?}", r.states_each_s);
    let recovery = r.recovery_s.expect("the intake queue empties");
    assert!(recovery <= 5.0, "recovered in {recovery} s");
    assert!(
        r.rss_peak_kb > 0 && r.rss_peak_kb < 300 * 1024,
        "peak {} kB",
        r.rss_peak_kb
    );
    assert!(r.robots_tracked_end <= 20, "{}", r.robots_tracked_end);
}
