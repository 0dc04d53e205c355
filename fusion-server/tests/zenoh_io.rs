//! The server's Zenoh face over a real loopback session: observations in (good and bad),
//! states out, queries answered, liveliness declared.

#[path = "hardening/server.rs"]
mod server;

use fusion_server::ServeConfig;
use fusion_server::{Clock, SystemClock};
use proto::net::{NetConfig, free_loopback_port};
use server::{eventually, obs};
use std::sync::Arc;
use std::time::Duration;

#[tokio::test(flavor = "multi_thread")]
async fn observations_in_states_and_answers_out() -> anyhow::Result<()> {
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let cfg = ServeConfig {
        server_id: "zio".into(),
        net: NetConfig::listening(&endpoint),
        state_rate_hz: 50.0,
        ..ServeConfig::default()
    };
    let live = fusion_server::shared(&cfg, Arc::new(SystemClock), None)?;
    let http = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let (stop_tx, mut stop_rx) = tokio::sync::watch::channel(false);
    let server = tokio::spawn(fusion_server::serve(cfg, live.clone(), http, async move {
        let _ = stop_rx.wait_for(|s| *s).await;
    }));

    let client = NetConfig::connecting(&endpoint).open().await?;
    // The server's liveliness token is visible (once the link is up).
    let mut token_seen = Vec::new();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    while token_seen.is_empty() && tokio::time::Instant::now() < deadline {
        let replies = client
            .liveliness()
            .get("rf/servers/*")
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        while let Ok(r) = replies.recv_async().await {
            if let Ok(s) = r.result() {
                token_seen.push(s.key_expr().as_str().to_string());
            }
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert_eq!(token_seen, vec!["rf/servers/zio"]);

    let states = client
        .declare_subscriber("rf/ball/state")
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let _token = client
        .liveliness()
        .declare_token("rf/robots/zr1")
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let publisher = client
        .declare_publisher("rf/robots/zr1/obs")
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let t0 = SystemClock.now();
    let n = 40;
    for k in 0..n {
        let o = obs(
            "zr1",
            k,
            t0.offset_secs(k as f64 * 0.01),
            0.5 + 0.002 * k as f64,
        );
        publisher
            .put(proto::encode(&o))
            .await
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        if k % 10 == 0 {
            // Bad input between the good: none of it may stop the good from flowing.
            publisher
                .put("{not json")
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            publisher
                .put(r#"{"version":99,"robot_id":"zr1"}"#)
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?;
        }
    }
    eventually("all good observations fused", || {
        live.with_engine(|e| (e.counters().observations_accepted == n).then_some(()))
    })
    .await;
    let metrics = live.metrics_text();
    assert!(metrics.contains(r#"reason="not_json"} 4"#), "{metrics}");
    assert!(metrics.contains(r#"reason="version"} 4"#), "{metrics}");
    eventually("robot online", || {
        live.with_engine(|e| {
            e.robots(SystemClock.now())
                .iter()
                .any(|r| r.robot_id == "zr1" && r.online)
                .then_some(())
        })
    })
    .await;

    // A published state arrives and decodes.
    let sample = tokio::time::timeout(Duration::from_secs(10), states.recv_async())
        .await?
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let state: proto::BallState = proto::decode(&sample.payload().to_bytes())?;
    assert!(
        (state.position_m[1] + 0.3).abs() < 0.05,
        "{:?}",
        state.position_m
    );

    // Queries: a prediction, an intercept, and an error for nonsense.
    let ask = |sel: &'static str| {
        let client = client.clone();
        async move {
            let replies = client.get(sel).await.map_err(|e| anyhow::anyhow!("{e}"))?;
            let r = replies
                .recv_async()
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            Ok::<_, anyhow::Error>(match r.result() {
                Ok(s) => Ok(s.payload().to_bytes().to_vec()),
                Err(e) => Err(String::from_utf8_lossy(&e.payload().to_bytes()).into_owned()),
            })
        }
    };
    let p: proto::Prediction = proto::decode(
        &ask("rf/ball/predict?t=1.5")
            .await?
            .map_err(anyhow::Error::msg)?,
    )?;
    assert_eq!(p.horizon_s, 1.5);
    let i: proto::Intercept = proto::decode(
        &ask("rf/ball/predict?robot=zr1;speed=0.4")
            .await?
            .map_err(anyhow::Error::msg)?,
    )?;
    assert_eq!(i.robot_id, "zr1");
    let err = ask("rf/ball/predict?t=banana")
        .await?
        .expect_err("an error reply");
    assert!(err.contains("t="), "{err}");

    let _ = stop_tx.send(true);
    server.await??;
    client.close().await.map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(())
}

/// A robot program's typed view (`proto::client`) against a real server: the server found,
/// states read, a prediction and an intercept asked, refusals and a missing server told
/// clearly.
#[tokio::test(flavor = "multi_thread")]
async fn a_robot_program_reads_the_ball_through_the_typed_client() -> anyhow::Result<()> {
    use proto::client::{BallClient, ClientError};
    let s = server::TestServer::start(
        "typed",
        ServeConfig {
            state_rate_hz: 50.0,
            ..ServeConfig::default()
        },
    )
    .await?;
    let endpoint = s.endpoint.clone();
    let client = BallClient::connect(&NetConfig::connecting(&endpoint), "rf").await?;
    assert_eq!(
        client.wait_for_server(Duration::from_secs(20)).await?,
        "typed"
    );
    let mut states = client.subscribe().await?;

    // A robot sees the ball rolling along +x (the link up first).
    s.until_accepted("tc1").await?;
    let t0 = SystemClock.now();
    for k in 0..30u64 {
        let o = obs(
            "tc1",
            100 + k,
            t0.offset_secs(k as f64 * 0.02),
            0.2 + 0.006 * k as f64,
        );
        s.put("rf/robots/tc1/obs", proto::encode(&o)).await?;
    }
    let state = tokio::time::timeout(Duration::from_secs(10), states.next())
        .await?
        .expect("a state");
    assert!(
        (state.position_m[1] + 0.3).abs() < 0.05,
        "{:?}",
        state.position_m
    );
    assert_eq!(states.rejected(), 0);

    let p = client.predict(1.0).await?;
    assert_eq!(p.horizon_s, 1.0);
    assert!(p.samples.windows(2).all(|w| w[0].t_s <= w[1].t_s));
    let i = client.intercept("tc1", Some(0.4)).await?;
    assert_eq!(i.robot_id, "tc1");
    match client.intercept("nobody", None).await {
        Err(ClientError::Refused { message, .. }) => {
            assert!(message.contains("nobody"), "{message}")
        }
        other => panic!("an unknown robot is refused, got {other:?}"),
    }
    assert!(matches!(
        client.predict(f64::NAN).await,
        Err(ClientError::BadParameter(_))
    ));
    assert!(client.intercept("not an id", None).await.is_err());

    // Nothing listens here: a clear error, in about the time given.
    let nowhere = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let lonely = BallClient::connect(&NetConfig::connecting(&nowhere), "rf").await?;
    let asked = std::time::Instant::now();
    let err = lonely
        .wait_for_server(Duration::from_millis(800))
        .await
        .expect_err("no server");
    assert!(
        asked.elapsed() < Duration::from_secs(5),
        "{:?}",
        asked.elapsed()
    );
    assert!(err.to_string().contains(&nowhere), "{err}");
    lonely.close().await?;

    client.close().await?;
    s.stop().await
}
