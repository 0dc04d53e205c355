//! The attacks on the shared ball state (made-up ids, oversized payloads, floods, slow
//! HTTP clients, clock trouble, clashing servers), each against a real server on loopback,
//! reduced in size so they run quickly. Every one must be refused, counted, and must not
//! stop honest robots.

#[path = "hardening/server.rs"]
mod server;

use fusion_server::serve::ServeConfig;
use server::{TestServer, eventually, now, obs};

/// A key whose robot chunk is not an id is refused, never taken for the payload's robot.
#[tokio::test(flavor = "multi_thread")]
async fn a_key_that_is_not_a_robot_id_is_refused() -> anyhow::Result<()> {
    let s = TestServer::start("h-key", ServeConfig::default()).await?;
    s.until_accepted("miro1").await?;
    let forged = proto::encode(&obs("miro1", 1000, now(), 0.5));
    s.put("rf/robots/not.an.id/obs", forged.clone()).await?;
    s.put("rf/robots/miro2/obs", forged).await?;
    eventually("both forgeries counted", || {
        (s.rejected("observation", "key_robot_id") == 1
            && s.rejected("observation", "key_mismatch") == 1)
            .then_some(())
    })
    .await;
    let ids: Vec<String> = s
        .live
        .with_engine(|e| e.robots(now()).into_iter().map(|r| r.robot_id).collect());
    assert_eq!(ids, ["miro1"]);
    s.stop().await
}
