//! The vision evaluation: a scenario rendered through each observing robot's two cameras,
//! every frame through the real agent pipeline, and the agent's observations (instead of
//! the simulator's synthetic ones) through the fusion core, scored by the same code as
//! [`crate::scenarios`].
//!
//! The agent gets nothing from the simulator but the images and its own sensor readings (a
//! pose with a wandering error, head joints with encoder error); it knows the lens only
//! through the shipped calibration. It does not receive the fused ball state here, so its
//! world validation runs without the team's estimate.

use crate::scenarios::{RunResult, evaluate_run};
use proto::{Camera, Observation};
use robot_agent::CameraModel;
use robot_agent::{Agent, DetectorKind, FrameInput, PipelineConfig};
use sim::BallTruth;
use sim::CameraRig;
use sim::LensModel;
use sim::{CameraWorld, CameraWorldConfig};
use sim::{Delivery, ObsKind, SimConfig, SimRun};
use std::path::PathBuf;
use std::time::Instant;
use vision::NoClock;
use vision::RgbImage;

/// The simulator puts pixel centres at +0.5 (its origin is the top-left pixel's corner);
/// the agent's camera model puts the top-left pixel's centre at (0, 0), OpenCV's way. A
/// pixel position of the agent plus this offset is the simulator's.
pub const SIM_PIXEL_OFFSET: f64 = 0.5;

/// How the rendered frames become deliveries.
#[derive(Debug, Clone)]
pub struct VisionConfig {
    pub camera: CameraWorldConfig,
    /// Fixed delay from capture to the fusion core: the pipeline plus the network.
    pub latency_s: f64,
    /// The agent's detector (the robot's default unless told otherwise).
    pub detector: DetectorKind,
    /// A model file of `ball-lab train` in place of the shipped one.
    pub model: Option<PathBuf>,
}

impl Default for VisionConfig {
    fn default() -> Self {
        VisionConfig {
            camera: CameraWorldConfig::default(),
            latency_s: 0.040,
            detector: DetectorKind::default(),
            model: None,
        }
    }
}

/// One camera frame judged against the renderer's truth, with the counting rules of
/// `sim_agent`: a ball is visible when it is in the frame, at least half of it shows,
/// its image radius is at least 4 px and its centre lies on the image; an observation is a
/// hit when its pixel lies within max(radius, 4) px of the true centre.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameStat {
    pub visible: bool,
    pub hit: bool,
    /// The agent published an observation for this frame.
    pub observed: bool,
    /// Confidence of the observation, if any.
    pub confidence: Option<f64>,
    /// The true ball's image radius (0 when out of view).
    pub radius_px: f64,
    /// Wall time of `Agent::on_frame`, milliseconds.
    pub pipeline_ms: f64,
    /// How far a hit is from the truth, in the image and on the floor.
    pub error: Option<SightingError>,
    /// Every candidate the classifier scored: its probability, and whether it was the ball
    /// (within max(radius, 4) px of the true centre).
    pub candidates: Vec<(f64, bool)>,
}

/// A hit's error against the renderer's truth. The floor error is split along and across
/// the line from the robot (as it reports its pose) to the true ball, and set against the
/// covariance the agent stated: an honest covariance gives a mean NEES near 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SightingError {
    /// Detected minus true ball centre, pixels (u right, v down).
    pub pixel_px: [f64; 2],
    /// Detected minus true image radius, pixels.
    pub radius_px: f64,
    /// True distance from the robot to the ball on the floor.
    pub range_m: f64,
    /// Floor error away from the robot (positive: the ball was put too far away).
    pub along_m: f64,
    /// Floor error across the view line.
    pub across_m: f64,
    /// Stated standard deviations along and across the same line.
    pub sigma_along_m: f64,
    pub sigma_across_m: f64,
    /// Normalised estimation error squared, eᵀ Σ⁻¹ e.
    pub nees: f64,
}

impl SightingError {
    fn of(truth: &BallTruth, obs: &Observation) -> Option<Self> {
        let (p, c) = (obs.pixel?, truth.center_px?);
        let robot = [obs.robot_pose.x_m, obs.robot_pose.y_m];
        let (dx, dy) = (truth.world_m[0] - robot[0], truth.world_m[1] - robot[1]);
        let range_m = dx.hypot(dy);
        if range_m < 1e-6 {
            return None;
        }
        let along = [dx / range_m, dy / range_m];
        let across = [-along[1], along[0]];
        let e = [
            obs.position_m[0] - truth.world_m[0],
            obs.position_m[1] - truth.world_m[1],
        ];
        let cov = nalgebra::Matrix2::from_row_slice(&obs.covariance_m2);
        let ev = nalgebra::Vector2::new(e[0], e[1]);
        let nees = cov
            .try_inverse()
            .map(|inv| (ev.transpose() * inv * ev)[0])?;
        let var = |u: [f64; 2]| {
            let u = nalgebra::Vector2::new(u[0], u[1]);
            (u.transpose() * cov * u)[0].max(0.0).sqrt()
        };
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        Some(SightingError {
            pixel_px: [
                p.u_px + SIM_PIXEL_OFFSET - c[0],
                p.v_px + SIM_PIXEL_OFFSET - c[1],
            ],
            radius_px: p.radius_px - truth.radius_px,
            range_m,
            along_m: dot(e, along),
            across_m: dot(e, across),
            sigma_along_m: var(along),
            sigma_across_m: var(across),
            nees,
        })
    }
}

impl FrameStat {
    /// A visible ball the agent found.
    pub fn true_hit(&self) -> bool {
        self.visible && self.hit
    }

    /// An observation that is not the ball.
    pub fn false_sighting(&self) -> bool {
        self.observed && !self.hit
    }
}

/// The fusion evaluation of one scenario and seed on the agent's observations, and the
/// per-frame detection record.
#[derive(Debug)]
pub struct VisionResult {
    pub result: RunResult,
    pub frames: Vec<FrameStat>,
    pub observations: usize,
}

/// Whether an agent pixel lies on the true ball.
fn on_ball(truth: &BallTruth, u_px: f64, v_px: f64) -> bool {
    truth.center_px.is_some_and(|c| {
        let (u, v) = (u_px + SIM_PIXEL_OFFSET, v_px + SIM_PIXEL_OFFSET);
        (u - c[0]).hypot(v - c[1]) <= truth.radius_px.max(4.0)
    })
}

fn judge(
    truth: Option<&BallTruth>,
    obs: Option<&Observation>,
    width: u32,
    height: u32,
) -> (bool, bool, f64) {
    let Some(t) = truth else {
        return (false, false, 0.0);
    };
    let on_image = |c: [f64; 2]| {
        (0.0..f64::from(width)).contains(&c[0]) && (0.0..f64::from(height)).contains(&c[1])
    };
    let visible = t.in_frame
        && t.visible_fraction >= 0.5
        && t.radius_px >= 4.0
        && t.center_px.is_some_and(on_image);
    let hit = obs
        .and_then(|o| o.pixel)
        .is_some_and(|p| on_ball(t, p.u_px, p.v_px));
    let radius = if t.in_frame { t.radius_px } else { 0.0 };
    (visible, hit, radius)
}

/// The agent for robot `id` as `run` makes it: the simulator calibration for both cameras,
/// the default pipeline settings with the configured detector, and the shipped classifier
/// (or the configured model's).
pub fn shipped_agent(id: &str, run: &SimRun, cfg: &VisionConfig) -> anyhow::Result<Agent> {
    let config = PipelineConfig::default();
    let chosen =
        robot_agent::choose_detector(cfg.detector, &config.detector, cfg.model.as_deref())?;
    let model = robot_agent::builtin::sim_calibration()?.model;
    Ok(Agent::new(
        id,
        run.pitch.clone(),
        config,
        [model, model],
        chosen,
    ))
}

/// Renders every observer's cameras over the run and feeds the frames to its agent. Returns
/// the agent's observations as deliveries (sorted by arrival, like the simulator's) and the
/// per-frame record.
pub fn perceive(
    run: &SimRun,
    cfg: &VisionConfig,
) -> anyhow::Result<(Vec<Delivery>, Vec<FrameStat>)> {
    let rig = CameraRig::new(LensModel::miro());
    let world = CameraWorld::new(run, &rig, cfg.camera, run.seed);
    let mut deliveries = Vec::new();
    let mut frames = Vec::new();
    for id in run.observer_ids() {
        let mut agent = shipped_agent(&id, run, cfg)?;
        for (k, t_s) in world.frame_times().enumerate() {
            let capture = world.capture(&id, t_s, k as u64);
            let stamp = run.stamp_of(t_s);
            let r = capture.reading;
            for ((frame, truth), camera) in capture
                .frames
                .into_iter()
                .zip([Camera::Left, Camera::Right])
            {
                let (w, h) = (frame.width, frame.height);
                let image = RgbImage::new(w, h, frame.rgb)?;
                let input = FrameInput {
                    stamp,
                    camera,
                    image: &image,
                    pose: r.pose,
                    pose_covariance: r.pose_covariance,
                    head: r.head,
                };
                let started = Instant::now();
                let outcome = agent.on_frame(&input, &mut NoClock)?;
                let pipeline_ms = started.elapsed().as_secs_f64() * 1e3;
                let (visible, hit, radius_px) =
                    judge(truth.as_ref(), outcome.observation.as_ref(), w, h);
                frames.push(FrameStat {
                    visible,
                    hit,
                    observed: outcome.observation.is_some(),
                    confidence: outcome.observation.as_ref().map(|o| o.confidence),
                    radius_px,
                    pipeline_ms,
                    error: truth
                        .as_ref()
                        .zip(outcome.observation.as_ref())
                        .filter(|_| hit)
                        .and_then(|(t, o)| SightingError::of(t, o)),
                    candidates: outcome
                        .result
                        .scored
                        .iter()
                        .map(|(c, p)| {
                            let ball = truth
                                .as_ref()
                                .is_some_and(|t| on_ball(t, c.center_px[0], c.center_px[1]));
                            (*p, ball)
                        })
                        .collect(),
                });
                if let Some(obs) = outcome.observation {
                    deliveries.push(Delivery {
                        arrival: stamp.offset_secs(cfg.latency_s),
                        obs,
                        kind: if hit {
                            ObsKind::Ball
                        } else {
                            ObsKind::FalsePositive
                        },
                    });
                }
            }
        }
    }
    deliveries.sort_by(|a, b| {
        (a.arrival, a.obs.stamp, &a.obs.robot_id).cmp(&(b.arrival, b.obs.stamp, &b.obs.robot_id))
    });
    Ok((deliveries, frames))
}

/// Runs one scenario and seed through the cameras and the agent, then scores every method
/// of [`evaluate_run`] on the agent's observations.
pub fn evaluate_vision_run(
    scenario: &str,
    seed: u64,
    sim_cfg: &SimConfig,
    cfg: &VisionConfig,
) -> anyhow::Result<VisionResult> {
    let mut run = sim::run_scenario(scenario, seed, sim_cfg)?;
    let (deliveries, frames) = perceive(&run, cfg)?;
    let observations = deliveries.len();
    run.deliveries = deliveries;
    Ok(VisionResult {
        result: evaluate_run(&run),
        frames,
        observations,
    })
}

/// Runs `scenarios` × `seeds` on `jobs` threads, reporting progress on stderr.
pub fn evaluate_vision(
    scenarios: &[&str],
    seeds: u64,
    sim_cfg: &SimConfig,
    cfg: &VisionConfig,
    jobs: usize,
) -> anyhow::Result<Vec<VisionResult>> {
    let mut results = crate::scenarios::for_each_run(scenarios, seeds, jobs, |name, seed| {
        evaluate_vision_run(name, seed, sim_cfg, cfg)
    })?;
    results.sort_by(|a, b| {
        (a.result.scenario.as_str(), a.result.seed)
            .cmp(&(b.result.scenario.as_str(), b.result.seed))
    });
    Ok(results)
}

/// How far the fitted camera model is from the simulator's true lens.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LensError {
    pub max_px: f64,
    pub rms_px: f64,
    /// Grid pixels compared.
    pub pixels: usize,
    /// Grid pixels the model could not project (counted, not in the error).
    pub failed: usize,
}

/// For a grid of pixel positions every `step_px` over the whole image (agent convention),
/// the true lens's ray through the same point, projected with `model`: the distance from
/// where it started. `offset_px` is added to convert the agent's pixel positions to the
/// simulator's ([`SIM_PIXEL_OFFSET`] is the right one; other values show why).
pub fn lens_error(
    model: &CameraModel,
    lens: &LensModel,
    step_px: f64,
    offset_px: f64,
) -> LensError {
    let (w, h) = (f64::from(lens.width), f64::from(lens.height));
    let mut sq = 0.0;
    let mut max_px: f64 = 0.0;
    let (mut pixels, mut failed) = (0, 0);
    let step = step_px.max(0.25);
    let mut v = 0.0;
    while v <= h - 1.0 {
        let mut u = 0.0;
        while u <= w - 1.0 {
            let projected = lens
                .ray([u + offset_px, v + offset_px])
                .and_then(|ray| model.project(ray));
            match projected {
                Some(p) => {
                    let e = (p[0] - u).hypot(p[1] - v);
                    sq += e * e;
                    max_px = max_px.max(e);
                    pixels += 1;
                }
                None => failed += 1,
            }
            u += step;
        }
        v += step;
    }
    LensError {
        max_px,
        rms_px: if pixels == 0 {
            f64::NAN
        } else {
            (sq / pixels as f64).sqrt()
        },
        pixels,
        failed,
    }
}

/// The shipped calibration against the simulator's lens, and the calibration's own RMS
/// reprojection error on its boards.
pub fn shipped_lens_error(step_px: f64) -> anyhow::Result<(f64, LensError)> {
    let cal = robot_agent::builtin::sim_calibration()?;
    Ok((
        cal.rms_px,
        lens_error(&cal.model, &LensModel::miro(), step_px, SIM_PIXEL_OFFSET),
    ))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn the_half_pixel_offset_is_the_convention_that_fits() {
        let model = robot_agent::builtin::sim_calibration().unwrap().model;
        let lens = LensModel::miro();
        let right = lens_error(&model, &lens, 20.0, SIM_PIXEL_OFFSET);
        let none = lens_error(&model, &lens, 20.0, 0.0);
        let wrong = lens_error(&model, &lens, 20.0, -0.5);
        assert_eq!(right.failed, 0);
        assert!(right.rms_px < none.rms_px, "{right:?} vs {none:?}");
        assert!(right.rms_px < wrong.rms_px, "{right:?} vs {wrong:?}");
        assert!(none.rms_px > 0.3, "the offset matters: {none:?}");
    }
}
