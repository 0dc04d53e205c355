//! Bounces the flight did not foresee: a change of course found at a wall ([`super::onset`])
//! is judged against a bounce before it is called a kick.
//!
//! The flight foresees a bounce where the configured walls are, with the restitution learned
//! so far. A real wall is a few centimetres elsewhere (a table measured roughly, a ball
//! rounder than stated, a camera's distortion near the edge) and a real bounce returns more
//! or less than the mean: the sightings after it are then surprising, and the change point
//! that follows looks like a kick. It is a bounce when, at the change, the ball was close to
//! a walled side, came in towards it, leaves away from it with a plausible share of its
//! normal speed, and keeps most of its speed along the wall. A bounce keeps the restitution
//! learning going (its sightings either side are measured as any bounce's) and is not
//! counted as a kick; the track's new velocity is the change point's either way.

use super::onset::{Kick, OnsetSighting};
use super::{Track, Tracker};
use crate::estimator::motion::speed;
use crate::estimator::surface::BounceEvent;

/// Shares of the normal speed a wall may return...
const RESTITUTION_RANGE: (f64, f64) = (0.1, 1.2);
/// ... with at least this normal speed in.
const MIN_NORMAL_IN_MPS: f64 = 0.1;
/// The speed along the wall may change by this share of the speed in, plus
/// [`TANGENTIAL_SLACK_MPS`] (a wall takes little of it; a kick changes it freely).
/// (A corner reverses both components: each is judged against its own wall.)
const TANGENTIAL_CHANGE: f64 = 0.4;
const TANGENTIAL_SLACK_MPS: f64 = 0.15;
/// The ball is at the wall when, just before the change, it was within this of it...
const NEAR_WALL_M: f64 = 0.1;
/// ... plus the normal distance it covers in this many sighting gaps (the change is known
/// to within one).
const NEAR_WALL_GAPS: f64 = 1.5;
/// The velocity it came with is read from a filter at most this long before the change.
const LOOK_BACK_S: f64 = 0.35;
/// The velocity it leaves with, from at most this many of the newest sightings.
const NEWEST: usize = 3;

/// What a change of course is.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum WallVerdict {
    Kick,
    /// Bounces the flight did not foresee.
    Bounce(Vec<BounceEvent>),
    /// The ball still comes in towards a wall it is at: not yet known.
    Wait,
}

impl Tracker {
    /// What `kick` (a change point of `track`, `now` its newest sighting) is.
    pub(super) fn judge_at_walls(
        &self,
        track: &Track,
        kick: &Kick,
        now: &OnsetSighting,
    ) -> WallVerdict {
        if !self.cfg.bounces_at_walls {
            return WallVerdict::Kick;
        }
        let b = &self.bounds;
        // The velocity now: a line through the newest sightings since the change (over so
        // short a time friction is below their noise). The kicked filter's own velocity is
        // not used: flown from before the change through walls that stand a little
        // elsewhere, it mixes the two sides of the bounce; nor are older sightings, which
        // may be of the ball still coming in.
        let mut since: Vec<(f64, [f64; 2])> = track
            .recent
            .iter()
            .filter(|r| r.t_s > kick.t_s)
            .map(|r| (r.t_s, r.z))
            .chain(std::iter::once((now.t_s, now.z)))
            .collect();
        since.drain(..since.len().saturating_sub(NEWEST));
        let Some(v_out) = slope(since.iter().copied()) else {
            return WallVerdict::Kick;
        };
        // Still coming in towards a wall it is at: the flight turned it too soon (the wall
        // stands farther out than it was put); what it does next tells.
        let coming_in = b.walled_sides().any(|(wall_m, k, dir)| {
            let to_wall_m = (wall_m - now.z[k]) * dir;
            v_out[k] * dir >= MIN_NORMAL_IN_MPS
                && to_wall_m <= NEAR_WALL_M
                && to_wall_m >= -self.cfg.surface.wall_max_offset_m
        });
        if coming_in {
            return WallVerdict::Wait;
        }
        let bounces = self.bounces_between(track, kick, v_out);
        if bounces.is_empty() {
            WallVerdict::Kick
        } else {
            WallVerdict::Bounce(bounces)
        }
    }

    /// The bounces a change of course from the filters before `kick` to `v_out` is: one
    /// wall's, or, in a corner, both walls'; none when it is no bounce.
    fn bounces_between(&self, track: &Track, kick: &Kick, v_out: [f64; 2]) -> Vec<BounceEvent> {
        let b = &self.bounds;
        let gap_s = track
            .recent
            .iter()
            .zip(track.recent.iter().skip(1))
            .map(|(a, c)| c.t_s - a.t_s)
            .fold(0.0, f64::max)
            .max(0.02);
        // The filters from just before the sightings up to the first after the change,
        // latest first.
        let before: Vec<_> = track
            .recent
            .iter()
            .rev()
            .skip_while(|r| r.t_s > kick.t_s + gap_s)
            .take_while(|r| kick.t_s - r.t_s <= LOOK_BACK_S)
            .collect();
        let Some(latest) = before.first() else {
            return Vec::new();
        };
        // Per axis: the wall it bounced off, or none when its speed along it was kept; a
        // change that is neither is no bounce.
        let mut walls: [Option<(f64, f64)>; 2] = [None, None];
        for k in 0..2 {
            walls[k] = b
                .walled_sides()
                .filter(|s| s.1 == k)
                .find_map(|(wall_m, _, dir)| {
                    // The latest filter that still came towards this wall.
                    let r = before
                        .iter()
                        .find(|r| r.before.velocity()[k] * dir >= MIN_NORMAL_IN_MPS)?;
                    let (p, v_in) = (r.before.position(), r.before.velocity());
                    let to_wall_m = (wall_m - p[k]) * dir;
                    let reach_m = NEAR_WALL_M
                        + (NEAR_WALL_GAPS * gap_s + (kick.t_s - r.t_s).max(0.0)) * v_in[k].abs();
                    let e = -v_out[k] / v_in[k];
                    let near = (-NEAR_WALL_M..=reach_m).contains(&to_wall_m);
                    (near && (RESTITUTION_RANGE.0..=RESTITUTION_RANGE.1).contains(&e))
                        .then_some((wall_m, v_in[k]))
                });
            if walls[k].is_none() {
                let v_in = latest.before.velocity();
                let change = (v_out[k] - v_in[k]).abs();
                if change > TANGENTIAL_CHANGE * speed(v_in) + TANGENTIAL_SLACK_MPS {
                    return Vec::new();
                }
            }
        }
        let corner = walls.iter().all(Option::is_some);
        walls
            .iter()
            .enumerate()
            .filter_map(|(axis, w)| {
                w.map(|(wall_m, v_in)| BounceEvent {
                    t_s: kick.t_s,
                    axis,
                    wall_m,
                    normal_velocity_in_mps: v_in,
                    corner,
                })
            })
            .collect()
    }
}

/// The least-squares velocity of sightings `(t, z)`; none from fewer than two, or from two
/// closer in time than a frame of two cameras.
fn slope(points: impl Iterator<Item = (f64, [f64; 2])>) -> Option<[f64; 2]> {
    let pts: Vec<_> = points.collect();
    let n = pts.len() as f64;
    let tm = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let stt: f64 = pts.iter().map(|p| (p.0 - tm).powi(2)).sum();
    if pts.len() < 2 || stt < (0.01f64).powi(2) / 2.0 {
        return None;
    }
    let v = |k: usize| {
        let m = pts.iter().map(|p| p.1[k]).sum::<f64>() / n;
        pts.iter().map(|p| (p.0 - tm) * (p.1[k] - m)).sum::<f64>() / stt
    };
    Some([v(0), v(1)])
}
