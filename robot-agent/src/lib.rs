//! The robot agent: finds the ball in a MiRo's camera frames, projects it onto the floor
//! with the robot's kinematics and publishes it as a `proto::Observation` with an honest
//! covariance.
//!
//! The vision modules are pure: functions over images and numbers, no clock reads, no I/O
//! except image file loading. The runtime is the shell around them: frame sources, the
//! perceive loop and Zenoh ([`run_agent`]); the `robot-agent` binary is a thin command
//! line over it ([`cli::main`]).
//!
//! This root is the crate's front door; behind it, private modules, one per concern:
//! calibration (chessboards, [`calibrate_with`]), detection (the `vision` crate's stages,
//! one frame to ball candidates: [`Detector`], the classifiers [`BallNet`] and
//! [`SvmModel`], re-exported here), training (the learned stages' training, apart from
//! what the robot runs), projection (pixel to floor point with its covariance, and the MiRo's
//! kinematics), the image buffers ([`RgbImage`], [`GrayImage`]), the pipeline of one frame
//! and the [`Agent`] between frames (with each camera's perception counters), a camera's
//! view for people watching ([`camera_view`]), image files and ROS messages ([`ros_msg`]),
//! and the runtime's frame sources ([`FrameSource`], [`McapSource`]). Three public modules are
//! APIs of their own: [`builtin`] (the shipped calibration and ball classifier),
//! [`labels`] (Pascal VOC and YOLO labels and the detector scored against them) and
//! [`cli`] (the command line, and the flag groups and steps the simulator-driven tools
//! share with it).
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
use vision as detection;
use vision::image;
mod io;
mod pipeline;
mod projection;
mod runtime;
#[cfg(test)]
mod test_fixtures;
mod view;

pub use agent::{Agent, FrameInput, PipelineConfig};
pub use calibration::camera::CameraModel;
pub use calibration::{Calibration, CalibrationError, ViewResult};
pub use detection::ballnet::BallNet;
pub use detection::checker::Checker;
pub use detection::detect::{CandidateClassifier, Detector, DetectorConfig, NoClock, StageClock};
pub use detection::heatnet::{HeatNet, PeakConfig};
pub use detection::hog::HOG_LEN;
pub use detection::hough::Circle;
pub use detection::patch::{Patch, PatchConfig, extract as extract_patch};
pub use detection::photo::{PhotoCandidate, PhotoRejection, detect_photo};
pub use detection::svm::Model as SvmModel;
pub use image::RgbImage;
pub use image::gray::GrayImage;
pub use io::image_io::{
    ImageIoError, decode_gray, decode_rgb, encode_png, image_files, image_files_recursive,
    load_gray, load_rgb,
};
pub use io::ros_msg;
#[cfg(any(test, feature = "test-support"))]
pub use io::ros_msg_fixtures;
pub use pipeline::{FrameResult, ScoredCandidate, ValidationConfig};
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
