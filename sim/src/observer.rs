//! One observing robot's perception: frame timing, dropouts, occlusion, detections, false
//! positives, phantoms, and packaging into wire `Observation`s with latency.
//!
//! Each observer draws from its own random streams, so what one robot sees never changes
//! what another sees, nor the ball's path.

use crate::latency::{LatencyProfile, Link};
use crate::noise::{
    CameraView, MAX_RANGE_M, MIN_RANGE_M, PoseError, cameras, detection_probability,
    false_positive_point, honest_covariance, measure, projection_height_m, scaled,
};
use crate::rng::Rng;
use crate::robots::ROBOT_RADIUS_M;
use crate::types::{Delivery, ObsKind, SimStats};
use crate::vec2::{V2, angle, axpy, perp, segment_distance, sub, unit_or, wrap_angle};
use proto::{Camera, Observation, Pose2, Stamp};

/// Both cameras capture at this rate, at the same instants.
pub const FRAME_RATE_HZ: f64 = 15.0;
/// Probability that a camera image is lost (transport, processing overrun).
pub const DROPOUT_P: f64 = 0.03;
/// Mean time between burst dropouts of a robot (perception stalls), and their length.
pub const BURST_MEAN_INTERVAL_S: f64 = 20.0;
pub const BURST_RANGE_S: (f64, f64) = (0.3, 1.0);
/// Per-image probability of mistaking a visible robot's white top for the ball.
pub const FALSE_POSITIVE_P: f64 = 0.01;
/// Fraction of a phantom-seeing robot's capture instants that report the phantom.
pub const PHANTOM_P: f64 = 0.2;
pub const BALL_CONFIDENCE: (f64, f64) = (0.7, 1.0);
pub const FALSE_POSITIVE_CONFIDENCE: (f64, f64) = (0.4, 0.8);
pub const PHANTOM_CONFIDENCE: (f64, f64) = (0.7, 0.95);

/// The true world at a capture instant.
#[derive(Debug, Clone, Copy)]
pub struct Scene<'a> {
    pub ball: V2,
    /// True poses of all robots (the observer's own included, at its index).
    pub poses: &'a [Pose2],
    pub ball_radius_m: f64,
    /// Epoch of t = 0.
    pub start: Stamp,
}

/// How the line of sight to the ball meets other robots' bodies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Occlusion {
    Clear,
    /// The ray grazes a body: the visible part's centre is shifted by `shift` and the ball
    /// is `fraction` (0..0.5) hidden.
    Partial {
        shift: V2,
        fraction: f64,
    },
    Full,
}

/// Tests the floor-plane segment camera → ball against the bodies in `others`.
pub fn occlusion(
    cam: V2,
    ball: V2,
    others: impl Iterator<Item = V2>,
    ball_radius_m: f64,
) -> Occlusion {
    let mut result = Occlusion::Clear;
    let ray = unit_or(sub(ball, cam), [1.0, 0.0]);
    for c in others {
        let (d, f) = segment_distance(cam, ball, c);
        if f <= 0.0 || f >= 1.0 || d >= ROBOT_RADIUS_M + ball_radius_m {
            continue;
        }
        if d < ROBOT_RADIUS_M {
            return Occlusion::Full;
        }
        let fraction = (ROBOT_RADIUS_M + ball_radius_m - d) / (2.0 * ball_radius_m);
        let side = crate::vec2::dot(perp(ray), sub(c, cam)).signum();
        let shift = crate::vec2::scale(perp(ray), -side * fraction * ball_radius_m);
        if matches!(result, Occlusion::Clear) {
            result = Occlusion::Partial { shift, fraction };
        }
    }
    result
}

/// Centres of all robots but `me`.
fn others(poses: &[Pose2], me: usize) -> impl Iterator<Item = V2> + '_ {
    poses
        .iter()
        .enumerate()
        .filter(move |(j, _)| *j != me)
        .map(|(_, p)| [p.x_m, p.y_m])
}

/// A sighting before packaging.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sighting {
    camera: Camera,
    position_m: V2,
    covariance_m2: [f64; 4],
    confidence: f64,
    kind: ObsKind,
}

/// The perception state of one observing robot.
#[derive(Debug, Clone, PartialEq)]
pub struct Observer {
    /// Index of the robot in the world's robot list.
    pub index: usize,
    pub robot_id: String,
    pub link: Link,
    pub clock_offset_s: f64,
    pub cov_scale: f64,
    /// A ball-like object this robot reports in `PHANTOM_P` of its capture instants.
    pub phantom_spot: Option<V2>,
    /// Capture instants so far.
    pub frames: u64,
    /// Its perception stalls so far (burst dropouts): from and to, seconds.
    pub stalls: Vec<[f64; 2]>,
    /// Captures per second.
    pub frame_rate_hz: f64,
    rng: Rng,
    latency_rng: Rng,
    pose_err: PoseError,
    pose_err_t_s: f64,
    phase_s: f64,
    burst_until_s: f64,
    next_burst_s: f64,
    seq: u64,
}

impl Observer {
    pub fn new(
        index: usize,
        robot_id: String,
        seed: u64,
        profile: LatencyProfile,
        clock_offset_s: f64,
        cov_scale: f64,
    ) -> Self {
        let mut rng = Rng::stream(seed, "observer", index as u64);
        let mut latency_rng = Rng::stream(seed, "latency", index as u64);
        let link = Link::draw(&mut latency_rng, profile);
        let pose_err = PoseError::stationary(&mut rng);
        let phase_s = rng.range(0.0, 1.0 / FRAME_RATE_HZ);
        let next_burst_s = rng.exponential(BURST_MEAN_INTERVAL_S);
        Observer {
            index,
            robot_id,
            link,
            clock_offset_s,
            cov_scale,
            phantom_spot: None,
            frames: 0,
            stalls: Vec::new(),
            frame_rate_hz: FRAME_RATE_HZ,
            rng,
            latency_rng,
            pose_err,
            pose_err_t_s: 0.0,
            phase_s,
            burst_until_s: 0.0,
            next_burst_s,
            seq: 0,
        }
    }

    /// True time of the next capture.
    pub fn next_capture_s(&self) -> f64 {
        self.phase_s + self.frames as f64 / self.frame_rate_hz
    }

    /// The same observer capturing `hz` times a second (its phase within a frame kept).
    pub fn with_frame_rate(mut self, hz: f64) -> Self {
        if hz.is_finite() && hz > 0.0 {
            self.phase_s *= self.frame_rate_hz / hz;
            self.frame_rate_hz = hz;
        }
        self
    }

    /// Takes the capture at `next_capture_s()`: both cameras, everything they report, each
    /// packaged with its arrival time. Returns (capture time, delivery) pairs.
    pub fn capture(&mut self, scene: &Scene, stats: &mut SimStats) -> Vec<(f64, Delivery)> {
        let t = self.next_capture_s();
        self.frames += 1;
        self.pose_err.evolve(t - self.pose_err_t_s, &mut self.rng);
        self.pose_err_t_s = t;
        while t >= self.next_burst_s {
            self.burst_until_s =
                self.next_burst_s + self.rng.range(BURST_RANGE_S.0, BURST_RANGE_S.1);
            self.stalls.push([self.next_burst_s, self.burst_until_s]);
            self.next_burst_s = self.burst_until_s + self.rng.exponential(BURST_MEAN_INTERVAL_S);
        }
        if t < self.burst_until_s {
            stats.camera_frames += 2;
            stats.dropped += 2;
            return Vec::new();
        }
        let Some(me) = scene.poses.get(self.index).copied() else {
            return Vec::new();
        };
        let views = cameras(&me);
        let mut sightings = Vec::new();
        if let Some(spot) = self.phantom_spot
            && self.rng.chance(PHANTOM_P)
        {
            sightings.push(self.phantom(&views, &me, spot, scene));
            stats.phantoms += 1;
        }
        for view in &views {
            stats.camera_frames += 1;
            if self.rng.chance(DROPOUT_P) {
                stats.dropped += 1;
                continue;
            }
            self.look_for_ball(view, &me, scene, stats, &mut sightings);
            self.false_positives(view, &me, scene, stats, &mut sightings);
        }
        let believed = self.pose_err.believed(&me);
        sightings
            .into_iter()
            .map(|s| (t, self.package(t, s, believed, scene.start)))
            .collect()
    }

    fn look_for_ball(
        &mut self,
        view: &CameraView,
        me: &Pose2,
        scene: &Scene,
        stats: &mut SimStats,
        out: &mut Vec<Sighting>,
    ) {
        let Some(d) = view.sees(scene.ball) else {
            return;
        };
        if !(MIN_RANGE_M..=MAX_RANGE_M).contains(&d) {
            return;
        }
        stats.ball_in_view += 1;
        let others = others(scene.poses, self.index);
        let (target, confidence_factor) =
            match occlusion(view.pos, scene.ball, others, scene.ball_radius_m) {
                Occlusion::Full => {
                    stats.occluded += 1;
                    return;
                }
                Occlusion::Partial { shift, fraction } => {
                    stats.partially_occluded += 1;
                    (axpy(scene.ball, 1.0, shift), 1.0 - fraction)
                }
                Occlusion::Clear => (scene.ball, 1.0),
            };
        if !self.rng.chance(detection_probability(d)) {
            return;
        }
        stats.ball_detections += 1;
        let confidence = confidence_factor * self.rng.range(BALL_CONFIDENCE.0, BALL_CONFIDENCE.1);
        out.push(self.sighting(view, me, target, scene, confidence, ObsKind::Ball));
    }

    fn false_positives(
        &mut self,
        view: &CameraView,
        me: &Pose2,
        scene: &Scene,
        stats: &mut SimStats,
        out: &mut Vec<Sighting>,
    ) {
        for (j, other) in scene.poses.iter().enumerate() {
            if j == self.index {
                continue;
            }
            let body = [other.x_m, other.y_m];
            let Some(d) = view.sees(body) else {
                continue;
            };
            if !(MIN_RANGE_M..=MAX_RANGE_M).contains(&d) || !self.rng.chance(FALSE_POSITIVE_P) {
                continue;
            }
            stats.false_positives += 1;
            let h = projection_height_m(scene.ball_radius_m);
            let target = false_positive_point(view.pos, body, h);
            let confidence = self
                .rng
                .range(FALSE_POSITIVE_CONFIDENCE.0, FALSE_POSITIVE_CONFIDENCE.1);
            out.push(self.sighting(view, me, target, scene, confidence, ObsKind::FalsePositive));
        }
    }

    /// The phantom, reported by whichever camera looks closer to it.
    fn phantom(
        &mut self,
        views: &[CameraView; 2],
        me: &Pose2,
        spot: V2,
        scene: &Scene,
    ) -> Sighting {
        let off = |v: &CameraView| wrap_angle(angle(sub(spot, v.pos)) - v.axis_rad).abs();
        let view = if off(&views[0]) <= off(&views[1]) {
            &views[0]
        } else {
            &views[1]
        };
        let confidence = self.rng.range(PHANTOM_CONFIDENCE.0, PHANTOM_CONFIDENCE.1);
        self.sighting(view, me, spot, scene, confidence, ObsKind::Phantom)
    }

    /// A noisy sighting of something truly at `target`, with the covariance this robot
    /// reports for it (honest, or scaled for misreporting robots).
    fn sighting(
        &mut self,
        view: &CameraView,
        me: &Pose2,
        target: V2,
        scene: &Scene,
        confidence: f64,
        kind: ObsKind,
    ) -> Sighting {
        let h = projection_height_m(scene.ball_radius_m);
        let robot = [me.x_m, me.y_m];
        Sighting {
            camera: view.camera,
            position_m: measure(view.pos, robot, target, h, &self.pose_err, &mut self.rng),
            covariance_m2: scaled(
                honest_covariance(view.pos, robot, target, h),
                self.cov_scale,
            ),
            confidence: confidence.clamp(0.0, 1.0),
            kind,
        }
    }

    fn package(&mut self, t: f64, s: Sighting, believed: Pose2, start: Stamp) -> Delivery {
        let seq = self.seq;
        self.seq += 1;
        let delay = self.link.delay_s(&mut self.latency_rng);
        Delivery {
            arrival: start.offset_secs(t + delay),
            obs: Observation {
                version: proto::VERSION,
                robot_id: self.robot_id.clone(),
                seq,
                camera: s.camera,
                stamp: start.offset_secs(t + self.clock_offset_s),
                position_m: s.position_m,
                covariance_m2: s.covariance_m2,
                confidence: s.confidence,
                robot_pose: believed,
                pixel: None,
            },
            kind: s.kind,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64, y: f64, theta: f64) -> Pose2 {
        Pose2 {
            x_m: x,
            y_m: y,
            theta_rad: theta,
        }
    }

    #[test]
    fn occlusion_full_partial_clear() {
        let r = 0.04;
        let cam = [0.0, 0.0];
        let ball = [2.0, 0.0];
        assert_eq!(
            occlusion(cam, ball, [[1.0, 0.05]].into_iter(), r),
            Occlusion::Full
        );
        assert_eq!(
            occlusion(cam, ball, [[1.0, 0.5]].into_iter(), r),
            Occlusion::Clear
        );
        // Behind the ball: not in the way.
        assert_eq!(
            occlusion(cam, ball, [[2.5, 0.0]].into_iter(), r),
            Occlusion::Clear
        );
        match occlusion(cam, ball, [[1.0, 0.15]].into_iter(), r) {
            Occlusion::Partial { shift, fraction } => {
                assert!(fraction > 0.0 && fraction < 0.5);
                // Shifted away from the occluder (which is at +y).
                assert!(shift[1] < 0.0);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn observer_reports_ball_with_stamps_seq_and_latency() {
        let start = Stamp(1_000_000_000_000_000_000);
        let mut obs = Observer::new(0, "miro1".into(), 7, LatencyProfile::Normal, 0.01, 1.0);
        let poses = [pose(0.0, 0.0, 0.0)];
        let scene = Scene {
            ball: [1.0, 0.1],
            poses: &poses,
            ball_radius_m: 0.04,
            start,
        };
        let mut stats = SimStats::default();
        let mut all = Vec::new();
        for _ in 0..300 {
            all.extend(obs.capture(&scene, &mut stats));
        }
        assert!(all.len() > 400, "{}", all.len());
        for (k, (t, d)) in all.iter().enumerate() {
            assert_eq!(d.obs.seq, k as u64);
            assert_eq!(d.kind, ObsKind::Ball);
            let stamp_t = d.obs.stamp.secs_since(start);
            assert!((stamp_t - t - 0.01).abs() < 1e-6);
            let delay = d.arrival.secs_since(start) - t;
            assert!((0.02 - 1e-6..=0.15 + 1e-6).contains(&delay), "{delay}");
            assert!((0.7..=1.0).contains(&d.obs.confidence));
        }
        assert_eq!(stats.camera_frames, 600);
        assert!(stats.dropped > 0);
    }

    #[test]
    fn misreporting_scales_the_reported_covariance_only() {
        let poses = [pose(0.0, 0.0, 0.0)];
        let scene = Scene {
            ball: [1.0, 0.0],
            poses: &poses,
            ball_radius_m: 0.04,
            start: Stamp(0),
        };
        let mut honest = Observer::new(0, "a".into(), 3, LatencyProfile::Normal, 0.0, 1.0);
        let mut under = Observer::new(0, "a".into(), 3, LatencyProfile::Normal, 0.0, 0.25);
        let mut stats = SimStats::default();
        let a = honest.capture(&scene, &mut stats);
        let b = under.capture(&scene, &mut stats);
        assert!(!a.is_empty() && a.len() == b.len());
        for ((_, x), (_, y)) in a.iter().zip(&b) {
            assert_eq!(x.obs.position_m, y.obs.position_m);
            assert!((y.obs.covariance_m2[0] - 0.25 * x.obs.covariance_m2[0]).abs() < 1e-15);
        }
    }
}
