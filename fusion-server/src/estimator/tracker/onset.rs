//! Kick onsets: a ball that starts moving (or changes course) without anybody reporting it.
//!
//! The first sightings after a kick are *surprising*: farther from the prediction than
//! noise explains, in one direction. A track keeps its last few sightings, each with the
//! filter as it was just before it. When a run of surprising sightings makes a kick clear
//! (`surprises_for_kick` in a row, or two whose d² sum to `onset_chi2` while the ball
//! recedes from where it was), the kick's time is found as a change point: for each recent
//! sighting, the filter from just before it, its velocity made unknown, is re-fed the
//! sightings since; the sightings before it keep the cost they had. The cheapest (smallest
//! total d²) start wins, and its filter replaces the track's. The position before the kick
//! anchors the estimate and the sightings since give the velocity at once, instead of the
//! filter slowly bending its old "at rest" velocity towards the data; and the first
//! sightings after a kick that were not yet surprising are not mistaken for the ball at
//! rest.
//!
//! A sighting that no track accepts but lies near the main track is kept too: a kick whose
//! second sighting is already beyond the gate is still the same ball.

use super::at_wall::WallVerdict;
use super::{Track, Tracker};
use crate::estimator::filter::{BallFilter, Learn, ProcessNoise};
use crate::estimator::motion::speed;
use crate::estimator::surface::BounceEvent;
use nalgebra::{Matrix2, Vector2};

/// Sightings a track keeps for change-point search...
const RECENT_MAX: usize = 12;
/// ... from at most this far back.
const RECENT_S: f64 = 0.4;
/// A kick may have started up to this many sightings before the first surprising one.
const ONSET_LOOKBACK: usize = 4;
/// An onset follows a sighting that fitted, at most this long before the first surprising
/// one: a track nobody has seen for a while is found again by a new hypothesis, not kicked.
const ONSET_WATCHED_S: f64 = 0.15;

/// A kicked ball is flown sliding only when at least this many sightings since the kick tell
/// its speed: from fewer (a slow robot), the kick's speed is too uncertain to say where the
/// slide ends, and a wrong end costs more than a roll.
const MIN_SLIDE_SIGHTINGS: usize = 3;

/// A suspected kick is served (as a branch of the path's covariance) when at least this
/// likely.
const MIN_SUSPICION: f64 = 0.9;

/// P(χ² > `d2`) with 2·`n` degrees of freedom (a run of `n` 2-D sightings).
fn chi2_survival(d2: f64, n: usize) -> f64 {
    let half = 0.5 * d2.max(0.0);
    let mut term = 1.0;
    let mut sum = 1.0;
    for k in 1..n {
        term *= half / k as f64;
        sum += term;
    }
    ((-half).exp() * sum).clamp(0.0, 1.0)
}

/// One sighting of a track and the filter as it was just before it.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Recent {
    pub before: BallFilter,
    pub t_s: f64,
    pub z: [f64; 2],
    pub r: Matrix2<f64>,
    /// Innovation d² against `before`.
    pub d2: f64,
    /// Index of the robot that reported it.
    pub robot: usize,
}

/// A kick found as a change point: the re-initialised filter, when it came and how fast;
/// and the bounces it is instead when it came at a wall as a bounce does ([`super::at_wall`]).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Kick {
    pub filter: BallFilter,
    pub t_s: f64,
    pub speed_mps: f64,
    pub bounces: Vec<BounceEvent>,
}

/// A sighting as the onset logic needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct OnsetSighting {
    pub t_s: f64,
    pub z: [f64; 2],
    pub r: Matrix2<f64>,
    pub robot: usize,
}

impl Tracker {
    /// The process noise for flying a re-initialised (just kicked) filter.
    fn kick_noise(&self) -> ProcessNoise {
        let cfg = &self.cfg;
        let mut noise = cfg.noise;
        noise.accel_m2ps3 = noise.accel_m2ps3.max(cfg.near_robot_accel_m2ps3);
        noise.rest_vel_m2ps3 = noise.rest_vel_m2ps3.max(cfg.near_robot_accel_m2ps3);
        noise.rest_velocity_tau_s = f64::INFINITY;
        noise
    }

    /// `before` with its velocity made unknown (and rolling), fed `sightings` and then flown
    /// to `t_s`: the filter and the sum of the sightings' d².
    fn refly<'a>(
        &self,
        before: &BallFilter,
        sightings: impl Iterator<Item = &'a Recent>,
        t_s: f64,
    ) -> (BallFilter, f64) {
        let mut f = before.clone();
        f.roll();
        let vv = self.cfg.spawn_velocity_sigma_mps.powi(2);
        for k in 2..4 {
            let v = f.state()[k];
            f.reset_component(k, v, vv);
        }
        let noise = self.kick_noise();
        let motion = self.motion();
        let mut cost = 0.0;
        for s in sightings {
            f.predict_to(s.t_s, &motion, &self.bounds, &noise);
            // A sighting the filter cannot take makes this flight impossible.
            cost += f
                .update(s.z, &s.r, Learn::default())
                .map_or(f64::INFINITY, |inn| inn.d2);
        }
        f.predict_to(t_s, &motion, &self.bounds, &noise);
        (f, cost)
    }

    /// `before` kicked at sighting `j` of `track`, flown to `t_s`; when the floor makes a
    /// kicked ball slide first and enough sightings tell how fast it goes, it slides on from
    /// there until it is `roll_ratio` as fast as the kick (its speed now plus what the slide
    /// took since the kick). The few sightings since the kick are flown rolling: over so
    /// short a time the two phases differ by less than the noise. The filter, its cost, the
    /// kick's time and speed.
    fn kicked_flight(&self, track: &Track, j: usize, t_s: f64) -> (BallFilter, f64, (f64, f64)) {
        let recent = &track.recent;
        // The kick came between the sighting before and this one.
        let kick_t_s = match j.checked_sub(1) {
            Some(k) => 0.5 * (recent[k].t_s + recent[j].t_s),
            None => recent[j].t_s,
        };
        let (mut f, cost) = self.refly(&recent[j].before, recent.iter().skip(j), t_s);
        let m = self.motion();
        let kick_speed = speed(f.velocity()) + m.slide_decel_mps2 * (t_s - kick_t_s).max(0.0);
        if recent.len() - j >= MIN_SLIDE_SIGHTINGS {
            f.slide_since(kick_t_s, &m);
        }
        (f, cost, (kick_t_s, kick_speed))
    }

    /// Whether the trailing run of surprising sightings of `track`, with `now` (d² `d2`)
    /// appended, makes a kick clear; returns where the run starts in `track.recent`.
    fn onset_run(&self, track: &Track, now: &OnsetSighting, d2: f64) -> Option<usize> {
        let cfg = &self.cfg;
        if d2 <= cfg.surprise_chi2 {
            return None;
        }
        let recent = &track.recent;
        let mut start = recent.len();
        while start > 0
            && recent[start - 1].d2 > cfg.surprise_chi2
            && now.t_s - recent[start - 1].t_s <= RECENT_S
        {
            start -= 1;
        }
        let first = recent.get(start)?;
        let watched = start
            .checked_sub(1)
            .is_some_and(|k| first.t_s - recent[k].t_s <= ONSET_WATCHED_S);
        // A robot known to see what the others do not cannot kick the ball alone.
        let credible = |r: usize| {
            self.robots
                .get(r)
                .is_some_and(|t| t.credible(cfg.outlier_rate_max))
        };
        let all_credible =
            recent.iter().skip(start).all(|s| credible(s.robot)) && credible(now.robot);
        if !watched || !all_credible {
            return None;
        }
        let motion = self.motion();
        let residual = |t_s: f64, z: [f64; 2]| {
            let mut f = first.before.clone();
            f.predict_to(t_s, &motion, &self.bounds, &self.kick_noise());
            Vector2::new(z[0] - f.state()[0], z[1] - f.state()[1])
        };
        let y_first = Vector2::new(
            first.z[0] - first.before.state()[0],
            first.z[1] - first.before.state()[1],
        );
        let y_now = residual(now.t_s, now.z);
        let aligned = recent
            .iter()
            .skip(start)
            .map(|s| residual(s.t_s, s.z))
            .chain(std::iter::once(y_now))
            .all(|y| y.dot(&y_first) > 0.0);
        if !aligned {
            return None;
        }
        let n = recent.len() - start + 1;
        let d2_sum: f64 = recent.iter().skip(start).map(|s| s.d2).sum::<f64>() + d2;
        let receding = y_now.norm() >= y_first.norm();
        let clear =
            n >= cfg.surprises_for_kick.max(2) || (n >= 2 && receding && d2_sum >= cfg.onset_chi2);
        clear.then_some(start)
    }

    /// The kicked filter of `track` at `now`, its start chosen among the sightings up to
    /// [`ONSET_LOOKBACK`] before the run's first: the kick (its filter without `now` applied)
    /// and the d² of `now` against it.
    fn kicked_filter(
        &self,
        track: &Track,
        run_start: usize,
        now: &OnsetSighting,
    ) -> Option<(Kick, f64)> {
        let recent = &track.recent;
        let lo = run_start.saturating_sub(ONSET_LOOKBACK);
        (lo..=run_start.min(recent.len().saturating_sub(1)))
            .map(|j| {
                let kept: f64 = recent.iter().take(j).skip(lo).map(|s| s.d2).sum();
                let (filter, cost, (t_s, speed_mps)) = self.kicked_flight(track, j, now.t_s);
                let d2_now = filter.innovation(now.z, &now.r).d2;
                let kick = Kick {
                    filter,
                    t_s,
                    speed_mps,
                    bounces: Vec::new(),
                };
                (kick, d2_now, kept + cost + d2_now)
            })
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .map(|(k, d2_now, _)| (k, d2_now))
    }

    /// `kick` as the walls judge it: a kick, bounces, or nothing yet (the ball still comes
    /// in towards a wall it may be about to bounce off).
    fn judged(&self, track: &Track, mut kick: Kick, now: &OnsetSighting) -> Option<Kick> {
        match self.judge_at_walls(track, &kick, now) {
            WallVerdict::Kick => Some(kick),
            WallVerdict::Bounce(b) => {
                kick.bounces = b;
                Some(kick)
            }
            WallVerdict::Wait => None,
        }
    }

    /// A kick the estimate's newest sightings suggest but do not yet make clear: the
    /// filter kicked at the first of its trailing run of surprising sightings, flown to
    /// `t_s`, and how likely the kick is (one minus the chance that noise alone gives the
    /// run's d², kept only when at least [`MIN_SUSPICION`]).
    pub fn suspected_kick(&self, t_s: f64) -> Option<(BallFilter, f64)> {
        let track = self.main()?;
        let recent = &track.recent;
        if recent.back().is_none_or(|s| t_s - s.t_s > RECENT_S) {
            return None;
        }
        let mut start = recent.len();
        while start > 0 && recent[start - 1].d2 > self.cfg.surprise_chi2 {
            start -= 1;
        }
        let first = recent.get(start)?;
        let run = recent.iter().skip(start);
        let d2: f64 = run.clone().map(|s| s.d2).sum();
        let likely = 1.0 - chi2_survival(d2, recent.len() - start);
        if likely < MIN_SUSPICION {
            return None;
        }
        let (f, _) = self.refly(&first.before, run, t_s);
        Some((f, likely))
    }

    /// Keeps a sighting of track `i`, before its filter is updated by it.
    pub(super) fn remember(&mut self, i: usize, s: &OnsetSighting) {
        let track = &mut self.tracks[i];
        let d2 = track.filter.innovation(s.z, &s.r).d2;
        track.recent.push_back(Recent {
            before: track.filter.clone(),
            t_s: s.t_s,
            z: s.z,
            r: s.r,
            d2,
            robot: s.robot,
        });
        while track.recent.len() > RECENT_MAX
            || track
                .recent
                .front()
                .is_some_and(|f| s.t_s - f.t_s > RECENT_S)
        {
            track.recent.pop_front();
        }
    }

    /// For a sighting that track `i` accepted with d² `d2` (before the update): the
    /// re-initialised filter when it makes a kick clear.
    pub(super) fn note_onset(&mut self, i: usize, d2: f64, s: &OnsetSighting) -> Option<Kick> {
        let track = &self.tracks[i];
        let start = self.onset_run(track, s, d2)?;
        let (kick, _) = self.kicked_filter(track, start, s)?;
        self.judged(track, kick, s)
    }

    /// For a sighting no track accepts: the main track re-initialised as kicked, when a
    /// run of surprising sightings ending in this one makes the kick clear and the kicked
    /// filter accepts it. A sighting near the main track that is not (yet) a kick is kept,
    /// so that the next one may confirm it.
    pub(super) fn kick_candidate(&mut self, s: &OnsetSighting) -> Option<(usize, Kick)> {
        let m = self.main?;
        let track = &self.tracks[m];
        let inn = track.filter.innovation(s.z, &s.r);
        if inn.y.norm() >= self.cfg.max_innovation_m {
            return None;
        }
        let kicked = self
            .onset_run(track, s, inn.d2)
            .and_then(|start| self.kicked_filter(track, start, s))
            .filter(|(_, d2)| *d2 < self.cfg.gate_chi2)
            .and_then(|(kick, _)| self.judged(track, kick, s));
        match kicked {
            Some(kick) => Some((m, kick)),
            None => {
                self.remember(m, s);
                None
            }
        }
    }
}
