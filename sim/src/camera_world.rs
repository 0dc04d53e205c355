//! A simulated match as the robots' cameras see it.
//!
//! For one robot of a [`SimRun`] at a time `t_s`, this builds the scene (the true ball,
//! the other MiRos, the light at that moment), moves the robot's head, renders both
//! cameras and gives the pose and joint readings the robot would have: the true pose plus
//! a slowly wandering localisation error, and the joints plus a small encoder error. Every
//! value is a pure function of the run, the settings, the robot and the time.

use crate::head::default_head;
use crate::render::{CameraRig, render_robot_cameras};
use crate::render_scene::{BallLook, BallPattern, BallTruth, Frame, Lighting, RobotBody, Scene};
use crate::rng::Rng;
use crate::run::SimRun;
use proto::miro::{LIFT_RANGE_RAD, PITCH_RANGE_RAD, YAW_RANGE_RAD};
use proto::{HeadJoints, Pose2};

/// How the cameras' world varies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraWorldConfig {
    /// Camera frames per second (both cameras at once).
    pub frame_rate_hz: f64,
    pub ball_look: BallLook,
    /// Sensor noise, 8-bit levels.
    pub noise_sigma: f64,
    /// Exposure and white balance drift over the match (auto-exposure, clouds, lamps).
    pub lighting_changes: bool,
    /// Heads turn towards the ball and bob; otherwise they hold the default pose.
    pub moving_heads: bool,
    /// Standard deviations of the pose the robot believes it has: x and y, metres, and
    /// heading, radians. The readings wander with periods of several seconds.
    pub pose_error_sigma: [f64; 2],
    /// Standard deviation of the joint encoders' error, radians.
    pub joint_error_sigma_rad: f64,
}

impl Default for CameraWorldConfig {
    fn default() -> Self {
        CameraWorldConfig {
            frame_rate_hz: 15.0,
            ball_look: BallLook::default(),
            noise_sigma: 2.0,
            lighting_changes: true,
            moving_heads: true,
            pose_error_sigma: [0.01, 0.01],
            joint_error_sigma_rad: 0.003,
        }
    }
}

/// What a robot reads from its own sensors at a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotReading {
    /// The pose the robot believes it has.
    pub pose: Pose2,
    /// Row-major 3×3 covariance of (x, y, θ) it reports.
    pub pose_covariance: [f64; 9],
    /// The head joints as the encoders read them.
    pub head: HeadJoints,
}

/// One capture of both cameras with everything the simulator knows about it.
#[derive(Debug, Clone)]
pub struct CameraCapture {
    pub t_s: f64,
    /// Left then right.
    pub frames: [(Frame, Option<BallTruth>); 2],
    pub reading: RobotReading,
    pub true_pose: Pose2,
    pub true_head: HeadJoints,
}

/// A run seen through the robots' cameras.
#[derive(Debug)]
pub struct CameraWorld<'a> {
    run: &'a SimRun,
    rig: &'a CameraRig,
    cfg: CameraWorldConfig,
    seed: u64,
}

/// A smooth wandering signal of unit standard deviation: three sinusoids with periods of
/// 3–12 s and phases drawn from `(seed, name, index)`.
fn wander(seed: u64, name: &str, index: u64, t_s: f64) -> f64 {
    let mut rng = Rng::stream(seed, name, index);
    let mut sum = 0.0;
    for _ in 0..3 {
        let period = rng.range(3.0, 12.0);
        let phase = rng.range(0.0, std::f64::consts::TAU);
        sum += (std::f64::consts::TAU * t_s / period + phase).sin();
    }
    // Three unit sinusoids with independent phases have variance 3/2.
    sum / 1.5f64.sqrt()
}

fn robot_index(run: &SimRun, id: &str) -> u64 {
    run.robots.iter().position(|r| r.id == id).unwrap_or(0) as u64
}

impl<'a> CameraWorld<'a> {
    pub fn new(run: &'a SimRun, rig: &'a CameraRig, cfg: CameraWorldConfig, seed: u64) -> Self {
        CameraWorld {
            run,
            rig,
            cfg,
            seed,
        }
    }

    pub fn run(&self) -> &SimRun {
        self.run
    }

    pub fn config(&self) -> &CameraWorldConfig {
        &self.cfg
    }

    /// Capture times from the start of the run to its end.
    pub fn frame_times(&self) -> impl Iterator<Item = f64> + use<> {
        let dt = 1.0 / self.cfg.frame_rate_hz.max(1e-3);
        let n = (self.run.duration_s / dt).floor() as u64;
        (0..=n).map(move |k| k as f64 * dt)
    }

    /// The light at `t_s`: exposure drifting by up to ±35 % and the white balance by a few
    /// per cent, the main light's direction slowly turning.
    pub fn lighting_at(&self, t_s: f64) -> Lighting {
        let base = Lighting::default();
        if !self.cfg.lighting_changes {
            return base;
        }
        let w = |name: &str, k: u64| wander(self.seed, name, k, t_s);
        Lighting {
            exposure: (1.0 + 0.2 * w("exposure", 0)).clamp(0.65, 1.35),
            gain_rgb: [1.0 + 0.04 * w("gain", 0), 1.0, 1.0 + 0.04 * w("gain", 2)],
            light_dir: [0.4 + 0.2 * w("light", 0), 0.3 + 0.2 * w("light", 1), 1.0],
            ..base
        }
    }

    /// The true head joints of robot `id` at `t_s`: the head turns towards the ball (as a
    /// ball-watching behaviour would, a few tenths of a second behind) and bobs.
    pub fn head_at(&self, id: &str, t_s: f64) -> HeadJoints {
        let base = default_head();
        if !self.cfg.moving_heads {
            return base;
        }
        let Some(track) = self.run.robot(id) else {
            return base;
        };
        let pose = track.pose_at(t_s);
        let ball = self.run.truth_at((t_s - 0.3).max(0.0)).position_m;
        let bearing = (ball[1] - pose.y_m).atan2(ball[0] - pose.x_m) - pose.theta_rad;
        let bearing = bearing.sin().atan2(bearing.cos());
        let k = robot_index(self.run, id);
        let clamp = |v: f64, (lo, hi): (f64, f64)| v.clamp(lo, hi);
        HeadJoints {
            lift_rad: clamp(
                base.lift_rad + 0.06 * wander(self.seed, "lift", k, t_s),
                LIFT_RANGE_RAD,
            ),
            yaw_rad: clamp(
                0.6 * bearing,
                (YAW_RANGE_RAD.0 * 0.8, YAW_RANGE_RAD.1 * 0.8),
            ),
            pitch_rad: clamp(
                base.pitch_rad + 0.05 * wander(self.seed, "pitch", k, t_s),
                PITCH_RANGE_RAD,
            ),
        }
    }

    /// What robot `id` reads at `t_s` given its true head joints.
    pub fn reading(&self, id: &str, t_s: f64, head: HeadJoints) -> RobotReading {
        let k = robot_index(self.run, id);
        let pose = self
            .run
            .robot(id)
            .map(|r| r.pose_at(t_s))
            .unwrap_or_default();
        let [s_xy, s_th] = self.cfg.pose_error_sigma;
        let w = |name: &str| wander(self.seed, name, k, t_s);
        let sj = self.cfg.joint_error_sigma_rad;
        RobotReading {
            pose: Pose2 {
                x_m: pose.x_m + s_xy * w("pose_x"),
                y_m: pose.y_m + s_xy * w("pose_y"),
                theta_rad: pose.theta_rad + s_th * w("pose_theta"),
            },
            pose_covariance: [
                s_xy * s_xy,
                0.0,
                0.0,
                0.0,
                s_xy * s_xy,
                0.0,
                0.0,
                0.0,
                s_th * s_th,
            ],
            head: HeadJoints {
                lift_rad: head.lift_rad + sj * w("enc_lift"),
                yaw_rad: head.yaw_rad + sj * w("enc_yaw"),
                pitch_rad: head.pitch_rad + sj * w("enc_pitch"),
            },
        }
    }

    /// The scene robot `id` looks at at `t_s`: the ball and every other robot.
    pub fn scene_at(&self, id: &str, t_s: f64) -> Scene {
        let ball = self.run.truth_at(t_s).position_m;
        let r = self.run.pitch.ball_radius_m;
        let robots = self
            .run
            .robots
            .iter()
            .filter(|other| other.id != id)
            .map(|other| RobotBody {
                pose: other.pose_at(t_s),
                head: self.head_at(&other.id, t_s),
            })
            .collect();
        Scene {
            pitch: self.run.pitch.clone(),
            ball_m: Some([ball[0], ball[1], r]),
            ball_look: self.cfg.ball_look,
            robots,
            lighting: self.lighting_at(t_s),
            noise_sigma: self.cfg.noise_sigma,
            seed: self.seed,
        }
    }

    /// Renders both cameras of robot `id` at `t_s`; `frame_index` picks the noise.
    pub fn capture(&self, id: &str, t_s: f64, frame_index: u64) -> CameraCapture {
        let true_pose = self
            .run
            .robot(id)
            .map(|r| r.pose_at(t_s))
            .unwrap_or_default();
        let true_head = self.head_at(id, t_s);
        let scene = self.scene_at(id, t_s);
        let k = robot_index(self.run, id);
        let frames = render_robot_cameras(
            self.rig,
            &scene,
            true_pose,
            true_head,
            frame_index.wrapping_mul(64).wrapping_add(k),
        );
        CameraCapture {
            t_s,
            frames,
            reading: self.reading(id, t_s, true_head),
            true_pose,
            true_head,
        }
    }
}

/// The patterned look: the default orange with white patches.
pub fn patterned_ball() -> BallLook {
    BallLook {
        pattern: BallPattern::Patches,
        ..BallLook::default()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::lens::LensModel;
    use crate::{SimConfig, run_scenario};

    fn run() -> SimRun {
        let cfg = SimConfig {
            duration_s: Some(4.0),
            ..SimConfig::default()
        };
        run_scenario("seed-1-across", 1, &cfg).unwrap()
    }

    #[test]
    fn readings_wander_around_the_truth_within_their_stated_spread() {
        let run = run();
        let rig = CameraRig::new(LensModel::miro());
        let world = CameraWorld::new(&run, &rig, CameraWorldConfig::default(), 7);
        let id = run.observer_ids()[0].clone();
        let mut sq = 0.0;
        let mut n = 0.0;
        for t in world.frame_times() {
            let head = world.head_at(&id, t);
            let r = world.reading(&id, t, head);
            let truth = run.robot(&id).unwrap().pose_at(t);
            sq += (r.pose.x_m - truth.x_m).powi(2);
            n += 1.0;
            assert!((r.head.yaw_rad - head.yaw_rad).abs() < 0.02);
        }
        let rms = (sq / n).sqrt();
        assert!(rms > 0.001 && rms < 0.03, "x error rms {rms}");
    }

    #[test]
    fn the_head_turns_towards_the_ball_and_stays_within_its_joint_ranges() {
        let run = run();
        let rig = CameraRig::new(LensModel::miro());
        let world = CameraWorld::new(&run, &rig, CameraWorldConfig::default(), 7);
        let id = run.observer_ids()[0].clone();
        for t in world.frame_times() {
            let h = world.head_at(&id, t);
            assert!((LIFT_RANGE_RAD.0..=LIFT_RANGE_RAD.1).contains(&h.lift_rad));
            assert!((YAW_RANGE_RAD.0..=YAW_RANGE_RAD.1).contains(&h.yaw_rad));
            assert!((PITCH_RANGE_RAD.0..=PITCH_RANGE_RAD.1).contains(&h.pitch_rad));
        }
        let still = CameraWorld::new(
            &run,
            &rig,
            CameraWorldConfig {
                moving_heads: false,
                ..CameraWorldConfig::default()
            },
            7,
        );
        assert_eq!(still.head_at(&id, 1.0), default_head());
    }

    #[test]
    fn captures_are_deterministic_and_show_the_ball_to_the_observer() {
        let run = run();
        let rig = CameraRig::new(LensModel::miro());
        let world = CameraWorld::new(&run, &rig, CameraWorldConfig::default(), 7);
        let id = run.observer_ids()[0].clone();
        let a = world.capture(&id, 1.0, 15);
        let b = world.capture(&id, 1.0, 15);
        assert_eq!(a.frames[0].0.rgb, b.frames[0].0.rgb);
        let seen = world
            .frame_times()
            .step_by(5)
            .enumerate()
            .filter(|(k, t)| {
                world
                    .capture(&id, *t, *k as u64)
                    .frames
                    .iter()
                    .any(|(_, truth)| truth.is_some_and(|b| b.in_frame && b.visible_fraction > 0.5))
            })
            .count();
        assert!(seen > 0, "the seed's observer never sees the ball");
    }
}
