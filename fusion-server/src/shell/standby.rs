//! Standby: several servers on one key prefix, exactly one publishing the ball. Each server
//! holds its liveliness token `{prefix}/servers/{id}` and watches the others'. The live
//! server with the smallest id is active: it publishes `{prefix}/ball/state`, with its id
//! in each sample's attachment. The others fuse the very same observations (they subscribe
//! to the robots like the active one) and stay quiet, so the state a standby takes over
//! with is as good as the active's. When the active server's token goes (it stopped, it
//! crashed and its link closed, or its link's lease ran out) the next one publishes from
//! its next tick.

use crate::shell::live::Live;
use std::collections::BTreeSet;
use std::sync::Arc;
use zenoh::sample::SampleKind;

/// Which servers are alive besides this one, and so whether this one publishes. Pure.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Roster {
    me: String,
    others: BTreeSet<String>,
}

impl Roster {
    pub fn new(me: &str) -> Self {
        Roster {
            me: me.to_string(),
            others: BTreeSet::new(),
        }
    }

    /// A server's token appeared (`alive`) or went.
    pub fn seen(&mut self, id: &str, alive: bool) {
        if id == self.me {
            return;
        }
        if alive {
            self.others.insert(id.to_string());
        } else {
            self.others.remove(id);
        }
    }

    /// This server publishes: no live server has a smaller id.
    pub fn active(&self) -> bool {
        self.others
            .iter()
            .next()
            .is_none_or(|first| *first > self.me)
    }

    /// The server that publishes.
    pub fn publisher(&self) -> &str {
        match self.others.iter().next() {
            Some(first) if *first < self.me => first,
            _ => &self.me,
        }
    }
}

/// The server id in a key `{prefix}/servers/{id}`.
fn server_of<'k>(prefix: &str, key: &'k str) -> Option<&'k str> {
    key.strip_prefix(prefix)?.strip_prefix("/servers/")
}

/// Watches the servers' tokens on `session` and keeps `live`'s active flag: until the
/// subscriber is dropped (returned, to be kept for the server's life).
pub async fn watch(
    session: &zenoh::Session,
    prefix: &str,
    me: &str,
    live: Arc<Live>,
) -> anyhow::Result<zenoh::pubsub::Subscriber<()>> {
    let roster = std::sync::Mutex::new(Roster::new(me));
    let prefix_owned = prefix.to_string();
    let l = live.clone();
    let subscriber = session
        .liveliness()
        .declare_subscriber(format!("{prefix}/servers/*"))
        .history(true)
        .callback(move |s| {
            let Some(id) = server_of(&prefix_owned, s.key_expr().as_str()) else {
                return;
            };
            let mut r = roster.lock().unwrap_or_else(|p| p.into_inner());
            let was = r.active();
            r.seen(id, s.kind() == SampleKind::Put);
            let now = r.active();
            l.set_active(now);
            if was != now {
                tracing::info!(
                    "{}: {} publishes the ball",
                    if now { "active" } else { "standby" },
                    r.publisher()
                );
            }
        })
        .await
        .map_err(|e| anyhow::anyhow!("watching the other servers: {e}"))?;
    Ok(subscriber)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smallest_live_id_publishes() {
        let mut r = Roster::new("pitch-b");
        assert!(r.active(), "alone, it publishes");
        r.seen("pitch-c", true);
        assert!(r.active());
        r.seen("pitch-a", true);
        assert!(!r.active(), "pitch-a is first");
        assert_eq!(r.publisher(), "pitch-a");
        r.seen("pitch-b", false);
        assert!(!r.active(), "its own token is not news");
        r.seen("pitch-a", false);
        assert!(r.active(), "pitch-a went: pitch-b takes over");
        assert_eq!(r.publisher(), "pitch-b");
    }

    #[test]
    fn server_ids_come_from_their_keys() {
        assert_eq!(server_of("rf", "rf/servers/pitch-a"), Some("pitch-a"));
        assert_eq!(server_of("rf", "lab/servers/pitch-a"), None);
        assert_eq!(server_of("rf", "rf/robots/miro1"), None);
    }
}
