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
//! crate's ([`Detector`] and the classifiers [`BallNet`] and [`SvmModel`] are re-exported
//! here for the agent's users); training, labels and calibration from chessboards are the
//! `lab` crate's, which the robot's program does not link. Two public modules are APIs of
//! their own: [`builtin`] (the shipped calibration and ball classifier) and [`cli`] (the
//! command line).
//!
//! ```
//! use robot_agent::{Detector, DetectorConfig, NoClock, RgbImage};
//!
//! // A grey carpet with an orange ball of radius 20 px centred at (80, 60).
//! let mut image = RgbImage::filled(160, 120, [90, 100, 90]).unwrap();
//! for y in 0..120u32 {
//!     for x in 0..160u32 {
//!         if (f64::from(x) - 80.0).hypot(f64::from(y) - 60.0) <= 20.0 {
//!             image.set_pixel(x, y, [235, 120, 25]);
//!         }
//!     }
//! }
//! let detector = Detector::new(DetectorConfig::default()).unwrap();
//! let proposals = detector.propose(&image, None, &mut NoClock).unwrap();
//! let nearest = proposals
//!     .items
//!     .iter()
//!     .map(|p| (p.frame.center_px[0] - 80.0).hypot(p.frame.center_px[1] - 60.0))
//!     .fold(f64::INFINITY, f64::min);
//! assert!(nearest < 3.0, "the ball is proposed ({nearest} px off)");
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
pub use vision::Circle;
pub use vision::GrayImage;
pub use vision::RgbImage;
pub use vision::photo::{PhotoCandidate, PhotoRejection, detect_photo};
pub use vision::stages::ballnet::BallNet;
pub use vision::stages::candidates::{HeatNet, PeakConfig};
pub use vision::stages::checker::Checker;
pub use vision::stages::hog::HOG_LEN;
pub use vision::stages::patch::{Patch, PatchConfig, extract as extract_patch};
pub use vision::stages::svm::Model as SvmModel;
pub use vision::{CandidateClassifier, Detector, DetectorConfig, NoClock, StageClock};
