//! What happened to a tracked ball, found from the track alone: its smoothed velocity, its
//! wall bounces and the pushes (kicks, robot contacts) no motion model can foresee.
//!
//! - Velocity: the least-squares slope of the positions within ±[`SMOOTHING_HALF_WINDOW_S`]
//!   of each sample.
//! - A wall bounce: a sample closest to a wall, the ball's centre within
//!   [`BOUNCE_NEAR_RADII`] ball radii of touching it, where the normal velocity reverses:
//!   straight lines fitted to the normal coordinate over [`BOUNCE_FIT_S`] before and after
//!   the sample come in faster than [`BOUNCE_MIN_SPEED_IN_MPS`] and go out faster than
//!   [`BOUNCE_MIN_SPEED_OUT_MPS`] (a glancing bounce keeps little normal speed). Its time is
//!   where the two lines meet.
//! - A push: the smoothed speed rises by more than [`PUSH_SPEED_GAIN_MPS`] over what it was
//!   in the preceding [`PUSH_LOOKBACK_S`] (friction and walls only ever slow a ball down).

use fusion_server::Bounds;
use proto::WallSide;
use serde::Serialize;
use tools::tracks::Track;

pub const SMOOTHING_HALF_WINDOW_S: f64 = 0.05;
pub const BOUNCE_NEAR_RADII: f64 = 3.0;
pub const BOUNCE_FIT_S: f64 = 0.15;
pub const BOUNCE_MIN_SPEED_IN_MPS: f64 = 0.08;
pub const BOUNCE_MIN_SPEED_OUT_MPS: f64 = 0.03;
pub const PUSH_SPEED_GAIN_MPS: f64 = 0.25;
pub const PUSH_LOOKBACK_S: f64 = 0.3;
/// A course change is measured between the smoothed velocities this long apart.
pub const STRIKE_SPAN_S: f64 = 4.0 * SMOOTHING_HALF_WINDOW_S;
/// A ball slower than this is about to stop...
pub const STOP_FROM_MPS: f64 = 0.1;
/// ... and has stopped when it then stays within this of one place for this long.
pub const REST_SPREAD_M: f64 = 0.03;
pub const REST_S: f64 = 0.5;
/// A ball moved (and may stop again) once faster than this.
pub const STOP_MOVED_MPS: f64 = 0.3;
/// A push is taken to act over this span around the sample that reveals it.
const PUSH_BEFORE_S: f64 = 2.0 * SMOOTHING_HALF_WINDOW_S;
const PUSH_AFTER_S: f64 = SMOOTHING_HALF_WINDOW_S;

/// A wall bounce seen in a track.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackBounce {
    pub t_s: f64,
    pub wall: WallSide,
    pub position_m: [f64; 2],
}

/// The track's smoothed velocity, bounces and pushes.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackEvents {
    times_s: Vec<f64>,
    pub velocity_mps: Vec<[f64; 2]>,
    pub bounces: Vec<TrackBounce>,
    /// Time spans `[from, to]` over which something pushed the ball.
    pub pushes: Vec<(f64, f64)>,
    /// Time spans over which something changed the ball's course away from the walls
    /// (a push, or a strike that slowed or turned it): the velocity changed by more than
    /// [`PUSH_SPEED_GAIN_MPS`] across [`STRIKE_SPAN_S`] while the ball was farther from
    /// every wall than [`BOUNCE_NEAR_RADII`] radii and the distance it covers in half that
    /// span and the smoothing's reach.
    pub course_changes: Vec<(f64, f64)>,
    /// Where the ball came to rest, and when: the samples of the [`REST_S`] after its
    /// smoothed speed last fell below [`STOP_FROM_MPS`] all lie within [`REST_SPREAD_M`] of
    /// their mean, which is the place.
    pub stops: Vec<(f64, [f64; 2])>,
}

impl TrackEvents {
    /// The events of `track` on a pitch whose ball centre is confined to `bounds`.
    pub fn of(track: &Track, bounds: &Bounds, ball_radius_m: f64) -> Self {
        let times_s: Vec<f64> = track.samples.iter().map(|s| s.t_s).collect();
        let pos: Vec<[f64; 2]> = track.samples.iter().map(|s| s.position_m).collect();
        let velocity_mps = smoothed_velocity(&times_s, &pos, SMOOTHING_HALF_WINDOW_S);
        let near_m = BOUNCE_NEAR_RADII * ball_radius_m;
        let bounces = wall_bounces(track, &times_s, &pos, bounds, near_m);
        let mut pushes = pushes(&times_s, &velocity_mps);
        // A ball placed elsewhere was moved by hand: no model foresees that either.
        for t_s in track.relocations_s() {
            let before = times_s[..times_s.partition_point(|t| *t < t_s)]
                .last()
                .copied()
                .unwrap_or(t_s);
            pushes.push((before, t_s + PUSH_BEFORE_S));
        }
        pushes.sort_by(|a, b| a.0.total_cmp(&b.0));
        let course_changes = course_changes(&times_s, &pos, &velocity_mps, bounds, near_m);
        let stops = stops(&times_s, &pos, &velocity_mps);
        TrackEvents {
            times_s,
            velocity_mps,
            bounces,
            pushes,
            course_changes,
            stops,
        }
    }

    /// The smoothed speed at `t_s`, interpolated; `None` outside the track.
    pub fn speed_at(&self, t_s: f64) -> Option<f64> {
        let (first, last) = (*self.times_s.first()?, *self.times_s.last()?);
        if t_s < first || t_s > last {
            return None;
        }
        let i = self.times_s.partition_point(|t| *t <= t_s);
        let speed = |k: usize| self.velocity_mps[k][0].hypot(self.velocity_mps[k][1]);
        if i == 0 || i >= self.times_s.len() {
            return Some(speed(i.min(self.times_s.len() - 1)));
        }
        let (t0, t1) = (self.times_s[i - 1], self.times_s[i]);
        let f = (t_s - t0) / (t1 - t0);
        Some(speed(i - 1) + f * (speed(i) - speed(i - 1)))
    }

    /// Whether something pushed the ball within (`t0_s`, `t1_s`].
    pub fn pushed_between(&self, t0_s: f64, t1_s: f64) -> bool {
        self.pushes.iter().any(|(a, b)| *a <= t1_s && *b > t0_s)
    }

    /// Whether something pushed the ball or changed its course away from the walls within
    /// (`t0_s`, `t1_s`].
    pub fn course_changed_between(&self, t0_s: f64, t1_s: f64) -> bool {
        self.pushed_between(t0_s, t1_s)
            || self
                .course_changes
                .iter()
                .any(|(a, b)| *a <= t1_s && *b > t0_s)
    }

    /// The ball's next stop after `t_s`: when and where.
    pub fn next_stop(&self, t_s: f64) -> Option<(f64, [f64; 2])> {
        self.stops.iter().find(|s| s.0 > t_s).copied()
    }

    /// The first bounce after `t_s`.
    pub fn next_bounce(&self, t_s: f64) -> Option<&TrackBounce> {
        self.bounces.iter().find(|b| b.t_s > t_s)
    }
}

/// Least-squares slope of `(t, p)` over the samples within ±`half_window_s` of each one
/// (at least its two neighbours).
fn smoothed_velocity(t: &[f64], p: &[[f64; 2]], half_window_s: f64) -> Vec<[f64; 2]> {
    let n = t.len();
    let (mut lo, mut hi) = (0usize, 0usize);
    (0..n)
        .map(|i| {
            while t[i] - t[lo] > half_window_s {
                lo += 1;
            }
            while hi + 1 < n && t[hi + 1] - t[i] <= half_window_s {
                hi += 1;
            }
            let a = lo.min(i.saturating_sub(1));
            let b = hi.max((i + 1).min(n - 1));
            slope(&t[a..=b], &p[a..=b])
        })
        .collect()
}

/// The least-squares slope of positions against time (zero for a single sample).
fn slope(t: &[f64], p: &[[f64; 2]]) -> [f64; 2] {
    let n = t.len() as f64;
    let tm = t.iter().sum::<f64>() / n;
    let (mut stt, mut stx, mut sty) = (0.0, 0.0, 0.0);
    let xm = p.iter().map(|q| q[0]).sum::<f64>() / n;
    let ym = p.iter().map(|q| q[1]).sum::<f64>() / n;
    for (ti, q) in t.iter().zip(p) {
        let dt = ti - tm;
        stt += dt * dt;
        stx += dt * (q[0] - xm);
        sty += dt * (q[1] - ym);
    }
    if stt > 0.0 {
        [stx / stt, sty / stt]
    } else {
        [0.0, 0.0]
    }
}

/// A line `a·t + b` fitted to (t, v); `None` for fewer than two distinct times.
fn line(points: impl Iterator<Item = (f64, f64)>) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = points.collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let tm = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let vm = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let stt: f64 = pts.iter().map(|p| (p.0 - tm).powi(2)).sum();
    let stv: f64 = pts.iter().map(|p| (p.0 - tm) * (p.1 - vm)).sum();
    (stt > 0.0).then(|| {
        let a = stv / stt;
        (a, vm - a * tm)
    })
}

/// The wall's contact coordinate for the ball's centre, its axis and outward sign.
fn wall_of(bounds: &Bounds, side: WallSide) -> (f64, usize, f64) {
    match side {
        WallSide::XMax => (bounds.x_max, 0, 1.0),
        WallSide::XMin => (bounds.x_min, 0, -1.0),
        WallSide::YMax => (bounds.y_max, 1, 1.0),
        WallSide::YMin => (bounds.y_min, 1, -1.0),
    }
}

fn wall_bounces(
    track: &Track,
    t: &[f64],
    pos: &[[f64; 2]],
    bounds: &Bounds,
    near_m: f64,
) -> Vec<TrackBounce> {
    let mut out: Vec<TrackBounce> = Vec::new();
    for (i, side) in WallSide::ALL.iter().enumerate() {
        if !bounds.walls[i] {
            continue;
        }
        let (contact, axis, sign) = wall_of(bounds, *side);
        // The normal coordinate grows towards the wall; the ball touches it at `sign · contact`.
        let normal = |j: usize| sign * pos[j][axis];
        let mut last: Option<f64> = None;
        for m in 1..t.len().saturating_sub(1) {
            if normal(m) < normal(m - 1) || normal(m) < normal(m + 1) {
                continue;
            }
            if sign * contact - normal(m) > near_m {
                continue;
            }
            let before = line(
                (0..m)
                    .rev()
                    .take_while(|j| t[m] - t[*j] <= BOUNCE_FIT_S)
                    .map(|j| (t[j], normal(j))),
            );
            let after = line(
                (m + 1..t.len())
                    .take_while(|j| t[*j] - t[m] <= BOUNCE_FIT_S)
                    .map(|j| (t[j], normal(j))),
            );
            let (Some((a1, b1)), Some((a2, b2))) = (before, after) else {
                continue;
            };
            if a1 < BOUNCE_MIN_SPEED_IN_MPS || a2 > -BOUNCE_MIN_SPEED_OUT_MPS {
                continue;
            }
            // Where the two lines meet, if between the closest sample's neighbours.
            let t_hit = (b2 - b1) / (a1 - a2);
            let t_s = if (t[m - 1]..=t[m + 1]).contains(&t_hit) {
                t_hit
            } else {
                t[m]
            };
            // Noise can make several closest samples of one bounce.
            if last.is_some_and(|l| t_s - l < BOUNCE_FIT_S) {
                continue;
            }
            last = Some(t_s);
            out.push(TrackBounce {
                t_s,
                wall: *side,
                position_m: track.position_at(t_s).unwrap_or(pos[m]),
            });
        }
    }
    out.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    out
}

fn pushes(t: &[f64], vel: &[[f64; 2]]) -> Vec<(f64, f64)> {
    let speed: Vec<f64> = vel.iter().map(|v| v[0].hypot(v[1])).collect();
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut lo = 0usize;
    for j in 0..t.len() {
        while t[j] - t[lo] > PUSH_LOOKBACK_S {
            lo += 1;
        }
        // The speed before the sample's own smoothing window reaches back.
        let earlier = (lo..j)
            .take_while(|i| t[j] - t[*i] >= 2.0 * SMOOTHING_HALF_WINDOW_S)
            .map(|i| speed[i])
            .reduce(f64::max);
        let Some(earlier) = earlier else { continue };
        if speed[j] - earlier <= PUSH_SPEED_GAIN_MPS {
            continue;
        }
        let span = (t[j] - PUSH_BEFORE_S, t[j] + PUSH_AFTER_S);
        match out.last_mut() {
            Some(last) if last.1 >= span.0 => last.1 = span.1,
            _ => out.push(span),
        }
    }
    out
}

/// Spans over which the velocity changed by more than [`PUSH_SPEED_GAIN_MPS`] across
/// [`STRIKE_SPAN_S`] away from the walls (see [`TrackEvents::course_changes`]).
fn course_changes(
    t: &[f64],
    pos: &[[f64; 2]],
    vel: &[[f64; 2]],
    bounds: &Bounds,
    near_m: f64,
) -> Vec<(f64, f64)> {
    let half = 0.5 * STRIKE_SPAN_S;
    let mut out: Vec<(f64, f64)> = Vec::new();
    for j in 0..t.len() {
        let (a, b) = (
            t.partition_point(|x| *x < t[j] - half),
            t.partition_point(|x| *x <= t[j] + half),
        );
        let (Some(va), Some(vb)) = (vel.get(a), b.checked_sub(1).and_then(|k| vel.get(k))) else {
            continue;
        };
        let dv = (vb[0] - va[0]).hypot(vb[1] - va[1]);
        if dv <= PUSH_SPEED_GAIN_MPS {
            continue;
        }
        // A bounce shows in the smoothed velocities this far either side of it.
        let reach =
            near_m + (half + SMOOTHING_HALF_WINDOW_S) * va[0].hypot(va[1]).max(vb[0].hypot(vb[1]));
        let p = pos[j];
        if bounds
            .walled_sides()
            .any(|(wall_m, k, dir)| (wall_m - p[k]) * dir <= reach)
        {
            continue;
        }
        let span = (t[j] - half, t[j] + half);
        match out.last_mut() {
            Some(last) if last.1 >= span.0 => last.1 = span.1,
            _ => out.push(span),
        }
    }
    out
}

/// See [`TrackEvents::stops`].
fn stops(t: &[f64], pos: &[[f64; 2]], vel: &[[f64; 2]]) -> Vec<(f64, [f64; 2])> {
    let speed = |i: usize| vel[i][0].hypot(vel[i][1]);
    let mut out = Vec::new();
    // Only a ball that moved since its last stop stops again (the noise of one at rest
    // crosses the threshold now and then).
    let mut moved = false;
    for i in 1..t.len() {
        moved |= speed(i) > STOP_MOVED_MPS;
        if !(moved && speed(i - 1) >= STOP_FROM_MPS && speed(i) < STOP_FROM_MPS) {
            continue;
        }
        let end = t.partition_point(|x| *x <= t[i] + REST_S);
        let rest = &pos[i..end];
        // The rest must be seen whole (no break in the track within it).
        let whole = end > i + 1
            && t[end - 1] - t[i] >= 0.9 * REST_S
            && t[i..end].windows(2).all(|w| w[1] - w[0] < 0.25);
        if !whole {
            continue;
        }
        let n = rest.len() as f64;
        let mean = [
            rest.iter().map(|p| p[0]).sum::<f64>() / n,
            rest.iter().map(|p| p[1]).sum::<f64>() / n,
        ];
        if rest
            .iter()
            .all(|p| (p[0] - mean[0]).hypot(p[1] - mean[1]) <= REST_SPREAD_M)
        {
            out.push((t[i], mean));
            moved = false;
        }
    }
    out
}

#[cfg(test)]
mod tests;
