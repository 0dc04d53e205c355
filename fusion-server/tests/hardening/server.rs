#![allow(dead_code)]

//! An in-process server on real loopback Zenoh (explicit port, scouting off) and a real
//! HTTP listener on port 0, and a Zenoh client connected to it.

use fusion_server::{Clock, SystemClock};
use fusion_server::{ServeConfig, Shared};
use proto::net::{NetConfig, free_loopback_port};
use proto::test_support::observation;
use proto::{Observation, Stamp};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

pub fn z(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("{e}")
}

pub fn obs(robot: &str, seq: u64, stamp: Stamp, x_m: f64) -> Observation {
    observation(robot, seq, stamp, [x_m, -0.3])
}

pub fn now() -> Stamp {
    SystemClock.now()
}

/// Polls `f` every 10 ms until it gives a value (20 s at most).
pub async fn eventually<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(tokio::time::Instant::now() < deadline, "timed out: {what}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

/// A running server, stopped by [`TestServer::stop`].
pub struct TestServer {
    pub live: Shared,
    pub endpoint: String,
    pub http: SocketAddr,
    /// The Foxglove WebSocket's address, when served ([`TestServer::start_with_foxglove`]).
    pub foxglove: Option<SocketAddr>,
    pub client: zenoh::Session,
    stop: tokio::sync::watch::Sender<bool>,
    task: tokio::task::JoinHandle<anyhow::Result<()>>,
}

impl TestServer {
    /// Starts a server with `cfg` (its id, Zenoh endpoint and HTTP address are set here)
    /// and connects a client session to it.
    pub async fn start(id: &str, cfg: ServeConfig) -> anyhow::Result<TestServer> {
        Self::start_logged(id, cfg, None).await
    }

    /// [`TestServer::start`] with a match log.
    pub async fn start_logged(
        id: &str,
        cfg: ServeConfig,
        log: Option<Arc<dyn fusion_server::MatchLog>>,
    ) -> anyhow::Result<TestServer> {
        Self::launch(id, cfg, log, Vec::new(), false).await
    }

    /// [`TestServer::start`], also serving the Foxglove WebSocket.
    pub async fn start_with_foxglove(id: &str, cfg: ServeConfig) -> anyhow::Result<TestServer> {
        Self::launch(id, cfg, None, Vec::new(), true).await
    }

    /// [`TestServer::start`] for a server that also connects to `peers` (other servers).
    pub async fn start_joining(id: &str, peers: &[&str]) -> anyhow::Result<TestServer> {
        let peers = peers.iter().map(|p| p.to_string()).collect();
        Self::launch(id, ServeConfig::default(), None, peers, false).await
    }

    async fn launch(
        id: &str,
        cfg: ServeConfig,
        log: Option<Arc<dyn fusion_server::MatchLog>>,
        peers: Vec<String>,
        foxglove: bool,
    ) -> anyhow::Result<TestServer> {
        let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
        let cfg = ServeConfig {
            server_id: id.into(),
            net: NetConfig {
                connect: peers,
                ..NetConfig::listening(&endpoint)
            },
            ..cfg
        };
        let live = fusion_server::shared(&cfg, Arc::new(SystemClock), log)?;
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
        let http = listener.local_addr()?;
        let foxglove = match foxglove {
            true => Some(tokio::net::TcpListener::bind("127.0.0.1:0").await?),
            false => None,
        };
        let foxglove_addr = foxglove.as_ref().map(|l| l.local_addr()).transpose()?;
        let (stop, mut stop_rx) = tokio::sync::watch::channel(false);
        let task = tokio::spawn(fusion_server::serve_all(
            cfg,
            live.clone(),
            listener,
            foxglove,
            async move {
                let _ = stop_rx.wait_for(|s| *s).await;
            },
        ));
        let client = NetConfig::connecting(&endpoint).open().await?;
        Ok(TestServer {
            live,
            endpoint,
            http,
            foxglove: foxglove_addr,
            client,
            stop,
            task,
        })
    }

    /// Puts `payload` on `key` from the client: lost if the link is not up yet (see
    /// [`TestServer::until_accepted`]).
    pub async fn put(
        &self,
        key: &str,
        payload: impl Into<zenoh::bytes::ZBytes>,
    ) -> anyhow::Result<()> {
        // Blocking, not dropping, when the link's queue is full: bursts of large payloads
        // must all arrive.
        self.client
            .put(key, payload)
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .await
            .map_err(z)
    }

    /// Publishes good observations from `robot` until the server has accepted one.
    pub async fn until_accepted(&self, robot: &str) -> anyhow::Result<()> {
        let key = format!("rf/robots/{robot}/obs");
        let mut seq = 0;
        let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
        loop {
            let accepted = self.live.with_engine(|e| {
                e.robots(now())
                    .iter()
                    .any(|r| r.robot_id == robot && r.observations_accepted > 0)
            });
            if accepted {
                return Ok(());
            }
            anyhow::ensure!(
                tokio::time::Instant::now() < deadline,
                "{robot} never accepted"
            );
            self.put(&key, proto::encode(&obs(robot, seq, now(), 0.5)))
                .await?;
            seq += 1;
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    /// The count of `rf_messages_rejected_total{kind,reason}` in /metrics (0 when absent).
    pub fn rejected(&self, kind: &str, reason: &str) -> u64 {
        let line = format!("rf_messages_rejected_total{{kind=\"{kind}\",reason=\"{reason}\"}} ");
        self.live
            .metrics_text()
            .lines()
            .find_map(|l| l.strip_prefix(&line).and_then(|v| v.parse().ok()))
            .unwrap_or(0)
    }

    /// A metric's value (first line starting with `name `), if present.
    pub fn metric(&self, name: &str) -> Option<f64> {
        let prefix = format!("{name} ");
        self.live
            .metrics_text()
            .lines()
            .find_map(|l| l.strip_prefix(&prefix).and_then(|v| v.parse().ok()))
    }

    /// A GET: the status code and the body.
    pub async fn get(&self, path: &str) -> anyhow::Result<(u16, String)> {
        let url = format!("http://{}{path}", self.http);
        tokio::task::spawn_blocking(move || {
            let agent: ureq::Agent = ureq::Agent::config_builder()
                .http_status_as_error(false)
                .timeout_global(Some(Duration::from_secs(10)))
                .build()
                .into();
            let mut answer = agent.get(url).call()?;
            let code = answer.status().as_u16();
            Ok((code, answer.body_mut().read_to_string()?))
        })
        .await?
    }

    pub async fn stop(self) -> anyhow::Result<()> {
        let _ = self.stop.send(true);
        self.task.await??;
        self.client.close().await.map_err(z)
    }
}
