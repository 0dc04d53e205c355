//! The replay's control endpoints over real HTTP (a port-0 listener, the server as
//! `serve` runs it), with the playing loop fed straight into the shared state.

use super::*;
use crate::engine::{Engine, EngineConfig};
use crate::matchlog::read::LogMessage;
use crate::matchlog::record::test_support::logged_observation;
use crate::shell::intake::{InputKind, Intake};
use crate::shell::replay_live::{Deliver, PlayConfig, play};
use futures_util::future::BoxFuture;
use proto::{KeySpace, Stamp};
use std::time::{Duration, Instant};

const T0: Stamp = Stamp(1_800_000_000_000_000_000);
/// The log's length, seconds.
const LOG_S: f64 = 40.0;

/// Where the ball rolls: slowly along x, so a state tells the match time.
fn ball_x_m(t_s: f64) -> f64 {
    -1.5 + 0.07 * t_s
}

/// `LOG_S` seconds of two robots seeing the ball at 10 Hz each.
fn log() -> Vec<LogMessage> {
    (0..(LOG_S * 20.0) as u64 + 1)
        .map(|i| {
            let t_s = i as f64 / 20.0;
            let robot = if i % 2 == 0 { "miro1" } else { "miro2" };
            let at = T0.offset_secs(t_s);
            logged_observation(robot, i, at, 0.03, [ball_x_m(t_s - 0.03), 0.2])
        })
        .collect()
}

/// Hands inputs to the server as the Zenoh subscriber does: observations through its
/// intake (the robots' rate limits, the queue), views straight to the shared state.
struct Direct(Arc<Live>, Arc<Intake>);

impl Deliver for Direct {
    fn deliver<'a>(&'a mut self, m: &'a LogMessage) -> BoxFuture<'a, ()> {
        Box::pin(async move {
            if crate::matchlog::replay::is_view(m) {
                self.0.on_view(&m.topic, &m.data);
            } else {
                self.1.receive(InputKind::Observation, &m.topic, &m.data)
            }
        })
    }
}

struct Replaying {
    addr: SocketAddr,
    live: Arc<Live>,
    stop: tokio::sync::oneshot::Sender<()>,
    player: tokio::task::JoinHandle<usize>,
}

/// A replaying server on a port-0 listener.
async fn replaying(access: ControlAccess) -> Replaying {
    let messages = log();
    let control = Arc::new(
        ReplayControl::new(
            messages[0].log_time,
            messages[messages.len() - 1].log_time,
            1.0,
        )
        .expect("control"),
    );
    let live = Arc::new(Live::new(
        Engine::new(EngineConfig::default()),
        KeySpace::default(),
        control.clock.clone(),
        4,
        false,
        None,
    ));
    live.set_replay(control.clone());
    live.set_control_access(access);
    let addr = serve_http(live.clone()).await;
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let l = live.clone();
    let player = tokio::spawn(async move {
        let cfg = PlayConfig {
            engine: EngineConfig::default(),
            keys: KeySpace::default(),
            stay: true,
        };
        let intake = Intake::start(l.clone()).expect("intake");
        let mut deliver = Direct(l.clone(), intake);
        play(
            l,
            control,
            &messages,
            cfg,
            &mut deliver,
            &mut |_, _| {},
            async {
                stopped.await.ok();
            },
        )
        .await
    });
    Replaying {
        addr,
        live,
        stop,
        player,
    }
}

async fn serve_http(live: Arc<Live>) -> SocketAddr {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("listener");
    let addr = listener.local_addr().expect("address");
    let app = crate::shell::http::app(live).into_make_service_with_connect_info::<SocketAddr>();
    tokio::spawn(axum::serve(listener, app).into_future());
    addr
}

/// One request (`GET` or `POST`): (status, body), whatever the status.
async fn request(
    addr: SocketAddr,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &str,
) -> (u16, String) {
    let url = format!("http://{addr}{path}");
    let (method, body) = (method.to_string(), body.to_string());
    let headers: Vec<(String, String)> = headers
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    tokio::task::spawn_blocking(move || {
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_global(Some(Duration::from_secs(10)))
            .build()
            .into();
        let mut answer = match method.as_str() {
            "GET" => headers
                .iter()
                .fold(agent.get(&url), |r, (k, v)| r.header(k, v))
                .call(),
            "POST" => headers
                .iter()
                .fold(agent.post(&url), |r, (k, v)| r.header(k, v))
                .send(body.as_str()),
            other => panic!("no {other} requests here"),
        }
        .expect("an answer within 10 s");
        let code = answer.status().as_u16();
        (code, answer.body_mut().read_to_string().expect("a body"))
    })
    .await
    .expect("the request's thread")
}

async fn status_of(addr: SocketAddr) -> serde_json::Value {
    let (code, body) = request(addr, "GET", "/api/replay", &[], "").await;
    assert_eq!(code, 200, "{body}");
    serde_json::from_str(&body).expect("JSON")
}

async fn post(addr: SocketAddr, action: &str, body: &str) -> (u16, serde_json::Value) {
    let path = format!("/api/replay/{action}");
    let (code, text) = request(addr, "POST", &path, &[], body).await;
    (code, serde_json::from_str(&text).expect("a JSON answer"))
}

/// Polls `f` every 20 ms for up to 10 s.
async fn eventually<T>(what: &str, mut f: impl AsyncFnMut() -> Option<T>) -> T {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Some(v) = f().await {
            return v;
        }
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

fn ball_x(live: &Live) -> Option<f64> {
    let v: serde_json::Value = serde_json::from_str(&live.view_json()).ok()?;
    v["ball"]["position_m"][0].as_f64()
}

#[tokio::test(flavor = "multi_thread")]
async fn the_replay_pauses_seeks_and_changes_speed_over_http() {
    let r = replaying(ControlAccess::LoopbackOnly).await;
    let s = status_of(r.addr).await;
    assert_eq!(s["paused"], false);
    assert!(
        (s["duration_s"].as_f64().expect("duration") - LOG_S).abs() < 1e-6,
        "{s}"
    );
    eventually("a ball", async || ball_x(&r.live)).await;

    // Paused, the clock stands still.
    let (code, s) = post(r.addr, "pause", "").await;
    assert_eq!(code, 200, "{s}");
    assert_eq!(s["paused"], true);
    let t1 = status_of(r.addr).await["t_s"].as_f64().expect("t_s");
    tokio::time::sleep(Duration::from_millis(150)).await;
    let t2 = status_of(r.addr).await["t_s"].as_f64().expect("t_s");
    assert_eq!(t1, t2);

    // A seek moves the clock and re-fuses the log up to there.
    let (code, s) = post(r.addr, "seek", r#"{"t_s": 30}"#).await;
    assert_eq!(code, 200, "{s}");
    assert!((s["t_s"].as_f64().expect("t_s") - 30.0).abs() < 1e-6, "{s}");
    let x = eventually("the ball at 30 s", async || {
        ball_x(&r.live).filter(|x| (x - ball_x_m(30.0)).abs() < 0.1)
    })
    .await;
    assert!((x - ball_x_m(30.0)).abs() < 0.1, "{x}");
    let accepted = r.live.with_engine(|e| e.counters().observations_accepted);
    assert!(
        (590..=605).contains(&accepted),
        "re-fused up to 30 s: {accepted}"
    );
    // Back in time, too.
    let (code, _) = post(r.addr, "seek", r#"{"t_s": 5.5}"#).await;
    assert_eq!(code, 200);
    eventually("the ball at 5.5 s", async || {
        ball_x(&r.live).filter(|x| (x - ball_x_m(5.5)).abs() < 0.1)
    })
    .await;

    // Faster, then playing: the clock runs at the new speed.
    let (code, s) = post(r.addr, "speed", r#"{"speed": 4}"#).await;
    assert_eq!((code, s["speed"].as_f64()), (200, Some(4.0)), "{s}");
    let (code, _) = post(r.addr, "play", "").await;
    assert_eq!(code, 200);
    assert_eq!(status_of(r.addr).await["paused"], false);
    let (wall, t1) = (Instant::now(), r.live.clock.now());
    tokio::time::sleep(Duration::from_millis(500)).await;
    let rate = r.live.clock.now().secs_since(t1) / wall.elapsed().as_secs_f64();
    assert!(
        (3.9..=4.1).contains(&rate),
        "match seconds per second: {rate}"
    );
    eventually("the ball following the clock", async || {
        let t_s = r.live.clock.now().secs_since(T0);
        ball_x(&r.live).filter(|x| (x - ball_x_m(t_s)).abs() < 0.1)
    })
    .await;

    // Near the end, it plays out and stands at the end.
    let (code, _) = post(r.addr, "seek", r#"{"t_s": 39}"#).await;
    assert_eq!(code, 200);
    let s = eventually("the end", async || {
        let s = status_of(r.addr).await;
        (s["ended"] == true).then_some(s)
    })
    .await;
    assert_eq!(s["paused"], true, "{s}");
    assert!((s["t_s"].as_f64().expect("t_s") - LOG_S).abs() < 0.2, "{s}");

    r.stop.send(()).ok();
    let delivered = tokio::time::timeout(Duration::from_secs(5), r.player)
        .await
        .expect("the loop stops on shutdown")
        .expect("no panic");
    assert!(delivered > 0);
}

#[tokio::test(flavor = "multi_thread")]
async fn bad_control_requests_are_explained() {
    let r = replaying(ControlAccess::LoopbackOnly).await;
    for (action, body, want) in [
        ("speed", r#"{"speed": 0}"#, 400),
        ("speed", r#"{"speed": 1000}"#, 400),
        ("speed", r#"{"speed": "fast"}"#, 400),
        ("speed", "", 400),
        ("seek", r#"{"t_s": -1}"#, 400),
        ("seek", r#"{"t_s": 41}"#, 400),
        ("seek", r#"{"t": 3}"#, 400),
        ("seek", "not json", 400),
        ("rewind", "", 404),
    ] {
        let (code, v) = post(r.addr, action, body).await;
        assert_eq!(code, want, "{action} {body}: {v}");
        assert!(v["error"].is_string(), "{v}");
    }
    // A page of another origin cannot steer it through the coach's browser.
    let (code, body) = request(
        r.addr,
        "POST",
        "/api/replay/pause",
        &[("Origin", "http://evil.example")],
        "",
    )
    .await;
    assert_eq!(code, 403, "{body}");
    assert_eq!(status_of(r.addr).await["paused"], false);
    let (code, _) = request(r.addr, "GET", "/api/replay/pause", &[], "").await;
    assert_eq!(code, 405);
    r.stop.send(()).ok();
}

#[tokio::test(flavor = "multi_thread")]
async fn a_control_token_is_required_when_set() {
    let r = replaying(ControlAccess::Token("s3cret-token".into())).await;
    for auth in [None, Some("Bearer wrong-token"), Some("s3cret-token")] {
        let headers: Vec<(&str, &str)> = auth.iter().map(|a| ("Authorization", *a)).collect();
        let (code, body) = request(r.addr, "POST", "/api/replay/pause", &headers, "").await;
        assert_eq!(code, 401, "{auth:?}: {body}");
    }
    let auth = [("Authorization", "Bearer s3cret-token")];
    let (code, body) = request(r.addr, "POST", "/api/replay/pause", &auth, "").await;
    assert_eq!(code, 200, "{body}");
    assert_eq!(status_of(r.addr).await["paused"], true);
    r.stop.send(()).ok();
}

#[test]
fn without_a_token_only_this_machine_may_steer() {
    let mut headers = HeaderMap::new();
    headers.insert(
        header::HOST,
        header::HeaderValue::from_static("127.0.0.1:8080"),
    );
    let access = ControlAccess::LoopbackOnly;
    let local: SocketAddr = "127.0.0.1:5000".parse().expect("address");
    let remote: SocketAddr = "192.0.2.7:5000".parse().expect("address");
    assert!(allowed(&access, &headers, Some(local)).is_ok());
    // A site's own name pointed at this machine (DNS rebinding) is refused.
    let mut rebound = HeaderMap::new();
    rebound.insert(
        header::HOST,
        header::HeaderValue::from_static("evil.example:8080"),
    );
    assert!(allowed(&access, &rebound, Some(local)).is_err());
    for host in ["localhost:8080", "[::1]:8080", "127.0.0.1", "LOCALHOST"] {
        assert!(loopback_host(host), "{host}");
    }
    for host in [
        "evil.example",
        "192.0.2.7:80",
        "localhost.evil.example:80",
        "[::2]:80",
    ] {
        assert!(!loopback_host(host), "{host}");
    }
    let refused = allowed(&access, &headers, Some(remote)).expect_err("refused");
    assert_eq!(refused.status, StatusCode::FORBIDDEN);
    assert!(allowed(&access, &headers, None).is_err());
    // With a token, the token decides, wherever the request comes from.
    let token = ControlAccess::Token("s3cret-token".into());
    let mut with = HeaderMap::new();
    with.insert(
        header::AUTHORIZATION,
        header::HeaderValue::from_static("Bearer s3cret-token"),
    );
    assert!(allowed(&token, &with, Some(remote)).is_ok());
    assert!(allowed(&token, &headers, Some(local)).is_err());
    assert!(allowed(&token, &HeaderMap::new(), Some(local)).is_err());
}

#[tokio::test(flavor = "multi_thread")]
async fn a_live_server_says_it_is_not_replaying() {
    let live = Arc::new(Live::new(
        Engine::new(EngineConfig::default()),
        KeySpace::default(),
        Arc::new(crate::clock::SystemClock),
        4,
        false,
        None,
    ));
    let addr = serve_http(live).await;
    let (code, body) = request(addr, "GET", "/api/replay", &[], "").await;
    assert_eq!(code, 404, "{body}");
    let (code, body) = request(addr, "POST", "/api/replay/pause", &[], "").await;
    assert_eq!(code, 404, "{body}");
}

/// Fifty seeks at random, with pauses and speed changes between them, leave the replay
/// serving what a straight replay of the same stretch serves: every recorded observation
/// after the last seek is fused (none refused as over a robot's rate, whichever way the
/// clock jumped) and the ball is where the log has it.
#[tokio::test(flavor = "multi_thread")]
async fn fifty_random_seeks_serve_what_a_straight_replay_does() {
    let r = replaying(ControlAccess::LoopbackOnly).await;
    eventually("a ball", async || ball_x(&r.live)).await;
    let mut rng = proto::rng::Rng::new(48);
    for _ in 0..50 {
        let t_s = rng.range(0.0, LOG_S - 1.0);
        let (code, s) = post(r.addr, "seek", &format!(r#"{{"t_s": {t_s}}}"#)).await;
        assert_eq!(code, 200, "{s}");
        if rng.chance(0.3) {
            let speed = [0.5, 1.0, 4.0, 16.0, 64.0][rng.index(5)];
            post(r.addr, "speed", &format!(r#"{{"speed": {speed}}}"#)).await;
        }
        let action = if rng.chance(0.3) { "pause" } else { "play" };
        post(r.addr, action, "").await;
        tokio::time::sleep(Duration::from_millis(rng.range(5.0, 60.0) as u64)).await;
    }
    // The stretch to compare: from 30 s, four seconds at four times real time.
    post(r.addr, "pause", "").await;
    post(r.addr, "speed", r#"{"speed": 4}"#).await;
    post(r.addr, "seek", r#"{"t_s": 30}"#).await;
    eventually("the ball at 30 s", async || {
        ball_x(&r.live).filter(|x| (x - ball_x_m(30.0)).abs() < 0.1)
    })
    .await;
    let refused_before = rate_limited(&r.live);
    post(r.addr, "play", "").await;
    tokio::time::sleep(Duration::from_millis(1000)).await;
    post(r.addr, "pause", "").await;
    let t_s = status_of(r.addr).await["t_s"].as_f64().expect("t_s");
    assert!((33.0..=36.0).contains(&t_s), "{t_s}");
    // Everything recorded up to the clock, less what may still be on its way.
    let logged = (t_s * 20.0).floor() as u64 + 1;
    let accepted = eventually("the stretch fused", async || {
        let n = r.live.with_engine(|e| e.counters().observations_accepted);
        (n + 2 >= logged).then_some(n)
    })
    .await;
    assert!(accepted <= logged, "{accepted} of {logged}");
    assert_eq!(
        rate_limited(&r.live),
        refused_before,
        "none refused for its rate"
    );
    assert_eq!(refused_before, 0, "not after any of the fifty seeks either");
    let x = ball_x(&r.live).expect("a ball");
    assert!(
        (x - ball_x_m(t_s)).abs() < 0.1,
        "{x} against {}",
        ball_x_m(t_s)
    );
    r.stop.send(()).ok();
}

/// Observations refused as over their robot's rate, so far.
fn rate_limited(live: &Live) -> u64 {
    let v: serde_json::Value = serde_json::from_str(&live.view_json()).expect("a view");
    v["rejected"]
        .as_object()
        .map(|m| {
            m.iter()
                .filter(|(k, _)| k.ends_with("rate_limited"))
                .filter_map(|(_, n)| n.as_u64())
                .sum()
        })
        .unwrap_or(0)
}
