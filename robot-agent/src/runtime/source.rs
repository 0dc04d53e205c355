//! Where camera frames come from: an image folder, an MCAP recording, or a running robot's
//! ROS topics from its ROS 1 master ([`crate::runtime::ros1_source`]) or over Zenoh
//! ([`crate::runtime::live_ros`]). Another crate brings its own source
//! by implementing [`FrameSource`].

use crate::runtime::frame::StoredFrame;
use crate::runtime::frames_io::{
    FrameRecord, McapFrames, load_image, read_index, read_mcap, state_at,
};
use crate::runtime::ros_frames::{RosTopics, RosTrack};
use anyhow::{Context, Result, bail};
use std::path::PathBuf;

/// Frames in capture order.
pub trait FrameSource: Send {
    /// The next frame, or `None` at the end.
    fn next_frame(&mut self) -> Result<Option<StoredFrame>>;
    /// Frames are paced by their stamps unless the source is a file (processed as fast as
    /// possible unless asked otherwise).
    fn live(&self) -> bool;
}

/// How a `--source` argument names a source.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceSpec {
    Images(PathBuf),
    Mcap(PathBuf),
    /// A running robot's ROS topics over Zenoh, in this encoding.
    Zenoh(crate::io::ros_msg::Encoding),
    /// A running robot's ROS 1 topics from its master.
    Ros1,
}

impl std::str::FromStr for SourceSpec {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Self> {
        if s == "ros1" {
            return Ok(SourceSpec::Ros1);
        }
        match s.split_once(':') {
            Some(("images", dir)) if !dir.is_empty() => Ok(SourceSpec::Images(dir.into())),
            Some(("mcap", file)) if !file.is_empty() => Ok(SourceSpec::Mcap(file.into())),
            Some(("zenoh", "ros2" | "cdr")) => {
                Ok(SourceSpec::Zenoh(crate::io::ros_msg::Encoding::Cdr))
            }
            Some(("zenoh", "ros1")) => Ok(SourceSpec::Zenoh(crate::io::ros_msg::Encoding::Ros1)),
            _ => bail!("source {s:?} is not images:DIR, mcap:FILE, ros1, zenoh:ros2 or zenoh:ros1"),
        }
    }
}

/// An image folder with its `frames.jsonl` index.
#[derive(Debug)]
pub struct ImagesSource {
    dir: PathBuf,
    records: std::vec::IntoIter<FrameRecord>,
}

impl ImagesSource {
    pub fn open(dir: PathBuf) -> Result<Self> {
        let records = read_index(&dir)?;
        tracing::info!("{}: {} frames", dir.display(), records.len());
        Ok(ImagesSource {
            dir,
            records: records.into_iter(),
        })
    }
}

impl FrameSource for ImagesSource {
    fn next_frame(&mut self) -> Result<Option<StoredFrame>> {
        let Some(r) = self.records.next() else {
            return Ok(None);
        };
        let image = load_image(&self.dir, &r.file)?;
        Ok(Some(StoredFrame {
            stamp: r.stamp,
            camera: r.camera,
            image,
            state: r.state,
        }))
    }

    fn live(&self) -> bool {
        false
    }
}

/// An MCAP recording of camera images and robot states: the project's JSON layout or a
/// MiRo's ROS channels.
#[derive(Debug)]
pub struct McapSource {
    frames: McapFrames,
    states: McapStates,
    next: usize,
}

/// Where a recording's frames take the robot's state from.
#[derive(Debug)]
enum McapStates {
    /// `/robot/state` messages.
    Json,
    /// ROS joint and pose messages (or the defaults).
    Ros(RosTrack),
}

impl McapSource {
    pub fn open(path: PathBuf, topics: &RosTopics) -> Result<Self> {
        let mut frames = read_mcap(&path, topics)?;
        let name = path.display().to_string();
        for (why, n) in &frames.skipped {
            tracing::warn!("{name}: skipped {n} message(s): {why}");
        }
        if !frames.ros.ignored.is_empty() {
            let ignored: Vec<String> = frames
                .ros
                .ignored
                .iter()
                .map(|(t, n)| format!("{t} ({n})"))
                .collect();
            tracing::info!("{name}: topics not used: {}", ignored.join(", "));
        }
        let states = if !frames.states.is_empty() || !frames.has_ros {
            if frames.states.is_empty() && !frames.images.is_empty() {
                bail!(
                    "{name} has images but no /robot/state messages: frames cannot be projected without the robot's pose"
                );
            }
            McapStates::Json
        } else {
            McapStates::Ros(RosTrack::new(
                std::mem::take(&mut frames.ros),
                topics,
                &name,
            ))
        };
        if frames.images.is_empty() {
            tracing::warn!(
                "{name}: no usable images (a ROS recording's camera topics are {} and {}: --left-topic, --right-topic)",
                topics.left_topic,
                topics.right_topic
            );
        }
        tracing::info!(
            "{name}: {} images, {} states",
            frames.images.len(),
            frames.states.len()
        );
        Ok(McapSource {
            frames,
            states,
            next: 0,
        })
    }
}

impl FrameSource for McapSource {
    fn next_frame(&mut self) -> Result<Option<StoredFrame>> {
        while let Some((stamp, camera, image)) = self.frames.images.get(self.next) {
            self.next += 1;
            let image = match image.decode() {
                Ok(i) => i,
                Err(e) => {
                    tracing::warn!("skipping an image at {}: {e:#}", stamp.0);
                    continue;
                }
            };
            let state = match &self.states {
                McapStates::Json => {
                    state_at(&self.frames.states, *stamp).context("no robot state")?
                }
                McapStates::Ros(track) => track.state_at(*stamp),
            };
            return Ok(Some(StoredFrame {
                stamp: *stamp,
                camera: *camera,
                image,
                state,
            }));
        }
        Ok(None)
    }

    fn live(&self) -> bool {
        false
    }
}
