//! The serving commands' flags and the little each command needs around the server: the
//! settings they resolve to, the match log, Ctrl-C, the HTTP listener. Any program that
//! runs a server (this crate's binary, the tools' demo) flattens [`ServeArgs`] into its
//! own command line.

use crate::clock::{Clock, SystemClock};
use crate::matchlog::MatchLog;
use crate::matchlog::McapLog;
use crate::matchlog::record::RecorderConfig;
use crate::shell::config::{ConfigError, PitchFlags, Settings};
use crate::shell::serve::ServeConfig;
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use std::sync::Arc;

/// Flags shared by every serving subcommand.
#[derive(Debug, Clone, Args)]
pub struct ServeArgs {
    /// TOML configuration file (flags override it).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// HTTP address for the API, the live stream and the page.
    /// [default: 127.0.0.1:8080, or `http` in the configuration file]
    #[arg(long)]
    pub http: Option<String>,
    /// Zenoh endpoint to listen on (repeatable).
    #[arg(long)]
    pub listen: Vec<String>,
    /// Zenoh endpoint to connect to, e.g. a zenohd router (repeatable).
    #[arg(long)]
    pub connect: Vec<String>,
    /// Zenoh mode: peer, client or router.
    #[arg(long)]
    pub mode: Option<String>,
    /// Turn on multicast and gossip scouting (off by default: only the given endpoints).
    #[arg(long)]
    pub scouting: bool,
    /// This server's id (its liveliness token is {prefix}/servers/{id}).
    #[arg(long)]
    pub id: Option<String>,
    /// Key prefix.
    #[arg(long)]
    pub prefix: Option<String>,
    /// Ball states published per second.
    #[arg(long)]
    pub rate_hz: Option<f64>,
    /// Also publish a state right after new observations (lowest latency).
    #[arg(long)]
    pub on_update: bool,
    /// Only accept these robots (comma-separated ids). With --tls, only these may join.
    #[arg(long, value_delimiter = ',')]
    pub roster: Vec<String>,
    /// TLS with mutual authentication and an access-control list from the roster: DIR
    /// holds this server's ca.pem, cert.pem and key.pem (`fusion-server keys` writes it).
    /// Endpoints must be tls/… (default tls/127.0.0.1:7447).
    #[arg(long, value_name = "DIR")]
    pub tls: Option<PathBuf>,
    /// With --tls: other servers (standby) to trust, comma-separated ids.
    #[arg(long, value_delimiter = ',')]
    pub servers: Vec<String>,
    /// With --tls: zenohd routers to trust, comma-separated ids.
    #[arg(long, value_delimiter = ',')]
    pub routers: Vec<String>,
    /// Serve without TLS, where anyone reaching the endpoints may publish (a lab network).
    #[arg(long, conflicts_with = "tls")]
    pub open: bool,
    /// Record every observation, status and published state as MCAP match logs in DIR.
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// Start a new log file after this many megabytes.
    #[arg(long)]
    pub record_max_mb: Option<f64>,
    /// Start a new log file after this many minutes.
    #[arg(long)]
    pub record_max_min: Option<f64>,
    /// End the log's open chunk and hand it to the operating system this often: what a
    /// killed server (kill -9, a power cut aside) can lose is what it accepted within this
    /// time before it died (default 250 ms).
    #[arg(long, value_name = "MS")]
    pub record_flush_ms: Option<f64>,
    /// Token the control endpoints (replay's pause, play, seek, speed) require as
    /// `Authorization: Bearer TOKEN`; without it only this machine may use them.
    #[arg(long, value_name = "TOKEN")]
    pub control_token: Option<String>,
    /// Serve the match to Foxglove (its WebSocket protocol) on PORT or HOST:PORT: the 3D
    /// scene and the raw channels, live. A port alone listens on this machine only.
    #[arg(long, value_name = "ADDR")]
    pub foxglove: Option<String>,
    #[command(flatten)]
    pub pitch: PitchFlags,
}

impl ServeArgs {
    /// The configuration file's settings (if there is a file) with these flags over them:
    /// one set of settings, checked in one place ([`Settings::apply`]).
    pub fn settings(&self) -> Result<Settings, ConfigError> {
        let mut s = match &self.config {
            Some(path) => Settings::load(path)?,
            None => Settings::default(),
        };
        self.overlay(&mut s)?;
        Ok(s)
    }

    /// Writes the flags that were given over `s`.
    fn overlay(&self, s: &mut Settings) -> Result<(), ConfigError> {
        fn set<T: Clone>(field: &mut Option<T>, flag: &Option<T>) {
            if flag.is_some() {
                field.clone_from(flag);
            }
        }
        set(&mut s.http, &self.http);
        set(&mut s.foxglove, &self.foxglove);
        set(&mut s.server_id, &self.id);
        set(&mut s.prefix, &self.prefix);
        set(&mut s.state_rate_hz, &self.rate_hz);
        set(&mut s.control_token, &self.control_token);
        if self.on_update {
            s.publish_on_update = Some(true);
        }
        if !self.roster.is_empty() {
            s.roster = Some(self.roster.clone());
        }
        if !self.servers.is_empty() {
            s.servers = Some(self.servers.clone());
        }
        if !self.routers.is_empty() {
            s.routers = Some(self.routers.clone());
        }
        if self.open {
            s.open = Some(true);
        }
        set(&mut s.record.dir, &self.record);
        set(&mut s.record.max_mb, &self.record_max_mb);
        set(&mut s.record.max_minutes, &self.record_max_min);
        set(
            &mut s.record.flush_interval_s,
            &self.record_flush_ms.map(|ms| ms / 1000.0),
        );
        let net_flags = !self.listen.is_empty()
            || !self.connect.is_empty()
            || self.mode.is_some()
            || self.scouting
            || self.tls.is_some();
        if net_flags {
            let mut z = s
                .zenoh
                .clone()
                .unwrap_or_else(|| ServeConfig::default().net);
            if !self.listen.is_empty() {
                z.listen.clone_from(&self.listen);
            }
            if !self.connect.is_empty() {
                z.connect.clone_from(&self.connect);
            }
            if let Some(m) = &self.mode {
                z.mode.clone_from(m);
                // A client only connects (to a router): no default listening endpoint.
                if m == "client" && self.listen.is_empty() {
                    z.listen.clear();
                }
            }
            if self.scouting {
                z.multicast_scouting = true;
                z.gossip_scouting = true;
            }
            if let Some(dir) = &self.tls {
                z.tls = Some(proto::net::TlsFiles::in_dir(dir));
                // The default endpoint, secured.
                if self.listen.is_empty() && z.listen == ServeConfig::default().net.listen {
                    z.listen = vec!["tls/127.0.0.1:7447".into()];
                }
            }
            s.zenoh = Some(z);
        }
        if self.pitch != PitchFlags::default() {
            let base = s.pitch.clone().unwrap_or_default();
            s.pitch = Some(self.pitch.over(&base)?);
        }
        Ok(())
    }
}

/// The server's configuration and, when recording, the match log's, from the flags over
/// the configuration file over the defaults.
pub fn serve_config(a: &ServeArgs) -> Result<(ServeConfig, Option<RecorderConfig>)> {
    let settings = a.settings()?;
    let mut cfg = ServeConfig::default();
    settings.apply(&mut cfg)?;
    cfg.net.check()?;
    Ok((cfg, settings.record.recorder()?))
}

/// Starts the match log, if one is configured.
pub fn start_log(rec: Option<RecorderConfig>) -> Result<Option<Arc<McapLog>>> {
    rec.map(|r| {
        let dir = r.dir.clone();
        McapLog::start(r, SystemClock.now())
            .map(Arc::new)
            .with_context(|| format!("starting the match log in {}", dir.display()))
    })
    .transpose()
}

/// Finishes the match log and says where it is.
pub fn finish_log(log: Option<Arc<McapLog>>) -> Result<()> {
    if let Some(log) = log
        && let Some(summary) = log.finish()?
    {
        for f in &summary.files {
            println!("match log: {}", f.display());
        }
        println!("{} messages recorded", summary.messages);
    }
    Ok(())
}

pub fn as_match_log(log: &Option<Arc<McapLog>>) -> Option<Arc<dyn MatchLog>> {
    log.clone().map(|l| l as Arc<dyn MatchLog>)
}

/// Resolves on Ctrl-C or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}

/// The Foxglove WebSocket's listener, when one is configured.
pub async fn bind_foxglove(
    addr: Option<std::net::SocketAddr>,
) -> Result<Option<tokio::net::TcpListener>> {
    let Some(addr) = addr else { return Ok(None) };
    let l = tokio::net::TcpListener::bind(addr).await.with_context(|| {
        format!("cannot listen for Foxglove on {addr} (choose another with --foxglove)")
    })?;
    Ok(Some(l))
}

/// Connections the kernel holds for the HTTP listener before it accepts them: a thousand
/// viewers arriving at once wait there instead of being refused.
pub const HTTP_BACKLOG: u32 = 4096;

pub async fn bind_http(addr: &str) -> Result<tokio::net::TcpListener> {
    let context = || format!("cannot listen for HTTP on {addr} (choose another with --http)");
    let mut resolved = tokio::net::lookup_host(addr).await.with_context(context)?;
    let sock_addr = resolved
        .next()
        .with_context(|| format!("{addr} names no address"))?;
    let socket = match sock_addr {
        std::net::SocketAddr::V4(_) => tokio::net::TcpSocket::new_v4(),
        std::net::SocketAddr::V6(_) => tokio::net::TcpSocket::new_v6(),
    }
    .with_context(context)?;
    socket.set_reuseaddr(true).with_context(context)?;
    socket.bind(sock_addr).with_context(context)?;
    socket.listen(HTTP_BACKLOG).with_context(context)
}
