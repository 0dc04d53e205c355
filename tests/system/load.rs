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
