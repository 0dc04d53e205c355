//! The live server: Zenoh subscribers, publisher, queryable and liveliness around the shared
//! state, the HTTP server, and the loop that publishes the ball state.

use crate::clock::Clock;
use crate::engine::{Engine, EngineConfig};
use crate::matchlog::MatchLog;
use crate::query;
use crate::shell::http::guard::{GuardedListener, HttpLimits, connection_cap};
use crate::shell::intake::{InputKind, Intake};
use crate::shell::live::{ControlAccess, Live};
use crate::shell::net::NetConfig;
use anyhow::{Context, Result};
use axum::serve::ListenerExt;
use proto::KeySpace;
use std::future::Future;
use std::sync::Arc;
use std::time::Duration;
use zenoh::Wait;
use zenoh::sample::SampleKind;

/// Everything a serving process needs to know.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    pub server_id: String,
    /// HTTP address (the caller binds it and hands the listener to [`serve`]).
    pub http: String,
    pub prefix: String,
    pub net: NetConfig,
    /// States published per second on `{prefix}/ball/state` and the live stream.
    pub state_rate_hz: f64,
    /// Also publish right after accepted observations (coalesced), for the lowest latency.
    pub publish_on_update: bool,
    /// Frames a live-stream client may fall behind before it skips.
    pub stream_buffer: usize,
    pub engine: EngineConfig,
    /// Token the control endpoints (`POST /api/replay/…`) require as
    /// `Authorization: Bearer TOKEN`; without one, only this machine may use them.
    pub control_token: Option<String>,
    /// Connection cap and deadlines of the HTTP side.
    pub http_limits: HttpLimits,
    /// Other servers (standby) the access-control list trusts, when links are TLS.
    pub servers: Vec<String>,
    /// `zenohd` routers the access-control list trusts, when links are TLS.
    pub routers: Vec<String>,
    /// Serve an open network (plain TCP, anyone may publish) knowingly: `serve` refuses
    /// to start without TLS otherwise.
    pub open: bool,
    /// Where the Foxglove WebSocket is served (`shell::foxglove`); None: it is not.
    pub foxglove: Option<std::net::SocketAddr>,
    /// Bounds on the robots' camera views.
    pub views: crate::camera_views::ViewLimits,
    /// Whether the match log keeps the camera views (`[record] views`).
    pub record_views: bool,
}

impl Default for ServeConfig {
    fn default() -> Self {
        ServeConfig {
            server_id: "server-1".into(),
            http: "127.0.0.1:8080".into(),
            prefix: proto::DEFAULT_PREFIX.into(),
            net: NetConfig::listening("tcp/127.0.0.1:7447"),
            state_rate_hz: 30.0,
            publish_on_update: false,
            stream_buffer: 8,
            engine: EngineConfig::default(),
            control_token: None,
            http_limits: HttpLimits::default(),
            servers: Vec::new(),
            routers: Vec::new(),
            open: false,
            foxglove: None,
            views: crate::camera_views::ViewLimits::default(),
            record_views: true,
        }
    }
}

impl ServeConfig {
    /// Refuses an open network unless asked for one (`--open`), and a secured one without
    /// a roster (the access-control list admits robots by name).
    pub fn check_security(&self) -> Result<()> {
        if self.net.is_secured() {
            anyhow::ensure!(
                self.engine.roster.is_some(),
                "TLS needs a roster (--roster ID,ID or `roster = [...]`): the access-control \
                 list admits robots by the name in their certificate"
            );
        } else {
            anyhow::ensure!(
                self.open,
                "no TLS: anyone who reaches the Zenoh endpoints could publish a ball. Give the \
                 certificates `fusion-server keys` made (--tls DIR, with --roster), or --open \
                 for an open lab network (docs/operations.md, \"Deploy on several machines \
                 securely\")"
            );
        }
        Ok(())
    }

    /// The Zenoh session: the links of `net` and, when they are TLS, the access-control
    /// list generated from the roster, the trusted servers (this one included) and routers.
    pub async fn open_session(&self) -> Result<zenoh::Session> {
        let mut z = self.net.zenoh_config()?;
        if self.net.is_secured() {
            let robots: Vec<String> = self.engine.roster.iter().flatten().cloned().collect();
            let mut servers = self.servers.clone();
            servers.push(self.server_id.clone());
            let roster = crate::security::acl::Roster {
                prefix: &self.prefix,
                robots: &robots,
                servers: &servers,
                routers: &self.routers,
            };
            crate::security::acl::install(&mut z, &roster).map_err(anyhow::Error::msg)?;
        }
        zenoh::open(z)
            .await
            .map_err(|e| anyhow::anyhow!("opening the Zenoh session: {e}"))
    }
}

/// A running server's handle on its shared state (tests and the demo look through it).
pub type Shared = Arc<Live>;

/// Builds the shared state for `cfg`.
pub fn shared(
    cfg: &ServeConfig,
    clock: Arc<dyn Clock>,
    log: Option<Arc<dyn MatchLog>>,
) -> Result<Shared> {
    let keys = KeySpace::new(&cfg.prefix).context("bad key prefix")?;
    let live = Live::new(
        Engine::new(cfg.engine.clone()),
        keys,
        clock,
        cfg.stream_buffer,
        cfg.publish_on_update,
        log,
    );
    live.views
        .configure(live.keys.clone(), cfg.views, cfg.record_views);
    live.set_control_access(match &cfg.control_token {
        Some(t) => ControlAccess::Token(t.clone()),
        None => ControlAccess::LoopbackOnly,
    });
    live.set_ws_send_timeout(crate::shell::http::guard::secs(
        cfg.http_limits.ws_send_timeout_s,
    ));
    Ok(Arc::new(live))
}

/// How long a starting server waits for its first Zenoh link before it looks for another
/// server with its id.
const LINK_WAIT: Duration = Duration::from_secs(2);
/// How long it waits for an answer to that question.
const DUPLICATE_QUERY_TIMEOUT: Duration = Duration::from_secs(1);

/// Fails when a server with the same id already holds `{prefix}/servers/{id}` on this Zenoh
/// network: two servers with one id would both publish the ball as that server.
async fn refuse_duplicate_id(
    session: &zenoh::Session,
    cfg: &ServeConfig,
    server_key: &str,
) -> Result<()> {
    // Links to the endpoints we connect to come up in the background: give them a moment,
    // or the question reaches nobody.
    if !cfg.net.connect.is_empty() {
        let deadline = tokio::time::Instant::now() + LINK_WAIT;
        loop {
            let info = session.info();
            let linked = info.peers_zid().await.next().is_some()
                || info.routers_zid().await.next().is_some();
            if linked || tokio::time::Instant::now() >= deadline {
                break;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
    let replies = session
        .liveliness()
        .get(server_key)
        .timeout(DUPLICATE_QUERY_TIMEOUT)
        .await
        .map_err(|e| anyhow::anyhow!("asking for other servers: {e}"))?;
    while let Ok(reply) = replies.recv_async().await {
        if reply.result().is_ok() {
            anyhow::bail!(
                "another fusion server with id {:?} is already on this Zenoh network \
                 (its liveliness token {server_key} answers); give this one another --id",
                cfg.server_id
            );
        }
    }
    Ok(())
}

/// Serves until `shutdown` resolves: Zenoh in and out on `cfg.net`, HTTP on `http`.
pub async fn serve(
    cfg: ServeConfig,
    live: Shared,
    http: tokio::net::TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<()> {
    serve_all(cfg, live, http, None, shutdown).await
}

/// [`serve`], and the Foxglove WebSocket on `foxglove` when given.
pub async fn serve_all(
    cfg: ServeConfig,
    live: Shared,
    http: tokio::net::TcpListener,
    foxglove: Option<tokio::net::TcpListener>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<()> {
    anyhow::ensure!(
        cfg.state_rate_hz.is_finite() && cfg.state_rate_hz > 0.0,
        "state rate must be positive, got {}",
        cfg.state_rate_hz
    );
    let session = cfg.open_session().await?;
    let keys = live.keys.clone();

    let intake = Intake::start(live.clone()).context("starting the intake thread")?;
    let i = intake.clone();
    let _obs = session
        .declare_subscriber(keys.all_obs())
        .callback(move |s| {
            let payload = s.payload().to_bytes();
            i.receive(InputKind::Observation, s.key_expr().as_str(), &payload);
        })
        .await
        .map_err(|e| anyhow::anyhow!("subscribing to observations: {e}"))?;
    let i = intake.clone();
    let _status = session
        .declare_subscriber(keys.all_status())
        .callback(move |s| {
            let payload = s.payload().to_bytes();
            i.receive(InputKind::Status, s.key_expr().as_str(), &payload);
        })
        .await
        .map_err(|e| anyhow::anyhow!("subscribing to statuses: {e}"))?;
    let l = live.clone();
    let _views = session
        .declare_subscriber(keys.all_views())
        .callback(move |s| {
            let payload = s.payload().to_bytes();
            l.on_view(s.key_expr().as_str(), &payload);
        })
        .await
        .map_err(|e| anyhow::anyhow!("subscribing to camera views: {e}"))?;
    let (l, i) = (live.clone(), intake.clone());
    let _alive = session
        .liveliness()
        .declare_subscriber(keys.all_robot_liveliness())
        .history(true)
        .callback(move |s| {
            let (key, alive) = (s.key_expr().as_str(), s.kind() == SampleKind::Put);
            if alive {
                i.liveliness(key);
            }
            l.on_liveliness(key, alive)
        })
        .await
        .map_err(|e| anyhow::anyhow!("subscribing to robot liveliness: {e}"))?;
    let l = live.clone();
    let _queryable = session
        .declare_queryable(keys.ball_predict())
        .callback(move |q| {
            let sized = query::check_size(q.parameters().as_str());
            if sized.is_err() {
                l.count_rejection("query", "too_large");
            }
            let parsed = sized.and_then(|()| query::parse(q.parameters().iter()));
            let result = parsed.and_then(|p| l.query(&p));
            let sent = match result {
                Ok(reply) => q.reply(q.key_expr().clone(), reply.to_json()).wait(),
                Err(e) => q.reply_err(e.to_string()).wait(),
            };
            if let Err(e) = sent {
                tracing::debug!("query reply failed: {e}");
            }
        })
        .await
        .map_err(|e| anyhow::anyhow!("declaring the predict queryable: {e}"))?;
    let server_key = keys.server_liveliness(&cfg.server_id)?;
    refuse_duplicate_id(&session, &cfg, &server_key).await?;
    // Watch the other servers of this prefix before declaring ours: a standby must know
    // its place before it could publish.
    let _standby =
        crate::shell::standby::watch(&session, &cfg.prefix, &cfg.server_id, live.clone()).await?;
    let _token = session
        .liveliness()
        .declare_token(server_key)
        .await
        .map_err(|e| anyhow::anyhow!("declaring the server token: {e}"))?;
    let publisher = session
        .declare_publisher(keys.ball_state())
        // Sent at once rather than batched: robots act on it.
        .express(true)
        .await
        .map_err(|e| anyhow::anyhow!("declaring the state publisher: {e}"))?;

    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let app = crate::shell::http::app(live.clone());
    let mut http_stop = stop_rx.clone();
    // `tap_io` only to get the connection's address to the handlers (the control
    // endpoints' loopback check).
    let mut limits = cfg.http_limits.clone();
    match crate::shell::http::guard::fd_limits() {
        Some(fd) => {
            limits.max_connections = connection_cap(limits.max_connections, fd.soft);
            tracing::info!(
                "open files: limit {} (was {}, hard limit {}); HTTP: at most {} connections, {} \
                 descriptors kept for Zenoh, the match log and the rest",
                fd.soft,
                fd.soft_before,
                fd.hard,
                limits.max_connections,
                crate::shell::http::guard::FD_RESERVE
            );
        }
        None => tracing::warn!("the open-files limit could not be read"),
    }
    let http = GuardedListener::new(http, &limits, live.stats.http.clone()).tap_io(|_| {});
    let http_task = tokio::spawn(async move {
        axum::serve(
            http,
            app.into_make_service_with_connect_info::<std::net::SocketAddr>(),
        )
        .with_graceful_shutdown(async move {
            let _ = http_stop.wait_for(|s| *s).await;
        })
        .await
    });
    let foxglove_task = foxglove.map(|listener| {
        live.enable_foxglove(&cfg.server_id);
        let app = crate::shell::foxglove::app(live.clone());
        let mut stop = stop_rx.clone();
        tokio::spawn(async move {
            axum::serve(listener, app)
                .with_graceful_shutdown(async move {
                    let _ = stop.wait_for(|s| *s).await;
                })
                .await
        })
    });
    tokio::spawn(async move {
        shutdown.await;
        let _ = stop_tx.send(true);
    });

    publish(&live, &publisher, &cfg, stop_rx).await;
    match http_task.await {
        Ok(Ok(())) => {}
        Ok(Err(e)) => tracing::warn!("HTTP server stopped with an error: {e}"),
        Err(e) => tracing::warn!("HTTP server task failed: {e}"),
    }
    if let Some(task) = foxglove_task {
        match task.await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => tracing::warn!("Foxglove server stopped with an error: {e}"),
            Err(e) => tracing::warn!("Foxglove server task failed: {e}"),
        }
    }
    session
        .close()
        .await
        .map_err(|e| anyhow::anyhow!("closing the Zenoh session: {e}"))?;
    tokio::task::spawn_blocking(move || intake.stop()).await?;
    Ok(())
}

/// The publisher task: the one owner of `{prefix}/ball/state`. On every tick it publishes
/// the state and hands the view to the live stream; with `publish_on_update` it also
/// publishes (without a view) when an accepted observation wakes it. Serialising runs off
/// the async workers. Returns when `stop` turns true.
async fn publish(
    live: &Shared,
    publisher: &zenoh::pubsub::Publisher<'static>,
    cfg: &ServeConfig,
    mut stop: tokio::sync::watch::Receiver<bool>,
) {
    let period = Duration::from_secs_f64(1.0 / cfg.state_rate_hz);
    // A little more than a tick: `GET /api/state` serves the last view while it is fresh.
    live.set_view_max_age(period.mul_f64(1.5));
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        let with_view = tokio::select! {
            _ = tick.tick() => true,
            _ = live.updated.notified(), if cfg.publish_on_update => false,
            _ = stop.wait_for(|s| *s) => break,
        };
        let l = live.clone();
        let publication = match tokio::task::spawn_blocking(move || l.publication(with_view)).await
        {
            Ok(p) => p,
            Err(e) => {
                tracing::warn!("taking the state to publish failed: {e}");
                continue;
            }
        };
        // A standby keeps the same state and says nothing; the active server signs what it
        // publishes with its id (the sample's attachment).
        if let Some(payload) = publication.payload
            && live.is_active()
            && let Err(e) = publisher
                .put(payload)
                .attachment(cfg.server_id.as_bytes().to_vec())
                .await
        {
            tracing::warn!("publishing the ball state failed: {e}");
        }
        if let Some(view) = publication.view {
            live.broadcast(view);
        }
    }
}
