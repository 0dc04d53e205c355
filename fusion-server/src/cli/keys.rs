//! `fusion-server keys`: the certificate authority of a secured network and one folder per
//! node (`ca.pem`, `cert.pem`, `key.pem`), plus each router's `zenohd` configuration.

use crate::security::keys::{Authority, Validity};
use crate::security::node_dir;
use crate::security::{acl, robot_common_name, router_common_name, server_common_name};
use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Args)]
pub struct KeysArgs {
    /// Folder of the network's keys: `ca/` (the authority: keep `ca.key` offline) and one
    /// folder per node. Run again with new ids to add nodes; issued ones are kept.
    #[arg(long, default_value = "keys")]
    pub out: PathBuf,
    /// Robot ids (comma-separated): folders `robot-{id}`.
    #[arg(long, value_delimiter = ',')]
    pub robots: Vec<String>,
    /// Server ids (comma-separated): folders `server-{id}`.
    #[arg(long, value_delimiter = ',')]
    pub servers: Vec<String>,
    /// zenohd router ids (comma-separated): folders `router-{id}` with a `zenohd.json5`.
    #[arg(long, value_delimiter = ',')]
    pub routers: Vec<String>,
    /// Host names or IP addresses servers and routers are reached at (repeatable);
    /// connecting nodes check them. localhost and 127.0.0.1 are always included.
    #[arg(long = "host")]
    pub hosts: Vec<String>,
    /// Days the certificates are valid.
    #[arg(long, default_value_t = 825)]
    pub days: u32,
    /// Key prefix the routers' access-control list is written for.
    #[arg(long, default_value = proto::DEFAULT_PREFIX)]
    pub prefix: String,
    /// Endpoints the routers listen on (repeatable).
    #[arg(long, default_value = "tls/127.0.0.1:7447")]
    pub router_listen: Vec<String>,
}

const KINDS: [&str; 3] = ["robot", "server", "router"];

pub fn run(a: KeysArgs) -> Result<()> {
    proto::KeySpace::new(&a.prefix).context("--prefix")?;
    for id in a.robots.iter().chain(&a.servers).chain(&a.routers) {
        anyhow::ensure!(proto::is_valid_id(id), "{id:?} is not a valid id");
    }
    anyhow::ensure!(a.days > 0, "--days must be positive");
    let validity = Validity::starting(jiff::Timestamp::now(), a.days)?;
    let ca_dir = a.out.join("ca");
    let (ca_cert, ca_key) = (ca_dir.join("ca.pem"), ca_dir.join("ca.key"));
    let ca = if ca_cert.exists() {
        let read = |p: &Path| std::fs::read_to_string(p).with_context(|| p.display().to_string());
        println!("authority: {} (kept)", ca_cert.display());
        Authority::load(&read(&ca_cert)?, &read(&ca_key)?)
            .context("loading the certificate authority")?
    } else {
        std::fs::create_dir_all(&ca_dir).with_context(|| ca_dir.display().to_string())?;
        let ca = Authority::new("robot football network authority", validity)?;
        std::fs::write(&ca_cert, &ca.issued.cert_pem)?;
        node_dir::write_secret(&ca_key, &ca.issued.key_pem)?;
        println!("authority: {} (new; keep ca.key secret)", ca_cert.display());
        ca
    };
    let mut hosts = vec!["localhost".to_string(), "127.0.0.1".to_string()];
    for h in &a.hosts {
        if !hosts.contains(h) {
            hosts.push(h.clone());
        }
    }
    let wanted = [
        ("robot", &a.robots, robot_common_name as fn(&str) -> String),
        ("server", &a.servers, server_common_name),
        ("router", &a.routers, router_common_name),
    ];
    for (kind, ids, common_name) in wanted {
        for id in ids {
            let dir = a.out.join(format!("{kind}-{id}"));
            if dir.join("cert.pem").exists() {
                println!("{kind} {id}: {} (kept)", dir.display());
                continue;
            }
            // Robots only connect; servers and routers are connected to, by these names.
            let names: &[String] = if kind == "robot" { &[] } else { &hosts };
            let issued = ca.issue(&common_name(id), names, validity)?;
            node_dir::write(&dir, &ca.issued.cert_pem, &issued)
                .with_context(|| dir.display().to_string())?;
            println!("{kind} {id}: {} ({})", dir.display(), common_name(id));
        }
    }
    // Everything issued in the folder so far: the network's roster.
    let issued = issued_ids(&a.out)?;
    let [robots, servers, routers] = &issued;
    let roster = acl::Roster {
        prefix: &a.prefix,
        robots,
        servers,
        routers,
    };
    for id in routers {
        let dir = std::path::absolute(a.out.join(format!("router-{id}")))?;
        let tls = proto::net::TlsFiles::in_dir(&dir);
        let config = crate::security::router_config(&a.router_listen, &tls, &roster);
        let path = dir.join("zenohd.json5");
        std::fs::write(&path, serde_json::to_string_pretty(&config)?)?;
        println!("router {id}: zenohd -c {}", path.display());
    }
    let list = |v: &[String]| v.join(",");
    for id in servers {
        let others: Vec<String> = servers.iter().filter(|s| *s != id).cloned().collect();
        let mut flags = format!(
            "--tls {} --roster {}",
            a.out.join(format!("server-{id}")).display(),
            list(robots)
        );
        if !others.is_empty() {
            flags += &format!(" --servers {}", list(&others));
        }
        if !routers.is_empty() {
            flags += &format!(" --routers {}", list(routers));
        }
        println!(
            "server {id}: fusion-server serve --id {id} --prefix {} {flags}",
            a.prefix
        );
    }
    Ok(())
}

/// The ids of every node folder in `out`, by kind (robot, server, router).
fn issued_ids(out: &Path) -> Result<[Vec<String>; 3]> {
    let mut ids: [Vec<String>; 3] = Default::default();
    for entry in std::fs::read_dir(out).with_context(|| out.display().to_string())? {
        let name = entry?.file_name().to_string_lossy().into_owned();
        for (i, kind) in KINDS.iter().enumerate() {
            if let Some(id) = name.strip_prefix(&format!("{kind}-"))
                && proto::is_valid_id(id)
            {
                ids[i].push(id.to_string());
            }
        }
    }
    ids.iter_mut().for_each(|v| v.sort());
    Ok(ids)
}
