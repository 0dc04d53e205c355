//! The robot agent's state between frames, without any I/O: camera models, detector,
//! sequence numbers, the team's latest ball state and counters (each camera's too). The
//! binary feeds it frames, their pipeline times and ball states, and publishes what it
//! returns.

use crate::calibration::camera::CameraModel;
use crate::camera_counters::CameraCounters;
use crate::pipeline::{Eye, FrameInput, FrameResult, SharedBall, ValidationConfig};
use crate::projection::kinematics::camera_pose;
use crate::projection::{ProjectionNoise, footprint};
use crate::runtime::detector_choice::ChosenDetector;
use proto::{
    BallState, BallStatus, Camera, CameraFootprint, HeadJoints, Observation, Pitch, PixelBall,
    Pose2, RobotStatus, StageTiming, Stamp,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use vision::{DetectError, DetectorConfig, StageClock};

/// Settings of the perception pipeline (the `[pipeline]` part of the agent's config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    pub detector: DetectorConfig,
    pub noise: ProjectionNoise,
    pub validation: ValidationConfig,
}

/// What one frame gave.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameOutcome {
    /// The observation to publish, if the frame holds a ball.
    pub observation: Option<Observation>,
    pub result: FrameResult,
}

/// Floor footprints are cut off at this range, metres.
const FOOTPRINT_RANGE_M: f64 = 3.0;

/// A robot's perception state.
pub struct Agent {
    robot_id: String,
    models: [CameraModel; 2],
    eyes: [Eye; 2],
    seq: u64,
    shared: Option<BallState>,
    frames: u64,
    rejections: BTreeMap<&'static str, u64>,
    /// The left and right cameras' counters.
    cameras: [CameraCounters; 2],
    /// The last status's stamp: where the cameras' current interval began.
    last_status: Option<Stamp>,
}

impl std::fmt::Debug for Agent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Agent")
            .field("robot_id", &self.robot_id)
            .field("seq", &self.seq)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

fn index(camera: Camera) -> usize {
    match camera {
        Camera::Left => 0,
        Camera::Right => 1,
    }
}

impl Agent {
    /// `models` are the left and right cameras' calibrations; `chosen` the detector (its
    /// settings replace `config.detector`).
    pub fn new(
        robot_id: &str,
        pitch: Pitch,
        config: PipelineConfig,
        models: [CameraModel; 2],
        chosen: ChosenDetector,
    ) -> Self {
        let ChosenDetector {
            kind,
            detector,
            classifier,
            ..
        } = chosen;
        let eye = Eye::new(
            detector,
            classifier,
            kind.circle_noise(config.noise),
            config.validation,
            pitch,
        );
        Agent {
            robot_id: robot_id.to_string(),
            models,
            eyes: [eye.clone(), eye],
            seq: 0,
            shared: None,
            frames: 0,
            rejections: BTreeMap::new(),
            cameras: Default::default(),
            last_status: None,
        }
    }

    pub fn robot_id(&self) -> &str {
        &self.robot_id
    }

    /// The calibration the agent uses for `camera`.
    pub fn camera_model(&self, camera: Camera) -> &CameraModel {
        &self.models[index(camera)]
    }

    /// Replaces `camera`'s calibration (e.g. one rescaled to the frames' size).
    pub fn set_camera_model(&mut self, camera: Camera, model: CameraModel) {
        self.models[index(camera)] = model;
    }

    /// Frames processed so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Observations produced so far.
    pub fn observations(&self) -> u64 {
        self.seq
    }

    /// Candidates rejected so far, by reason.
    pub fn rejections(&self) -> &BTreeMap<&'static str, u64> {
        &self.rejections
    }

    /// Keeps the team's latest ball state for validating later frames.
    pub fn on_ball_state(&mut self, state: BallState) {
        if self.shared.as_ref().is_none_or(|s| s.stamp <= state.stamp) {
            self.shared = Some(state);
        }
    }

    /// The shared ball predicted to `stamp` (constant velocity; validation only needs a
    /// generous gate), or `None` when there is no usable one.
    pub(crate) fn shared_at(&self, stamp: Stamp) -> Option<SharedBall> {
        let s = self.shared.as_ref()?;
        if s.status == BallStatus::Lost {
            return None;
        }
        let dt = stamp.secs_since(s.stamp);
        let c = &s.covariance;
        Some(SharedBall {
            position_m: [
                s.position_m[0] + s.velocity_mps[0] * dt.max(0.0),
                s.position_m[1] + s.velocity_mps[1] * dt.max(0.0),
            ],
            covariance_m2: [c[0], c[1], c[4], c[5]],
            age_s: dt.abs(),
        })
    }

    /// Runs the pipeline on one frame: the camera's [`Eye`], then [`Agent::account`].
    pub fn on_frame(
        &mut self,
        frame: &FrameInput<'_>,
        clock: &mut dyn StageClock,
    ) -> Result<FrameOutcome, DetectError> {
        let i = index(frame.camera);
        let shared = self.shared_at(frame.stamp);
        let result = self.eyes[i].look(frame, &self.models[i], shared, clock)?;
        Ok(self.account(frame, result))
    }

    /// The camera's eye (a copy), to run on a thread of its own: [`Eye::look`] with
    /// [`Agent::camera_model`] and [`Agent::shared_at`], then [`Agent::account`].
    pub(crate) fn eye(&self, camera: Camera) -> Eye {
        self.eyes[index(camera)].clone()
    }

    /// Counts what `frame` gave and makes its observation, numbered in the order frames
    /// are accounted.
    pub(crate) fn account(&mut self, frame: &FrameInput<'_>, result: FrameResult) -> FrameOutcome {
        let i = index(frame.camera);
        self.frames += 1;
        for (_, why) in &result.rejected {
            *self.rejections.entry(why.reason()).or_default() += 1;
        }
        self.cameras[i].on_frame(frame.stamp, &result);
        let observation = result.sighting.as_ref().map(|s| {
            let obs = Observation {
                version: proto::VERSION,
                robot_id: self.robot_id.clone(),
                seq: self.seq,
                camera: frame.camera,
                stamp: frame.stamp,
                position_m: s.floor.position_m,
                covariance_m2: s.floor.covariance_m2,
                confidence: s.confidence.clamp(0.0, 1.0),
                robot_pose: frame.pose,
                pixel: Some(PixelBall {
                    u_px: s.circle.center_px[0],
                    v_px: s.circle.center_px[1],
                    radius_px: s.circle.radius_px,
                }),
            };
            self.seq += 1;
            obs
        });
        FrameOutcome {
            observation,
            result,
        }
    }

    /// The pipeline's time on `camera`'s last frame (the shell measures it), for the
    /// camera's median in the status.
    pub fn record_pipeline_ms(&mut self, camera: Camera, pipeline_ms: f64) {
        self.cameras[index(camera)].on_pipeline_ms(pipeline_ms);
    }

    /// The robot's status: pose, head, frame rate, stage timings, each camera's floor
    /// footprint and each camera's perception counters, with rates over the interval since
    /// the last status (which this one closes).
    pub fn status(
        &mut self,
        stamp: Stamp,
        pose: Pose2,
        pose_covariance: [f64; 9],
        head: HeadJoints,
        fps: f64,
        timings: Vec<StageTiming>,
    ) -> RobotStatus {
        let footprints = [Camera::Left, Camera::Right]
            .into_iter()
            .map(|camera| CameraFootprint {
                camera,
                polygon_m: footprint(
                    &self.models[index(camera)],
                    &camera_pose(&pose, &head, camera),
                    FOOTPRINT_RANGE_M,
                    6,
                ),
            })
            .collect();
        let since = self.last_status.replace(stamp);
        let cameras = [Camera::Left, Camera::Right]
            .into_iter()
            .map(|camera| self.cameras[index(camera)].close_interval(camera, since, stamp))
            .collect();
        RobotStatus {
            version: proto::VERSION,
            robot_id: self.robot_id.clone(),
            stamp,
            pose,
            pose_covariance,
            head,
            fps,
            timings,
            footprints,
            cameras,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::test_fixtures::{head as head_yawed, miro_lens as lens};
    use proto::Validate;
    use vision::{HoughOnly, NoClock, RgbImage};

    fn head() -> HeadJoints {
        head_yawed(0.0)
    }

    fn agent() -> Agent {
        Agent::new(
            "miro1",
            Pitch::default(),
            PipelineConfig::default(),
            [lens(), lens()],
            crate::runtime::detector_choice::ChosenDetector::with_classifier(
                crate::runtime::detector_choice::DetectorKind::Dissertation,
                &PipelineConfig::default().detector,
                std::sync::Arc::new(HoughOnly),
            )
            .unwrap(),
        )
    }

    /// A frame with an orange disc in the lower middle of the image, about the size a ball
    /// there would have.
    fn frame_with_ball() -> RgbImage {
        let mut data = Vec::with_capacity(640 * 360 * 3);
        for y in 0..360 {
            for x in 0..640 {
                let d = (f64::from(x) - 300.0).hypot(f64::from(y) - 250.0);
                data.extend_from_slice(if d <= 26.0 {
                    &[235, 120, 30]
                } else {
                    &[120, 118, 112]
                });
            }
        }
        RgbImage::new(640, 360, data).unwrap()
    }

    #[test]
    fn a_frame_with_a_ball_gives_a_valid_observation_with_increasing_seq() {
        let mut a = agent();
        let image = frame_with_ball();
        let input = FrameInput {
            stamp: Stamp(1_000_000_000),
            camera: Camera::Left,
            image: &image,
            pose: Pose2::default(),
            pose_covariance: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4],
            head: head(),
        };
        let first = a.on_frame(&input, &mut NoClock).unwrap();
        let o1 = first
            .observation
            .unwrap_or_else(|| panic!("{:?}", first.result));
        let o2 = a
            .on_frame(&input, &mut NoClock)
            .unwrap()
            .observation
            .unwrap();
        assert_eq!((o1.seq, o2.seq), (0, 1));
        let ctx = proto::ValidationContext::new(Pitch::default(), Stamp(1_000_000_000));
        o1.validate(&ctx).unwrap();
        assert_eq!(o1.robot_id, "miro1");
        assert!(
            o1.position_m[0] > 0.2,
            "the ball is ahead: {:?}",
            o1.position_m
        );
        let blank = RgbImage::filled(640, 360, [120, 118, 112]).unwrap();
        let none = a
            .on_frame(
                &FrameInput {
                    image: &blank,
                    ..input
                },
                &mut NoClock,
            )
            .unwrap();
        assert!(none.observation.is_none());
        assert_eq!((a.frames(), a.observations()), (3, 2));
    }

    /// The settings shown in the agent's guide are the defaults, and parse.
    #[test]
    fn the_guide_shows_the_default_settings() {
        let guide = include_str!("../../docs/robot-agent.md");
        let block = guide
            .split("```toml\n")
            .nth(1)
            .and_then(|b| b.split("```").next())
            .unwrap();
        let parsed: PipelineConfig = toml::from_str(block).unwrap();
        assert_eq!(parsed, PipelineConfig::default());
        assert!(toml::from_str::<PipelineConfig>("[detector]\nadapt_rate = 0.0").is_ok());
        assert!(toml::from_str::<PipelineConfig>("[detector]\ncolour = 1").is_err());
    }

    #[test]
    fn status_carries_footprints_for_both_cameras() {
        let mut a = agent();
        let cov = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4];
        let s = a.status(Stamp(5), Pose2::default(), cov, head(), 15.0, Vec::new());
        assert_eq!(s.footprints.len(), 2);
        assert!(s.footprints.iter().all(|f| f.polygon_m.len() >= 12));
        let left_y: f64 = s.footprints[0].polygon_m.iter().map(|p| p[1]).sum();
        let right_y: f64 = s.footprints[1].polygon_m.iter().map(|p| p[1]).sum();
        assert!(left_y > right_y, "the left camera looks left");
        let ctx = proto::ValidationContext::new(Pitch::default(), Stamp(5));
        s.validate(&ctx).unwrap();
        // Both cameras' counters, even without frames.
        let cameras: Vec<Camera> = s.cameras.iter().map(|c| c.camera).collect();
        assert_eq!(cameras, [Camera::Left, Camera::Right]);
        assert!(
            s.cameras
                .iter()
                .all(|c| c.frames == 0 && c.frames_per_s == 0.0)
        );
    }

    #[test]
    fn status_counts_each_cameras_frames_over_the_interval() {
        let mut a = agent();
        let (ball, blank) = (
            frame_with_ball(),
            RgbImage::filled(640, 360, [120, 118, 112]).unwrap(),
        );
        let cov = [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-4];
        // The interval begins with a status at 0 s.
        a.status(Stamp(0), Pose2::default(), cov, head(), 15.0, Vec::new());
        // Left: a ball every 0.1 s for 1 s; right: one blank frame.
        for k in 1..=10u64 {
            let input = FrameInput {
                stamp: Stamp(k * 100_000_000),
                camera: Camera::Left,
                image: &ball,
                pose: Pose2::default(),
                pose_covariance: cov,
                head: head(),
            };
            a.on_frame(&input, &mut NoClock).unwrap();
            a.record_pipeline_ms(Camera::Left, 2.0 + k as f64);
        }
        let blank_input = FrameInput {
            stamp: Stamp(500_000_000),
            camera: Camera::Right,
            image: &blank,
            pose: Pose2::default(),
            pose_covariance: cov,
            head: head(),
        };
        a.on_frame(&blank_input, &mut NoClock).unwrap();
        a.record_pipeline_ms(Camera::Right, 1.0);
        let s = a.status(
            Stamp(1_000_000_000),
            Pose2::default(),
            cov,
            head(),
            15.0,
            Vec::new(),
        );
        let ctx = proto::ValidationContext::new(Pitch::default(), s.stamp);
        s.validate(&ctx).unwrap();
        let (left, right) = (&s.cameras[0], &s.cameras[1]);
        assert_eq!((left.frames, left.balls), (10, 10));
        assert!(left.candidates >= 10);
        assert!((left.frames_per_s - 10.0).abs() < 1e-9, "{left:?}");
        assert!((left.balls_per_s - 10.0).abs() < 1e-9, "{left:?}");
        assert!((left.detector_ms - 7.5).abs() < 1e-9, "{left:?}");
        assert_eq!((right.frames, right.balls), (1, 0));
        assert!((right.frames_per_s - 1.0).abs() < 1e-9, "{right:?}");
        assert_eq!(right.detector_ms, 1.0);
    }
}
