//! Who may join a secured Zenoh network and what each may do there.
//!
//! Every node holds a certificate signed by the network's certificate authority ([`keys`]
//! issues them), and its certificate's common name says what it is: `robot:{id}` or
//! `server:{id}`. The access-control list ([`acl`]), generated from the roster, lets robot
//! `{id}` publish only under `{prefix}/robots/{id}`, read only `{prefix}/ball/…`, and lets
//! only servers publish the ball. Servers apply it themselves; `zenohd` routers are given
//! the same list in their configuration.

pub mod acl;
pub mod keys;
pub mod node_dir;

/// The common name in robot `id`'s certificate.
pub fn robot_common_name(id: &str) -> String {
    format!("robot:{id}")
}

/// The common name in server `id`'s certificate.
pub fn server_common_name(id: &str) -> String {
    format!("server:{id}")
}

/// The common name in router `id`'s certificate (routers are trusted like servers).
pub fn router_common_name(id: &str) -> String {
    format!("router:{id}")
}

/// A `zenohd` router's whole configuration (JSON5 is a superset of this JSON): router
/// mode on `listen`, no scouting, TLS with mutual authentication from `tls`, and the
/// access-control list of `roster`.
pub fn router_config(
    listen: &[String],
    tls: &proto::net::TlsFiles,
    roster: &acl::Roster<'_>,
) -> serde_json::Value {
    let path = |p: &std::path::Path| p.display().to_string();
    serde_json::json!({
        "mode": "router",
        "listen": { "endpoints": listen },
        "connect": { "endpoints": [] },
        "scouting": {
            "multicast": { "enabled": false },
            "gossip": { "enabled": false },
        },
        "transport": { "link": { "tls": {
            "root_ca_certificate": path(&tls.ca),
            "listen_certificate": path(&tls.cert),
            "listen_private_key": path(&tls.key),
            "connect_certificate": path(&tls.cert),
            "connect_private_key": path(&tls.key),
            "enable_mtls": true,
            "verify_name_on_connect": true,
        }}},
        "access_control": acl::access_control(roster),
    })
}
