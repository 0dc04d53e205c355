//! A match log played back as if live, under control: the server's clock runs through the
//! recorded match and can be paused, sped up or slowed down, and moved to any time of the
//! log (the engine is then re-fused up to that time, see [`crate::matchlog::replay::Seeker`]).
//! The HTTP control endpoints ([`crate::shell::http`]) drive a [`ReplayControl`]; [`play`] is the
//! loop that hands each recorded input over when the clock reaches it.

use crate::engine::EngineConfig;
use crate::matchlog::read::LogMessage;
use crate::matchlog::replay::{Seeker, is_input, is_view, views_before};
use crate::shell::live::Live;
use crate::shell::replay_control::ReplayControl;
use futures_util::future::BoxFuture;
use proto::KeySpace;
use std::future::Future;
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use std::time::{Duration, Instant};

/// After a seek, how long the loop waits at most for the inputs it already handed over to
/// land (over Zenoh) before it replaces the engine: a late one would meet the new clock.
const SETTLE_MAX: Duration = Duration::from_secs(1);

/// Waits (a while at most) until the server has received `inputs` inputs in all.
async fn settle(live: &Live, inputs: u64) {
    let deadline = Instant::now() + SETTLE_MAX;
    while live.stats.inputs_received.load(Relaxed) < inputs && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

/// Hands a recorded input to the server: over Zenoh in the program, straight into the
/// shared state in tests.
pub trait Deliver: Send {
    fn deliver<'a>(&'a mut self, m: &'a LogMessage) -> BoxFuture<'a, ()>;
}

/// What [`play`] needs besides the messages.
#[derive(Debug, Clone)]
pub struct PlayConfig {
    pub engine: EngineConfig,
    pub keys: KeySpace,
    /// At the end of the log, pause there and wait for a seek (until shutdown) instead of
    /// returning.
    pub stay: bool,
}

/// Plays `messages` (in log order) as `control`'s clock reaches them, honouring pause,
/// speed and seeks, until the end of the log (or, with `stay`, until `shutdown`).
/// `progress(done, total)` is called now and then. Returns the messages handed over.
pub async fn play(
    live: Arc<Live>,
    control: Arc<ReplayControl>,
    messages: &[LogMessage],
    cfg: PlayConfig,
    deliver: &mut dyn Deliver,
    progress: &mut (dyn FnMut(usize, usize) + Send),
    shutdown: impl Future<Output = ()>,
) -> usize {
    tokio::pin!(shutdown);
    let mut seeker = Seeker::new(cfg.engine, cfg.keys);
    let mut next = 0;
    let mut delivered = 0;
    let received_before = live.stats.inputs_received.load(Relaxed);
    loop {
        if let Some(at) = control.take_seek() {
            settle(&live, received_before + delivered as u64).await;
            let (engine, index) = seeker.engine_at(messages, at);
            live.replace_engine(engine);
            // The cameras show what they saw last before the new time, from the moment the
            // clock moved (not once they have come round over the network).
            let now = live.clock.now();
            live.views.replace(
                views_before(messages, index)
                    .into_iter()
                    .map(|m| (m.topic.as_str(), m.data.as_slice())),
                now,
            );
            next = index;
            control.set_ended(false);
            continue;
        }
        let Some(m) = messages.get(next) else {
            progress(messages.len(), messages.len());
            if !cfg.stay {
                return delivered;
            }
            control.set_ended(true);
            // Stand at the end until a control request (a seek back) comes.
            let end = control.end;
            control.clock.rebase(|s| {
                s.paused = true;
                s.at = s.at.min(end);
            });
            tokio::select! {
                _ = control.changed.notified() => continue,
                _ = &mut shutdown => return delivered,
            }
        };
        if !is_input(m) && !is_view(m) {
            next += 1;
            continue;
        }
        match control.clock.wall_until(m.log_time) {
            Some(d) if d.is_zero() => {
                deliver.deliver(m).await;
                // Views are not fusion inputs: the settling after a seek does not wait
                // for them.
                delivered += usize::from(is_input(m));
                next += 1;
                if next % 1000 == 0 {
                    progress(next, messages.len());
                }
            }
            wait => {
                // Sleep at most a second at a time: a slow clock still notices controls.
                let d = wait.unwrap_or(Duration::from_secs(3600));
                tokio::select! {
                    _ = tokio::time::sleep(d.min(Duration::from_secs(1))) => {}
                    _ = control.changed.notified() => {}
                    _ = &mut shutdown => return delivered,
                }
            }
        }
    }
}
