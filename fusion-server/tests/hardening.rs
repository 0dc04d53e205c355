//! The attacks on the shared ball state (made-up ids, oversized payloads, floods, slow
//! HTTP clients, clock trouble, clashing servers), each against a real server on loopback,
//! reduced in size so they run quickly. Every one must be refused, counted, and must not
//! stop honest robots.

#[path = "hardening/server.rs"]
mod server;

use fusion_server::matchlog::McapLog;
use fusion_server::record::RecorderConfig;
use fusion_server::serve::ServeConfig;
use server::{TestServer, eventually, now, obs, z};
use std::sync::Arc;

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
    }
}

/// Oversized payloads are refused before they are parsed, over-long lists in a status are
/// refused by validation, oversized queries are refused on both faces; each is counted by
/// reason, and none of the refused inputs reaches the match log.
#[tokio::test(flavor = "multi_thread")]
async fn oversized_inputs_are_refused_counted_and_not_recorded() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let log = Arc::new(McapLog::start(RecorderConfig::new(dir.path()), now())?);
    let as_log: Arc<dyn fusion_server::live::MatchLog> = log.clone();
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
    let long = "x".repeat(fusion_server::query::MAX_QUERY_BYTES);
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
    let read = fusion_server::mcap_read::read_logs(&summary.files)?;
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

fn with_admission(a: fusion_server::engine::AdmissionConfig) -> ServeConfig {
    let mut cfg = ServeConfig::default();
    cfg.engine.admission = a;
    cfg
}

/// 256 made-up liveliness tokens fill the robot table; an honest robot arriving later is
/// refused only until they have been quiet for the expiry time (1 s here).
#[tokio::test(flavor = "multi_thread")]
async fn made_up_tokens_hold_the_robot_table_only_until_they_expire() -> anyhow::Result<()> {
    use fusion_server::engine::{AdmissionConfig, MAX_ROBOTS};
    let s = TestServer::start(
        "h-table",
        with_admission(AdmissionConfig {
            robot_expiry_s: 1.0,
            ..AdmissionConfig::default()
        }),
    )
    .await?;
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
    // The honest robot gets in (after at most the expiry time), the tokens still held.
    s.until_accepted("honest").await?;
    assert!(s.rejected("observation", "too_many_robots") >= 1);
    let known = s.live.with_engine(|e| e.robots(now()).len());
    assert!(known < MAX_ROBOTS, "{known}");
    drop(tokens);
    s.stop().await
}

/// One robot flooding is held to its rate (counted as `rate_limited`); another robot's
/// observations keep being accepted.
#[tokio::test(flavor = "multi_thread")]
async fn a_flooding_robot_is_rate_limited() -> anyhow::Result<()> {
    use fusion_server::engine::AdmissionConfig;
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
