//! The agent process on a secured network: `sim_agent run --tls DIR` joins a TLS listener
//! that demands a certificate from the network's authority and applies the roster's
//! access-control list. With its own certificate its observations arrive; with another
//! robot's certificate, publishing under an id that is not its own, none do.

#![allow(clippy::unwrap_used)]

use fusion_server::security::acl::{self, Roster};
use fusion_server::security::keys::{Authority, Issued, Validity};
use fusion_server::security::{robot_common_name, server_common_name};
use proto::net::{NetConfig, TlsFiles, free_loopback_port};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

const SIM_AGENT: &str = env!("CARGO_BIN_EXE_sim_agent");

fn write(dir: &Path, ca: &Authority, node: &Issued) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("ca.pem"), &ca.issued.cert_pem).unwrap();
    std::fs::write(dir.join("cert.pem"), &node.cert_pem).unwrap();
    std::fs::write(dir.join("key.pem"), &node.key_pem).unwrap();
    dir.to_path_buf()
}

/// Runs `sim_agent` as miro1 for 3 s with the certificate in `tls`; returns how many of
/// its observations the listener received.
async fn observations_received(tls: &Path, server_tls: &Path) -> u64 {
    let endpoint = format!("tls/127.0.0.1:{}", free_loopback_port().unwrap());
    let net = NetConfig {
        tls: Some(TlsFiles::in_dir(server_tls)),
        ..NetConfig::listening(&endpoint)
    };
    let mut config = net.zenoh_config().unwrap();
    let (robots, servers) = (
        vec!["miro1".to_string(), "miro2".into()],
        vec!["main".to_string()],
    );
    acl::install(
        &mut config,
        &Roster {
            prefix: "rf",
            robots: &robots,
            servers: &servers,
            routers: &[],
        },
    )
    .unwrap();
    let session = zenoh::open(config).await.unwrap();
    let count = Arc::new(AtomicU64::new(0));
    let c = count.clone();
    let _sub = session
        .declare_subscriber("rf/robots/*/obs")
        .callback(move |_| {
            c.fetch_add(1, Ordering::Relaxed);
        })
        .await
        .unwrap();
    let child = Command::new(SIM_AGENT)
        .args(["run", "--robot-id", "miro1", "--connect", &endpoint])
        .arg("--tls")
        .arg(tls)
        .args([
            "--scenario",
            "seed-1-across",
            "--seed",
            "2",
            "--duration-s",
            "3",
        ])
        .env("RUST_LOG", "warn,zenoh=error")
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let out = tokio::task::spawn_blocking(move || child.wait_with_output())
        .await
        .unwrap()
        .unwrap();
    assert!(out.status.success());
    tokio::time::sleep(Duration::from_millis(300)).await;
    let _ = session.close().await;
    count.load(Ordering::Relaxed)
}

#[tokio::test(flavor = "multi_thread")]
async fn the_agent_joins_with_its_own_certificate_only() {
    let tmp = tempfile::tempdir().unwrap();
    let validity = Validity::starting(jiff::Timestamp::now(), 2).unwrap();
    let ca = Authority::new("test authority", validity).unwrap();
    let hosts = ["127.0.0.1".to_string()];
    let server = write(
        &tmp.path().join("server"),
        &ca,
        &ca.issue(&server_common_name("main"), &hosts, validity)
            .unwrap(),
    );
    let miro1 = write(
        &tmp.path().join("miro1"),
        &ca,
        &ca.issue(&robot_common_name("miro1"), &[], validity)
            .unwrap(),
    );
    let miro2 = write(
        &tmp.path().join("miro2"),
        &ca,
        &ca.issue(&robot_common_name("miro2"), &[], validity)
            .unwrap(),
    );
    let own = observations_received(&miro1, &server).await;
    assert!(
        own >= 10,
        "only {own} observations with its own certificate"
    );
    let borrowed = observations_received(&miro2, &server).await;
    assert_eq!(borrowed, 0, "miro2's certificate published as miro1");
}
