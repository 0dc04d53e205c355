//! The agent's shell: frame sources, the perceive loop and Zenoh. Frames come from a
//! [`source::FrameSource`] (an image folder, an MCAP recording, a running robot's ROS topics
//! from its ROS 1 master or over Zenoh, or any source another crate implements), go through the pipeline on their
//! own thread, and the observations and status go out over Zenoh.
//!
//! [`run()`] is the whole agent as the `robot-agent run` command runs it; a caller with its
//! own frames passes [`Source::Given`], and a [`FrameHook`] sees every processed frame with
//! the pipeline's outcome (to score it against what the caller knows of the frame).
//!
//! - [`source`]: the frame-source trait and the image-folder and recording sources.
//! - [`frames_io`]: the stored frame, image folders with their index, MCAP recordings.
//! - [`ros_frames`]: a MiRo's ROS recordings as frames and robot states.
//! - [`live_ros`]: a running MiRo's ROS topics over Zenoh as a live source, and the inbox
//!   every live source's messages go through.
//! - [`ros1_source`]: a running MiRo's topics from its ROS 1 master, no bridge.
//! - [`models`]: calibrations and pipeline settings from files.
//! - [`detector_choice`]: the one place the detector and its model file are chosen.
//! - [`timer`]: per-stage timings for the status.
//! - `eyes`: each camera's detector on a thread of its own, results taken back in order.
//! - `views`: the camera views' pacing and their encoder thread.

pub mod detector_choice;
mod eyes;
pub mod frame;
pub mod frames_io;
pub mod live_ros;
pub mod models;
mod perceive;
pub mod ros1_source;
pub mod ros_frames;
mod run;
pub mod source;
pub mod timer;
mod views;

pub use perceive::{FrameHook, FrameReport, Summary};
pub use run::{RunArgs, Source, run};

use proto::Stamp;
use std::time::{SystemTime, UNIX_EPOCH};

/// The wall clock as a stamp (the shell's only clock read).
pub fn wall_now() -> Stamp {
    let d = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    Stamp(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}
