//! The robot agent: finds the ball in a MiRo's camera frames, projects it onto the floor
//! with the robot's kinematics and publishes it as a `proto::Observation` with an honest
//! covariance.
//!
//! The vision modules are pure: functions over images and numbers, no clock reads, no I/O
//! except image file loading. The runtime is the shell around them: frame sources, the
//! perceive loop and Zenoh ([`run_agent`]); the `robot-agent` binary is a thin command
//! line over it ([`cli::main`]).
//!
//! This root is the crate's front door; behind it, private modules, one per concern: the
//! calibration file ([`Calibration`]), projection (pixel to floor point with its
//! covariance, and the MiRo's kinematics), the pipeline of one frame and the [`Agent`]
//! between frames (with each camera's perception counters), a camera's view for people
//! watching ([`camera_view`]), image files and ROS messages ([`ros_msg`]), and the
//! runtime's frame sources ([`FrameSource`], [`McapSource`]). The detector is the `vision`
//! crate's, through its own front door; training, labels and calibration from chessboards
//! are the `lab` crate's, which the robot's program does not link. Two public modules are APIs of
//! their own: [`builtin`] (the shipped calibration and ball classifier) and [`cli`] (the
//! command line).
//!
//! ```
//! use proto::{Camera, HeadJoints, Pitch, Pose2, Stamp};
//! use robot_agent::{Agent, DetectorKind, FrameInput, PipelineConfig, builtin, choose_detector};
//!
//! // The robot's detector, chosen in the one place every command chooses it.
//! let settings = PipelineConfig::default();
//! let chosen = choose_detector(DetectorKind::default(), &settings.detector, None).unwrap();
//! let lens = builtin::sim_calibration().unwrap().model;
//! let mut agent = Agent::new("miro1", Pitch::default(), settings, [lens, lens], chosen);
//!
//! // A frame of grey carpet: nothing to publish, and the frame counted.
//! let image = vision::RgbImage::filled(640, 360, [120, 118, 112]).unwrap();
//! let frame = FrameInput {
//!     stamp: Stamp(1_000_000_000),
//!     camera: Camera::Left,
//!     image: &image,
//!     pose: Pose2::default(),
//!     pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
//!     head: HeadJoints::default(),
//! };
//! let outcome = agent.on_frame(&frame, &mut vision::NoClock).unwrap();
//! assert!(outcome.observation.is_none());
//! assert_eq!(agent.frames(), 1);
//! ```

mod agent;
pub mod builtin;
mod calibration;
mod camera_counters;
pub mod cli;
mod io;
mod pipeline;
mod projection;
mod runtime;
#[cfg(test)]
mod test_fixtures;
mod view;

pub use agent::{Agent, PipelineConfig};
pub use calibration::camera::CameraModel;
pub use calibration::{Calibration, CalibrationError, ViewResult};
pub use io::image_io::{
    ImageIoError, decode_gray, decode_rgb, encode_png, image_files, image_files_recursive,
    load_gray, load_rgb,
};
pub use io::ros_msg;
#[cfg(any(test, feature = "test-support"))]
pub use io::ros_msg_fixtures;
pub use pipeline::{FrameInput, FrameResult, ScoredCandidate, ValidationConfig};
pub use runtime::detector_choice::{ChosenDetector, DetectorArgs, DetectorKind, choose_detector};
pub use runtime::frame::{RobotState, StoredFrame};
pub use runtime::models::{load_config, load_models};
pub use runtime::ros_frames::RosTopics;
pub use runtime::source::{FrameSource, McapSource};
pub use runtime::timer::StageTimer;
pub use runtime::{
    FrameHook, FrameReport, RunArgs, Source, Summary as RunSummary, run as run_agent, wall_now,
};
pub use view::{VIEW_JPEG_TARGET_BYTES, ViewError, camera_view};
