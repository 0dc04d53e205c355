//! Scoring a method's tick records against the simulator's ground truth, with the seed's
//! definitions: relative error η = ‖p̂ − p‖ / ‖p − p_robot‖, score s = e^(−η).

use crate::methods::{HORIZONS_S, TickRecord};
use sim::{BallEvent, SimRun};

/// Ball slower than this counts as at rest for the stop-point metric.
const MOVING_MPS: f64 = 0.05;
/// Relative errors use at least this range, so a ball touching the robot does not explode η.
const MIN_RANGE_M: f64 = 0.1;
/// True bounces up to this far ahead are scored for bounce timing.
const BOUNCE_WINDOW_S: f64 = 2.0;

/// Raw per-tick samples of one method on one or more runs; merged across seeds.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    pub ticks: usize,
    pub ticks_possible: usize,
    pub scores: Vec<f64>,
    pub position_err_m: Vec<f64>,
    pub velocity_err_mps: Vec<f64>,
    pub velocity_scores: Vec<f64>,
    pub direction_err_deg: Vec<f64>,
    pub distance_rel_err: Vec<f64>,
    /// Per horizon: absolute and relative errors.
    pub horizon_err_m: Vec<Vec<f64>>,
    pub horizon_rel_err: Vec<Vec<f64>>,
    /// Per horizon: absolute errors of predictions whose window holds a true wall bounce.
    pub bounce_horizon_err_m: Vec<Vec<f64>>,
    pub stop_err_m: Vec<f64>,
    pub bounce_time_err_s: Vec<f64>,
    pub bounce_missed: usize,
    /// Signed displacement of the estimate towards the phantom, per tick (phantom runs).
    pub phantom_pull_m: Vec<f64>,
}

impl Samples {
    pub fn new() -> Self {
        let per_h = || vec![Vec::new(); HORIZONS_S.len()];
        Samples {
            horizon_err_m: per_h(),
            horizon_rel_err: per_h(),
            bounce_horizon_err_m: per_h(),
            ..Samples::default()
        }
    }

    pub fn merge(&mut self, o: Samples) {
        self.ticks += o.ticks;
        self.ticks_possible += o.ticks_possible;
        self.scores.extend(o.scores);
        self.position_err_m.extend(o.position_err_m);
        self.velocity_err_mps.extend(o.velocity_err_mps);
        self.velocity_scores.extend(o.velocity_scores);
        self.direction_err_deg.extend(o.direction_err_deg);
        self.distance_rel_err.extend(o.distance_rel_err);
        for (k, v) in o.horizon_err_m.into_iter().enumerate() {
            self.horizon_err_m[k].extend(v);
        }
        for (k, v) in o.horizon_rel_err.into_iter().enumerate() {
            self.horizon_rel_err[k].extend(v);
        }
        for (k, v) in o.bounce_horizon_err_m.into_iter().enumerate() {
            self.bounce_horizon_err_m[k].extend(v);
        }
        self.stop_err_m.extend(o.stop_err_m);
        self.bounce_time_err_s.extend(o.bounce_time_err_s);
        self.bounce_missed += o.bounce_missed;
        self.phantom_pull_m.extend(o.phantom_pull_m);
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The robot whose range normalises the relative error: the single observer in the seed's
/// scenarios, the observer nearest the ball in team scenarios.
fn reference_robot(run: &SimRun, t_s: f64, ball: [f64; 2]) -> Option<[f64; 2]> {
    run.robots
        .iter()
        .filter(|r| r.observer)
        .map(|r| {
            let p = r.pose_at(t_s);
            [p.x_m, p.y_m]
        })
        .min_by(|a, b| dist(*a, ball).total_cmp(&dist(*b, ball)))
}

/// An external push (kick or robot contact) in (t0, t1]: no motion model can foresee it.
fn pushed_between(run: &SimRun, t0: f64, t1: f64) -> bool {
    run.events.iter().any(|e| match e {
        BallEvent::Kick { t_s, .. } | BallEvent::RobotContact { t_s, .. } => {
            *t_s > t0 && *t_s <= t1
        }
        _ => false,
    })
}

fn event_time(e: &BallEvent) -> f64 {
    match e {
        BallEvent::Kick { t_s, .. }
        | BallEvent::WallBounce { t_s, .. }
        | BallEvent::RobotContact { t_s, .. }
        | BallEvent::Stopped { t_s, .. } => *t_s,
    }
}

/// Scores one method's records on one run. `without_phantom` is the same method's records
/// with the phantom reports withheld: the phantom's pull is measured against them (and
/// against the truth), so that lag or noise is not mistaken for the phantom's doing.
pub fn score(
    run: &SimRun,
    records: &[TickRecord],
    n_ticks_possible: usize,
    without_phantom: Option<&[TickRecord]>,
) -> Samples {
    let mut s = Samples::new();
    s.ticks = records.len();
    s.ticks_possible = n_ticks_possible;
    let phantom = run.phantom.as_ref().map(|(_, spot)| *spot);
    for r in records {
        let truth = run.truth_at(r.t_s);
        let p = truth.position_m;
        let err = dist(r.position, p);
        s.position_err_m.push(err);
        if let Some(robot) = reference_robot(run, r.t_s, p) {
            let range = dist(p, robot).max(MIN_RANGE_M);
            s.scores.push((-err / range).exp());
            let est_range = dist(r.position, robot);
            s.distance_rel_err.push((est_range / range - 1.0).abs());
            let a_true = (p[1] - robot[1]).atan2(p[0] - robot[0]);
            let a_est = (r.position[1] - robot[1]).atan2(r.position[0] - robot[0]);
            let mut d = (a_est - a_true).to_degrees().abs() % 360.0;
            if d > 180.0 {
                d = 360.0 - d;
            }
            s.direction_err_deg.push(d);
        }
        let v = truth.velocity_mps;
        let verr = dist(r.velocity, v);
        s.velocity_err_mps.push(verr);
        s.velocity_scores
            .push((-verr / (v[0].hypot(v[1]) + 1.0)).exp());
        for (k, h) in HORIZONS_S.iter().enumerate() {
            let t_f = r.t_s + h;
            if t_f > run.duration_s || pushed_between(run, r.t_s, t_f) {
                continue;
            }
            let future = run.truth_at(t_f).position_m;
            let e = dist(r.predicted[k], future);
            s.horizon_err_m[k].push(e);
            if let Some(robot) = reference_robot(run, t_f, future) {
                s.horizon_rel_err[k].push(e / dist(future, robot).max(MIN_RANGE_M));
            }
            let bounced = run.events.iter().any(
                |ev| matches!(ev, BallEvent::WallBounce { t_s, .. } if *t_s > r.t_s && *t_s <= t_f),
            );
            if bounced {
                s.bounce_horizon_err_m[k].push(e);
            }
        }
        score_stop_and_bounce(run, r, &mut s);
        let reference = without_phantom.and_then(|recs| recs.iter().find(|q| q.t_s == r.t_s));
        if let (Some(spot), Some(q)) = (phantom, reference) {
            // Displacement towards the phantom compared with where the estimate would be
            // without it, and compared with the truth: both, so that a kick followed a frame
            // earlier or later in one run than the other is not mistaken for the phantom.
            let towards = |from: [f64; 2]| {
                let d = [spot[0] - from[0], spot[1] - from[1]];
                let n = d[0].hypot(d[1]).max(1e-9);
                (r.position[0] - from[0]) * d[0] / n + (r.position[1] - from[1]) * d[1] / n
            };
            s.phantom_pull_m.push(towards(q.position).min(towards(p)));
        }
    }
    s
}

fn score_stop_and_bounce(run: &SimRun, r: &TickRecord, s: &mut Samples) {
    let truth = run.truth_at(r.t_s);
    let next = run.events.iter().find(|e| event_time(e) > r.t_s);
    // Stop point: only while rolling freely towards a stop no one will interrupt.
    let moving = truth.velocity_mps[0].hypot(truth.velocity_mps[1]) > MOVING_MPS;
    if moving {
        let stop_event = run
            .events
            .iter()
            .filter(|e| event_time(e) > r.t_s)
            .find(|e| !matches!(e, BallEvent::WallBounce { .. }));
        if let (Some(BallEvent::Stopped { position_m, .. }), Some((_, predicted))) =
            (stop_event, r.stop)
        {
            s.stop_err_m.push(dist(*position_m, predicted));
        }
    }
    // Bounce timing: the next event is a wall bounce within the window.
    if let Some(BallEvent::WallBounce { t_s, .. }) = next
        && *t_s - r.t_s <= BOUNCE_WINDOW_S
    {
        match r.first_bounce_t_s {
            Some(pred) => s.bounce_time_err_s.push((pred - t_s).abs()),
            None => s.bounce_missed += 1,
        }
    }
}

pub fn quantile(v: &[f64], q: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return None;
    }
    s.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    Some(s[lo] + (s[hi] - s[lo]) * (pos - lo as f64))
}

pub fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

pub fn rms(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
}
