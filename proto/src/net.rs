//! Zenoh session settings shared by every process of the product (with the `zenoh`
//! feature): peer mode with explicit endpoints, and scouting off unless asked for, so
//! nothing leaves the configured links. With [`TlsFiles`], every link is TLS with mutual
//! authentication: a node proves who it is with a certificate signed by the network's
//! certificate authority, and its certificate's common name is what access-control lists
//! name it by.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum NetError {
    #[error("zenoh endpoint {0:?} is not of the form PROTOCOL/HOST:PORT (e.g. tcp/127.0.0.1:7447)")]
    BadEndpoint(String),
    #[error("zenoh mode {0:?} is not peer, client or router")]
    BadMode(String),
    #[error("zenoh configuration: {0}")]
    Config(String),
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error(
        "zenoh endpoint {0:?} is not TLS: with certificates every endpoint off this machine must \
         be tls/HOST:PORT, or peers could join without one"
    )]
    PlainEndpoint(String),
    #[error("zenoh endpoint {0:?} is TLS but no certificates are given (--tls DIR)")]
    NoCertificates(String),
    #[error("TLS file {path}: {source}")]
    TlsFile {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// A node's TLS files (PEM): the network's certificate authority, and this node's
/// certificate and private key, both for the links it accepts and those it opens.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TlsFiles {
    /// The certificate authority every node's certificate must be signed by.
    pub ca: PathBuf,
    /// This node's certificate (its common name names it to access-control lists).
    pub cert: PathBuf,
    /// This node's private key.
    pub key: PathBuf,
}

impl TlsFiles {
    /// `ca.pem`, `cert.pem` and `key.pem` in `dir`: the layout `fusion-server keys` writes
    /// for every node.
    pub fn in_dir(dir: &Path) -> Self {
        TlsFiles {
            ca: dir.join("ca.pem"),
            cert: dir.join("cert.pem"),
            key: dir.join("key.pem"),
        }
    }

    /// Every file is there and readable.
    pub fn check(&self) -> Result<(), NetError> {
        for path in [&self.ca, &self.cert, &self.key] {
            std::fs::File::open(path).map_err(|source| NetError::TlsFile {
                path: path.clone(),
                source,
            })?;
        }
        Ok(())
    }
}

/// How a process joins the Zenoh network.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NetConfig {
    /// `peer` (default), `client` (only talks through routers) or `router`.
    pub mode: String,
    /// Endpoints this process listens on, e.g. `tcp/127.0.0.1:7447`.
    pub listen: Vec<String>,
    /// Endpoints this process connects to: peers, or `zenohd` routers.
    pub connect: Vec<String>,
    /// Multicast scouting (finds peers on the LAN by UDP multicast). Off by default.
    pub multicast_scouting: bool,
    /// Gossip scouting (peers tell each other about peers). Off by default.
    pub gossip_scouting: bool,
    /// TLS with mutual authentication on every link (endpoints must then be `tls/`).
    pub tls: Option<TlsFiles>,
}

impl Default for NetConfig {
    fn default() -> Self {
        NetConfig {
            mode: "peer".into(),
            listen: Vec::new(),
            connect: Vec::new(),
            multicast_scouting: false,
            gossip_scouting: false,
            tls: None,
        }
    }
}

/// Checks that `e` is `PROTOCOL/HOST:PORT`; returns its host.
fn check_endpoint(e: &str) -> Result<&str, NetError> {
    let bad = || NetError::BadEndpoint(e.to_string());
    let (proto, rest) = e.split_once('/').ok_or_else(bad)?;
    let addr = rest.split(['?', '#']).next().unwrap_or_default();
    let (host, port) = addr.rsplit_once(':').ok_or_else(bad)?;
    if proto.is_empty() || host.is_empty() || port.parse::<u16>().is_err() {
        return Err(bad());
    }
    Ok(host)
}

/// Whether `host` (of an endpoint) is this machine only: 127.0.0.0/8, ::1 or localhost.
fn is_loopback(host: &str) -> bool {
    let host = host.trim_start_matches('[').trim_end_matches(']');
    host == "localhost"
        || host
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

impl NetConfig {
    /// Only listens on `endpoint`.
    pub fn listening(endpoint: &str) -> Self {
        NetConfig {
            listen: vec![endpoint.to_string()],
            ..NetConfig::default()
        }
    }

    /// Only connects to `endpoint`.
    pub fn connecting(endpoint: &str) -> Self {
        NetConfig {
            connect: vec![endpoint.to_string()],
            ..NetConfig::default()
        }
    }

    pub fn check(&self) -> Result<(), NetError> {
        if !matches!(self.mode.as_str(), "peer" | "client" | "router") {
            return Err(NetError::BadMode(self.mode.clone()));
        }
        for e in self.listen.iter().chain(&self.connect) {
            let host = check_endpoint(e)?;
            let is_tls = e.starts_with("tls/");
            match &self.tls {
                // A loopback link stays on this machine (a ROS bridge beside the agent).
                Some(_) if !is_tls && !is_loopback(host) => {
                    return Err(NetError::PlainEndpoint(e.clone()));
                }
                None if is_tls => return Err(NetError::NoCertificates(e.clone())),
                _ => {}
            }
        }
        match &self.tls {
            Some(t) => t.check(),
            None => Ok(()),
        }
    }

    /// Whether links are TLS with mutual authentication.
    pub fn is_secured(&self) -> bool {
        self.tls.is_some()
    }

    /// The Zenoh configuration: exactly the listed endpoints, scouting as configured.
    pub fn zenoh_config(&self) -> Result<zenoh::Config, NetError> {
        self.check()?;
        let mut c = zenoh::Config::default();
        let set = |c: &mut zenoh::Config, k: &str, v: String| {
            c.insert_json5(k, &v)
                .map_err(|e| NetError::Config(format!("{k}: {e}")))
        };
        set(&mut c, "mode", json(self.mode.as_str()))?;
        set(&mut c, "listen/endpoints", json(&self.listen))?;
        set(&mut c, "connect/endpoints", json(&self.connect))?;
        set(
            &mut c,
            "scouting/multicast/enabled",
            json(&self.multicast_scouting),
        )?;
        set(
            &mut c,
            "scouting/gossip/enabled",
            json(&self.gossip_scouting),
        )?;
        // Keep retrying a connect endpoint that is not up yet (robots may start first), or
        // gone (a server restarted): first after 0.1 s, then half as long again each time
        // up to 0.5 s, so that a peer is back within a second of the other end listening
        // again, and a server that stays down gets two attempts a second, no more.
        set(&mut c, "connect/exit_on_failure", "false".into())?;
        set(
            &mut c,
            "connect/retry",
            format!(
                r#"{{"period_init_ms": {RETRY_FIRST_MS}, "period_max_ms": {RETRY_MAX_MS}, "period_increase_factor": 1.5}}"#
            ),
        )?;
        // No admin space, no timestamps we do not use.
        set(&mut c, "adminspace/enabled", "false".into())?;
        if let Some(t) = &self.tls {
            let path = |p: &PathBuf| {
                p.to_str()
                    .map(json)
                    .ok_or_else(|| NetError::Config(format!("{} is not UTF-8", p.display())))
            };
            let tls = "transport/link/tls";
            set(&mut c, &format!("{tls}/root_ca_certificate"), path(&t.ca)?)?;
            set(&mut c, &format!("{tls}/listen_certificate"), path(&t.cert)?)?;
            set(&mut c, &format!("{tls}/listen_private_key"), path(&t.key)?)?;
            set(
                &mut c,
                &format!("{tls}/connect_certificate"),
                path(&t.cert)?,
            )?;
            set(&mut c, &format!("{tls}/connect_private_key"), path(&t.key)?)?;
            // Both ends prove themselves, and the one connecting checks the other's name.
            set(&mut c, &format!("{tls}/enable_mtls"), "true".into())?;
            set(
                &mut c,
                &format!("{tls}/verify_name_on_connect"),
                "true".into(),
            )?;
        }
        Ok(c)
    }

    /// Opens a session with this configuration.
    pub async fn open(&self) -> Result<zenoh::Session, NetError> {
        let cfg = self.zenoh_config()?;
        zenoh::open(cfg)
            .await
            .map_err(|e| NetError::Zenoh(e.to_string()))
    }
}

/// A lost or missing connect endpoint is tried again after this long at first ...
pub const RETRY_FIRST_MS: u64 = 100;
/// ... and at most this long: the bound on reconnecting once the other end listens again.
pub const RETRY_MAX_MS: u64 = 500;

/// JSON text of a configuration value (plain strings, lists and booleans cannot fail).
fn json<T: Serialize + ?Sized>(v: &T) -> String {
    serde_json::to_string(v).unwrap_or_default()
}

/// A loopback TCP port that was free a moment ago (for tests and the demo's defaults).
pub fn free_loopback_port() -> std::io::Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(l.local_addr()?.port())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_are_checked() {
        assert!(NetConfig::listening("tcp/127.0.0.1:7447").check().is_ok());
        for bad in ["127.0.0.1:7447", "tcp/127.0.0.1", "tcp/:1", "tcp/h:99999"] {
            assert!(NetConfig::listening(bad).check().is_err(), "{bad}");
        }
        let c = NetConfig {
            mode: "satellite".into(),
            ..NetConfig::default()
        };
        assert!(matches!(c.check(), Err(NetError::BadMode(_))));
    }

    #[test]
    fn scouting_is_off_and_endpoints_are_explicit() -> Result<(), NetError> {
        let z = NetConfig::listening("tcp/127.0.0.1:7447").zenoh_config()?;
        let get = |k: &str| z.get_json(k).unwrap_or_default();
        assert_eq!(get("scouting/multicast/enabled"), "false");
        assert_eq!(get("scouting/gossip/enabled"), "false");
        assert_eq!(get("listen/endpoints"), r#"["tcp/127.0.0.1:7447"]"#);
        assert_eq!(get("connect/endpoints"), "[]");
        let retry: serde_json::Value =
            serde_json::from_str(&get("connect/retry")).unwrap_or_default();
        assert_eq!(retry["period_init_ms"], 100, "{retry}");
        assert_eq!(retry["period_max_ms"], 500, "{retry}");
        Ok(())
    }

    #[test]
    fn tls_needs_tls_endpoints_and_readable_files() -> Result<(), Box<dyn std::error::Error>> {
        let dir = std::env::temp_dir().join(format!("rf-net-tls-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let files = TlsFiles::in_dir(&dir);
        let secured = |e: &str| NetConfig {
            tls: Some(files.clone()),
            ..NetConfig::listening(e)
        };
        // A plain endpoint next to certificates would let peers in without one, unless it
        // is a loopback one (nothing off this machine reaches it).
        for plain in [
            "tcp/0.0.0.0:7447",
            "tcp/192.168.1.4:7447",
            "tcp/pitch.local:7447",
        ] {
            assert!(
                matches!(secured(plain).check(), Err(NetError::PlainEndpoint(_))),
                "{plain}"
            );
        }
        for local in ["tcp/127.0.0.1:7448", "tcp/localhost:7448", "tcp/[::1]:7448"] {
            assert!(
                !matches!(secured(local).check(), Err(NetError::PlainEndpoint(_))),
                "{local}"
            );
        }
        assert!(matches!(
            NetConfig::connecting("tls/127.0.0.1:7447").check(),
            Err(NetError::NoCertificates(_))
        ));
        // The files are missing, then there.
        assert!(matches!(
            secured("tls/127.0.0.1:7447").check(),
            Err(NetError::TlsFile { .. })
        ));
        for f in [&files.ca, &files.cert, &files.key] {
            std::fs::write(f, "-")?;
        }
        let c = secured("tls/127.0.0.1:7447");
        c.check()?;
        assert!(c.is_secured());
        let z = c.zenoh_config()?;
        let get = |k: &str| z.get_json(k).unwrap_or_default();
        assert_eq!(get("transport/link/tls/enable_mtls"), "true");
        assert_eq!(get("transport/link/tls/verify_name_on_connect"), "true");
        assert!(get("transport/link/tls/connect_certificate").ends_with("cert.pem\""));
        std::fs::remove_dir_all(&dir)?;
        Ok(())
    }
}
