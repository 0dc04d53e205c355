//! `--source zenoh:ros2` or `zenoh:ros1`: a running MiRo's ROS topics over Zenoh.
//!
//! A Zenoh ROS bridge on the robot (`zenoh-bridge-ros2dds` for ROS 2, `zenoh-bridge-ros1`
//! for ROS 1) republishes ROS topics as Zenoh keys: a topic's key is its name without the
//! leading slash (under `--ros-key-prefix` when the bridge adds a namespace), its payload
//! the message's serialised bytes (CDR for ROS 2, the ROS 1 serialisation for ROS 1) —
//! the same bytes a recording holds, read by the same decoders. The topics are the ones
//! of [`RosTopics`]; the pose topic's type is told by its size (a `Pose2D` is three
//! doubles, anything longer an `Odometry`).
//!
//! Each image goes to the pipeline with the head joints and pose stamped at or just before
//! it (of the last [`STATE_HISTORY`] of each). A pipeline that falls behind finds at most [`QUEUE_FRAMES`] frames waiting; later
//! ones are dropped and counted, as are messages that cannot be decoded.

use crate::io::ros_msg::{self, Encoding, Header};
use crate::runtime::frame::{RobotState, StoredFrame};
use crate::runtime::ros_frames::{OdomPose, RosTopics, robot_state};
use crate::runtime::source::FrameSource;
use anyhow::{Context, Result};
use proto::{Camera, HeadJoints, Stamp};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Frames that may wait for the pipeline.
pub const QUEUE_FRAMES: usize = 4;

/// A frame received and not yet decoded.
struct Pending {
    stamp: Stamp,
    camera: Camera,
    bytes: Vec<u8>,
    state: RobotState,
}

/// The state messages of the last [`STATE_HISTORY`] arrivals per topic, by stamp: an image
/// takes the latest at or before its own stamp (the earliest kept when all are later).
#[derive(Debug, Default)]
struct Latest {
    heads: VecDeque<(Stamp, HeadJoints)>,
    poses: Vec<VecDeque<(Stamp, OdomPose)>>,
}

/// State messages kept per topic (a MiRo publishes its joints and pose at 50 Hz: about
/// 0.3 s).
pub const STATE_HISTORY: usize = 16;

/// The entry of `history` for an image stamped `at`.
fn at_or_before<T: Copy>(history: &VecDeque<(Stamp, T)>, at: Stamp) -> Option<(Stamp, T)> {
    history
        .iter()
        .filter(|(s, _)| *s <= at)
        .max_by_key(|(s, _)| *s)
        .or_else(|| history.iter().min_by_key(|(s, _)| *s))
        .copied()
}

fn remember<T>(history: &mut VecDeque<(Stamp, T)>, stamp: Stamp, value: T) {
    if history.len() == STATE_HISTORY {
        history.pop_front();
    }
    history.push_back((stamp, value));
}

/// Counts kept while the source runs.
#[derive(Debug, Default)]
struct Counts {
    frames: AtomicU64,
    dropped: AtomicU64,
    bad: AtomicU64,
}

/// A running robot's camera, joint and pose topics over Zenoh.
pub struct LiveRosSource {
    frames: RosFrames,
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
}

impl std::fmt::Debug for LiveRosSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveRosSource").finish_non_exhaustive()
    }
}

/// The Zenoh key of a ROS topic.
pub fn topic_key(prefix: &str, topic: &str) -> String {
    let name = topic.trim_start_matches('/');
    let prefix = prefix.trim_matches('/');
    if prefix.is_empty() {
        name.to_string()
    } else {
        format!("{prefix}/{name}")
    }
}

/// A header's stamp, or the arrival time when the publisher left it at zero.
fn stamp_or_now(header: &Header) -> Stamp {
    if header.stamp.0 == 0 {
        crate::runtime::wall_now()
    } else {
        header.stamp
    }
}

/// A pose message's bytes: a `Pose2D` is three doubles (after CDR's 4-byte header).
fn decode_pose(encoding: Encoding, bytes: &[u8]) -> Result<(Option<Stamp>, OdomPose)> {
    let pose2d_len = match encoding {
        Encoding::Ros1 => 24,
        Encoding::Cdr => 28,
    };
    if bytes.len() == pose2d_len {
        let p = ros_msg::decode_pose2d(encoding, bytes)?;
        return Ok((
            None,
            OdomPose {
                pose: p.pose(),
                covariance: crate::runtime::ros_frames::default_pose_covariance(),
            },
        ));
    }
    let o = ros_msg::decode_odometry(encoding, bytes)?;
    let c = o.planar_covariance();
    let set = [c[0], c[4], c[8]].iter().all(|v| v.is_finite() && *v > 0.0);
    let pose = o.pose();
    anyhow::ensure!(
        pose.x_m.is_finite() && pose.y_m.is_finite() && pose.theta_rad.is_finite(),
        "pose is not finite"
    );
    Ok((
        (o.header.stamp.0 != 0).then_some(o.header.stamp),
        OdomPose {
            pose,
            covariance: if set {
                c
            } else {
                crate::runtime::ros_frames::default_pose_covariance()
            },
        },
    ))
}

/// Where a live source's messages go: the latest joints and poses kept, each image queued
/// for the pipeline with them (the same for the Zenoh bridge's topics and the MiRo's own
/// ROS 1 master).
#[derive(Clone)]
pub struct RosInbox {
    tx: SyncSender<Pending>,
    latest: Arc<Mutex<Latest>>,
    counts: Arc<Counts>,
    encoding: Encoding,
    origin: proto::Pose2,
}

/// The topic a live message came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RosRole {
    Image(Camera),
    Joints,
    /// The pose topic at this place in `--pose-topic` (the first has priority).
    Pose(usize),
}

impl RosInbox {
    /// The inbox and the frame source that reads it.
    pub fn new(topics: &RosTopics, encoding: Encoding, stop: Arc<AtomicBool>) -> (Self, RosFrames) {
        let (tx, rx) = sync_channel::<Pending>(QUEUE_FRAMES);
        let counts = Arc::new(Counts::default());
        let inbox = RosInbox {
            tx,
            latest: Arc::new(Mutex::new(Latest {
                heads: VecDeque::new(),
                poses: vec![VecDeque::new(); topics.pose_topic.len()],
            })),
            counts: counts.clone(),
            encoding,
            origin: topics.pose_origin,
        };
        (inbox, RosFrames { rx, stop, counts })
    }

    /// The topics to subscribe to, with their roles.
    pub fn roles(topics: &RosTopics) -> Vec<(String, RosRole)> {
        let mut roles = vec![
            (topics.left_topic.clone(), RosRole::Image(Camera::Left)),
            (topics.right_topic.clone(), RosRole::Image(Camera::Right)),
            (topics.joints_topic.clone(), RosRole::Joints),
        ];
        roles.extend(
            topics
                .pose_topic
                .iter()
                .enumerate()
                .map(|(k, t)| (t.clone(), RosRole::Pose(k))),
        );
        roles
    }

    /// One message's bytes; what cannot be decoded is counted and dropped.
    pub fn receive(&self, role: RosRole, bytes: &[u8]) {
        let ok = match role {
            RosRole::Image(camera) => self.image(camera, bytes),
            RosRole::Joints => self.joints(bytes),
            RosRole::Pose(k) => self.pose(k, bytes),
        };
        if !ok {
            self.counts.bad.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn image(&self, camera: Camera, bytes: &[u8]) -> bool {
        let Ok(image) = ros_msg::decode_compressed_image(self.encoding, bytes) else {
            return false;
        };
        let stamp = stamp_or_now(&image.header);
        let state = match self.latest.lock() {
            Ok(l) => robot_state(
                at_or_before(&l.heads, stamp).map(|(_, h)| h),
                l.poses.iter().find_map(|p| at_or_before(p, stamp)),
                self.origin,
            ),
            Err(_) => return true,
        };
        let pending = Pending {
            stamp,
            camera,
            bytes: image.data,
            state,
        };
        self.counts.frames.fetch_add(1, Ordering::Relaxed);
        if let Err(TrySendError::Full(_)) = self.tx.try_send(pending) {
            self.counts.dropped.fetch_add(1, Ordering::Relaxed);
        }
        true
    }

    fn joints(&self, bytes: &[u8]) -> bool {
        let Ok(joints) = ros_msg::decode_joint_state(self.encoding, bytes) else {
            return false;
        };
        match (joints.miro_head(), self.latest.lock()) {
            (Some(h), Ok(mut l)) => {
                remember(&mut l.heads, stamp_or_now(&joints.header), h);
                true
            }
            _ => false,
        }
    }

    fn pose(&self, k: usize, bytes: &[u8]) -> bool {
        match (decode_pose(self.encoding, bytes), self.latest.lock()) {
            (Ok((stamp, pose)), Ok(mut l)) => {
                let stamp = stamp.unwrap_or_else(crate::runtime::wall_now);
                if let Some(history) = l.poses.get_mut(k) {
                    remember(history, stamp, pose);
                }
                true
            }
            _ => false,
        }
    }
}

/// The frames of a live source, decoded on the pipeline's thread.
pub struct RosFrames {
    rx: Receiver<Pending>,
    stop: Arc<AtomicBool>,
    counts: Arc<Counts>,
}

impl LiveRosSource {
    /// Subscribes to the topics on `session`.
    pub async fn open(
        session: &zenoh::Session,
        topics: &RosTopics,
        encoding: Encoding,
        key_prefix: &str,
        stop: Arc<AtomicBool>,
    ) -> Result<Self> {
        let (inbox, frames) = RosInbox::new(topics, encoding, stop);
        let mut subscribers = Vec::new();
        for (topic, role) in RosInbox::roles(topics) {
            let inbox = inbox.clone();
            let key = topic_key(key_prefix, &topic);
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |sample| inbox.receive(role, &sample.payload().to_bytes()))
                .await
                .map_err(|e| anyhow::anyhow!("subscribing to {key}: {e}"))?;
            subscribers.push(sub);
        }
        tracing::info!(
            "waiting for frames on {} and {}",
            topic_key(key_prefix, &topics.left_topic),
            topic_key(key_prefix, &topics.right_topic)
        );
        Ok(LiveRosSource {
            frames,
            _subscribers: subscribers,
        })
    }
}

impl FrameSource for LiveRosSource {
    fn next_frame(&mut self) -> Result<Option<StoredFrame>> {
        self.frames.next_frame()
    }

    fn live(&self) -> bool {
        true
    }
}

impl FrameSource for RosFrames {
    fn next_frame(&mut self) -> Result<Option<StoredFrame>> {
        while !self.stop.load(Ordering::Relaxed) {
            let p = match self.rx.recv_timeout(Duration::from_millis(100)) {
                Ok(p) => p,
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => return Ok(None),
            };
            let image = match crate::io::image_io::decode_rgb(&p.bytes)
                .context("decoding a camera image")
            {
                Ok(i) => i,
                Err(e) => {
                    self.counts.bad.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!("skipping a frame at {}: {e:#}", p.stamp.0);
                    continue;
                }
            };
            return Ok(Some(StoredFrame {
                stamp: p.stamp,
                camera: p.camera,
                image,
                state: p.state,
            }));
        }
        Ok(None)
    }

    fn live(&self) -> bool {
        true
    }
}

impl Drop for RosFrames {
    fn drop(&mut self) {
        let c = &self.counts;
        tracing::info!(
            "live ROS source: {} frames received, {} dropped while the pipeline was busy, {} messages not decodable",
            c.frames.load(Ordering::Relaxed),
            c.dropped.load(Ordering::Relaxed),
            c.bad.load(Ordering::Relaxed)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_image_takes_the_state_stamped_at_or_before_it() {
        let mut h = VecDeque::new();
        assert_eq!(at_or_before::<u8>(&h, Stamp(5)), None);
        for (s, v) in [(10, 1u8), (20, 2), (30, 3)] {
            remember(&mut h, Stamp(s), v);
        }
        assert_eq!(at_or_before(&h, Stamp(25)), Some((Stamp(20), 2)));
        assert_eq!(at_or_before(&h, Stamp(30)), Some((Stamp(30), 3)));
        assert_eq!(
            at_or_before(&h, Stamp(5)),
            Some((Stamp(10), 1)),
            "all later: the earliest"
        );
        for s in 0..STATE_HISTORY as u64 {
            remember(&mut h, Stamp(100 + s), 9);
        }
        assert_eq!(h.len(), STATE_HISTORY);
        assert_eq!(at_or_before(&h, Stamp(25)), Some((Stamp(100), 9)));
    }

    #[test]
    fn topics_become_keys() {
        assert_eq!(
            topic_key("", "/miro/sensors/caml/compressed"),
            "miro/sensors/caml/compressed"
        );
        assert_eq!(
            topic_key("/robot7/", "/miro/sensors/odom"),
            "robot7/miro/sensors/odom"
        );
    }
}
