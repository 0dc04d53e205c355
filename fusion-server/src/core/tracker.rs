//! Track management: which hypothesis each observation belongs to, when an alternative
//! hypothesis takes over, and how much each robot is trusted.
//!
//! Every observation is gated (χ², 2 dof, on S = HPHᵀ + R) against every hypothesis and
//! updates the closest one that accepts it. Observations no hypothesis accepts start a new
//! one. A hypothesis replaces the main track when it is supported by more recent
//! observations from enough distinct robots: that is how a kick or a relocation is followed
//! within a few frames, and why a phantom seen by one robot does not capture the estimate.

use super::filter::{BallFilter, DECEL, Innovation, ProcessNoise, RESTITUTION};
use super::motion::{Bounds, MotionModel, speed};
use nalgebra::Matrix2;
use proto::Pose2;
use std::collections::VecDeque;
use std::sync::Arc;

mod trust;
pub use trust::RobotTrust;

/// One observation as the core sees it: capture time already on the fusion time axis.
#[derive(Debug, Clone, PartialEq)]
pub struct ObsInput {
    /// Capture time, seconds since the fusion epoch.
    pub t_s: f64,
    pub robot: Arc<str>,
    pub position_m: [f64; 2],
    pub covariance_m2: Matrix2<f64>,
    pub robot_pose: Pose2,
}

/// Tuning of the tracker. `Default` is what the server runs with.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerConfig {
    /// χ² gate on the innovation (2 dof; 11.83 keeps 99.73 % of consistent observations).
    pub gate_chi2: f64,
    /// Observations farther than this from a track's prediction never update it, however
    /// uncertain it has grown: an unseen ball is found again by a new hypothesis, not by
    /// stretching a stale linearisation.
    pub max_innovation_m: f64,
    /// Velocity uncertainty of a new hypothesis.
    pub spawn_velocity_sigma_mps: f64,
    pub max_tracks: usize,
    /// A hypothesis with no observation for this long is dropped.
    pub candidate_ttl_s: f64,
    /// Support is counted over this recent window.
    pub promote_window_s: f64,
    pub promote_min_hits: usize,
    /// When the main track has had no support for this long, a hypothesis seen by a single
    /// (well-behaved) robot may take over.
    pub main_silence_s: f64,
    /// Robots whose share of observations off the main track is above this cannot alone
    /// promote a hypothesis (they see phantoms).
    pub outlier_rate_max: f64,
    /// Ball closer than this to a robot: it may be kicked or pushed at any moment.
    pub near_robot_m: f64,
    /// After a takeover (a kick), extra process noise for this long.
    pub kick_boost_s: f64,
    /// An update whose innovation's d² exceeds this is surprising (5.99: 5 % of consistent
    /// observations)...
    pub surprise_chi2: f64,
    /// ... and this many surprising updates in a row mean the ball was kicked (by someone
    /// no robot reports, or too softly for the gate to refuse): the track gets the same
    /// extra process noise as after a takeover.
    pub surprises_for_kick: usize,
    /// After a kick or a bounce the ball slides; do not learn the rolling deceleration then.
    pub learn_quiet_s: f64,
    /// Do not learn the deceleration below this speed (the stop dominates).
    pub learn_min_speed_mps: f64,
    pub learn_decel: bool,
    pub learn_restitution: bool,
    /// Base motion model; its deceleration and restitution are the starting values.
    pub motion: MotionModel,
    pub decel_sigma_mps2: f64,
    pub restitution_sigma: f64,
    pub noise: ProcessNoise,
    /// Extra white-acceleration density per (m/s)² of speed.
    pub accel_speed_gain: f64,
    /// White-acceleration density near robots and just after a kick.
    pub near_robot_accel_m2ps3: f64,
    /// EWMA weight of one observation in a robot's trust estimate.
    pub trust_alpha: f64,
    pub trust_range: (f64, f64),
}

impl Default for TrackerConfig {
    fn default() -> Self {
        TrackerConfig {
            gate_chi2: 11.83,
            max_innovation_m: 0.6,
            spawn_velocity_sigma_mps: 1.5,
            max_tracks: 6,
            candidate_ttl_s: 0.6,
            promote_window_s: 0.4,
            promote_min_hits: 3,
            main_silence_s: 0.5,
            outlier_rate_max: 0.1,
            near_robot_m: 0.4,
            kick_boost_s: 0.2,
            surprise_chi2: 5.99,
            surprises_for_kick: 3,
            learn_quiet_s: 0.4,
            learn_min_speed_mps: 0.12,
            learn_decel: true,
            learn_restitution: true,
            motion: MotionModel::default(),
            decel_sigma_mps2: 0.1,
            restitution_sigma: 0.15,
            noise: ProcessNoise {
                accel_m2ps3: 0.0005,
                rest_pos_m2ps: 2e-5,
                rest_vel_m2ps3: 0.02,
                rest_velocity_tau_s: 0.3,
                decel_per_s: 1e-5,
                restitution_per_s: 1e-5,
                bounce_normal_frac: 0.15,
                bounce_tangential_frac: 0.06,
            },
            accel_speed_gain: 0.003,
            near_robot_accel_m2ps3: 2.0,
            trust_alpha: 0.03,
            trust_range: (0.2, 25.0),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    pub id: u64,
    pub filter: BallFilter,
    pub last_hit_s: f64,
    pub born_s: f64,
    /// Recent supporting observations: (time, robot index).
    hits: VecDeque<(f64, usize)>,
    quiet_until_s: f64,
    boost_until_s: f64,
    /// A wall bounce was flown through and no observation has informed the restitution since.
    bounce_unlearned: bool,
    /// Surprising updates in a row (see [`TrackerConfig::surprise_chi2`]).
    surprises: usize,
}

impl Track {
    fn support(&self, now_s: f64, window_s: f64) -> (usize, usize, Vec<usize>) {
        self.support_since(now_s - window_s)
    }

    /// Supporting observations at or after `since_s`: count, distinct robots, the robots.
    fn support_since(&self, since_s: f64) -> (usize, usize, Vec<usize>) {
        let mut robots: Vec<usize> = Vec::new();
        let mut n = 0;
        for (t, r) in self.hits.iter().rev() {
            if *t < since_s {
                break;
            }
            n += 1;
            if !robots.contains(r) {
                robots.push(*r);
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
}

/// The whole tracking state. `Clone` is cheap enough to snapshot after every observation,
/// which is how late observations are replayed in capture order.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracker {
    cfg: Arc<TrackerConfig>,
    bounds: Bounds,
    tracks: Vec<Track>,
    main: Option<usize>,
    robots: Vec<RobotTrust>,
    next_id: u64,
    decel_updates: u32,
    restitution_updates: u32,
    /// Observations dropped for lying beyond a wall, where no ball can be.
    outside_walls: u64,
    /// Kicks inferred from surprising updates.
    kicks_inferred: u64,
    /// Time of the newest applied observation.
    pub t_s: f64,
}

const HIT_HISTORY_S: f64 = 1.5;
/// ... and at most this many (a flood of observations must not make states expensive to
/// copy; support counts only need to reach a few).
const MAX_HITS: usize = 1024;
/// A track updated this recently is being watched.
const WATCHED_S: f64 = 0.5;
/// Robots that reported anything this recently count as on the pitch (a robot that sees
/// no ball sends nothing, so this is long).
const ACTIVE_ROBOT_S: f64 = 5.0;

impl Tracker {
    pub fn new(cfg: Arc<TrackerConfig>, bounds: Bounds) -> Self {
        Tracker {
            cfg,
            bounds,
            tracks: Vec::new(),
            main: None,
            robots: Vec::new(),
            next_id: 1,
            decel_updates: 0,
            kicks_inferred: 0,
            restitution_updates: 0,
            outside_walls: 0,
            t_s: f64::NEG_INFINITY,
        }
    }

    pub fn config(&self) -> &TrackerConfig {
        &self.cfg
    }

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

    /// Kicks inferred from runs of surprising updates.
    pub fn kicks_inferred(&self) -> u64 {
        self.kicks_inferred
    }

    /// Observations / bounces that informed the learned deceleration / restitution.
    pub fn learning_counts(&self) -> (u32, u32) {
        (self.decel_updates, self.restitution_updates)
    }

    /// The process noise for a track predicted from its current state.
    pub fn noise_for(&self, track: &Track) -> ProcessNoise {
        let cfg = &self.cfg;
        let mut noise = cfg.noise;
        let s = speed(track.filter.velocity());
        noise.accel_m2ps3 += cfg.accel_speed_gain * s * s;
        // Near a robot the ball may be kicked at any moment; but only while it is being
        // watched: an unseen ball's uncertainty must not balloon until anything fits.
        let watched = track.filter.t_s - track.last_hit_s < WATCHED_S;
        if watched
            && (self.near_robot(track.filter.position(), track.filter.t_s)
                || track.filter.t_s < track.boost_until_s)
        {
            noise.accel_m2ps3 = noise.accel_m2ps3.max(cfg.near_robot_accel_m2ps3);
            noise.rest_vel_m2ps3 = noise.rest_vel_m2ps3.max(cfg.near_robot_accel_m2ps3);
        }
        if watched && track.filter.t_s < track.boost_until_s {
            // Just born or just kicked: the velocity is unknown, not "probably zero".
            noise.rest_velocity_tau_s = f64::INFINITY;
        }
        noise
    }

    fn near_robot(&self, p: [f64; 2], t_s: f64) -> bool {
        self.robots.iter().any(|r| {
            t_s - r.last_obs_s < 1.0
                && (r.pose.x_m - p[0]).hypot(r.pose.y_m - p[1]) < self.cfg.near_robot_m
        })
    }

    fn robot_index(&mut self, o: &ObsInput) -> usize {
        if let Some(i) = self.robots.iter().position(|r| r.robot == o.robot) {
            return i;
        }
        self.robots.push(RobotTrust {
            robot: o.robot.clone(),
            pose: o.robot_pose,
            last_obs_s: o.t_s,
            covariance_scale: 1.0,
            outlier_rate: 0.0,
            outlier_samples: 0,
            observations: 0,
        });
        self.robots.len() - 1
    }

    /// Applies one observation at its capture time (callers feed them in time order).
    pub fn apply(&mut self, o: &ObsInput) {
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

        match best {
            Some((i, d2)) => {
                self.update_track(i, ri, o, &r_eff);
                self.note_surprise(i, d2, o.t_s);
            }
            None => self.spawn(ri, o, &r_eff),
        }
        self.promote(o.t_s);
        self.prune(o.t_s);
    }

    fn predict_all(&mut self, t_s: f64) {
        let quiet = self.cfg.learn_quiet_s;
        for i in 0..self.tracks.len() {
            let noise = self.noise_for(&self.tracks[i]);
            let track = &mut self.tracks[i];
            if let Some(flight) =
                track
                    .filter
                    .predict_to(t_s, &self.cfg.motion, &self.bounds, &noise)
                && flight.hits().next().is_some()
            {
                // The ball slides for a moment after a bounce.
                track.quiet_until_s = track.quiet_until_s.max(t_s + quiet);
                track.bounce_unlearned = true;
            }
        }
    }

    fn update_track(&mut self, i: usize, ri: usize, o: &ObsInput, r_eff: &Matrix2<f64>) {
        let is_main = self.main == Some(i);
        let near = self.near_robot(self.tracks[i].filter.position(), o.t_s);
        let track = &self.tracks[i];
        let learn_decel = is_main
            && self.cfg.learn_decel
            && !near
            && o.t_s >= track.quiet_until_s
            && o.t_s >= track.boost_until_s
            && speed(track.filter.velocity()) > self.cfg.learn_min_speed_mps;
        let learn_restitution = is_main
            && self.cfg.learn_restitution
            && !near
            && o.t_s >= track.boost_until_s
            && track.filter.p[(0, RESTITUTION)].abs() + track.filter.p[(1, RESTITUTION)].abs()
                > 1e-9;
        let track = &mut self.tracks[i];
        track
            .filter
            .update(o.position_m, r_eff, [learn_decel, learn_restitution]);
        track.last_hit_s = track.last_hit_s.max(o.t_s);
        track.hits.push_back((o.t_s, ri));
        while track
            .hits
            .front()
            .is_some_and(|(t, _)| *t < o.t_s - HIT_HISTORY_S)
        {
            track.hits.pop_front();
        }
        if track.hits.len() > MAX_HITS {
            track.hits.pop_front();
        }
        if learn_decel {
            self.decel_updates = self.decel_updates.saturating_add(1);
        }
        if learn_restitution && track.bounce_unlearned {
            // Count each bounce once, at the first observation after it that informs it.
            track.bounce_unlearned = false;
            self.restitution_updates = self.restitution_updates.saturating_add(1);
        }
    }

    /// Counts surprising updates in a row; enough of them and the track is treated as just
    /// kicked: its velocity is free to change for a moment.
    fn note_surprise(&mut self, i: usize, d2: f64, t_s: f64) {
        let cfg = &self.cfg;
        let track = &mut self.tracks[i];
        if d2 <= cfg.surprise_chi2 {
            track.surprises = 0;
            return;
        }
        track.surprises += 1;
        if track.surprises >= cfg.surprises_for_kick.max(1) {
            track.surprises = 0;
            track.boost_until_s = track.boost_until_s.max(t_s + cfg.kick_boost_s);
            track.quiet_until_s = track.quiet_until_s.max(t_s + cfg.learn_quiet_s);
            self.kicks_inferred += 1;
        }
    }

    fn spawn(&mut self, ri: usize, o: &ObsInput, r_eff: &Matrix2<f64>) {
        let cfg = &self.cfg;
        let params = match self.main() {
            Some(m) => [
                (m.filter.x[DECEL], m.filter.p[(DECEL, DECEL)]),
                (
                    m.filter.x[RESTITUTION],
                    m.filter.p[(RESTITUTION, RESTITUTION)],
                ),
            ],
            None => [
                (cfg.motion.decel_mps2, cfg.decel_sigma_mps2.powi(2)),
                (cfg.motion.restitution, cfg.restitution_sigma.powi(2)),
            ],
        };
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
            hits: VecDeque::from([(o.t_s, ri)]),
            quiet_until_s: o.t_s + cfg.learn_quiet_s,
            bounce_unlearned: false,
            surprises: 0,
            // A new hypothesis is often a ball just kicked and still sliding.
            boost_until_s: o.t_s + cfg.kick_boost_s,
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

    /// A hypothesis takes over when, since it was born, it has gathered clearly more support
    /// than the main track: from several robots, or from one credible robot while the main
    /// track got nothing at all (a kick seen by one robot first). A robot that keeps seeing
    /// things nobody else sees is not credible, so its phantom never takes over.
    fn promote(&mut self, t_s: f64) {
        let cfg = self.cfg.clone();
        let window = cfg.promote_window_s;
        let active_robots = self
            .robots
            .iter()
            .filter(|r| t_s - r.last_obs_s < ACTIVE_ROBOT_S)
            .count();
        let main_silent = self
            .main()
            .is_none_or(|m| t_s - m.last_hit_s > cfg.main_silence_s);
        let mut best: Option<(usize, usize)> = None;
        for (i, tr) in self.tracks.iter().enumerate() {
            if Some(i) == self.main {
                continue;
            }
            let since = tr.born_s.max(t_s - window);
            let (hits, n_robots, robots) = tr.support_since(since);
            let main_hits = self.main().map_or(0, |m| m.support_since(since).0);
            if hits < cfg.promote_min_hits || 2 * main_hits >= hits {
                continue;
            }
            // Before there is any estimate, a steady stream of sightings is needed: a
            // phantom flickers, and one stray report from another robot must not vouch
            // for it. After that, two robots agreeing suffice.
            if self.main.is_none() {
                let steady = tr.hits.iter().filter(|(t, _)| *t >= since).fold(
                    Vec::<(usize, usize)>::new(),
                    |mut per_robot, (_, r)| {
                        match per_robot.iter_mut().find(|(id, _)| id == r) {
                            Some((_, n)) => *n += 1,
                            None => per_robot.push((*r, 1)),
                        }
                        per_robot
                    },
                );
                let steady_robots = steady.iter().filter(|(_, n)| *n >= 2).count();
                if steady_robots < 2 && hits < 2 * cfg.promote_min_hits {
                    continue;
                }
            }
            let diverse = n_robots >= active_robots.clamp(1, 2);
            let credible = robots
                .iter()
                .all(|r| self.robots[*r].credible(cfg.outlier_rate_max));
            let unopposed = main_hits == 0 || main_silent;
            let lone_ok = unopposed && credible && hits > cfg.promote_min_hits;
            if (diverse || lone_ok) && best.is_none_or(|(_, h)| hits > h) {
                best = Some((i, hits));
            }
        }
        let Some((i, _)) = best else { return };
        if let Some(old) = self.main() {
            // The floor and the walls did not change: keep what was learned about them.
            let keep = [
                (old.filter.x[DECEL], old.filter.p[(DECEL, DECEL)]),
                (
                    old.filter.x[RESTITUTION],
                    old.filter.p[(RESTITUTION, RESTITUTION)],
                ),
            ];
            let f = &mut self.tracks[i].filter;
            for (k, (v, var)) in [(DECEL, keep[0]), (RESTITUTION, keep[1])] {
                f.x[k] = v;
                for j in 0..6 {
                    f.p[(k, j)] = 0.0;
                    f.p[(j, k)] = 0.0;
                }
                f.p[(k, k)] = var;
            }
        }
        let tr = &mut self.tracks[i];
        tr.boost_until_s = t_s + cfg.kick_boost_s;
        tr.quiet_until_s = tr.quiet_until_s.max(t_s + cfg.learn_quiet_s);
        self.main = Some(i);
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
        let dx = c.filter.x.fixed_rows::<4>(0) - m.filter.x.fixed_rows::<4>(0);
        let p = c.filter.p.fixed_view::<4, 4>(0, 0) + m.filter.p.fixed_view::<4, 4>(0, 0);
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
