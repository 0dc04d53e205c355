//! Track management: which hypothesis each observation belongs to, when an alternative
//! hypothesis takes over, and how much each robot is trusted.
//!
//! Every observation is gated (χ², 2 dof, on S = HPHᵀ + R) against every hypothesis and
//! updates the closest one that accepts it. Observations no hypothesis accepts start a new
//! one. A hypothesis replaces the main track when it has clearly more recent support, from
//! enough distinct robots or steadily from one, counted in expected sightings per camera
//! stream ([`acquire`]); a kick nobody reports re-initialises the track's velocity from a
//! change point ([`onset`]). docs/fusion.md states the rules.

use super::calibration::{AFTER_KICK_S, Calibration, HORIZONS_S, Phase};
use super::filter::{BallFilter, DECEL, Innovation, Learn, ModelPrior, ProcessNoise, RESTITUTION};
use super::motion::{Bounds, MotionModel, fly, speed};
use super::spread::spread;
use super::surface::{BounceEvent, Surface};
use super::views::{Views, existence};
use nalgebra::Matrix2;
use proto::{Camera, Pose2};
use std::collections::VecDeque;
use std::sync::Arc;

mod acquire;
mod at_wall;
mod config;
mod events;
mod onset;
mod trust;
pub use acquire::{CameraClocks, Hit};
pub use config::TrackerConfig;
use events::MotionLog;
pub use events::{MotionEvent, MotionEventKind};
use onset::{Kick, OnsetSighting, Recent};
pub use trust::RobotTrust;

/// One observation as the core sees it: capture time already on the fusion time axis.
#[derive(Debug, Clone, PartialEq)]
pub struct ObsInput {
    /// Capture time, seconds since the fusion epoch.
    pub t_s: f64,
    pub robot: Arc<str>,
    pub camera: Camera,
    pub position_m: [f64; 2],
    pub covariance_m2: Matrix2<f64>,
    pub robot_pose: Pose2,
    /// Not a sighting: the robot's status says this camera captured `frames` frames since
    /// `since_s` and reported nothing in them (`position_m` is then the robot's).
    pub nothing_seen: Option<NothingSeen>,
}

/// Frames a camera captured without a sighting, from a robot's status.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NothingSeen {
    pub since_s: f64,
    pub frames: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    pub id: u64,
    pub filter: BallFilter,
    pub last_hit_s: f64,
    pub born_s: f64,
    /// Recent supporting observations.
    hits: VecDeque<Hit>,
    /// The ball may slide until then (after a kick or a bounce): its filter does not learn
    /// the rolling deceleration.
    quiet_until_s: f64,
    boost_until_s: f64,
    /// The last few sightings, each with the filter from just before it (see [`onset`]).
    recent: VecDeque<Recent>,
    /// The sighting that started this hypothesis, while it is its only one: a later
    /// sighting nothing accepts may pair with it ([`TrackerConfig::pair_max_dt_s`]).
    first: Option<([f64; 2], Matrix2<f64>)>,
    /// Log-odds that the ball is where this hypothesis says ([`super::views`]).
    logodds: f64,
    /// The frame whose miss was counted last (robot, camera, capture time): one per frame.
    last_miss: Option<(usize, Camera, f64)>,
}

impl Track {
    fn support(&self, now_s: f64, window_s: f64) -> (usize, usize, Vec<usize>) {
        self.support_since(now_s - window_s)
    }

    /// Supporting observations at or after `since_s`: count, distinct robots, the robots.
    fn support_since(&self, since_s: f64) -> (usize, usize, Vec<usize>) {
        let mut robots: Vec<usize> = Vec::new();
        let mut n = 0;
        for h in self.hits.iter().rev() {
            if h.t_s < since_s {
                break;
            }
            n += 1;
            if !robots.contains(&h.robot) {
                robots.push(h.robot);
            }
        }
        (n, robots.len(), robots)
    }

    /// Number of supporting observations within `window_s` of `now_s`.
    pub fn recent_hits(&self, now_s: f64, window_s: f64) -> usize {
        self.support(now_s, window_s).0
    }

    /// Robots that supported this track within `window_s`.
    pub fn contributors(&self, now_s: f64, window_s: f64) -> Vec<usize> {
        self.support(now_s, window_s).2
    }

    /// Probability that the ball is where this hypothesis says: 1 while it is seen, falling
    /// while cameras look at its place and do not see it.
    pub fn existence(&self) -> f64 {
        existence(self.logodds)
    }
}

/// The whole tracking state. `Clone` is cheap enough to snapshot after every observation,
/// which is how late observations are replayed in capture order.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracker {
    cfg: Arc<TrackerConfig>,
    /// The walls where the pitch puts them...
    pitch_bounds: Bounds,
    /// ... and where the ball turns, as learned ([`Surface::wall_offsets_m`]).
    bounds: Bounds,
    tracks: Vec<Track>,
    main: Option<usize>,
    robots: Vec<RobotTrust>,
    next_id: u64,
    /// The floor and walls, learned from the estimate's stretches and bounces.
    surface: Surface,
    /// The [`Surface::version`] the filters' model states were last set from.
    surface_synced: u64,
    /// Observations that informed the estimate's rolling deceleration.
    decel_updates: u32,
    /// Observations dropped for lying beyond a wall, where no ball can be.
    outside_walls: u64,
    /// Hypotheses restarted through two sightings (two-point initiation).
    pairs: u64,
    /// The estimate's bounces and inferred kicks.
    motion_log: MotionLog,
    /// Observations whose innovation covariance could not be factored: not applied.
    singular_updates: u64,
    /// Observations that went to hypotheses other than the estimate (waiting for promotion,
    /// or phantoms).
    held: u64,
    /// New robots that took the place of one long quiet ([`MAX_ROBOT_SLOTS`]).
    robot_slots_reused: u64,
    /// Frames that looked at a hypothesis and did not see it (negative information).
    misses: u64,
    /// How the estimate's forecasts fared: the served covariances' scales.
    calibration: Calibration,
    /// Time of the newest applied observation.
    pub t_s: f64,
}

const HIT_HISTORY_S: f64 = 1.5;
/// A kick from below this speed, or changing the velocity by more, was a push: the
/// forecasts from before it are not scored ([`Calibration::kicked`]).
const PUSH_MPS: f64 = 0.5;
/// ... unless it came this close to a wall, where a bounce the flight mistook is likelier.
const PUSH_WALL_M: f64 = 0.15;
/// Two sightings closer in time than this are one frame's (two cameras, or a duplicate):
/// no speed can be read from them.
const MIN_PAIR_DT_S: f64 = 0.01;
/// ... and at most this many (a flood of observations must not make states expensive to
/// copy; support counts only need to reach a few).
const MAX_HITS: usize = 1024;
/// A track updated this recently is being watched.
const WATCHED_S: f64 = 0.5;
/// Robots that reported anything this recently count as on the pitch (a robot that sees
/// no ball sends nothing, so this is long).
const ACTIVE_ROBOT_S: f64 = 5.0;
/// Robots the tracker learns about at most. Past this a new robot takes the place of the
/// one quiet the longest, if that one has been quiet for [`ROBOT_SLOT_IDLE_S`], so a stream
/// of made-up ids cannot grow the state (or the search for a robot) without end.
pub const MAX_ROBOT_SLOTS: usize = 1024;
/// How long a robot must have been quiet before its place may go to another; far longer
/// than any hit or sighting history that refers to it.
const ROBOT_SLOT_IDLE_S: f64 = 30.0;

impl Tracker {
    pub fn new(cfg: Arc<TrackerConfig>, bounds: Bounds) -> Self {
        let surface = Surface::new(
            &cfg.motion,
            cfg.surface,
            cfg.learn_decel,
            cfg.learn_restitution,
        );
        Tracker {
            cfg,
            pitch_bounds: bounds,
            bounds,
            tracks: Vec::new(),
            main: None,
            robots: Vec::new(),
            next_id: 1,
            surface,
            surface_synced: 0,
            decel_updates: 0,
            motion_log: MotionLog::default(),
            singular_updates: 0,
            held: 0,
            robot_slots_reused: 0,
            outside_walls: 0,
            pairs: 0,
            misses: 0,
            calibration: Calibration::default(),
            t_s: f64::NEG_INFINITY,
        }
    }

    pub fn config(&self) -> &TrackerConfig {
        &self.cfg
    }

    /// Where the ball's centre turns at the walls: the pitch's bounds, each wall moved by
    /// what the bounces taught.
    pub fn bounds(&self) -> &Bounds {
        &self.bounds
    }

    pub fn main(&self) -> Option<&Track> {
        self.main.and_then(|i| self.tracks.get(i))
    }

    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    pub fn robots(&self) -> &[RobotTrust] {
        &self.robots
    }

    pub fn robot_name(&self, index: usize) -> Option<&Arc<str>> {
        self.robots.get(index).map(|r| &r.robot)
    }

    /// Observations dropped because they lay beyond a wall.
    pub fn outside_walls(&self) -> u64 {
        self.outside_walls
    }

    /// True when `o` lies beyond a walled side by more than its own 3σ (and 5 cm): another
    /// object seen over the wall, or a robot body's projection, never the ball.
    fn beyond_wall(&self, o: &ObsInput) -> bool {
        let b = &self.bounds;
        let (x, y) = (o.position_m[0], o.position_m[1]);
        let sd = |k: usize| o.covariance_m2[(k, k)].max(0.0).sqrt();
        let out_by = [x - b.x_max, b.x_min - x, y - b.y_max, b.y_min - y];
        (0..4).any(|i| b.walls[i] && out_by[i] > (3.0 * sd(i / 2)).max(0.05))
    }

    /// New robots that took the place of one long quiet, the table being full.
    pub fn robot_slots_reused(&self) -> u64 {
        self.robot_slots_reused
    }

    /// Frames counted as looking at a hypothesis and not seeing it.
    pub fn misses(&self) -> u64 {
        self.misses
    }

    /// Hypotheses restarted through two sightings of a moving ball.
    pub fn pairs_initiated(&self) -> u64 {
        self.pairs
    }

    /// Kicks of the estimate inferred from runs of surprising updates.
    pub fn kicks_inferred(&self) -> u64 {
        self.motion_log.kicks()
    }

    /// Wall bounces the estimate went through: foreseen by its flight, or found at a wall
    /// in a run of surprising sightings ([`at_wall`]).
    pub fn bounces_seen(&self) -> u64 {
        self.motion_log.bounces()
    }

    /// The estimate's last bounces and inferred kicks, oldest first.
    pub fn motion_events(&self) -> impl Iterator<Item = &MotionEvent> {
        self.motion_log.events()
    }

    /// Observations not applied because their innovation covariance was not positive
    /// definite (a numerical failure the filter refuses rather than hides).
    pub fn singular_updates(&self) -> u64 {
        self.singular_updates
    }

    /// Observations applied to hypotheses that were not the estimate at the time.
    pub fn held_in_hypotheses(&self) -> u64 {
        self.held
    }

    /// Observations / bounces that informed the learned deceleration / restitution.
    pub fn learning_counts(&self) -> (u32, u32) {
        (self.decel_updates, self.surface.counts().bounces)
    }

    /// The learned floor and walls.
    pub fn surface(&self) -> &Surface {
        &self.surface
    }

    /// The motion model with what has been learned about the floor and the walls.
    pub fn motion(&self) -> MotionModel {
        self.surface.model(&self.cfg.motion)
    }

    /// The learned values as a filter's prior: (mean, variance) of each.
    /// The deceleration is the estimate's own while there is one (it follows the floor
    /// under the ball), else the surface's.
    fn learned_prior(&self) -> ModelPrior {
        let (d, e) = (self.surface.rolling_decel(), self.surface.restitution());
        let decel = match self.main() {
            Some(m) => (
                m.filter.state()[DECEL],
                m.filter.covariance()[(DECEL, DECEL)],
            ),
            None => (d.mean, d.variance),
        };
        ModelPrior {
            decel,
            restitution: (e.mean, e.variance),
        }
    }

    /// Sets every hypothesis' restitution state to the learned value and moves the walls to
    /// where the ball turns, when either changed.
    fn sync_surface(&mut self) {
        if self.surface.walls_version() == self.surface_synced {
            return;
        }
        self.surface_synced = self.surface.walls_version();
        let off = self.surface.wall_offsets_m();
        let b = &self.pitch_bounds;
        self.bounds = Bounds {
            x_max: b.x_max + off[0],
            x_min: b.x_min - off[1],
            y_max: b.y_max + off[2],
            y_min: b.y_min - off[3],
            walls: b.walls,
        };
        let prior = self.learned_prior();
        for tr in &mut self.tracks {
            tr.filter
                .reset_component(RESTITUTION, prior.restitution.0, prior.restitution.1);
        }
    }

    /// The process noise for a track predicted from its current state.
    pub fn noise_for(&self, track: &Track) -> ProcessNoise {
        let cfg = &self.cfg;
        let mut noise = cfg.noise;
        let s = speed(track.filter.velocity());
        noise.accel_m2ps3 += cfg.accel_speed_gain * s * s;
        // Near a robot the ball may be kicked at any moment; but only while it is being
        // watched: an unseen ball's uncertainty must not balloon until anything fits.
        let watched = track.filter.time_s() - track.last_hit_s < WATCHED_S;
        if watched
            && (self.near_robot(track.filter.position(), track.filter.time_s())
                || track.filter.time_s() < track.boost_until_s)
        {
            noise.accel_m2ps3 = noise.accel_m2ps3.max(cfg.near_robot_accel_m2ps3);
            noise.rest_vel_m2ps3 = noise.rest_vel_m2ps3.max(cfg.near_robot_accel_m2ps3);
        }
        if watched && track.filter.time_s() < track.boost_until_s {
            // Just born or just kicked: the velocity is unknown, not "probably zero".
            noise.rest_velocity_tau_s = f64::INFINITY;
        }
        noise
    }

    /// The process noise of a track's predicted path: the flight's own (growing with the
    /// speed), without what a robot nearby might do to the ball. A kick is not foreseen by
    /// any path; the path's uncertainty is that of the flight without one.
    pub fn prediction_noise_for(&self, track: &Track) -> ProcessNoise {
        let cfg = &self.cfg;
        let mut noise = cfg.noise;
        let s = speed(track.filter.velocity());
        noise.accel_m2ps3 += cfg.accel_speed_gain * s * s;
        noise
    }

    fn near_robot(&self, p: [f64; 2], t_s: f64) -> bool {
        self.robot_within(p, t_s, self.cfg.near_robot_m)
    }

    fn robot_within(&self, p: [f64; 2], t_s: f64, range_m: f64) -> bool {
        self.robots.iter().any(|r| {
            t_s - r.last_obs_s < 1.0 && (r.pose.x_m - p[0]).hypot(r.pose.y_m - p[1]) < range_m
        })
    }

    fn robot_index(&mut self, o: &ObsInput) -> usize {
        if let Some(i) = self.robots.iter().position(|r| r.robot == o.robot) {
            return i;
        }
        let fresh = RobotTrust {
            robot: o.robot.clone(),
            pose: o.robot_pose,
            last_obs_s: o.t_s,
            covariance_scale: 1.0,
            outlier_rate: 0.0,
            outlier_samples: 0,
            observations: 0,
            clocks: CameraClocks::default(),
        };
        if self.robots.len() >= MAX_ROBOT_SLOTS {
            let quietest = self
                .robots
                .iter()
                .enumerate()
                .filter(|(_, r)| o.t_s - r.last_obs_s > ROBOT_SLOT_IDLE_S)
                .min_by(|a, b| a.1.last_obs_s.total_cmp(&b.1.last_obs_s))
                .map(|(i, _)| i);
            if let Some(i) = quietest {
                self.robots[i] = fresh;
                self.robot_slots_reused += 1;
                return i;
            }
        }
        self.robots.push(fresh);
        self.robots.len() - 1
    }

    /// Applies one observation at its capture time (callers feed them in time order);
    /// `views` are the robots' camera footprints, for what the frame did not see.
    pub fn apply(&mut self, o: &ObsInput, views: &Views) {
        if let Some(n) = o.nothing_seen {
            self.nothing_seen(o, n, views);
            return;
        }
        if self.beyond_wall(o) {
            self.outside_walls += 1;
            return;
        }
        let ri = self.robot_index(o);
        {
            let r = &mut self.robots[ri];
            r.pose = o.robot_pose;
            r.last_obs_s = r.last_obs_s.max(o.t_s);
            r.observations += 1;
            r.clocks.get_mut(o.camera).tick(o.t_s);
        }
        self.t_s = self.t_s.max(o.t_s);
        self.predict_all(o.t_s);

        let r_eff = o.covariance_m2 * self.relative_trust(ri);
        let (gate, max_jump) = (self.cfg.gate_chi2, self.cfg.max_innovation_m);
        let best = self
            .tracks
            .iter()
            .enumerate()
            .map(|(i, tr)| (i, tr.filter.innovation(o.position_m, &r_eff)))
            .filter(|(_, inn)| inn.d2 < gate && inn.y.norm() < max_jump)
            // Most likely track: d² + ln|S| (the negative log-likelihood up to constants),
            // so a vague young hypothesis does not steal observations from a sharp one.
            .min_by(|a, b| {
                let cost = |inn: &Innovation| inn.d2 + inn.s.determinant().max(1e-300).ln();
                cost(&a.1).total_cmp(&cost(&b.1))
            })
            .map(|(i, inn)| (i, inn.d2));

        self.learn_trust(ri, o);
        self.learn_outlier_rate(ri, o, best.is_some_and(|(i, _)| Some(i) == self.main));

        let sighting = OnsetSighting {
            t_s: o.t_s,
            z: o.position_m,
            r: r_eff,
            robot: ri,
        };
        // A sighting the main track does not accept may be its kick's: tried against the
        // main track kicked before it may start (or feed) a hypothesis of its own, unless
        // an established other track claims it.
        let claimed = best.filter(|(i, _)| {
            Some(*i) == self.main || self.tracks[*i].hits.len() >= self.cfg.promote_min_hits
        });
        let kicked = match claimed {
            Some(_) => None,
            None => self.kick_candidate(&sighting),
        };
        match (kicked, best) {
            (Some((m, kick)), _) => {
                self.kicked(m, kick, &sighting);
                self.remember(m, &sighting);
                self.update_track(m, ri, o, &r_eff);
            }
            (None, Some((i, d2))) => {
                if Some(i) == self.main {
                    let id = self.tracks[i].id;
                    self.calibration.sighting(o.t_s, id, o.position_m, &r_eff);
                }
                if let Some(kick) = self.note_onset(i, d2, &sighting) {
                    self.kicked(i, kick, &sighting);
                }
                self.remember(i, &sighting);
                self.update_track(i, ri, o, &r_eff);
            }
            (None, None) => match self.pairing(o) {
                Some(i) => self.pair(i, ri, o, &r_eff),
                None => self.spawn(ri, o, &r_eff),
            },
        }
        self.misses_in_view(ri, o, views);
        self.promote(o.t_s);
        self.prune(o.t_s);
        self.sync_surface();
        self.keep_forecast(o.t_s);
    }

    /// Keeps a forecast of the estimate just updated at `t_s`, when one is due.
    fn keep_forecast(&mut self, t_s: f64) {
        let Some(track) = self.main() else { return };
        if track.last_hit_s != t_s || !self.calibration.due(t_s) {
            return;
        }
        let f = &track.filter;
        let model = f.model(&self.motion());
        let noise = self.prediction_noise_for(track);
        let mut samples = Vec::with_capacity(HORIZONS_S.len());
        for h in HORIZONS_S {
            let flown = fly(f.position(), f.velocity(), h, &model, &self.bounds);
            samples.push(proto::PathSample {
                t_s: h,
                position_m: flown.position,
                velocity_mps: flown.velocity,
                covariance_m2: None,
            });
        }
        let mut forecast = proto::Prediction {
            version: proto::VERSION,
            stamp: proto::Stamp::from_secs_f64(0.0),
            horizon_s: HORIZONS_S[HORIZONS_S.len() - 1],
            samples,
            bounces: Vec::new(),
            stop: None,
        };
        spread(
            &mut forecast,
            f.state(),
            f.covariance(),
            &model,
            &self.bounds,
            &noise,
        );
        let (id, phase) = (track.id, self.phase_of(track, t_s));
        self.calibration.forecast(t_s, id, phase, &forecast);
    }

    /// Whether `track` was kicked or began within [`AFTER_KICK_S`] of `t_s`.
    fn phase_of(&self, track: &Track, t_s: f64) -> Phase {
        let kicked_s = track.boost_until_s - self.cfg.kick_boost_s;
        if t_s - kicked_s < AFTER_KICK_S || t_s - track.born_s < AFTER_KICK_S {
            Phase::AfterKick
        } else {
            Phase::Settled
        }
    }

    /// The estimate's phase at `t_s` for [`Calibration::apply`] (settled without one).
    pub fn calibration_phase(&self, t_s: f64) -> Phase {
        self.main()
            .map_or(Phase::Settled, |track| self.phase_of(track, t_s))
    }

    /// How the estimate's forecasts fared, and the scales they taught.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    /// The hypothesis seen once whose sighting `o` continues at the lowest plausible speed.
    fn pairing(&self, o: &ObsInput) -> Option<usize> {
        let cfg = &self.cfg;
        self.tracks
            .iter()
            .enumerate()
            .filter(|(i, _)| Some(*i) != self.main)
            .filter_map(|(i, tr)| {
                let (z0, _) = tr.first?;
                let dt = o.t_s - tr.born_s;
                let moved = (o.position_m[0] - z0[0]).hypot(o.position_m[1] - z0[1]);
                let ok = dt > MIN_PAIR_DT_S && dt <= cfg.pair_max_dt_s;
                let v = moved / dt;
                (ok && v <= cfg.pair_max_speed_mps).then_some((i, v))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    /// Restarts hypothesis `i` through its first sighting and `o` (two-point initiation).
    fn pair(&mut self, i: usize, ri: usize, o: &ObsInput, r_eff: &Matrix2<f64>) {
        let cfg = self.cfg.clone();
        let track = &mut self.tracks[i];
        let Some((z0, r0)) = track.first.take() else {
            return;
        };
        let prior = ModelPrior {
            decel: (
                track.filter.state()[DECEL],
                track.filter.covariance()[(DECEL, DECEL)],
            ),
            restitution: (
                track.filter.state()[RESTITUTION],
                track.filter.covariance()[(RESTITUTION, RESTITUTION)],
            ),
        };
        track.filter = BallFilter::through(
            (z0, &r0, track.born_s),
            (o.position_m, r_eff, o.t_s),
            cfg.pair_velocity_slack_mps,
            prior,
        );
        track.recent.clear();
        track.boost_until_s = track.boost_until_s.max(o.t_s + cfg.kick_boost_s);
        self.pairs += 1;
        self.held += 1;
        self.record_hit(i, ri, o);
    }

    /// Negative information: robot `ri`'s frame that reported `o` looked at every
    /// hypothesis inside its camera's footprint; those it did not report lose existence by
    /// how likely the detector was to see a ball there.
    fn misses_in_view(&mut self, ri: usize, o: &ObsInput, views: &Views) {
        self.miss(ri, o, 1.0, views);
    }

    /// A robot's status: its camera captured frames since its previous status and reported
    /// nothing in them.
    fn nothing_seen(&mut self, o: &ObsInput, n: NothingSeen, views: &Views) {
        let Some(ri) = self.robots.iter().position(|r| r.robot == o.robot) else {
            return; // Never a sighting: nothing proves it could have seen the ball.
        };
        if self.robots[ri].last_obs_s >= n.since_s {
            return; // It did report frames since: they told their own misses.
        }
        self.t_s = self.t_s.max(o.t_s);
        self.predict_all(o.t_s);
        let frames = n.frames.min(self.cfg.views.max_frames_per_status);
        self.miss(ri, o, frames, views);
        self.promote(o.t_s);
        self.sync_surface();
    }

    /// `frames` frames of robot `ri`'s camera at `o.t_s` did not see the hypotheses in its
    /// footprint (except one this very frame reported).
    fn miss(&mut self, ri: usize, o: &ObsInput, frames: f64, views: &Views) {
        let vc = &self.cfg.views;
        if !vc.enabled {
            return;
        }
        let robot = &self.robots[ri];
        if robot.observations < vc.min_robot_observations
            || !robot.credible(self.cfg.outlier_rate_max)
        {
            return;
        }
        let Some(footprint) = views.at(&robot.robot, o.camera, o.t_s, vc.max_age_s) else {
            return;
        };
        let (lo, _) = vc.logodds_range;
        let me = [o.robot_pose.x_m, o.robot_pose.y_m];
        for track in &mut self.tracks {
            let seen_now = track
                .hits
                .back()
                .is_some_and(|h| h.robot == ri && h.t_s == o.t_s);
            let same_frame = track.last_miss == Some((ri, o.camera, o.t_s));
            if seen_now || same_frame {
                continue;
            }
            // The camera looked at the hypothesis only if it looked at all of where it
            // may be (its 2σ extent along each axis), not just at its centre: a ball just
            // outside a footprint's edge, hidden by the robot's own body, is not refuted.
            let p = track.filter.position();
            let cov = track.filter.covariance();
            let reach = [0, 1].map(|k| 2.0 * cov[(k, k)].max(0.0).sqrt());
            let extent = [
                p,
                [p[0] + reach[0], p[1]],
                [p[0] - reach[0], p[1]],
                [p[0], p[1] + reach[1]],
                [p[0], p[1] - reach[1]],
            ];
            if !extent.iter().all(|q| footprint.contains(*q)) {
                continue;
            }
            let vetoed = track
                .hits
                .iter()
                .rev()
                .take_while(|h| h.t_s >= o.t_s - vc.veto_s)
                .any(|h| h.robot != ri);
            if vetoed {
                continue;
            }
            let recall = vc.recall_at((p[0] - me[0]).hypot(p[1] - me[1])).min(0.99);
            if recall <= 0.0 {
                continue;
            }
            track.logodds = (track.logodds + frames * (1.0 - recall).ln()).max(lo);
            track.last_miss = Some((ri, o.camera, o.t_s));
            self.misses += frames.round() as u64;
        }
    }

    fn predict_all(&mut self, t_s: f64) {
        let motion = self.motion();
        let mut bounces = Vec::new();
        for i in 0..self.tracks.len() {
            let noise = self.noise_for(&self.tracks[i]);
            let track = &mut self.tracks[i];
            let flown_from_s = track.filter.time_s();
            let Some(flight) = track.filter.predict_to(t_s, &motion, &self.bounds, &noise) else {
                continue;
            };
            if flight.hits().next().is_some() {
                track.quiet_until_s = track.quiet_until_s.max(t_s + self.cfg.learn_quiet_s);
            }
            if Some(i) != self.main {
                continue;
            }
            // The estimate met a wall: the sightings on either side measure the bounce.
            let b = &self.bounds;
            for hit in flight.hits() {
                let other = 1 - hit.axis;
                let (lo, hi) = if other == 0 {
                    (b.x_min, b.x_max)
                } else {
                    (b.y_min, b.y_max)
                };
                let margin = self.cfg.surface.bounce_max_offset_m;
                let corner_walls = if other == 0 { [1, 0] } else { [3, 2] };
                let corner = (b.walls[corner_walls[0]] && hit.position[other] < lo + margin)
                    || (b.walls[corner_walls[1]] && hit.position[other] > hi - margin);
                bounces.push(BounceEvent {
                    t_s: flown_from_s + hit.t_s,
                    axis: hit.axis,
                    wall_m: hit.position[hit.axis],
                    normal_velocity_in_mps: hit.velocity_in[hit.axis],
                    corner,
                });
            }
        }
        for b in bounces {
            self.motion_log.bounce(b.t_s, b.axis, b.wall_m);
            self.surface.bounce(b);
        }
    }

    /// Track `i` changed course (found at `t_s`): its filter is the re-initialised one. At a
    /// wall, in the way a bounce changes it, it is a bounce its flight did not foresee;
    /// elsewhere, a kick.
    fn kicked(&mut self, i: usize, kick: Kick, now: &OnsetSighting) {
        let t_s = now.t_s;
        let bounces = kick.bounces;
        let is_main = self.main == Some(i);
        // A ball kicked from rest, beside a robot or hard (its velocity changed by more than
        // [`PUSH_MPS`], away from the walls) was pushed: what was forecast before could not
        // know. A small change of
        // course in full flight, away from robots, may be the flight's own failure (a
        // bounce it did not foresee, a floor unlike the model), and its forecasts are scored
        // as they stand.
        let before = &self.tracks[i].filter;
        let (v0, v1) = (before.velocity(), kick.filter.velocity());
        let p = kick.filter.position();
        let b = &self.bounds;
        let gaps = [
            b.x_max - p[0],
            p[0] - b.x_min,
            b.y_max - p[1],
            p[1] - b.y_min,
        ];
        let at_wall = (0..4).any(|k| b.walls[k] && gaps[k] < PUSH_WALL_M);
        let pushed = speed(v0) < PUSH_MPS
            || self.near_robot(before.position(), t_s)
            || (speed([v1[0] - v0[0], v1[1] - v0[1]]) > PUSH_MPS && !at_wall);
        let cfg = &self.cfg;
        let track = &mut self.tracks[i];
        track.filter = kick.filter;
        track.recent.clear();
        track.quiet_until_s = track.quiet_until_s.max(t_s + cfg.learn_quiet_s);
        if bounces.is_empty() {
            track.boost_until_s = track.boost_until_s.max(t_s + cfg.kick_boost_s);
            if is_main {
                if pushed {
                    self.calibration.kicked(kick.t_s);
                }
                self.motion_log.kick(kick.t_s);
                self.surface.kick(kick.t_s, kick.speed_mps);
            }
            return;
        }
        // A wall does not start a slide.
        track.filter.roll();
        if is_main {
            for b in bounces {
                self.motion_log.bounce(b.t_s, b.axis, b.wall_m);
                self.surface.bounce_found(b);
            }
        }
    }

    fn update_track(&mut self, i: usize, ri: usize, o: &ObsInput, r_eff: &Matrix2<f64>) {
        let is_main = self.main == Some(i);
        if !is_main {
            self.held += 1;
        }
        let position = self.tracks[i].filter.position();
        let near = self.near_robot(position, o.t_s);
        let touching = self.robot_within(position, o.t_s, self.cfg.surface.touch_m);
        let cfg = &self.cfg;
        let track = &mut self.tracks[i];
        // The rolling deceleration is learned by the gain too, stretch by stretch (the
        // surface's value is the floor's, for new estimates); the walls only by the surface.
        let learn = Learn {
            decel: is_main
                && cfg.learn_decel
                && !near
                && o.t_s >= track.quiet_until_s
                && o.t_s >= track.boost_until_s
                && speed(track.filter.velocity()) > cfg.learn_min_speed_mps,
            restitution: false,
        };
        if track.filter.update(o.position_m, r_eff, learn).is_err() {
            self.singular_updates += 1;
            return;
        }
        if learn.decel {
            self.decel_updates = self.decel_updates.saturating_add(1);
        }
        if let Some(kick_t_s) = track.filter.kick_time_s() {
            // Still sliding: the kick's speed, read again with this sighting.
            let motion = self.surface.model(&self.cfg.motion);
            track.filter.slide_since(kick_t_s, &motion);
        }
        if is_main {
            if touching {
                // A robot may touch it: what follows is a new stretch.
                self.surface.restart(o.t_s);
            } else {
                let var_m2 = 0.5 * r_eff.trace();
                let s = speed(track.filter.velocity());
                self.surface.sighting(o.t_s, o.position_m, var_m2, s);
            }
        }
        self.record_hit(i, ri, o);
    }

    /// `o` (from robot `ri`) supports track `i`.
    fn record_hit(&mut self, i: usize, ri: usize, o: &ObsInput) {
        let (lo, hi) = self.cfg.views.logodds_range;
        let gain = self.cfg.views.hit_logodds;
        let track = &mut self.tracks[i];
        track.logodds = (track.logodds + gain).clamp(lo, hi);
        track.first = None;
        track.last_hit_s = track.last_hit_s.max(o.t_s);
        track.hits.push_back(Hit {
            t_s: o.t_s,
            robot: ri,
            camera: o.camera,
        });
        while track
            .hits
            .front()
            .is_some_and(|h| h.t_s < o.t_s - HIT_HISTORY_S)
        {
            track.hits.pop_front();
        }
        if track.hits.len() > MAX_HITS {
            track.hits.pop_front();
        }
    }

    fn spawn(&mut self, ri: usize, o: &ObsInput, r_eff: &Matrix2<f64>) {
        self.held += 1;
        let cfg = &self.cfg;
        let params = self.learned_prior();
        let filter = BallFilter::start(
            o.position_m,
            r_eff,
            o.t_s,
            cfg.spawn_velocity_sigma_mps,
            params,
        );
        let track = Track {
            id: self.next_id,
            filter,
            last_hit_s: o.t_s,
            born_s: o.t_s,
            hits: VecDeque::from([Hit {
                t_s: o.t_s,
                robot: ri,
                camera: o.camera,
            }]),
            recent: VecDeque::new(),
            first: Some((o.position_m, *r_eff)),
            logodds: cfg.views.initial_logodds,
            last_miss: None,
            // A new hypothesis is often a ball just kicked and still sliding.
            boost_until_s: o.t_s + cfg.kick_boost_s,
            quiet_until_s: o.t_s + cfg.learn_quiet_s,
        };
        self.next_id += 1;
        if self.tracks.len() >= cfg.max_tracks {
            // Make room by dropping the stalest hypothesis that is not the main track.
            if let Some(victim) = (0..self.tracks.len())
                .filter(|i| Some(*i) != self.main)
                .min_by(|a, b| {
                    self.tracks[*a]
                        .last_hit_s
                        .total_cmp(&self.tracks[*b].last_hit_s)
                })
            {
                self.remove(victim);
            }
        }
        // Even the first hypothesis becomes the estimate only through `promote`, with the
        // same support any other needs: the first report may well be a phantom.
        self.tracks.push(track);
    }

    /// Hypothesis `i` becomes the estimate.
    fn take_over(&mut self, i: usize, t_s: f64) {
        let cfg = self.cfg.clone();
        // The floor and the walls did not change: the new estimate flies with what was
        // learned about them, and the surface's stretches start over with it.
        let keep = self.learned_prior();
        let tr = &mut self.tracks[i];
        if self.main.is_some() {
            tr.filter.reset_component(DECEL, keep.decel.0, keep.decel.1);
        }
        tr.filter
            .reset_component(RESTITUTION, keep.restitution.0, keep.restitution.1);
        tr.boost_until_s = t_s + cfg.kick_boost_s;
        tr.quiet_until_s = tr.quiet_until_s.max(t_s + cfg.learn_quiet_s);
        self.main = Some(i);
        self.surface.restart(t_s);
    }

    fn prune(&mut self, t_s: f64) {
        let ttl = self.cfg.candidate_ttl_s;
        let mut i = 0;
        while i < self.tracks.len() {
            let stale = Some(i) != self.main && t_s - self.tracks[i].last_hit_s > ttl;
            let merged = Some(i) != self.main && self.duplicates_main(i);
            if stale || merged {
                self.remove(i);
            } else {
                i += 1;
            }
        }
    }

    /// A hypothesis that has converged onto the main track is redundant.
    fn duplicates_main(&self, i: usize) -> bool {
        let (Some(m), Some(c)) = (self.main(), self.tracks.get(i)) else {
            return false;
        };
        let dx = c.filter.state().fixed_rows::<4>(0) - m.filter.state().fixed_rows::<4>(0);
        let p = c.filter.covariance().fixed_view::<4, 4>(0, 0)
            + m.filter.covariance().fixed_view::<4, 4>(0, 0);
        p.try_inverse()
            .is_some_and(|pi| (dx.transpose() * pi * dx)[(0, 0)] < 1.0)
    }

    fn remove(&mut self, i: usize) {
        self.tracks.remove(i);
        self.main = match self.main {
            Some(m) if m == i => None,
            Some(m) if m > i => Some(m - 1),
            other => other,
        };
    }
}
