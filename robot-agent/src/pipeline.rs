//! One camera frame to at most one ball sighting on the floor: detection, projection and
//! world validation.
//!
//! Each candidate circle from the [`Detector`] is projected onto the floor
//! ([`crate::projection`]) and checked against the world:
//!
//! - the floor point must lie on the pitch, give or take a margin (a ball cannot be beyond
//!   the walls; a lamp or a robot's top projects far away);
//! - the distance implied by the ball's image radius must agree with the ground-plane range
//!   (something round of the ball's colour but higher up or of another size does not);
//! - when the team's shared ball state is fresh, the point must not be implausibly far from
//!   it, allowing for the state's covariance, the sighting's covariance and how far the ball
//!   could have rolled since.
//!
//! Of the candidates that pass, the most probable is the frame's sighting, and its
//! classifier probability (calibrated by the classifier) is the sighting's confidence.
//! Rejections are kept with their reasons so the agent can count them, and every scored
//! candidate's fate (the ball, a runner-up, or rejected and why) with the stage that
//! proposed it, for the camera's view.

use crate::calibration::camera::CameraModel;
use crate::projection::{
    FloorPoint, ImageBall, ProjectionError, ProjectionNoise, angular_radius_from_image_radius,
    project_ball,
};
use proto::{Camera, CandidateOutcome, CandidateStage, HeadJoints, Pitch, Pose2, Stamp};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use vision::Circle;
use vision::image::RgbImage;
use vision::{Candidate, CandidateClassifier, DetectError, Detector, StageClock};

/// Settings of projection and world validation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ValidationConfig {
    /// How far beyond the pitch's inner edge a floor point may lie, metres.
    pub pitch_margin_m: f64,
    /// Accepted range of (distance from the image radius) / (ground-plane distance).
    pub radius_ratio_min: f64,
    pub radius_ratio_max: f64,
    /// Candidates below this probability are not balls.
    pub min_probability: f64,
    /// Mahalanobis distance beyond which a sighting contradicts the shared state.
    pub shared_gate: f64,
    /// Fastest the ball is taken to roll when widening the shared state's gate, m/s.
    pub shared_max_speed_mps: f64,
    /// A shared state older than this is not used, seconds.
    pub shared_max_age_s: f64,
}

impl Default for ValidationConfig {
    fn default() -> Self {
        ValidationConfig {
            pitch_margin_m: 0.15,
            radius_ratio_min: 0.6,
            radius_ratio_max: 1.6,
            min_probability: 0.5,
            shared_gate: 5.0,
            shared_max_speed_mps: 3.0,
            shared_max_age_s: 1.0,
        }
    }
}

/// The team's ball estimate, as far as validation needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SharedBall {
    /// Predicted to the frame's capture time, field frame, metres.
    pub position_m: [f64; 2],
    /// Row-major 2×2 position covariance, square metres.
    pub covariance_m2: [f64; 4],
    /// Seconds between the shared state's stamp and the frame's capture.
    pub age_s: f64,
}

/// What a camera frame is processed with.
#[derive(Debug, Clone, Copy)]
pub struct FrameContext<'a> {
    pub camera: Camera,
    pub model: &'a CameraModel,
    pub pose: Pose2,
    /// Row-major 3×3 covariance of (x, y, θ).
    pub pose_covariance: [f64; 9],
    pub head: HeadJoints,
    pub pitch: &'a Pitch,
    pub shared: Option<SharedBall>,
}

/// Why a candidate circle is not the frame's ball.
#[derive(Debug, Clone, PartialEq)]
pub enum Rejection {
    LowProbability { probability: f64 },
    Projection(ProjectionError),
    OffPitch { outside_m: f64 },
    RadiusMismatch { ratio: f64 },
    FarFromShared { mahalanobis: f64 },
}

impl Rejection {
    /// A short name for counters.
    pub fn reason(&self) -> &'static str {
        match self {
            Rejection::LowProbability { .. } => "low_probability",
            Rejection::Projection(_) => "projection",
            Rejection::OffPitch { .. } => "off_pitch",
            Rejection::RadiusMismatch { .. } => "radius_mismatch",
            Rejection::FarFromShared { .. } => "far_from_shared",
        }
    }
}

/// A validated ball in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    pub circle: Circle,
    /// The classifier's probability that this is the ball.
    pub confidence: f64,
    pub floor: FloorPoint,
}

/// One scored candidate and what became of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoredCandidate {
    /// Centre and radius in the frame's pixels.
    pub circle: Circle,
    /// The classifier's probability that it is the ball.
    pub probability: f64,
    /// The detector stage that proposed it.
    pub stage: CandidateStage,
    /// The frame's ball, a valid runner-up, or rejected.
    pub outcome: CandidateOutcome,
    /// With `outcome` `Rejected`: [`Rejection::reason`].
    pub reason: Option<&'static str>,
}

/// The outcome of one frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameResult {
    pub sighting: Option<Sighting>,
    pub rejected: Vec<(Circle, Rejection)>,
    /// Every candidate the classifier scored, with its probability, most probable first.
    pub scored: Vec<(Circle, f64)>,
    /// The same candidates with their stage and fate, most probable first.
    pub candidates: Vec<ScoredCandidate>,
}

/// One captured camera frame with the robot's state at capture.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    pub stamp: Stamp,
    pub camera: Camera,
    pub image: &'a RgbImage,
    pub pose: Pose2,
    /// Row-major 3×3 covariance of (x, y, θ).
    pub pose_covariance: [f64; 9],
    pub head: HeadJoints,
}

/// One camera's pipeline: its detector (whose colour window adapts to that camera's
/// light), the candidate classifier and the checks after projection. The agent holds one
/// per camera; the perceive loop runs each on its camera's own thread.
#[derive(Clone)]
pub(crate) struct Eye {
    detector: Detector,
    classifier: Arc<dyn CandidateClassifier + Send + Sync>,
    noise: ProjectionNoise,
    validation: ValidationConfig,
    pitch: Pitch,
}

impl std::fmt::Debug for Eye {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Eye").finish_non_exhaustive()
    }
}

impl Eye {
    pub(crate) fn new(
        detector: Detector,
        classifier: Arc<dyn CandidateClassifier + Send + Sync>,
        noise: ProjectionNoise,
        validation: ValidationConfig,
        pitch: Pitch,
    ) -> Eye {
        Eye {
            detector,
            classifier,
            noise,
            validation,
            pitch,
        }
    }

    /// Detection, projection and validation of one frame seen through `model`, with the
    /// team's ball at its capture (`shared`); the colour window adapts to a sighting.
    pub(crate) fn look(
        &mut self,
        frame: &FrameInput<'_>,
        model: &CameraModel,
        shared: Option<SharedBall>,
        clock: &mut dyn StageClock,
    ) -> Result<FrameResult, DetectError> {
        let ctx = FrameContext {
            camera: frame.camera,
            model,
            pose: frame.pose,
            pose_covariance: frame.pose_covariance,
            head: frame.head,
            pitch: &self.pitch,
            shared,
        };
        let result = process_frame(
            &self.detector,
            self.classifier.as_ref(),
            &self.noise,
            &self.validation,
            frame.image,
            &ctx,
            clock,
        )?;
        if let Some(s) = &result.sighting {
            self.detector.adapt(frame.image, &s.circle)?;
        }
        Ok(result)
    }
}

/// Detection, projection and validation of one camera frame.
#[allow(clippy::too_many_arguments)]
pub fn process_frame(
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
    noise: &ProjectionNoise,
    validation: &ValidationConfig,
    image: &RgbImage,
    ctx: &FrameContext<'_>,
    clock: &mut dyn StageClock,
) -> Result<FrameResult, DetectError> {
    // With the candidate network, the tracked ball's predicted place is always a candidate.
    let hint = detector
        .config()
        .proposer
        .net()
        .then(|| predicted_circle(ctx, validation))
        .flatten();
    let candidates = detector.detect_with_hint(image, Some(ctx.model), hint, classifier, clock)?;
    let mut result = FrameResult::default();
    for candidate in candidates {
        result
            .scored
            .push((candidate.circle, candidate.probability));
        let (outcome, reason) = match validate(candidate, noise, validation, ctx) {
            Ok(sighting) if result.sighting.is_none() => {
                result.sighting = Some(sighting);
                (CandidateOutcome::Ball, None)
            }
            // Candidates come most probable first: later valid ones are runners-up.
            Ok(_) => (CandidateOutcome::RunnerUp, None),
            Err(why) => {
                let reason = why.reason();
                result.rejected.push((candidate.circle, why));
                (CandidateOutcome::Rejected, Some(reason))
            }
        };
        result.candidates.push(ScoredCandidate {
            circle: candidate.circle,
            probability: candidate.probability,
            stage: candidate.stage,
            outcome,
            reason,
        });
    }
    clock.mark("project");
    Ok(result)
}

/// Where the team's fresh shared ball should appear in this camera's image: its centre
/// and radius in pixels, or `None` when there is no fresh state or it is behind the camera
/// or off the image.
pub fn predicted_circle(ctx: &FrameContext<'_>, cfg: &ValidationConfig) -> Option<Circle> {
    let shared = ctx.shared.filter(|s| s.age_s <= cfg.shared_max_age_s)?;
    let r_m = ctx.pitch.ball_radius_m;
    let cam = crate::projection::kinematics::camera_pose(&ctx.pose, &ctx.head, ctx.camera);
    let world = nalgebra::Vector3::new(shared.position_m[0], shared.position_m[1], r_m);
    let p = cam.field_from_camera.inverse() * (world - cam.centre_m);
    let distance_m = p.norm();
    if p.z <= 0.0 || distance_m <= r_m {
        return None;
    }
    let centre = ctx.model.project([p.x, p.y, p.z])?;
    // A point on the ball's rim, across the line of sight.
    let across = p.cross(&nalgebra::Vector3::y()).normalize() * r_m;
    let rim = ctx
        .model
        .project([p.x + across.x, p.y + across.y, p.z + across.z])?;
    let radius_px = (rim[0] - centre[0]).hypot(rim[1] - centre[1]).max(1.0);
    let (w, h) = (
        f64::from(ctx.model.intrinsics.width_px),
        f64::from(ctx.model.intrinsics.height_px),
    );
    let inside = (0.0..w).contains(&centre[0]) && (0.0..h).contains(&centre[1]);
    inside.then_some(Circle {
        center_px: centre,
        radius_px,
        score: 0.0,
    })
}

fn validate(
    candidate: Candidate,
    noise: &ProjectionNoise,
    cfg: &ValidationConfig,
    ctx: &FrameContext<'_>,
) -> Result<Sighting, Rejection> {
    if candidate.probability < cfg.min_probability {
        return Err(Rejection::LowProbability {
            probability: candidate.probability,
        });
    }
    let circle = candidate.circle;
    let ball_radius_m = ctx.pitch.ball_radius_m;
    let angular_radius_rad = candidate
        .angular_radius_rad
        .filter(|a| *a > 0.0)
        .or_else(|| {
            angular_radius_from_image_radius(ctx.model, circle.center_px, circle.radius_px)
        });
    let ball = ImageBall {
        center_px: circle.center_px,
        radius_px: circle.radius_px,
        // A sparse blob's radius is too uncertain to range by: the ground plane alone.
        angular_radius_rad: angular_radius_rad.filter(|_| !candidate.sparse_blob),
    };
    let floor = project_ball(
        ctx.model,
        ctx.camera,
        &ball,
        &ctx.pose,
        &ctx.pose_covariance,
        &ctx.head,
        ball_radius_m,
        noise,
    )
    .map_err(Rejection::Projection)?;
    let outside_m = ctx.pitch.outside_distance_m(floor.position_m);
    if outside_m > cfg.pitch_margin_m {
        return Err(Rejection::OffPitch { outside_m });
    }
    if let Some(alpha) = angular_radius_rad {
        // The two range cues must roughly agree before they are combined.
        let seen_m = ball_radius_m / alpha.sin();
        let cam = crate::projection::kinematics::camera_pose(&ctx.pose, &ctx.head, ctx.camera);
        let drop_m = cam.centre_m.z - ball_radius_m;
        let ground_m = floor.ground_range_m.hypot(drop_m);
        let ratio = seen_m / ground_m;
        if !(cfg.radius_ratio_min..=cfg.radius_ratio_max).contains(&ratio) {
            return Err(Rejection::RadiusMismatch { ratio });
        }
    }
    if let Some(shared) = ctx.shared.filter(|s| s.age_s <= cfg.shared_max_age_s) {
        let mahalanobis = shared_distance(&shared, &floor, cfg.shared_max_speed_mps);
        if mahalanobis > cfg.shared_gate {
            return Err(Rejection::FarFromShared { mahalanobis });
        }
    }
    Ok(Sighting {
        circle,
        confidence: candidate.probability,
        floor,
    })
}

/// Mahalanobis distance between a floor point and the shared ball, with the gate widened
/// isotropically by how far the ball could have rolled since the shared state.
fn shared_distance(shared: &SharedBall, floor: &FloorPoint, max_speed_mps: f64) -> f64 {
    let roll = (max_speed_mps * shared.age_s.max(0.0)).powi(2);
    let c = [
        shared.covariance_m2[0] + floor.covariance_m2[0] + roll,
        shared.covariance_m2[1] + floor.covariance_m2[1],
        shared.covariance_m2[2] + floor.covariance_m2[2],
        shared.covariance_m2[3] + floor.covariance_m2[3] + roll,
    ];
    let det = c[0] * c[3] - c[1] * c[2];
    let dx = floor.position_m[0] - shared.position_m[0];
    let dy = floor.position_m[1] - shared.position_m[1];
    if !(det > 0.0 && det.is_finite()) {
        return f64::INFINITY;
    }
    let d2 = (c[3] * dx * dx - (c[1] + c[2]) * dx * dy + c[0] * dy * dy) / det;
    d2.max(0.0).sqrt()
}

#[cfg(test)]
#[path = "pipeline_tests.rs"]
mod tests;
