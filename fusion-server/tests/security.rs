//! A secured network on real processes: `fusion-server keys` makes the certificates, a
//! `fusion-server serve --tls` process fuses, and Zenoh sessions over loopback TLS play an
//! honest robot and three impostors, straight to the server and through a router: a
//! router-mode session loading the `zenohd.json5` that `keys` wrote, as `zenohd` does, or,
//! with `RF_ZENOHD=/path/to/zenohd`, the real `zenohd` process.
//!
//! - an impostor with no certificate (plain TCP) and one whose certificate another
//!   authority signed never get a link;
//! - a genuine robot (miro2) that publishes as miro1, forges ball states and answers
//!   predictions is stopped by the access-control list: the server receives none of it,
//!   and the honest robot sees no forged state or answer;
//! - the honest robot's observations arrive, every one, and it receives the ball.

mod support;

use fusion_server::{Clock, SystemClock};
use proto::net::{NetConfig, TlsFiles, free_loopback_port};
use std::path::Path;
use std::process::Command;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use support::{BIN, Proc, get_json, http_get, start_server_on, wait_for};

const HONEST: [f64; 2] = [0.8, -0.3];
const FORGED: [f64; 2] = [-0.9, 0.5];
const MARK: &str = "FORGED-BY-IMPOSTOR";

fn keys(out: &Path, args: &[&str]) {
    let o = Command::new(BIN)
        .arg("keys")
        .arg("--out")
        .arg(out)
        .args(args)
        .output()
        .expect("runs fusion-server keys");
    assert!(
        o.status.success(),
        "keys: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn metric(addr: &str, name: &str) -> f64 {
    let (code, body) = http_get(addr, "/metrics").expect("GET /metrics");
    assert_eq!(code, 200);
    body.lines()
        .find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.parse().ok())
        .unwrap_or_else(|| panic!("no {name} in /metrics"))
}

/// Whether the server's `/metrics` has a row for `robot` (it has accepted one of its
/// observations).
fn heard_from(addr: &str, robot: &str) -> bool {
    let (code, body) = http_get(addr, "/metrics").expect("GET /metrics");
    code == 200 && body.contains(&format!("rf_robot_obs_rate_hz{{robot=\"{robot}\"}}"))
}

/// A session joining at `endpoint` as `mode` (peer, or client of a router).
async fn session(endpoint: &str, tls: Option<&Path>, mode: &str) -> zenoh::Session {
    NetConfig {
        mode: mode.into(),
        connect: vec![endpoint.to_string()],
        tls: tls.map(TlsFiles::in_dir),
        ..NetConfig::default()
    }
    .open()
    .await
    .expect("session opens (links come up, or not, in the background)")
}

/// A valid camera view of `robot`'s left camera, captured now.
fn camera_view(robot: &str, seq: u64) -> Vec<u8> {
    let v = proto::test_support::camera_view(robot, proto::Camera::Left, seq, SystemClock.now());
    proto::encode(&v)
}

fn obs(robot: &str, seq: u64, at: [f64; 2]) -> Vec<u8> {
    let o = proto::test_support::observation(robot, seq, SystemClock.now(), at);
    proto::encode(&o)
}

async fn put(p: &zenoh::pubsub::Publisher<'_>, payload: Vec<u8>) {
    p.put(payload).await.expect("put");
}

async fn publisher(s: &zenoh::Session, key: &str) -> zenoh::pubsub::Publisher<'static> {
    s.declare_publisher(key.to_string())
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .await
        .expect("publisher")
}

/// The scenario: the server's HTTP at `addr`, robots and impostors joining at `endpoint`
/// (the server's, or a router's) as `mode`, certificates in `dir` and a foreign
/// authority's in `foreign`.
async fn impostors_are_refused(addr: &str, endpoint: &str, mode: &str, dir: &Path, foreign: &Path) {
    let plain_endpoint = endpoint.replacen("tls/", "tcp/", 1);
    let honest = session(endpoint, Some(&dir.join("robot-miro1")), mode).await;
    let genuine_other = session(endpoint, Some(&dir.join("robot-miro2")), mode).await;
    // Peers, so that opening does not fail when the link is refused.
    let foreign_ca = session(endpoint, Some(&foreign.join("robot-miro1")), "peer").await;
    let plain = session(&plain_endpoint, None, "peer").await;

    // What the honest robot receives on the ball.
    let states: Arc<Mutex<Vec<Vec<u8>>>> = Arc::default();
    let s = states.clone();
    let _sub = honest
        .declare_subscriber("rf/ball/state")
        .callback(move |sample| {
            if let Ok(mut v) = s.lock() {
                v.push(sample.payload().to_bytes().to_vec());
            }
        })
        .await
        .expect("subscriber");
    let _token = honest
        .liveliness()
        .declare_token("rf/robots/miro1")
        .await
        .expect("token");
    let own = publisher(&honest, "rf/robots/miro1/obs").await;
    let other_own = publisher(&genuine_other, "rf/robots/miro2/obs").await;

    // Both genuine robots' observations until the server's ball comes back to the honest
    // one and the server has heard miro2 too: on a loaded machine a TLS link can come up
    // seconds after its session opened.
    let (mut honest_sent, mut seq) = (0u64, 0u64);
    let deadline = tokio::time::Instant::now() + Duration::from_secs(45);
    let mut other_seq = 1_000u64;
    loop {
        let ball_back = states.lock().map(|v| !v.is_empty()).unwrap_or(false);
        if ball_back && heard_from(addr, "miro2") {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the links did not come up: ball state back to miro1: {ball_back}; {} of \
             {honest_sent} observations reached the server",
            metric(addr, "rf_inputs_received_total")
        );
        put(&own, obs("miro1", seq, HONEST)).await;
        put(&other_own, obs("miro2", other_seq, HONEST)).await;
        (honest_sent, seq, other_seq) = (honest_sent + 1, seq + 1, other_seq + 1);
        tokio::time::sleep(Duration::from_millis(30)).await;
    }

    // Those sent before the link was up are lost: count from here.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let before = metric(addr, "rf_inputs_received_total");
    let accepted_before = metric(addr, "rf_observations_accepted_total");
    honest_sent = 0;

    // The impostors: publish as miro1, forge the ball, answer predictions.
    let forged_queries = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let fq = forged_queries.clone();
    let _fake_predict = genuine_other
        .declare_queryable("rf/ball/predict")
        .callback(move |q| {
            fq.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let _ = zenoh::Wait::wait(q.reply("rf/ball/predict", MARK));
        })
        .await
        .expect("queryable (declared; the access list keeps it from the others)");
    let mut impostor_puts = 0u64;
    let mut legit_other = 0u64;
    for (i, s) in [&genuine_other, &foreign_ca, &plain]
        .into_iter()
        .enumerate()
    {
        let as_miro1 = publisher(s, "rf/robots/miro1/obs").await;
        let ball = publisher(s, "rf/ball/state").await;
        let status = publisher(s, "rf/robots/miro1/status").await;
        let view = publisher(s, "rf/robots/miro1/view/left").await;
        for k in 0..40 {
            put(&as_miro1, obs("miro1", 10_000 + k, FORGED)).await;
            put(&ball, format!("{{\"mark\":\"{MARK}\"}}").into_bytes()).await;
            put(&status, MARK.as_bytes().to_vec()).await;
            put(&view, camera_view("miro1", k)).await;
            impostor_puts += 4;
        }
        if i == 0 {
            // miro2 may still speak for itself.
            let mine = publisher(s, "rf/robots/miro2/obs").await;
            for k in 0..20 {
                put(&mine, obs("miro2", other_seq + k, HONEST)).await;
                legit_other += 1;
            }
            let own_view = publisher(s, "rf/robots/miro2/view/left").await;
            put(&own_view, camera_view("miro2", 0)).await;
        }
    }

    // The honest robot asks for a prediction: only the server answers. The server's
    // queryable reaches the robot through the router once its route is declared, which on
    // a loaded machine may be after the first ask: asked again, a few times at most.
    let mut answers = Vec::new();
    for _ in 0..5 {
        let replies = honest
            .get("rf/ball/predict?t=0.5")
            .timeout(Duration::from_secs(5))
            .await
            .expect("query");
        while let Ok(r) = replies.recv_async().await {
            if let Ok(s) = r.result() {
                answers.push(s.payload().to_bytes().to_vec());
            }
        }
        if !answers.is_empty() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
    }
    assert!(!answers.is_empty(), "the server answers the prediction");
    for a in &answers {
        assert!(
            !String::from_utf8_lossy(a).contains(MARK),
            "a forged answer reached the robot"
        );
        proto::decode::<proto::Prediction>(a).expect("the server's prediction");
    }
    assert_eq!(
        forged_queries.load(std::sync::atomic::Ordering::Relaxed),
        0,
        "the honest robot's query reached the impostor's queryable"
    );

    // More honest observations after the attack; all of them, and nothing else, arrive.
    for _ in 0..30 {
        put(&own, obs("miro1", seq, HONEST)).await;
        (honest_sent, seq) = (honest_sent + 1, seq + 1);
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let expected = (honest_sent + legit_other) as f64;
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    loop {
        let got = metric(addr, "rf_inputs_received_total") - before;
        if got >= expected {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "timed out waiting for every honest observation: {got} of {expected} arrived"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let received = metric(addr, "rf_inputs_received_total") - before;
    println!(
        "after the links were up: sent {honest_sent} honest + {legit_other} of miro2's own, \
         {impostor_puts} by impostors; the server received {received}"
    );
    assert_eq!(
        received, expected,
        "only the honest inputs reached the server"
    );
    assert_eq!(
        metric(addr, "rf_observations_accepted_total") - accepted_before,
        expected
    );

    // A robot's camera view is its own: miro2's is kept, none of the impostors' as miro1.
    wait_for("miro2's own view", Duration::from_secs(10), || {
        let (code, _) = http_get(addr, "/api/robots/miro2/view/left").ok()?;
        (code == 200).then_some(())
    });
    let (code, _) = http_get(addr, "/api/robots/miro1/view/left").expect("HTTP");
    assert_eq!(code, 404, "an impostor's view of miro1 was kept");
    assert_eq!(metric(addr, "rf_camera_views_received_total"), 1.0);

    // The server's ball is the honest one, and so is every state the robot got.
    let state = get_json(addr, "/api/state");
    let x = state["ball"]["position_m"][0].as_f64().unwrap_or(f64::NAN);
    assert!((x - HONEST[0]).abs() < 0.1, "server's ball: {state}");
    let got = states.lock().map(|v| v.clone()).unwrap_or_default();
    assert!(!got.is_empty());
    for payload in &got {
        assert!(
            !String::from_utf8_lossy(payload).contains(MARK),
            "a forged state reached the honest robot"
        );
        let s: proto::BallState = proto::decode(payload).expect("the server's state");
        assert!(
            (s.position_m[0] - FORGED[0]).abs() > 0.5,
            "{:?}",
            s.position_m
        );
    }
    for s in [honest, genuine_other, foreign_ca, plain] {
        let _ = s.close().await;
    }
}

/// Server `main`, secured with its folder in `dir`, on a TLS endpoint.
fn start_server(dir: &Path, extra: &[&str]) -> (Proc, String, String) {
    let tls = dir.join("server-main").to_string_lossy().into_owned();
    let security = ["--id", "main", "--tls", &tls, "--roster", "miro1,miro2"];
    start_server_on("tls", &security, extra)
}

#[tokio::test(flavor = "multi_thread")]
async fn impostors_never_reach_a_secured_server_or_its_robots() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let (dir, foreign) = (tmp.path().join("keys"), tmp.path().join("foreign"));
    keys(&dir, &["--robots", "miro1,miro2", "--servers", "main"]);
    keys(&foreign, &["--robots", "miro1"]);
    // Without certificates, or a roster, or --open, serve refuses to start.
    let o = Command::new(BIN)
        .args(["serve", "--http", "127.0.0.1:0"])
        .output()
        .expect("runs");
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--open"));

    let (_server, endpoint, addr) = start_server(&dir, &[]);
    impostors_are_refused(&addr, &endpoint, "peer", &dir, &foreign).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn impostors_never_get_through_a_router_with_the_generated_configuration() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let (dir, foreign) = (tmp.path().join("keys"), tmp.path().join("foreign"));
    let router_endpoint = format!("tls/127.0.0.1:{}", free_loopback_port().expect("port"));
    keys(
        &dir,
        &[
            "--robots",
            "miro1,miro2",
            "--servers",
            "main",
            "--routers",
            "r1",
            "--router-listen",
            &router_endpoint,
        ],
    );
    keys(&foreign, &["--robots", "miro1"]);
    let config_file = dir.join("router-r1/zenohd.json5");
    let router = Router::start(&config_file, &router_endpoint).await;

    // The server joins the router as a peer, trusting it; robots are the router's clients
    // (two peers that only meet through a router, with gossip off, never hear each other).
    let (_server, _own_endpoint, addr) =
        start_server(&dir, &["--connect", &router_endpoint, "--routers", "r1"]);
    impostors_are_refused(&addr, &router_endpoint, "client", &dir, &foreign).await;
    router.stop().await;
}

/// The router: `zenohd` itself when `RF_ZENOHD` names it, else a router-mode session.
enum Router {
    Zenohd(std::process::Child),
    InProcess(zenoh::Session),
}

impl Router {
    async fn start(config_file: &Path, endpoint: &str) -> Router {
        match std::env::var_os("RF_ZENOHD") {
            Some(bin) => {
                let child = Command::new(bin)
                    .arg("--config")
                    .arg(config_file)
                    .stdout(std::process::Stdio::null())
                    .spawn()
                    .expect("RF_ZENOHD runs");
                println!("router: zenohd process {}", child.id());
                let router = Router::Zenohd(child);
                let addr = endpoint.trim_start_matches("tls/").to_string();
                wait_for("zenohd listening", Duration::from_secs(20), || {
                    std::net::TcpStream::connect(&addr).ok()
                });
                router
            }
            None => {
                let config = zenoh::Config::from_file(config_file)
                    .expect("zenohd.json5 loads as a Zenoh configuration");
                Router::InProcess(zenoh::open(config).await.expect("router starts"))
            }
        }
    }

    async fn stop(self) {
        if let Router::InProcess(s) = &self {
            let _ = s.close().await;
        }
    }
}

impl Drop for Router {
    fn drop(&mut self) {
        if let Router::Zenohd(c) = self {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Which Zenoh modes hear each other through a `zenohd` router, on plain TCP: two peers
/// that meet only at the router (gossip off) do not; a client with anything does. Needs
/// `RF_ZENOHD=/path/to/zenohd`.
#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs zenohd: RF_ZENOHD=/path/to/zenohd cargo test -p fusion-server --test security -- --ignored"]
async fn which_modes_meet_through_zenohd() {
    let bin = std::env::var_os("RF_ZENOHD").expect("RF_ZENOHD names the zenohd binary");
    let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port().expect("port"));
    let mut router = Command::new(bin)
        .args(["--listen", &endpoint, "--no-multicast-scouting"])
        .stdout(std::process::Stdio::null())
        .spawn()
        .expect("zenohd runs");
    tokio::time::sleep(Duration::from_millis(800)).await;
    let mut heard = Vec::new();
    for (from, to) in [
        ("peer", "peer"),
        ("client", "peer"),
        ("peer", "client"),
        ("client", "client"),
    ] {
        let sub_session = session(&endpoint, None, to).await;
        let pub_session = session(&endpoint, None, from).await;
        let key = format!("modes/{from}/{to}");
        let sub = sub_session
            .declare_subscriber(key.clone())
            .await
            .expect("sub");
        let p = publisher(&pub_session, &key).await;
        tokio::time::sleep(Duration::from_millis(500)).await;
        for k in 0..20u8 {
            put(&p, vec![k]).await;
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
        let mut n = 0;
        while let Ok(Some(_)) = sub.try_recv() {
            n += 1;
        }
        println!("{from} publishes, {to} subscribes, through zenohd: {n} of 20");
        heard.push(n);
        let _ = pub_session.close().await;
        let _ = sub_session.close().await;
    }
    let _ = router.kill();
    let _ = router.wait();
    assert_eq!(heard, [0, 20, 20, 20]);
}
