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
//! Each image goes to the pipeline with the latest head joints and pose received before
//! it. A pipeline that falls behind finds at most [`QUEUE_FRAMES`] frames waiting; later
//! ones are dropped and counted, as are messages that cannot be decoded.

use crate::io::ros_msg::{self, Encoding, Header};
use crate::runtime::frame::{RobotState, StoredFrame};
use crate::runtime::ros_frames::{OdomPose, RosTopics, robot_state};
use crate::runtime::source::FrameSource;
use anyhow::{Context, Result};
use proto::{Camera, HeadJoints, Stamp};
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

/// The latest state messages: head joints, and a pose per pose topic (by preference).
#[derive(Debug, Default)]
struct Latest {
    head: Option<HeadJoints>,
    poses: Vec<Option<(Stamp, OdomPose)>>,
}

/// Counts kept while the source runs.
#[derive(Debug, Default)]
struct Counts {
    frames: AtomicU64,
    dropped: AtomicU64,
    bad: AtomicU64,
}

/// A running robot's camera, joint and pose topics.
pub struct LiveRosSource {
    rx: Receiver<Pending>,
    stop: Arc<AtomicBool>,
    counts: Arc<Counts>,
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

impl LiveRosSource {
    /// Subscribes to the topics on `session`.
    pub async fn open(
        session: &zenoh::Session,
        topics: &RosTopics,
        encoding: Encoding,
        key_prefix: &str,
        stop: Arc<AtomicBool>,
    ) -> Result<Self> {
        let (tx, rx) = sync_channel::<Pending>(QUEUE_FRAMES);
        let latest = Arc::new(Mutex::new(Latest {
            head: None,
            poses: vec![None; topics.pose_topic.len()],
        }));
        let counts = Arc::new(Counts::default());
        let mut subscribers = Vec::new();
        let origin = topics.pose_origin;
        for (topic, camera) in [
            (&topics.left_topic, Camera::Left),
            (&topics.right_topic, Camera::Right),
        ] {
            let (tx, latest, counts): (SyncSender<Pending>, _, _) =
                (tx.clone(), latest.clone(), counts.clone());
            let key = topic_key(key_prefix, topic);
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes();
                    let Ok(image) = ros_msg::decode_compressed_image(encoding, &bytes) else {
                        counts.bad.fetch_add(1, Ordering::Relaxed);
                        return;
                    };
                    let state = match latest.lock() {
                        Ok(l) => {
                            robot_state(l.head, l.poses.iter().flatten().next().copied(), origin)
                        }
                        Err(_) => return,
                    };
                    let pending = Pending {
                        stamp: stamp_or_now(&image.header),
                        camera,
                        bytes: image.data,
                        state,
                    };
                    counts.frames.fetch_add(1, Ordering::Relaxed);
                    if let Err(TrySendError::Full(_)) = tx.try_send(pending) {
                        counts.dropped.fetch_add(1, Ordering::Relaxed);
                    }
                })
                .await
                .map_err(|e| anyhow::anyhow!("subscribing to {key}: {e}"))?;
            subscribers.push(sub);
        }
        {
            let (latest, counts) = (latest.clone(), counts.clone());
            let key = topic_key(key_prefix, &topics.joints_topic);
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes();
                    let head = ros_msg::decode_joint_state(encoding, &bytes)
                        .ok()
                        .and_then(|j| j.miro_head());
                    match (head, latest.lock()) {
                        (Some(h), Ok(mut l)) => l.head = Some(h),
                        _ => {
                            counts.bad.fetch_add(1, Ordering::Relaxed);
                        }
                    }
                })
                .await
                .map_err(|e| anyhow::anyhow!("subscribing to {key}: {e}"))?;
            subscribers.push(sub);
        }
        for (k, topic) in topics.pose_topic.iter().enumerate() {
            let (latest, counts) = (latest.clone(), counts.clone());
            let key = topic_key(key_prefix, topic);
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes();
                    match (decode_pose(encoding, &bytes), latest.lock()) {
                        (Ok((stamp, pose)), Ok(mut l)) => {
                            let stamp = stamp.unwrap_or_else(crate::runtime::wall_now);
                            if let Some(slot) = l.poses.get_mut(k) {
                                *slot = Some((stamp, pose));
                            }
                        }
                        _ => {
                            counts.bad.fetch_add(1, Ordering::Relaxed);
                        }
                    }
                })
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
            rx,
            stop,
            counts,
            _subscribers: subscribers,
        })
    }
}

impl FrameSource for LiveRosSource {
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

impl Drop for LiveRosSource {
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
