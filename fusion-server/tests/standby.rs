//! Two servers on one prefix: exactly one publishes the ball, signed with its id; when it
//! stops, the standby, which fused the same observations, publishes within half a second.

#[path = "hardening/server.rs"]
mod server;

use proto::BallState;
use server::*;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Every state received: (when, the publishing server's id, the state).
type Seen = Arc<Mutex<Vec<(Instant, String, BallState)>>>;

#[tokio::test(flavor = "multi_thread")]
async fn the_standby_takes_over_when_the_active_server_stops() -> anyhow::Result<()> {
    let a = TestServer::start("pitch-a", fusion_server::ServeConfig::default()).await?;
    let b = TestServer::start_joining("pitch-b", &[&a.endpoint]).await?;
    eventually("pitch-b standing by", || {
        (!b.live.is_active()).then_some(())
    })
    .await;
    assert!(a.live.is_active(), "pitch-a (the smaller id) publishes");

    // A robot and a watcher linked to both servers.
    let both = proto::net::NetConfig {
        connect: vec![a.endpoint.clone(), b.endpoint.clone()],
        ..proto::net::NetConfig::default()
    };
    let robot = both.open().await?;
    let watcher = both.open().await?;
    let seen: Seen = Arc::default();
    let s = seen.clone();
    let _sub = watcher
        .declare_subscriber("rf/ball/state")
        .callback(move |sample| {
            let id = sample
                .attachment()
                .map(|a| String::from_utf8_lossy(&a.to_bytes()).into_owned())
                .unwrap_or_default();
            if let Ok(state) = proto::decode::<BallState>(&sample.payload().to_bytes()) {
                s.lock().expect("lock").push((Instant::now(), id, state));
            }
        })
        .await
        .map_err(z)?;
    let feeding = tokio::spawn(async move {
        for seq in 0..400u64 {
            let o = obs("miro1", seq, now(), -0.5 + 0.002 * seq as f64);
            let _ = robot.put("rf/robots/miro1/obs", proto::encode(&o)).await;
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    });
    eventually("states from pitch-a", || {
        (seen.lock().expect("lock").len() > 20).then_some(())
    })
    .await;
    // Both fuse the same observations: the standby's estimate is the active one's.
    let (pa, pb) = (
        a.live.with_engine(|e| e.ball_state(now())),
        b.live.with_engine(|e| e.ball_state(now())),
    );
    let (pa, pb) = (pa.expect("a's ball"), pb.expect("b's ball"));
    let gap_m = (pa.position_m[0] - pb.position_m[0]).hypot(pa.position_m[1] - pb.position_m[1]);
    assert!(
        gap_m < 0.02,
        "the standby's ball is {gap_m} m from the active's"
    );

    let stopped = Instant::now();
    a.stop().await?;
    eventually("states from pitch-b", || {
        let seen = seen.lock().expect("lock");
        seen.iter().any(|(_, id, _)| id == "pitch-b").then_some(())
    })
    .await;
    assert!(b.live.is_active());
    let seen = seen.lock().expect("lock").clone();
    let before: Vec<_> = seen.iter().filter(|(t, _, _)| *t < stopped).collect();
    assert!(
        before.iter().all(|(_, id, _)| id == "pitch-a"),
        "only the active server published while both ran"
    );
    let last_a = before
        .last()
        .map(|(t, _, _)| *t)
        .expect("states before the stop");
    let first_b = seen
        .iter()
        .find(|(_, id, _)| id == "pitch-b")
        .map(|(t, _, _)| *t)
        .expect("a state from pitch-b");
    let silence = first_b.duration_since(last_a);
    eprintln!("last state from pitch-a to first from pitch-b: {silence:?}");
    assert!(
        silence < Duration::from_millis(500),
        "the ball went unpublished for {silence:?}"
    );
    feeding.abort();
    b.stop().await
}
