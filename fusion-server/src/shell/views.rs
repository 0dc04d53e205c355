//! The robots' camera views in the live server: each payload from Zenoh goes through the
//! pure [`CameraViews`] (bounds, checks, the newest view per camera); a kept one is pushed
//! to the page's view stream, written to the match log (image, annotations and metadata,
//! unless `[record] views = false`) and handed to Foxglove clients. Refusals are counted by
//! reason and logged at most every few seconds.

use crate::camera_views::images::{self, ANNOTATIONS_SCHEMA, IMAGE_SCHEMA};
use crate::camera_views::{CameraViews, StoredView, ViewLimits};
use crate::matchlog::{LogKind, MatchLog};
use crate::shell::foxglove_hub::FoxgloveHub;
use proto::{Camera, KeySpace, Stamp};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::sync::broadcast;

/// Views the page's stream holds for a slow reader before it skips the oldest.
pub const VIEW_STREAM_BUFFER: usize = 16;

/// Refusals are logged at most this often.
const REFUSAL_LOG_EVERY: Duration = Duration::from_secs(5);

/// What the server knows of the robots' views.
#[derive(Debug)]
pub struct ViewHub {
    views: Mutex<CameraViews>,
    /// Each kept view's payload as it came, for the page.
    pub stream: broadcast::Sender<Arc<str>>,
    /// Whether kept views go into the match log.
    record: AtomicBool,
    last_refusal_log: Mutex<Option<Instant>>,
}

/// The views' counts, for the metrics.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ViewCounts {
    pub accepted: u64,
    pub refused: BTreeMap<&'static str, u64>,
    pub kept: u64,
}

fn kind_of(schema: &str) -> LogKind {
    match schema {
        IMAGE_SCHEMA => LogKind::Image,
        ANNOTATIONS_SCHEMA => LogKind::Annotations,
        _ => LogKind::View,
    }
}

impl ViewHub {
    pub fn new(keys: KeySpace) -> Self {
        let (stream, _) = broadcast::channel(VIEW_STREAM_BUFFER);
        ViewHub {
            views: Mutex::new(CameraViews::new(keys, ViewLimits::default())),
            stream,
            record: AtomicBool::new(true),
            last_refusal_log: Mutex::new(None),
        }
    }

    fn lock(&self) -> MutexGuard<'_, CameraViews> {
        self.views.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Sets the bounds (forgetting what was kept) and whether views are logged.
    pub fn configure(&self, keys: KeySpace, limits: ViewLimits, record: bool) {
        *self.lock() = CameraViews::new(keys, limits);
        self.record.store(record, Relaxed);
    }

    /// A view payload that arrived on `key` at `now`; whether it was kept.
    pub fn on_view(
        &self,
        key: &str,
        payload: &[u8],
        now: Stamp,
        log: Option<&Arc<dyn MatchLog>>,
        foxglove: Option<&Arc<FoxgloveHub>>,
    ) -> bool {
        let result = self.lock().offer(key, payload, now);
        match result {
            Ok(v) => {
                self.hand_out(&v, now, log, foxglove);
                true
            }
            Err(e) => {
                let mut last = self
                    .last_refusal_log
                    .lock()
                    .unwrap_or_else(|p| p.into_inner());
                if last.is_none_or(|t| t.elapsed() >= REFUSAL_LOG_EVERY) {
                    *last = Some(Instant::now());
                    tracing::warn!(
                        "refused a camera view on {key}: {e} (further refusals are counted in \
                         /metrics as rf_camera_views_refused_total)"
                    );
                }
                false
            }
        }
    }

    fn hand_out(
        &self,
        v: &StoredView,
        now: Stamp,
        log: Option<&Arc<dyn MatchLog>>,
        foxglove: Option<&Arc<FoxgloveHub>>,
    ) {
        // No receivers is not an error: nobody is watching.
        let _ = self.stream.send(v.json.clone());
        let to_log = log.filter(|_| self.record.load(Relaxed));
        if to_log.is_none() && foxglove.is_none_or(|h| !h.watched()) {
            return;
        }
        for r in images::records(v) {
            let kind = kind_of(r.schema);
            if let Some(log) = to_log {
                log.log(kind, &r.topic, now, &r.payload);
            }
            if let Some(hub) = foxglove {
                hub.publish(kind, &r.topic, now, &r.payload);
            }
        }
    }

    /// The newest view of one camera.
    pub fn latest(&self, robot_id: &str, camera: Camera) -> Option<Arc<StoredView>> {
        self.lock().latest(robot_id, camera)
    }

    /// The newest view of every camera.
    pub fn all(&self) -> Vec<Arc<StoredView>> {
        self.lock().all()
    }

    /// Forgets the kept views (a replay moved in time).
    pub fn clear(&self) {
        self.lock().clear();
    }

    /// Replaces every kept view by `views` (key, payload) at once: a replay moved in time
    /// shows what the cameras saw last before the new time, and a reader never finds the
    /// views gone in between. They go to the page's stream, not to the match log.
    pub fn replace<'a>(&self, views: impl IntoIterator<Item = (&'a str, &'a [u8])>, now: Stamp) {
        let kept: Vec<Arc<StoredView>> = {
            let mut v = self.lock();
            v.clear();
            views
                .into_iter()
                .filter_map(|(key, payload)| v.offer(key, payload, now).ok())
                .collect()
        };
        for v in kept {
            let _ = self.stream.send(v.json.clone());
        }
    }

    pub fn counts(&self) -> ViewCounts {
        let v = self.lock();
        ViewCounts {
            accepted: v.accepted(),
            refused: v.refused().clone(),
            kept: v.all().len() as u64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Camera;
    use proto::test_support::camera_view;

    /// A match log that keeps the topics it is given.
    #[derive(Debug, Default)]
    struct Topics(Mutex<Vec<String>>);

    impl MatchLog for Topics {
        fn log(&self, _: LogKind, topic: &str, _: Stamp, _: &[u8]) {
            self.0
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(topic.to_string());
        }

        fn counts(&self) -> (u64, u64) {
            (0, 0)
        }
    }

    const T0: Stamp = Stamp(1_700_000_000_000_000_000);

    fn offer(hub: &ViewHub, log: &Arc<dyn MatchLog>) -> bool {
        let keys = KeySpace::default();
        let key = keys.robot_view("miro1", Camera::Left).unwrap_or_default();
        let payload = proto::encode(&camera_view("miro1", Camera::Left, 0, T0));
        hub.on_view(&key, &payload, T0, Some(log), None)
    }

    #[test]
    fn kept_views_are_logged_unless_the_settings_say_not() {
        let topics = Arc::new(Topics::default());
        let log: Arc<dyn MatchLog> = topics.clone();
        let hub = ViewHub::new(KeySpace::default());
        let mut stream = hub.stream.subscribe();
        assert!(offer(&hub, &log));
        let logged = topics.0.lock().map(|t| t.clone()).unwrap_or_default();
        assert_eq!(
            logged,
            [
                "/robots/miro1/left/image",
                "/robots/miro1/left/annotations",
                "rf/robots/miro1/view/left"
            ]
        );
        assert!(stream.try_recv().is_ok(), "pushed to the page's stream");

        let topics = Arc::new(Topics::default());
        let log: Arc<dyn MatchLog> = topics.clone();
        hub.configure(KeySpace::default(), ViewLimits::default(), false);
        assert!(offer(&hub, &log), "still kept and served");
        assert!(topics.0.lock().map(|t| t.is_empty()).unwrap_or(false));
        assert_eq!(hub.counts().kept, 1);
    }
}
