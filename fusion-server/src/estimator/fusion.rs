//! The public face of the core: observations in (in any arrival order), ball state out.
//!
//! Observations are applied by capture time. Those that arrive late, up to
//! `late_window_s` behind the newest one, are inserted in capture order and the tracker is
//! replayed from the snapshot just before them, so the estimate is exactly the one an
//! in-order arrival would have given. Older ones are counted and dropped. The fused
//! estimate is never fed back in as an observation.

use super::calibration::Phase as CalibrationPhase;
use super::filter::{BallFilter, DECEL, RESTITUTION};
use super::intercept::{InterceptSolution, intercept};
use super::motion::{Bounds, fly, speed};
use super::predict;
use super::spread::{covariance_at, mix, mixed, spread, within_reach};
use super::tracker::{MotionEventKind, NothingSeen, ObsInput, RobotTrust, Tracker, TrackerConfig};
use super::views::{Footprint, FootprintError, Views};
use nalgebra::Matrix2;
use proto::{
    BallState, BallStatus, Camera, CameraFootprint, ModelParams, Observation, Pitch, Pose2,
    Prediction, Stamp,
};
use std::collections::VecDeque;
use std::sync::Arc;

/// How far from its centre a robot touches the ball: about half a MiRo's body, metres.
pub const ROBOT_REACH_M: f64 = 0.1;

#[derive(Debug, Clone, PartialEq)]
pub struct FusionConfig {
    pub pitch: Pitch,
    /// How late an observation may arrive (capture time behind the receiver's clock) and
    /// still be used.
    pub late_window_s: f64,
    /// How far a capture stamp may be ahead of the receiver's clock (robots' clock offsets).
    pub max_future_s: f64,
    pub tracker: TrackerConfig,
    /// Prediction horizon and sample spacing of the path in each `BallState`.
    pub horizon_s: f64,
    pub sample_dt_s: f64,
    /// Unseen for longer than this: coasting; longer than `lost_after_s`: lost.
    pub coasting_after_s: f64,
    pub lost_after_s: f64,
    /// Slower than this: stopped.
    pub stopped_speed_mps: f64,
    /// Robots that updated the estimate within this window are its contributors.
    pub contributors_window_s: f64,
}

impl Default for FusionConfig {
    fn default() -> Self {
        FusionConfig {
            pitch: Pitch::default(),
            late_window_s: 0.5,
            max_future_s: 1.0,
            tracker: TrackerConfig::default(),
            horizon_s: 3.0,
            sample_dt_s: 0.1,
            coasting_after_s: 0.5,
            lost_after_s: 3.0,
            stopped_speed_mps: 0.03,
            contributors_window_s: 1.0,
        }
    }
}

impl FusionConfig {
    /// The defaults on `pitch` (see [`FusionConfig::set_pitch`]).
    pub fn for_pitch(pitch: Pitch) -> Self {
        let mut cfg = FusionConfig::default();
        cfg.set_pitch(pitch);
        cfg
    }

    /// Puts the fusion on `pitch`. The pitch's wall restitution becomes the filter's
    /// starting restitution, which the filter then learns from the bounces it sees: the
    /// one place where a pitch turns into the motion model's starting value.
    pub fn set_pitch(&mut self, pitch: Pitch) {
        self.tracker.motion.restitution = pitch.wall_restitution;
        self.pitch = pitch;
    }
}

/// What happened to one ingested observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ingest {
    /// Applied in capture order on top of the current state.
    Applied,
    /// Arrived out of order; inserted and `replayed` later observations re-applied.
    Reordered { replayed: usize },
    /// Older than the late window: dropped.
    TooLate { late_s: f64 },
    /// Already seen (same robot, camera, sequence number and stamp): dropped.
    Duplicate,
    /// Not finite, or a covariance that is not positive definite: dropped.
    Rejected,
    /// Captured later than the receiver's clock allows (beyond `max_future_s`): dropped.
    FromTheFuture { ahead_s: f64 },
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FusionCounters {
    pub applied: u64,
    pub reordered: u64,
    pub replayed: u64,
    pub too_late: u64,
    pub duplicates: u64,
    pub rejected: u64,
    pub future: u64,
    /// Observations beyond a wall, dropped by the tracker.
    pub outside_walls: u64,
    /// Observations that went to hypotheses other than the estimate: waiting for enough
    /// support to be promoted, or phantoms that never are.
    pub held_in_hypotheses: u64,
    /// Kicks of the estimate the tracker inferred from runs of surprising sightings.
    pub kicks_inferred: u64,
    /// Wall bounces the estimate went through: foreseen by its flight, or found at a wall
    /// where a run of surprising sightings would otherwise have been a kick.
    pub bounces_seen: u64,
    /// Observations the filter could not apply: their innovation covariance was not
    /// positive definite.
    pub singular_updates: u64,
    /// New robots that took the place of one long quiet, the tracker's table being full.
    pub robot_slots_reused: u64,
    /// Frames that looked at a hypothesis and did not see it (negative information).
    pub misses_in_view: u64,
    /// Camera footprints kept, and refused (not a polygon, the whole pitch, ...).
    pub footprints_accepted: u64,
    pub footprints_rejected: u64,
    /// The estimate's forecasts scored against later sightings, and of those the ones
    /// outside the served 95 % region ([`super::calibration`]).
    pub forecasts_scored: u64,
    pub forecasts_outside_95: u64,
}

fn saturate(n: u64) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Finite numbers and a symmetric positive-definite covariance: what the filter can use.
/// (The server validates at its boundary; the core still never takes poison.)
fn usable(obs: &Observation, r: &Matrix2<f64>) -> bool {
    let pose = &obs.robot_pose;
    let finite = obs.position_m.iter().all(|v| v.is_finite())
        && [pose.x_m, pose.y_m, pose.theta_rad]
            .iter()
            .all(|v| v.is_finite())
        && r.iter().all(|v| v.is_finite());
    finite
        && r[(0, 0)] > 0.0
        && r[(1, 1)] > 0.0
        && r.determinant() > 0.0
        && (r[(0, 1)] - r[(1, 0)]).abs() <= 1e-9 * r[(0, 0)].max(r[(1, 1)])
}

/// What a robot's status says its cameras looked at ([`Fusion::footprints`]).
#[derive(Debug, Clone, Copy)]
pub struct ViewReport<'a> {
    pub robot: &'a str,
    /// Capture time of the status, on the fusion's clock.
    pub stamp: Stamp,
    pub pose: Pose2,
    pub footprints: &'a [CameraFootprint],
    /// Frames a second its perception processes.
    pub fps: f64,
    /// Capture time of its previous status, on the fusion's clock.
    pub since: Option<Stamp>,
}

/// Origin of the core's f64 time axis (2020-01-01T00:00:00Z). A fixed origin, rather than
/// the first observation's stamp, keeps the arithmetic identical whatever arrives first;
/// f64 seconds keep 30 ns resolution for decades after it.
const TIME_ORIGIN: Stamp = Stamp(1_577_836_800_000_000_000);

type Key = (u64, Arc<str>, u64, u8);

#[derive(Debug, Clone)]
struct Pending {
    key: Key,
    input: ObsInput,
    /// A checkpoint: the state right after this observation (every few observations).
    after: Option<Tracker>,
}

/// Checkpoints are at least this far apart in capture time: at robot rates every pending
/// observation keeps one (a late arrival replays only what follows it); under a flood,
/// in-order arrivals clone the state only this rarely.
const CHECKPOINT_SPACING_S: f64 = 0.005;
/// Committed observations folded into the base state at most this many at a time.
const FOLD_EVERY: usize = 16;

/// The fusion core. Time is always passed in; nothing here reads a clock.
#[derive(Debug, Clone)]
pub struct Fusion {
    cfg: FusionConfig,
    /// A state from before every pending observation: `base_then` applied on top of it
    /// gives the state after every committed observation (older than the late window).
    base: Tracker,
    base_then: Vec<ObsInput>,
    /// Observations inside the late window, in capture order, with checkpoints.
    /// The window ends at `newest`, the latest receiver clock seen.
    pending: VecDeque<Pending>,
    /// The state after every observation received so far.
    current: Tracker,
    /// Capture time of the newest checkpoint.
    last_checkpoint_s: f64,
    newest: Option<Stamp>,
    names: Vec<Arc<str>>,
    counters: FusionCounters,
    /// The robots' recent camera footprints.
    views: Views,
}

impl Fusion {
    pub fn new(cfg: FusionConfig) -> Self {
        let bounds = Bounds::from_pitch(&cfg.pitch);
        let base = Tracker::new(Arc::new(cfg.tracker.clone()), bounds);
        Fusion {
            cfg,
            current: base.clone(),
            last_checkpoint_s: f64::NEG_INFINITY,
            base,
            base_then: Vec::new(),
            pending: VecDeque::new(),
            newest: None,
            names: Vec::new(),
            counters: FusionCounters::default(),
            views: Views::default(),
        }
    }

    pub fn config(&self) -> &FusionConfig {
        &self.cfg
    }

    pub fn counters(&self) -> FusionCounters {
        FusionCounters {
            outside_walls: self.tracker().outside_walls(),
            held_in_hypotheses: self.tracker().held_in_hypotheses(),
            kicks_inferred: self.tracker().kicks_inferred(),
            bounces_seen: self.tracker().bounces_seen(),
            singular_updates: self.tracker().singular_updates(),
            robot_slots_reused: self.tracker().robot_slots_reused(),
            forecasts_scored: self.tracker().calibration().counts().0,
            forecasts_outside_95: self.tracker().calibration().counts().1,
            misses_in_view: self.tracker().misses(),
            ..self.counters
        }
    }

    /// The estimate's last wall bounces and inferred kicks, oldest first, with when each
    /// happened.
    pub fn motion_events(&self) -> impl Iterator<Item = (Stamp, MotionEventKind)> + '_ {
        self.tracker()
            .motion_events()
            .map(|e| (self.stamp_of(e.t_s), e.kind))
    }

    /// The tracker after every observation received so far.
    pub fn tracker(&self) -> &Tracker {
        &self.current
    }

    /// Interns robot names so states share them.
    fn name(&mut self, robot: &str) -> Arc<str> {
        if let Some(n) = self.names.iter().find(|n| ***n == *robot) {
            return n.clone();
        }
        // Names no longer held by any state or snapshot go (a stream of made-up ids must
        // not grow the list, nor the search through it, without end).
        if self.names.len() >= 2 * crate::estimator::tracker::MAX_ROBOT_SLOTS {
            self.names.retain(|n| Arc::strong_count(n) > 1);
        }
        let n: Arc<str> = Arc::from(robot);
        self.names.push(n.clone());
        n
    }

    fn t_of(&self, stamp: Stamp) -> f64 {
        stamp.secs_since(TIME_ORIGIN)
    }

    fn stamp_of(&self, t_s: f64) -> Stamp {
        TIME_ORIGIN.offset_secs(t_s)
    }

    /// Takes one observation, whenever it arrives. `received` is the receiver's clock at
    /// arrival: the late window is measured on it, so that one robot with a clock running
    /// ahead cannot make everybody else's observations look late.
    pub fn ingest(&mut self, obs: &Observation, received: Stamp) -> Ingest {
        let c = &obs.covariance_m2;
        let r = Matrix2::new(c[0], c[1], c[2], c[3]);
        if !usable(obs, &r) {
            self.counters.rejected += 1;
            return Ingest::Rejected;
        }
        let ahead_s = obs.stamp.secs_since(received);
        if ahead_s > self.cfg.max_future_s {
            self.counters.future += 1;
            return Ingest::FromTheFuture { ahead_s };
        }
        let horizon = self.newest.map_or(received, |n| n.max(received));
        let late_s = horizon.secs_since(obs.stamp);
        if late_s > self.cfg.late_window_s {
            self.counters.too_late += 1;
            return Ingest::TooLate { late_s };
        }
        let robot = self.name(&obs.robot_id);
        let camera = match obs.camera {
            Camera::Left => 0,
            Camera::Right => 1,
        };
        let key: Key = (obs.stamp.0, robot.clone(), obs.seq, camera);
        let pos = self.pending.partition_point(|p| p.key < key);
        if self.pending.get(pos).is_some_and(|p| p.key == key) {
            self.counters.duplicates += 1;
            return Ingest::Duplicate;
        }
        let input = ObsInput {
            t_s: self.t_of(obs.stamp),
            robot,
            camera: obs.camera,
            position_m: obs.position_m,
            covariance_m2: r,
            robot_pose: obs.robot_pose,
            nothing_seen: None,
        };
        let ingest = self.place(pos, key, input, horizon);
        self.counters.applied += 1;
        if matches!(ingest, Ingest::Reordered { .. }) {
            self.counters.reordered += 1;
        }
        ingest
    }

    /// Puts `input` at `pos` of the pending observations and brings the state up to date.
    fn place(&mut self, pos: usize, key: Key, input: ObsInput, horizon: Stamp) -> Ingest {
        let appended = pos == self.pending.len();
        if appended {
            self.current.apply(&input, &self.views);
            let due = input.t_s - self.last_checkpoint_s >= CHECKPOINT_SPACING_S;
            let after = due.then(|| self.current.clone());
            if due {
                self.last_checkpoint_s = input.t_s;
            }
            self.pending.push_back(Pending { key, input, after });
        } else {
            self.pending.insert(
                pos,
                Pending {
                    key,
                    input,
                    after: None,
                },
            );
            self.replay_from(pos);
        }
        let replayed = self.pending.len() - pos - 1;
        self.newest = Some(horizon);
        self.commit();
        if replayed == 0 {
            Ingest::Applied
        } else {
            self.counters.replayed += replayed as u64;
            Ingest::Reordered { replayed }
        }
    }

    /// Folds observations that fell out of the late window into the base state.
    fn commit(&mut self) {
        let Some(newest) = self.newest else { return };
        while self
            .pending
            .front()
            .is_some_and(|p| newest.secs_since(Stamp(p.key.0)) > self.cfg.late_window_s)
        {
            let Some(p) = self.pending.pop_front() else {
                break;
            };
            match p.after {
                Some(state) => {
                    self.base = state;
                    self.base_then.clear();
                }
                None => self.base_then.push(p.input),
            }
        }
        // Without checkpoints (a quiet window) fold the committed inputs in, bounded.
        if self.base_then.len() >= FOLD_EVERY {
            for input in self.base_then.drain(..) {
                self.base.apply(&input, &self.views);
            }
        }
    }

    /// Recomputes the states from pending observation `pos` on, starting from the nearest
    /// checkpoint before it (or the committed state).
    fn replay_from(&mut self, pos: usize) {
        let checkpoint = (0..pos)
            .rev()
            .find_map(|i| self.pending[i].after.as_ref().map(|t| (i + 1, t.clone())));
        let (start, mut tracker) = match checkpoint {
            Some(c) => c,
            None => {
                let mut t = self.base.clone();
                for input in &self.base_then {
                    t.apply(input, &self.views);
                }
                (0, t)
            }
        };
        let mut last = start
            .checked_sub(1)
            .map_or(f64::NEG_INFINITY, |i| self.pending[i].input.t_s);
        for i in start..self.pending.len() {
            let p = &mut self.pending[i];
            tracker.apply(&p.input, &self.views);
            let due = p.input.t_s - last >= CHECKPOINT_SPACING_S;
            p.after = due.then(|| tracker.clone());
            if due {
                last = p.input.t_s;
            }
        }
        self.last_checkpoint_s = last;
        self.current = tracker;
    }

    /// Takes a robot's camera footprints from its status captured at `stamp` (on the
    /// fusion's clock), for the negative information of its frames: each frame it reports
    /// looked at its footprint, and, when it reported none since its previous status
    /// (`since`), its `fps` frames a second since then saw nothing there. Each footprint is
    /// checked on its own: the bad are refused (and counted), the others kept.
    pub fn footprints(&mut self, status: &ViewReport<'_>, received: Stamp) -> Vec<FootprintError> {
        let bounds = *self.tracker().bounds();
        let t_s = self.t_of(status.stamp);
        let horizon = self.newest.map_or(received, |n| n.max(received));
        let in_window = horizon.secs_since(status.stamp) <= self.cfg.late_window_s
            && status.stamp.secs_since(received) <= self.cfg.max_future_s;
        let mut refused = Vec::new();
        for f in status.footprints {
            let fp = match Footprint::new(
                &f.polygon_m,
                [status.pose.x_m, status.pose.y_m],
                &bounds,
                &self.cfg.tracker.views,
            ) {
                Ok(fp) => fp,
                Err(e) => {
                    self.counters.footprints_rejected += 1;
                    refused.push(e);
                    continue;
                }
            };
            self.views.record(status.robot, f.camera, t_s, fp);
            self.counters.footprints_accepted += 1;
            let Some(since) = status
                .since
                .filter(|_| in_window && self.cfg.tracker.views.enabled)
            else {
                continue;
            };
            let max_s = self.cfg.tracker.views.max_age_s;
            let since_s = self.t_of(since).max(t_s - max_s);
            let frames = status.fps.clamp(0.0, 1000.0) * (t_s - since_s);
            if frames.is_nan() || frames < 1.0 {
                continue;
            }
            let robot = self.name(status.robot);
            // After every sighting of the same stamp and robot: statuses carry no sequence.
            let key: Key = (status.stamp.0, robot.clone(), u64::MAX, 2 + f.camera as u8);
            let pos = self.pending.partition_point(|p| p.key < key);
            if self.pending.get(pos).is_some_and(|p| p.key == key) {
                continue;
            }
            let input = ObsInput {
                t_s,
                robot,
                camera: f.camera,
                position_m: [status.pose.x_m, status.pose.y_m],
                covariance_m2: Matrix2::identity(),
                robot_pose: status.pose,
                nothing_seen: Some(NothingSeen { since_s, frames }),
            };
            self.place(pos, key, input, horizon);
        }
        refused
    }

    /// The main track's filter predicted to `at` (no earlier than its own time).
    pub fn filter_at(&self, at: Stamp) -> Option<BallFilter> {
        let tracker = self.tracker();
        let track = tracker.main()?;
        let mut f = track.filter.clone();
        let t_s = self.t_of(at);
        let noise = tracker.noise_for(track);
        f.predict_to(t_s, &tracker.motion(), tracker.bounds(), &noise);
        Some(f)
    }

    /// The shared ball state at `at`, with its predicted path.
    pub fn ball_state(&self, at: Stamp) -> Option<BallState> {
        let tracker = self.tracker();
        let track = tracker.main()?;
        let f = self.filter_at(at)?;
        let since_seen_s = f.time_s() - track.last_hit_s;
        let status = if since_seen_s > self.cfg.lost_after_s {
            BallStatus::Lost
        } else if since_seen_s > self.cfg.coasting_after_s {
            BallStatus::Coasting
        } else if speed(f.velocity()) < self.cfg.stopped_speed_mps {
            BallStatus::Stopped
        } else {
            BallStatus::Tracking
        };
        let mut covariance = [0.0; 16];
        for i in 0..4 {
            for j in 0..4 {
                covariance[i * 4 + j] = f.covariance()[(i, j)];
            }
        }
        let contributors = track
            .contributors(track.last_hit_s, self.cfg.contributors_window_s)
            .into_iter()
            .filter_map(|i| tracker.robot_name(i).map(|n| n.to_string()))
            .collect();
        let (decel_samples, restitution_samples) = tracker.learning_counts();
        let motion = tracker.motion();
        Some(BallState {
            version: proto::VERSION,
            stamp: self.stamp_of(f.time_s()),
            position_m: f.position(),
            velocity_mps: f.velocity(),
            covariance,
            status,
            last_seen: Some(self.stamp_of(track.last_hit_s)),
            contributors,
            existence: track.existence(),
            model: ModelParams {
                rolling_decel_mps2: f.state()[DECEL],
                wall_restitution: f.state()[RESTITUTION],
                decel_samples,
                restitution_samples,
                tangential_retention: motion.tangential_retention,
                slide_decel_mps2: motion.slide_decel_mps2,
                bounces_seen: saturate(self.tracker().bounces_seen()),
                kicks_inferred: saturate(self.tracker().kicks_inferred()),
            },
            prediction: self.prediction_of(&f, self.cfg.horizon_s),
        })
    }

    /// The predicted path from the filter's state, every point and the stop with its
    /// covariance ([`spread`]).
    fn prediction_of(&self, f: &BallFilter, horizon_s: f64) -> Prediction {
        let tracker = self.tracker();
        let model = f.model(&tracker.motion());
        let mut prediction = predict::path(
            f.position(),
            f.velocity(),
            &model,
            tracker.bounds(),
            self.stamp_of(f.time_s()),
            horizon_s,
            self.cfg.sample_dt_s,
        );
        if let Some(track) = tracker.main() {
            let noise = tracker.prediction_noise_for(track);
            spread(
                &mut prediction,
                f.state(),
                f.covariance(),
                &model,
                tracker.bounds(),
                &noise,
            );
            let phase = tracker.calibration_phase(f.time_s());
            tracker.calibration().apply(phase, &mut prediction);
            // A kick suspected but not yet clear: the covariance covers both branches.
            if let Some((kicked, likely)) = tracker.suspected_kick(f.time_s()) {
                let kicked_model = kicked.model(&tracker.motion());
                let mut other = predict::path(
                    kicked.position(),
                    kicked.velocity(),
                    &kicked_model,
                    tracker.bounds(),
                    prediction.stamp,
                    horizon_s,
                    self.cfg.sample_dt_s,
                );
                spread(
                    &mut other,
                    kicked.state(),
                    kicked.covariance(),
                    &kicked_model,
                    tracker.bounds(),
                    &noise,
                );
                tracker
                    .calibration()
                    .apply(CalibrationPhase::AfterKick, &mut other);
                mix(&mut prediction, &other, likely);
            }
        }
        prediction
    }

    /// The predicted path from `at` over `horizon_s`.
    pub fn predict(&self, at: Stamp, horizon_s: f64) -> Option<Prediction> {
        let f = self.filter_at(at)?;
        Some(self.prediction_of(&f, horizon_s))
    }

    /// Where a robot at `robot_m` with top speed `speed_mps` can first meet the ball, and how
    /// likely the ball is within its reach there (the ball's position covariance at that time,
    /// the robot's reach: [`ROBOT_REACH_M`] and the ball's radius, plus the ground it can cover
    /// in the time it has to spare).
    pub fn intercept(
        &self,
        at: Stamp,
        robot_m: [f64; 2],
        speed_mps: f64,
    ) -> Option<InterceptSolution> {
        let f = self.filter_at(at)?;
        let tracker = self.tracker();
        let model = f.model(&tracker.motion());
        let mut s = intercept(
            f.position(),
            f.velocity(),
            &model,
            tracker.bounds(),
            robot_m,
            speed_mps,
        )?;
        if let Some(track) = tracker.main() {
            let noise = tracker.prediction_noise_for(track);
            let scale = tracker
                .calibration()
                .scale(tracker.calibration_phase(f.time_s()), s.t_s);
            let cov = covariance_at(
                f.state(),
                f.covariance(),
                &model,
                tracker.bounds(),
                &noise,
                s.t_s,
                s.point_m,
            )
            .map(|v| v * scale);
            // The robot reaches the ball when it touches it, and what time it has to spare
            // it can spend going further.
            let spare_s = (s.t_s
                - (s.point_m[0] - robot_m[0]).hypot(s.point_m[1] - robot_m[1]) / speed_mps)
                .max(0.0);
            let reach_m = self.cfg.pitch.ball_radius_m + ROBOT_REACH_M + speed_mps * spare_s;
            let mut probability = within_reach(cov, reach_m);
            // A kick suspected but not yet clear: the ball may be on the other branch.
            if let Some((kicked, likely)) = tracker.suspected_kick(f.time_s()) {
                let kicked_model = kicked.model(&tracker.motion());
                let flown = fly(
                    kicked.position(),
                    kicked.velocity(),
                    s.t_s,
                    &kicked_model,
                    tracker.bounds(),
                );
                let c_kicked = covariance_at(
                    kicked.state(),
                    kicked.covariance(),
                    &kicked_model,
                    tracker.bounds(),
                    &noise,
                    s.t_s,
                    flown.position,
                );
                let c = mixed(cov, c_kicked, s.point_m, flown.position, 1.0);
                probability = (1.0 - likely) * probability + likely * within_reach(c, reach_m);
            }
            s.probability = Some(probability);
        }
        Some(s)
    }

    /// What the core has learned about each robot.
    pub fn robots(&self) -> &[RobotTrust] {
        self.tracker().robots()
    }
}

#[cfg(test)]
mod acquisition_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod wall_tests;
