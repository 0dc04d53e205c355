//! The robot agent: finds the ball in a MiRo's camera frames, projects it onto the floor
//! with the robot's kinematics and publishes it as a `proto::Observation` with an honest
//! covariance.
//!
//! The vision modules are pure: functions over images and numbers, no clock reads, no I/O
//! except [`io::image_io`]'s file loading. [`runtime`] is the shell around them: frame
//! sources, the perceive loop and Zenoh; the `robot-agent` binary is a thin command line
//! over it and [`cli`].
//!
//! - [`calibration`]: camera models, chessboard detection and camera calibration.
//! - [`detection`]: one frame to ball candidates, one stage per module, and the ball
//!   classifier's training.
//! - [`projection`]: pixel to floor point with its covariance, and the MiRo's kinematics.
//! - [`image`]: the RGB8 frame and binary mask buffers of the detection pipeline.
//! - [`pipeline`]: detection, projection and world validation of one frame, at most one
//!   ball per frame.
//! - [`agent`]: a robot's perception state between frames: observations, status, counters.
//! - [`builtin`]: the shipped calibration of the simulated camera and the ball classifier.
//! - [`labels`]: labelled ball boxes (Pascal VOC and YOLO readers) and the detector scored
//!   against them.
//! - [`io`]: image files, and the ROS messages of a MiRo's recordings.
//! - [`runtime`]: frame sources (image folders, MCAP recordings, live ROS over Zenoh) and
//!   the perceive loop that publishes observations and status.
//! - [`cli`]: flag groups and command steps shared by the `robot-agent` binary and the
//!   simulator-driven tools.

pub mod agent;
pub mod builtin;
pub mod calibration;
pub mod cli;
pub mod detection;
pub mod image;
pub mod io;
pub mod labels;
pub mod pipeline;
pub mod projection;
pub mod runtime;
#[cfg(test)]
mod test_fixtures;
