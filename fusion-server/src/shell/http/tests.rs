use super::*;
use crate::clock::Clock;
use crate::engine::{Engine, EngineConfig};
use crate::shell::live::Live;
use axum::body::Body;
use axum::http::Request;
use http_body_util::BodyExt;
use proto::{Camera, KeySpace, Observation, Pose2, Stamp};
use std::sync::atomic::{AtomicU64, Ordering};
use tower::ServiceExt;

/// A clock the test moves by hand.
#[derive(Debug, Default)]
struct HandClock(AtomicU64);

impl Clock for HandClock {
    fn now(&self) -> Stamp {
        Stamp(self.0.load(Ordering::SeqCst))
    }
}

const T0: u64 = 1_800_000_000_000_000_000;

fn live_with_ball() -> (Arc<Live>, Arc<HandClock>) {
    let clock = Arc::new(HandClock(AtomicU64::new(T0)));
    let live = Arc::new(Live::new(
        Engine::new(EngineConfig::default()),
        KeySpace::default(),
        clock.clone(),
        4,
        false,
        None,
    ));
    for k in 0..30u64 {
        let t = k as f64 / 15.0;
        let o = Observation {
            version: proto::VERSION,
            robot_id: "miro1".into(),
            seq: k,
            camera: Camera::Right,
            stamp: Stamp(T0).offset_secs(t),
            position_m: [0.3 * t, 0.0],
            covariance_m2: [4e-4, 0.0, 0.0, 4e-4],
            confidence: 0.9,
            robot_pose: Pose2::default(),
            pixel: None,
        };
        clock
            .0
            .store(Stamp(T0).offset_secs(t + 0.05).0, Ordering::SeqCst);
        live.on_observation("rf/robots/miro1/obs", &proto::encode(&o));
    }
    live.on_observation("rf/robots/miro1/obs", b"garbage");
    (live, clock)
}

async fn get(app: Router, uri: &str) -> (StatusCode, String) {
    let req = Request::builder()
        .uri(uri)
        .body(Body::empty())
        .expect("request");
    let resp = app.oneshot(req).await.expect("response");
    let status = resp.status();
    let body = resp.into_body().collect().await.expect("body").to_bytes();
    (status, String::from_utf8_lossy(&body).into_owned())
}

fn json(body: &str) -> serde_json::Value {
    serde_json::from_str(body).expect("JSON body")
}

#[tokio::test]
async fn state_robots_and_health() {
    let (live, _) = live_with_ball();
    let (s, body) = get(app(live.clone()), "/api/state").await;
    assert_eq!(s, StatusCode::OK);
    let v = json(&body);
    let x = v["ball"]["position_m"][0].as_f64().expect("x");
    assert!((x - 0.3 * 29.0 / 15.0).abs() < 0.05, "{x}");
    assert_eq!(v["robots"][0]["robot_id"], "miro1");
    assert!(v["pitch"]["length_m"].as_f64().is_some());
    let (s, body) = get(app(live.clone()), "/api/robots").await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(json(&body)[0]["observations_accepted"], 30);
    let (s, body) = get(app(live), "/healthz").await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(json(&body)["status"], "ok");
}

#[tokio::test]
async fn the_history_holds_the_published_states() {
    let (live, clock) = live_with_ball();
    let (_, body) = get(app(live.clone()), "/api/history").await;
    assert_eq!(json(&body)["samples"].as_array().map(Vec::len), Some(0));
    // Two seconds of publications at 30 Hz, the ball coasting on.
    let start = clock.now();
    for k in 1..=60 {
        clock
            .0
            .store(start.offset_secs(f64::from(k) / 30.0).0, Ordering::SeqCst);
        live.publication(false);
    }
    let (s, body) = get(app(live), "/api/history").await;
    assert_eq!(s, StatusCode::OK);
    let v = json(&body);
    let samples = v["samples"].as_array().expect("samples");
    assert!((18..=21).contains(&samples.len()), "{}", samples.len());
    let first = &samples[0];
    assert!(first["position_m"][0].as_f64().is_some_and(|x| x > 0.5));
    assert!(first["ellipse_2sigma_m"].as_f64().is_some_and(|e| e > 0.0));
    assert!(v["stamp"].as_u64().is_some());
}

#[tokio::test]
async fn predict_and_intercept_answer_or_explain() {
    let (live, _) = live_with_ball();
    let (s, body) = get(app(live.clone()), "/api/predict?t=1.5").await;
    assert_eq!(s, StatusCode::OK, "{body}");
    let p: proto::Prediction = proto::decode(body.as_bytes()).expect("a Prediction");
    assert_eq!(p.horizon_s, 1.5);
    let (s, body) = get(app(live.clone()), "/api/intercept?robot=miro1&speed=0.4").await;
    assert_eq!(s, StatusCode::OK, "{body}");
    let i: proto::Intercept = proto::decode(body.as_bytes()).expect("an Intercept");
    assert_eq!(i.robot_id, "miro1");
    for (uri, want) in [
        ("/api/predict", StatusCode::BAD_REQUEST),
        ("/api/predict?t=abc", StatusCode::BAD_REQUEST),
        ("/api/predict?t=1;robot=x", StatusCode::BAD_REQUEST),
        ("/api/intercept?t=1", StatusCode::BAD_REQUEST),
        ("/api/intercept?robot=ghost", StatusCode::NOT_FOUND),
        ("/nowhere", StatusCode::NOT_FOUND),
    ] {
        let (s, body) = get(app(live.clone()), uri).await;
        assert_eq!(s, want, "{uri}: {body}");
        assert!(json(&body)["error"].is_string(), "{uri}: {body}");
    }
}

#[tokio::test]
async fn metrics_count_rejections_and_the_page_is_served() {
    let (live, _) = live_with_ball();
    let (s, text) = get(app(live.clone()), "/metrics").await;
    assert_eq!(s, StatusCode::OK);
    assert!(text.contains("rf_observations_accepted_total 30"), "{text}");
    assert!(
        text.contains(r#"rf_messages_rejected_total{kind="observation",reason="not_json"} 1"#),
        "{text}"
    );
    assert!(
        text.contains(r#"rf_robot_obs_rate_hz{robot="miro1"}"#),
        "{text}"
    );
    assert!(
        text.contains("rf_obs_to_state_latency_seconds_count 0"),
        "{text}"
    );
    let (s, page) = get(app(live), "/").await;
    assert_eq!(s, StatusCode::OK);
    assert!(page.contains("<html"), "{page}");
}

#[tokio::test(flavor = "multi_thread")]
async fn the_stream_pushes_states_and_a_stuck_client_only_loses_frames() -> anyhow::Result<()> {
    use futures_util::StreamExt;
    let (live, _) = live_with_ball();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let addr = listener.local_addr()?;
    let server = tokio::spawn(axum::serve(listener, app(live.clone())).into_future());
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/api/stream")).await?;
    // The first frame is the current view, sent on connect.
    let first = ws.next().await.expect("a frame")?;
    let v: serde_json::Value = serde_json::from_str(first.to_text()?)?;
    assert!(v["ball"]["position_m"].is_array());
    while live.stats.ws_clients.load(Relaxed) == 0 {
        tokio::task::yield_now().await;
    }
    // A tick's publication: the wire payload and the view, serialised once.
    let publication = live.publication(true);
    assert!(publication.payload.is_some(), "a ball to publish");
    live.broadcast(publication.view.expect("a view for the stream"));
    let next = ws.next().await.expect("a frame")?;
    assert!(next.to_text()?.contains("\"ball\""));
    assert_eq!(live.stats.states_published.load(Relaxed), 1);
    // Publish far more than the client reads (64 KiB frames overflow the socket buffers
    // while the client is not reading); publishing never waits for it.
    let frames = 2000;
    let big: Arc<str> = Arc::from(format!("{{\"pad\":\"{}\"}}", "x".repeat(65_536)));
    for _ in 0..frames {
        live.broadcast(big.clone());
    }
    live.broadcast(Arc::from("{\"last\":true}"));
    let mut got = 0;
    loop {
        let m = ws.next().await.expect("open stream")?;
        if m.to_text()?.contains("\"last\"") {
            break;
        }
        got += 1;
    }
    assert!(got < frames, "a slow client cannot get every frame ({got})");
    let dropped = live.stats.ws_frames_dropped.load(Relaxed);
    assert!(
        dropped > 0 && got + dropped as usize >= frames,
        "got {got}, dropped {dropped}"
    );
    server.abort();
    Ok(())
}

#[tokio::test]
async fn the_state_shows_recent_sightings_with_reasons_and_rejections() {
    let (live, clock) = live_with_ball();
    // A sighting far off the pitch: refused, and shown with the reason.
    let far = Observation {
        version: proto::VERSION,
        robot_id: "miro1".into(),
        seq: 99,
        camera: Camera::Left,
        stamp: Stamp(clock.0.load(Ordering::SeqCst)).offset_secs(-0.02),
        position_m: [4.0, 0.0],
        covariance_m2: [4e-4, 0.0, 0.0, 4e-4],
        confidence: 0.9,
        robot_pose: Pose2::default(),
        pixel: None,
    };
    live.on_observation("rf/robots/miro1/obs", &proto::encode(&far));
    let (s, body) = get(app(live), "/api/state").await;
    assert_eq!(s, StatusCode::OK);
    let v = json(&body);
    let obs = v["observations"].as_array().expect("observations");
    assert_eq!(obs.len(), 31, "the last 2 s: {body}");
    assert!(
        obs[..30]
            .iter()
            .all(|o| o["accepted"] == true && o["reason"].is_null())
    );
    assert_eq!(obs[30]["accepted"], false);
    assert_eq!(obs[30]["reason"], "outside_pitch");
    assert_eq!(obs[30]["covariance_m2"][0], 4e-4);
    assert_eq!(v["rejected"]["observation/not_json"], 1);
    assert_eq!(v["rejected"]["observation/outside_pitch"], 1);
    assert!(v["replay"].is_null());
    let latency_s = v["robots"][0]["latency_s"].as_f64().expect("latency");
    assert!((latency_s - 0.05).abs() < 1e-6, "{latency_s}");
}

/// A state is serialised once per tick: `GET /api/state` serves the published view while
/// it is fresh, and takes a new one once it is not.
#[tokio::test]
async fn the_state_endpoint_serves_the_published_view_while_it_is_fresh() {
    let (live, clock) = live_with_ball();
    // Without a publisher task nothing is cached: each request takes the view now.
    assert!(!Arc::ptr_eq(&live.current_view(), &live.current_view()));
    live.set_view_max_age(std::time::Duration::from_secs(60));
    // Nobody watches the stream: a tick makes no view.
    assert!(live.publication(true).view.is_none());
    let _watcher = live.stream.subscribe();
    let view = live.publication(true).view.expect("a view");
    assert!(Arc::ptr_eq(&live.current_view(), &view));
    let (status, body) = get(app(live.clone()), "/api/state").await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(body, view.to_string());
    // The next tick replaces it.
    let later = Stamp(clock.0.load(Ordering::SeqCst)).offset_secs(0.5);
    clock.0.store(later.0, Ordering::SeqCst);
    let next = live.publication(true).view.expect("a view");
    assert!(!Arc::ptr_eq(&next, &view));
    assert!(Arc::ptr_eq(&live.current_view(), &next));
    // Requests between ticks share one view.
    assert!(Arc::ptr_eq(&live.current_view(), &live.current_view()));
}
