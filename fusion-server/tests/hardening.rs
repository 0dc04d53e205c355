//! The attacks on the shared ball state (made-up ids, oversized payloads, floods, slow
//! HTTP clients, clock trouble, clashing servers), each against a real server on loopback,
//! reduced in size so they run quickly. Every one must be refused, counted, and must not
//! stop honest robots.

#[path = "hardening/server.rs"]
mod server;

use fusion_server::McapLog;
use fusion_server::RecorderConfig;
use fusion_server::ServeConfig;
use server::{TestServer, eventually, now, obs, z};
use std::sync::Arc;
use std::time::Duration;

/// A key whose robot chunk is not an id is refused, never taken for the payload's robot.
#[tokio::test(flavor = "multi_thread")]
async fn a_key_that_is_not_a_robot_id_is_refused() -> anyhow::Result<()> {
    let s = TestServer::start("h-key", ServeConfig::default()).await?;
    s.until_accepted("miro1").await?;
    let forged = proto::encode(&obs("miro1", 1000, now(), 0.5));
    s.put("rf/robots/not.an.id/obs", forged.clone()).await?;
    s.put("rf/robots/miro2/obs", forged).await?;
    eventually("both forgeries counted", || {
        (s.rejected("observation", "key_robot_id") == 1
            && s.rejected("observation", "key_mismatch") == 1)
            .then_some(())
    })
    .await;
    let ids: Vec<String> = s
        .live
        .with_engine(|e| e.robots(now()).into_iter().map(|r| r.robot_id).collect());
    assert_eq!(ids, ["miro1"]);
    s.stop().await
}

fn status(robot: &str) -> proto::RobotStatus {
    proto::RobotStatus {
        version: proto::VERSION,
        robot_id: robot.into(),
        stamp: now(),
        pose: proto::Pose2::default(),
        pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-3],
        head: proto::HeadJoints::default(),
        fps: 15.0,
        timings: vec![],
        footprints: vec![],
        cameras: vec![],
    }
}

/// Oversized payloads are refused before they are parsed, over-long lists in a status are
/// refused by validation, oversized queries are refused on both faces; each is counted by
/// reason, and none of the refused inputs reaches the match log.
#[tokio::test(flavor = "multi_thread")]
async fn oversized_inputs_are_refused_counted_and_not_recorded() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let log = Arc::new(McapLog::start(RecorderConfig::new(dir.path()), now())?);
    let as_log: Arc<dyn fusion_server::MatchLog> = log.clone();
    let s = TestServer::start_logged("h-size", ServeConfig::default(), Some(as_log)).await?;
    s.until_accepted("miro1").await?;

    // A valid observation padded with whitespace past the cap (the attack used 10 MB).
    let mut padded = proto::encode(&obs("miro1", 5000, now(), 0.5));
    padded.extend(std::iter::repeat_n(b' ', 8 * 1024));
    s.put("rf/robots/miro1/obs", padded).await?;
    let mut huge = status("miro1");
    huge.timings = (0..5000)
        .map(|k| proto::StageTiming {
            stage: format!("stage{k}"),
            ms: 1.0,
        })
        .collect();
    s.put("rf/robots/miro1/status", proto::encode(&huge))
        .await?;
    let mut many = status("miro1");
    many.timings = vec![
        proto::StageTiming {
            stage: "s".into(),
            ms: 1.0,
        };
        proto::MAX_STATUS_TIMINGS + 1
    ];
    s.put("rf/robots/miro1/status", proto::encode(&many))
        .await?;
    let mut long_name = status("miro1");
    long_name.timings = vec![proto::StageTiming {
        stage: "x".repeat(1000),
        ms: 1.0,
    }];
    s.put("rf/robots/miro1/status", proto::encode(&long_name))
        .await?;
    eventually("the oversized inputs counted", || {
        (s.rejected("observation", "too_large") == 1
            && s.rejected("status", "too_large") == 1
            && s.rejected("status", "too_many") == 1
            && s.rejected("status", "too_long") == 1)
            .then_some(())
    })
    .await;

    // Queries: an over-long parameter text, over HTTP and over Zenoh.
    let long = "x".repeat(fusion_server::MAX_QUERY_BYTES);
    let (code, body) = s.get(&format!("/api/predict?t=1&pad={long}")).await?;
    assert_eq!(code, 414, "{body}");
    let replies = s
        .client
        .get(format!("rf/ball/predict?t=1;pad={long}"))
        .await
        .map_err(z)?;
    let reply = replies.recv_async().await.map_err(z)?;
    let err = reply.result().expect_err("an error reply");
    let err = String::from_utf8_lossy(&err.payload().to_bytes()).into_owned();
    assert!(err.contains("bytes long"), "{err}");
    assert_eq!(s.rejected("query", "too_large"), 2);
    let (code, body) = s.get("/api/predict?t=1").await?;
    assert!(
        matches!(code, 200 | 404),
        "a normal query is answered: {code} {body}"
    );

    let skipped = s.metric("rf_record_skipped_rejected_total").unwrap_or(0.0);
    assert!(skipped >= 4.0, "{skipped}");
    s.stop().await?;
    let summary = log.finish()?.expect("a summary");
    let read = fusion_server::read_logs(&summary.files)?;
    let inputs: Vec<_> = read
        .messages
        .iter()
        .filter(|m| m.topic.starts_with("rf/robots/"))
        .collect();
    assert!(!inputs.is_empty());
    for m in inputs {
        assert!(m.data.len() < 4096, "{} bytes on {}", m.data.len(), m.topic);
    }
    Ok(())
}

fn with_admission(a: fusion_server::AdmissionConfig) -> ServeConfig {
    let mut cfg = ServeConfig::default();
    cfg.engine.admission = a;
    cfg
}

/// 256 made-up liveliness tokens fill the robot table; an honest robot arriving later gets
/// in with its first observation, taking the place of a token that never sent anything.
#[tokio::test(flavor = "multi_thread")]
async fn made_up_tokens_do_not_keep_an_honest_robot_out() -> anyhow::Result<()> {
    use fusion_server::MAX_ROBOTS;
    let s = TestServer::start("h-table", ServeConfig::default()).await?;
    let mut tokens = Vec::new();
    for k in 0..MAX_ROBOTS {
        let t = s
            .client
            .liveliness()
            .declare_token(format!("rf/robots/fake{k}"))
            .await
            .map_err(z)?;
        tokens.push(t);
    }
    eventually("the table full", || {
        s.live
            .with_engine(|e| (e.robots(now()).len() == MAX_ROBOTS).then_some(()))
    })
    .await;
    let asked = tokio::time::Instant::now();
    s.until_accepted("honest").await?;
    assert!(
        asked.elapsed() < Duration::from_secs(5),
        "{:?}",
        asked.elapsed()
    );
    assert_eq!(s.rejected("observation", "too_many_robots"), 0);
    assert!(s.metric("rf_robots_evicted_total") >= Some(1.0));
    let known = s.live.with_engine(|e| e.robots(now()).len());
    assert_eq!(known, MAX_ROBOTS);
    drop(tokens);
    s.stop().await
}

/// A burst of 300 made-up robot ids in 0.3 s on an open network, then five honest robots:
/// their observations are accepted (at least 95 %), none refused as `too_many_robots`.
#[tokio::test(flavor = "multi_thread")]
async fn a_burst_of_made_up_ids_does_not_lock_honest_robots_out() -> anyhow::Result<()> {
    let s = TestServer::start("h-burst", ServeConfig::default()).await?;
    s.until_accepted("link").await?;
    let t = now();
    for k in 0..300u64 {
        let id = format!("fake{k}");
        s.put(
            &format!("rf/robots/{id}/obs"),
            proto::encode(&obs(&id, 0, t, 0.4)),
        )
        .await?;
        tokio::time::sleep(Duration::from_micros(1000)).await;
    }
    eventually("the burst handled", || {
        (s.metric("rf_inputs_received_total") >= Some(301.0)).then_some(())
    })
    .await;
    let per_robot = 20u64;
    for seq in 0..per_robot {
        for r in 0..5 {
            let id = format!("honest{r}");
            s.put(
                &format!("rf/robots/{id}/obs"),
                proto::encode(&obs(&id, seq, now(), 0.4)),
            )
            .await?;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let accepted = eventually("the honest observations handled", || {
        let (accepted, handled) = s.live.with_engine(|e| {
            let robots = e.robots(now());
            let honest = robots.iter().filter(|r| r.robot_id.starts_with("honest"));
            honest.fold((0, 0), |(a, h), r| {
                (
                    a + r.observations_accepted,
                    h + r.observations_accepted + r.observations_rejected,
                )
            })
        });
        (handled >= 5 * per_robot * 95 / 100).then_some(accepted)
    })
    .await;
    assert!(
        accepted * 100 >= 95 * 5 * per_robot,
        "{accepted} of {}",
        5 * per_robot
    );
    assert_eq!(s.rejected("observation", "too_many_robots"), 0);
    s.stop().await
}

/// One robot flooding is held to its rate (counted as `rate_limited`); another robot's
/// observations keep being accepted.
#[tokio::test(flavor = "multi_thread")]
async fn a_flooding_robot_is_rate_limited() -> anyhow::Result<()> {
    use fusion_server::AdmissionConfig;
    let s = TestServer::start(
        "h-rate",
        with_admission(AdmissionConfig {
            rate_limit_hz: 50.0,
            rate_burst: 20.0,
            ..AdmissionConfig::default()
        }),
    )
    .await?;
    s.until_accepted("flood").await?;
    s.until_accepted("honest").await?;
    let t = now();
    for seq in 0..500 {
        s.put(
            "rf/robots/flood/obs",
            proto::encode(&obs("flood", 10_000 + seq, t, 0.5)),
        )
        .await?;
    }
    eventually("the flood counted", || {
        (s.rejected("observation", "rate_limited") >= 300).then_some(())
    })
    .await;
    let before = s.live.with_engine(|e| {
        e.robots(now())
            .iter()
            .find(|r| r.robot_id == "honest")
            .map_or(0, |r| r.observations_accepted)
    });
    for seq in 0..5 {
        s.put(
            "rf/robots/honest/obs",
            proto::encode(&obs("honest", 10_000 + seq, now(), 0.5)),
        )
        .await?;
        tokio::time::sleep(std::time::Duration::from_millis(30)).await;
    }
    eventually("the honest robot still accepted", || {
        s.live.with_engine(|e| {
            e.robots(now())
                .iter()
                .any(|r| r.robot_id == "honest" && r.observations_accepted >= before + 5)
                .then_some(())
        })
    })
    .await;
    s.stop().await
}

fn with_http(h: fusion_server::HttpLimits) -> ServeConfig {
    ServeConfig {
        http_limits: h,
        ..ServeConfig::default()
    }
}

/// Reads until the server closes the connection (or `within` passes): true when closed.
async fn closed_by_server(c: &mut tokio::net::TcpStream, within: Duration) -> bool {
    use tokio::io::AsyncReadExt;
    let mut buf = [0u8; 4096];
    let deadline = tokio::time::Instant::now() + within;
    loop {
        match tokio::time::timeout_at(deadline, c.read(&mut buf)).await {
            Ok(Ok(0)) | Ok(Err(_)) => return true,
            Ok(Ok(_)) => continue,
            Err(_) => return false,
        }
    }
}

/// Slowloris: clients sending their headers a byte at a time are cut off by the request
/// deadline, idle ones by the idle deadline; the page is still served meanwhile.
#[tokio::test(flavor = "multi_thread")]
async fn slow_and_idle_http_clients_are_cut_off() -> anyhow::Result<()> {
    use fusion_server::HttpLimits;
    use tokio::io::AsyncWriteExt;
    let s = TestServer::start(
        "h-slow",
        with_http(HttpLimits {
            request_timeout_s: 0.5,
            idle_timeout_s: 0.5,
            ..HttpLimits::default()
        }),
    )
    .await?;
    let mut slow = Vec::new();
    for _ in 0..8 {
        let mut c = tokio::net::TcpStream::connect(s.http).await?;
        c.write_all(b"GET / HTTP/1.1\r\nHost: t\r\n").await?;
        slow.push(c);
    }
    let mut idle = tokio::net::TcpStream::connect(s.http).await?;
    // Trickle a header byte every 100 ms: each keeps the idle deadline away, not the
    // request deadline.
    let trickle = async {
        for _ in 0..30 {
            for c in &mut slow {
                if c.write_all(b"X").await.is_err() {
                    continue;
                }
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    };
    let (code, _) = s.get("/healthz").await?;
    assert_eq!(code, 200);
    trickle.await;
    for c in &mut slow {
        assert!(
            closed_by_server(c, Duration::from_secs(5)).await,
            "a slowloris client kept"
        );
    }
    assert!(
        closed_by_server(&mut idle, Duration::from_secs(5)).await,
        "an idle client kept"
    );
    eventually("the deadlines counted", || {
        (s.metric("rf_http_request_timeouts_total") >= Some(8.0)
            && s.metric("rf_http_idle_timeouts_total") >= Some(1.0))
        .then_some(())
    })
    .await;
    s.stop().await
}

/// Beyond the connection cap, new connections are closed at once (counted); once others
/// close, the server answers again.
#[tokio::test(flavor = "multi_thread")]
async fn connections_beyond_the_cap_are_closed_at_once() -> anyhow::Result<()> {
    use fusion_server::HttpLimits;
    let s = TestServer::start(
        "h-cap",
        with_http(HttpLimits {
            max_connections: 4,
            ..HttpLimits::default()
        }),
    )
    .await?;
    use tokio::io::AsyncWriteExt;
    let mut held = Vec::new();
    for _ in 0..4 {
        // Each in the middle of a request: busy, so none may be closed for the newcomer.
        let mut c = tokio::net::TcpStream::connect(s.http).await?;
        c.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n").await?;
        held.push(c);
    }
    eventually("four open", || {
        (s.metric("rf_http_connections") == Some(4.0)).then_some(())
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let mut extra = tokio::net::TcpStream::connect(s.http).await?;
    assert!(closed_by_server(&mut extra, Duration::from_secs(5)).await);
    assert_eq!(s.metric("rf_http_connections_refused_total"), Some(1.0));
    drop(held);
    eventually("room again", || {
        (s.metric("rf_http_connections") == Some(0.0)).then_some(())
    })
    .await;
    let (code, _) = s.get("/healthz").await?;
    assert_eq!(code, 200);
    s.stop().await
}

/// At the cap, a new connection takes the place of the one idle the longest: idle sockets
/// cannot lock the page and the API out.
#[tokio::test(flavor = "multi_thread")]
async fn idle_connections_make_room_for_new_ones() -> anyhow::Result<()> {
    use fusion_server::HttpLimits;
    let s = TestServer::start(
        "h-idle",
        with_http(HttpLimits {
            max_connections: 4,
            ..HttpLimits::default()
        }),
    )
    .await?;
    let mut idle = Vec::new();
    for _ in 0..4 {
        idle.push(tokio::net::TcpStream::connect(s.http).await?);
    }
    eventually("four open", || {
        (s.metric("rf_http_connections") == Some(4.0)).then_some(())
    })
    .await;
    // Idle for more than a second: each new request closes one of them.
    tokio::time::sleep(Duration::from_millis(1200)).await;
    for _ in 0..3 {
        let (code, _) = s.get("/api/state").await?;
        assert_eq!(code, 200);
    }
    assert!(s.metric("rf_http_idle_evicted_total") >= Some(1.0));
    assert_eq!(s.metric("rf_http_connections_refused_total"), Some(0.0));
    let mut closed = 0;
    for c in &mut idle {
        if closed_by_server(c, Duration::from_millis(200)).await {
            closed += 1;
        }
    }
    assert!(closed >= 1, "an idle connection was closed");
    s.stop().await
}

/// Statuses of `robots` robots as large as the caps allow (the most footprints of the most
/// corners): large frames on the live stream and large scenes, to fill socket buffers fast.
async fn put_big_statuses(s: &TestServer, robots: u64) -> anyhow::Result<()> {
    for k in 0..robots {
        let robot = format!("big{k}");
        let mut st = status(&robot);
        st.footprints = vec![
            proto::CameraFootprint {
                camera: proto::Camera::Left,
                polygon_m: vec![[0.123_456_789, -0.987_654_321]; proto::MAX_FOOTPRINT_POINTS],
            };
            proto::MAX_STATUS_FOOTPRINTS
        ];
        s.put(&format!("rf/robots/{robot}/status"), proto::encode(&st))
            .await?;
    }
    Ok(())
}

/// A Foxglove WebSocket client of the server at `addr`.
async fn foxglove_client(
    addr: std::net::SocketAddr,
) -> anyhow::Result<
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>,
> {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let mut request = format!("ws://{addr}/").into_client_request()?;
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", "foxglove.websocket.v1".parse()?);
    Ok(tokio_tungstenite::connect_async(request).await?.0)
}

/// A live-stream client that stops reading is dropped after the send timeout (counted),
/// instead of holding an ever larger send buffer.
#[tokio::test(flavor = "multi_thread")]
async fn a_stuck_stream_client_is_dropped() -> anyhow::Result<()> {
    use fusion_server::HttpLimits;
    let s = TestServer::start(
        "h-ws",
        with_http(HttpLimits {
            ws_send_timeout_s: 0.3,
            ..HttpLimits::default()
        }),
    )
    .await?;
    // The link up first: a put before it is lost.
    s.until_accepted("link").await?;
    // Large (but valid) statuses make large frames, to fill the socket buffers quickly.
    let robots = 40;
    put_big_statuses(&s, robots).await?;
    let in_time = tokio::time::Instant::now() + Duration::from_secs(20);
    loop {
        let (accepted, rejected) = s.live.with_engine(|e| {
            let c = e.counters();
            let rejected: u64 = c
                .rejected
                .iter()
                .filter(|((kind, _), _)| *kind == "status")
                .map(|(_, n)| *n)
                .sum();
            (c.statuses_accepted, rejected)
        });
        if accepted == robots {
            break;
        }
        assert!(
            tokio::time::Instant::now() < in_time,
            "{accepted} of {robots} statuses accepted, {rejected} rejected"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let url = format!("ws://{}/api/stream", s.http);
    let (stuck, _) = tokio_tungstenite::connect_async(&url).await?;
    eventually("the stuck client dropped", || {
        (s.metric("rf_ws_send_timeouts_total") >= Some(1.0)).then_some(())
    })
    .await;
    eventually("no client left", || {
        (s.metric("rf_ws_clients") == Some(0.0)).then_some(())
    })
    .await;
    assert!(s.metric("rf_ws_frames_dropped_total") >= Some(1.0));
    drop(stuck);
    s.stop().await
}

/// A Foxglove client that subscribes and then stops reading is dropped after the send
/// timeout, and what it missed is counted; the server goes on publishing.
#[tokio::test(flavor = "multi_thread")]
async fn a_stuck_foxglove_client_is_dropped_and_counted() -> anyhow::Result<()> {
    use fusion_server::HttpLimits;
    use futures_util::{SinkExt, StreamExt};
    use tokio_tungstenite::tungstenite::Message;
    let s = TestServer::start_with_foxglove(
        "h-fox",
        with_http(HttpLimits {
            ws_send_timeout_s: 0.3,
            ..HttpLimits::default()
        }),
    )
    .await?;
    s.until_accepted("link").await?;
    // Robots with large footprints make large scene updates, to fill the socket buffers.
    let robots = 40;
    put_big_statuses(&s, robots).await?;
    eventually("the statuses accepted", || {
        s.live
            .with_engine(|e| (e.counters().statuses_accepted == robots).then_some(()))
    })
    .await;
    let addr = s.foxglove.expect("a Foxglove listener");
    let mut stuck = foxglove_client(addr).await?;
    // Subscribe to every channel it is told of until the scene is among them, then read no more.
    let mut subscribed_scene = false;
    while !subscribed_scene {
        let msg = tokio::time::timeout(Duration::from_secs(20), stuck.next())
            .await?
            .ok_or_else(|| anyhow::anyhow!("closed"))??;
        if let Message::Text(t) = msg {
            let v: serde_json::Value = serde_json::from_str(t.as_str())?;
            if v["op"] == "advertise" {
                let subs: Vec<_> = v["channels"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .map(|c| serde_json::json!({"id": c["id"], "channelId": c["id"]}))
                    .collect();
                subscribed_scene |= v["channels"]
                    .as_array()
                    .is_some_and(|cs| cs.iter().any(|c| c["topic"] == "/scene"));
                let sub = serde_json::json!({"op": "subscribe", "subscriptions": subs});
                stuck.send(Message::Text(sub.to_string().into())).await?;
            }
        }
    }
    eventually("the stuck client dropped", || {
        (s.metric("rf_foxglove_send_timeouts_total") >= Some(1.0)).then_some(())
    })
    .await;
    eventually("no client left", || {
        (s.metric("rf_foxglove_clients") == Some(0.0)).then_some(())
    })
    .await;
    assert!(s.metric("rf_foxglove_messages_sent_total") >= Some(1.0));
    assert!(s.metric("rf_foxglove_messages_dropped_total") >= Some(1.0));
    // A new client is served as before.
    let mut fresh = foxglove_client(addr).await?;
    let first = tokio::time::timeout(Duration::from_secs(10), fresh.next())
        .await?
        .ok_or_else(|| anyhow::anyhow!("closed"))??;
    assert!(first.to_text()?.contains("serverInfo"), "{first:?}");
    drop(stuck);
    s.stop().await
}

/// A robot whose clock is 200 ms behind the server's shows that offset in /api/robots and
/// /metrics and is marked suspect; a robot on time is not.
#[tokio::test(flavor = "multi_thread")]
async fn a_robot_clock_off_by_200_ms_is_seen() -> anyhow::Result<()> {
    let s = TestServer::start("h-clock", ServeConfig::default()).await?;
    s.until_accepted("ontime").await?;
    for seq in 0..20 {
        let t = now();
        s.put(
            "rf/robots/ontime/obs",
            proto::encode(&obs("ontime", 100 + seq, t, 0.5)),
        )
        .await?;
        let late = proto::Stamp(t.0 - 200_000_000);
        s.put(
            "rf/robots/behind/obs",
            proto::encode(&obs("behind", 100 + seq, late, 0.5)),
        )
        .await?;
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    eventually("the robot behind heard", || {
        s.live.with_engine(|e| {
            e.robots(now())
                .iter()
                .any(|r| r.robot_id == "behind" && r.observations_accepted >= 15)
                .then_some(())
        })
    })
    .await;
    let robots: serde_json::Value = serde_json::from_str(&s.get("/api/robots").await?.1)?;
    let offset = |id: &str| {
        robots
            .as_array()
            .and_then(|a| a.iter().find(|r| r["robot_id"] == id))
            .map(|r| (r["clock_offset_s"].as_f64(), r["clock_suspect"].as_bool()))
    };
    let (behind, suspect) = offset("behind").expect("behind listed");
    let behind = behind.expect("an estimate");
    assert!((0.2..0.3).contains(&behind), "{behind}");
    assert_eq!(suspect, Some(true));
    let (ontime, suspect) = offset("ontime").expect("ontime listed");
    assert!(ontime.expect("an estimate").abs() < 0.1, "{ontime:?}");
    assert_eq!(suspect, Some(false));
    assert_eq!(s.metric("rf_robots_clock_suspect"), Some(1.0));
    let metrics = s.live.metrics_text();
    assert!(
        metrics.contains("rf_robot_clock_offset_seconds{robot=\"behind\"} 0.2"),
        "{metrics}"
    );
    s.stop().await
}

/// A second server with an id already on the network refuses to start, with a clear
/// error; one with another id joins.
#[tokio::test(flavor = "multi_thread")]
async fn a_duplicate_server_id_is_refused() -> anyhow::Result<()> {
    use fusion_server::SystemClock;
    use proto::net::{NetConfig, free_loopback_port};
    let first = TestServer::start("h-dup", ServeConfig::default()).await?;
    let run = |id: &str| {
        let net = NetConfig {
            listen: vec![format!("tcp/127.0.0.1:{}", free_loopback_port()?)],
            connect: vec![first.endpoint.clone()],
            ..NetConfig::default()
        };
        let cfg = ServeConfig {
            server_id: id.into(),
            net,
            ..ServeConfig::default()
        };
        let live = fusion_server::shared(&cfg, Arc::new(SystemClock), None)?;
        anyhow::Ok((cfg, live))
    };
    let (cfg, live) = run("h-dup")?;
    let http = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let err = fusion_server::serve(cfg, live, http, std::future::pending())
        .await
        .expect_err("a second h-dup refused");
    assert!(
        format!("{err:#}").contains("already on this Zenoh network"),
        "{err:#}"
    );

    let (cfg, live) = run("h-other")?;
    let http = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let (stop, mut stop_rx) = tokio::sync::watch::channel(false);
    let other = tokio::spawn(fusion_server::serve(cfg, live, http, async move {
        let _ = stop_rx.wait_for(|s| *s).await;
    }));
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(!other.is_finished(), "another id runs beside it");
    let _ = stop.send(true);
    other.await??;
    first.stop().await
}

/// A burst of valid observations, sent as fast as the client can, is judged on arrival:
/// none of it becomes `too_late` while the fusion works through it.
#[tokio::test(flavor = "multi_thread")]
async fn a_burst_of_valid_observations_is_not_made_late() -> anyhow::Result<()> {
    use fusion_server::AdmissionConfig;
    let s = TestServer::start(
        "h-burst",
        with_admission(AdmissionConfig {
            rate_limit_hz: 1e6,
            rate_burst: 1e6,
            ..AdmissionConfig::default()
        }),
    )
    .await?;
    s.until_accepted("burst").await?;
    let n = 3000_u64;
    let publisher = s
        .client
        .declare_publisher("rf/robots/burst/obs")
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .await
        .map_err(z)?;
    for seq in 0..n {
        let o = obs("burst", 1000 + seq, now(), 0.5 + 1e-4 * seq as f64);
        publisher.put(proto::encode(&o)).await.map_err(z)?;
    }
    let accepted = || {
        s.live.with_engine(|e| {
            e.robots(now())
                .iter()
                .find(|r| r.robot_id == "burst")
                .map_or(0, |r| r.observations_accepted + r.observations_rejected)
        })
    };
    eventually("the burst worked through", || {
        (accepted() > n).then_some(())
    })
    .await;
    assert_eq!(s.rejected("observation", "too_late"), 0);
    assert_eq!(s.rejected("observation", "queue_full"), 0);
    drop(publisher);
    s.stop().await
}
