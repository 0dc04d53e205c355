//! The robots' camera views (`proto::CameraView`): what arrives is bounded and checked, the
//! newest view of each camera is kept. Pure: payloads and the time they arrived in, views
//! and counted refusals out. The shell hands the kept views to the page, the match log and
//! Foxglove ([`images`] draws them as Foxglove images and annotations).
//!
//! A view is refused, cheapest check first: a payload over the size cap (before it is
//! decoded), a key that names no robot or camera, a robot over its rate (before it is
//! decoded), a payload that does not decode, a `robot_id` or `camera` other than the key's,
//! a view that fails `proto`'s validation (its JPEG included), or one older than the view
//! kept for that camera. Nothing of a refused view is kept.

pub mod images;

use crate::engine::RateBuckets;
use proto::{
    Camera, CameraView, KeySpace, MAX_VIEW_PAYLOAD_BYTES, Pitch, Stamp, ValidationContext,
    camera_of_chunk,
};
use std::collections::BTreeMap;
use std::sync::Arc;

/// Robots whose view rate is remembered; beyond, every bucket starts full again.
const RATE_BUCKETS: usize = 256;

/// Bounds on what robots may send.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewLimits {
    /// The largest payload, bytes.
    pub max_payload_bytes: usize,
    /// Views a second one robot may send (all its cameras together), and the burst.
    pub rate_hz: f64,
    pub burst: f64,
    /// Cameras whose newest view is kept; beyond, the one heard from longest ago is
    /// forgotten.
    pub max_cameras: usize,
    /// Largest accepted |stamp − arrival|, seconds.
    pub max_clock_skew_s: f64,
}

impl Default for ViewLimits {
    /// 64 kB, 8 views a second per robot (an agent's default is 2 a camera), bursts of 8,
    /// 256 cameras, 10 s of clock skew.
    fn default() -> Self {
        ViewLimits {
            max_payload_bytes: MAX_VIEW_PAYLOAD_BYTES,
            rate_hz: 8.0,
            burst: 8.0,
            max_cameras: 256,
            max_clock_skew_s: 10.0,
        }
    }
}

/// Why a view was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ViewRefusal {
    #[error("the payload is {bytes} bytes (limit {limit})")]
    TooLarge { bytes: usize, limit: usize },
    #[error("the key names no robot and camera (`{{prefix}}/robots/{{id}}/view/{{left|right}}`)")]
    BadKey,
    #[error("robot {0} sends views faster than its rate")]
    RateLimited(String),
    #[error("{0}")]
    Decode(String),
    #[error("robot_id {found:?} is not the key's robot {key:?}")]
    WrongRobot { found: String, key: String },
    #[error("camera {found:?} is not the key's camera {key:?}")]
    WrongCamera { found: Camera, key: Camera },
    #[error("{0}")]
    Invalid(#[from] proto::ValidationError),
    #[error("older than the view kept for this camera")]
    Stale,
}

impl ViewRefusal {
    /// A short stable label for counting.
    pub fn reason(&self) -> &'static str {
        match self {
            ViewRefusal::TooLarge { .. } => "too_large",
            ViewRefusal::BadKey => "bad_key",
            ViewRefusal::RateLimited(_) => "rate_limited",
            ViewRefusal::Decode(_) => "decode",
            ViewRefusal::WrongRobot { .. } => "wrong_robot",
            ViewRefusal::WrongCamera { .. } => "wrong_camera",
            ViewRefusal::Invalid(e) => e.reason(),
            ViewRefusal::Stale => "stale",
        }
    }
}

/// A kept view.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredView {
    /// The key it came on.
    pub key: String,
    /// The view as it came, but for its image (`jpeg_base64` empty).
    pub meta: CameraView,
    /// The image.
    pub jpeg: Arc<[u8]>,
    /// The payload as it came (the whole view, image included), for the page.
    pub json: Arc<str>,
    /// When it arrived.
    pub received: Stamp,
}

/// The newest view of each camera, and what was refused.
#[derive(Debug, Clone)]
pub struct CameraViews {
    keys: KeySpace,
    limits: ViewLimits,
    latest: BTreeMap<(String, Camera), Arc<StoredView>>,
    buckets: RateBuckets<RATE_BUCKETS>,
    accepted: u64,
    refused: BTreeMap<&'static str, u64>,
}

impl CameraViews {
    pub fn new(keys: KeySpace, limits: ViewLimits) -> Self {
        CameraViews {
            keys,
            limits,
            latest: BTreeMap::new(),
            buckets: RateBuckets::default(),
            accepted: 0,
            refused: BTreeMap::new(),
        }
    }

    /// A view payload that arrived on `key` at `now`: kept (and returned) or refused
    /// (counted by reason).
    pub fn offer(
        &mut self,
        key: &str,
        payload: &[u8],
        now: Stamp,
    ) -> Result<Arc<StoredView>, ViewRefusal> {
        let result = self.check(key, payload, now);
        match &result {
            Ok(v) => {
                self.accepted += 1;
                self.keep(v.clone());
            }
            Err(e) => *self.refused.entry(e.reason()).or_default() += 1,
        }
        result
    }

    fn check(
        &mut self,
        key: &str,
        payload: &[u8],
        now: Stamp,
    ) -> Result<Arc<StoredView>, ViewRefusal> {
        let limit = self.limits.max_payload_bytes;
        if payload.len() > limit {
            return Err(ViewRefusal::TooLarge {
                bytes: payload.len(),
                limit,
            });
        }
        let (robot, camera) = self.key_parts(key).ok_or(ViewRefusal::BadKey)?;
        if !self
            .buckets
            .take(robot, now, self.limits.rate_hz, self.limits.burst)
        {
            return Err(ViewRefusal::RateLimited(robot.to_string()));
        }
        let mut view: CameraView = proto::decode(payload).map_err(|e| match e {
            proto::DecodeError::Version { found, expected } => {
                ViewRefusal::Invalid(proto::ValidationError::UnsupportedVersion {
                    found: u32::try_from(found).unwrap_or(u32::MAX),
                    expected,
                })
            }
            other => ViewRefusal::Decode(other.to_string()),
        })?;
        if view.robot_id != robot {
            return Err(ViewRefusal::WrongRobot {
                found: view.robot_id,
                key: robot.to_string(),
            });
        }
        if view.camera != camera {
            return Err(ViewRefusal::WrongCamera {
                found: view.camera,
                key: camera,
            });
        }
        let ctx = ValidationContext {
            max_clock_skew_s: self.limits.max_clock_skew_s,
            ..ValidationContext::new(Pitch::default(), now)
        };
        view.validate_fields(&ctx)?;
        let jpeg = view.jpeg()?;
        let slot = (view.robot_id.clone(), view.camera);
        if self
            .latest
            .get(&slot)
            .is_some_and(|v| v.meta.stamp > view.stamp)
        {
            return Err(ViewRefusal::Stale);
        }
        view.jpeg_base64.clear();
        Ok(Arc::new(StoredView {
            key: key.to_string(),
            meta: view,
            jpeg: Arc::from(jpeg),
            json: Arc::from(String::from_utf8_lossy(payload).into_owned()),
            received: now,
        }))
    }

    /// The robot id and camera of a view key.
    fn key_parts<'k>(&self, key: &'k str) -> Option<(&'k str, Camera)> {
        let robot = self.keys.robot_id_of(key)?;
        let rest = key
            .strip_prefix(self.keys.prefix())?
            .strip_prefix("/robots/")?
            .strip_prefix(robot)?
            .strip_prefix("/view/")?;
        Some((robot, camera_of_chunk(rest)?))
    }

    fn keep(&mut self, v: Arc<StoredView>) {
        let slot = (v.meta.robot_id.clone(), v.meta.camera);
        if !self.latest.contains_key(&slot) && self.latest.len() >= self.limits.max_cameras {
            let oldest = self
                .latest
                .iter()
                .min_by_key(|(_, v)| v.received)
                .map(|(k, _)| k.clone());
            if let Some(k) = oldest {
                self.latest.remove(&k);
            }
        }
        self.latest.insert(slot, v);
    }

    /// The newest view of one camera.
    pub fn latest(&self, robot_id: &str, camera: Camera) -> Option<Arc<StoredView>> {
        self.latest.get(&(robot_id.to_string(), camera)).cloned()
    }

    /// The newest view of every camera, by robot and camera.
    pub fn all(&self) -> Vec<Arc<StoredView>> {
        self.latest.values().cloned().collect()
    }

    /// Forgets every kept view (a replay moved in time); the counts stay.
    pub fn clear(&mut self) {
        self.latest.clear();
        self.buckets.clear();
    }

    /// Views kept so far.
    pub fn accepted(&self) -> u64 {
        self.accepted
    }

    /// Views refused so far, by reason.
    pub fn refused(&self) -> &BTreeMap<&'static str, u64> {
        &self.refused
    }
}

#[cfg(test)]
mod tests;
