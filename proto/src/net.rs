//! Zenoh session settings shared by every process of the product (with the `zenoh`
//! feature): peer mode with explicit endpoints, and scouting off unless asked for, so
//! nothing leaves the configured links.

use serde::{Deserialize, Serialize};
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
}

impl Default for NetConfig {
    fn default() -> Self {
        NetConfig {
            mode: "peer".into(),
            listen: Vec::new(),
            connect: Vec::new(),
            multicast_scouting: false,
            gossip_scouting: false,
        }
    }
}

fn check_endpoint(e: &str) -> Result<(), NetError> {
    let bad = || NetError::BadEndpoint(e.to_string());
    let (proto, rest) = e.split_once('/').ok_or_else(bad)?;
    let addr = rest.split(['?', '#']).next().unwrap_or_default();
    let (host, port) = addr.rsplit_once(':').ok_or_else(bad)?;
    if proto.is_empty() || host.is_empty() || port.parse::<u16>().is_err() {
        return Err(bad());
    }
    Ok(())
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
        self.listen
            .iter()
            .chain(&self.connect)
            .try_for_each(|e| check_endpoint(e))
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
        // Keep retrying a connect endpoint that is not up yet (robots may start first).
        set(&mut c, "connect/exit_on_failure", "false".into())?;
        // No admin space, no timestamps we do not use.
        set(&mut c, "adminspace/enabled", "false".into())?;
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
        Ok(())
    }
}
