//! Scoring a method's tick records against a run's ground truth, with the seed's
//! definitions: relative error η = ‖p̂ − p‖ / ‖p − p_robot‖, score s = e^(−η).
//!
//! A method is asked for its estimate at every evaluation tick ([`tick_times_s`]); its
//! answers ([`TickRecord`]) are turned into raw [`Samples`] by [`score`], samples of several
//! runs are pooled with [`Samples::merge`], and [`Summary::of`] condenses them into the
//! figures the accuracy report prints.

use crate::{BallEvent, ObsKind, SimRun};
use serde::Serialize;
use std::collections::BTreeMap;

/// Prediction horizons at which every method is scored (seconds).
pub const HORIZONS_S: [f64; 7] = [0.1, 0.2, 0.5, 0.75, 1.0, 1.5, 2.0];
/// Spacing of the evaluation ticks.
pub const TICK_S: f64 = 0.05;
/// How far ahead a predicted wall bounce is looked for.
pub const BOUNCE_LOOKAHEAD_S: f64 = 3.0;

/// Ball slower than this counts as at rest for the stop-point metric.
const MOVING_MPS: f64 = 0.05;
/// Relative errors use at least this range, so a ball touching the robot does not explode η.
const MIN_RANGE_M: f64 = 0.1;
/// True bounces up to this far ahead are scored for bounce timing.
const BOUNCE_WINDOW_S: f64 = 2.0;

/// One method's estimate at one evaluation tick (`t_s` seconds after the run's start).
#[derive(Debug, Clone, PartialEq)]
pub struct TickRecord {
    pub t_s: f64,
    pub position: [f64; 2],
    pub velocity: [f64; 2],
    /// Predicted positions at `t_s + HORIZONS_S[k]`.
    pub predicted: Vec<[f64; 2]>,
    /// Predicted stop: absolute time and point.
    pub stop: Option<(f64, [f64; 2])>,
    /// Predicted first wall bounce, absolute time.
    pub first_bounce_t_s: Option<f64>,
}

/// Number of evaluation ticks in a run of `duration_s`: the ticks are `k · TICK_S` for
/// `k = 1..=tick_count(duration_s)`.
pub fn tick_count(duration_s: f64) -> usize {
    (duration_s / TICK_S).floor() as usize
}

/// The evaluation ticks of a run of `duration_s`, seconds after its start.
pub fn tick_times_s(duration_s: f64) -> impl Iterator<Item = f64> {
    (1..=tick_count(duration_s)).map(|k| k as f64 * TICK_S)
}

/// Raw per-tick samples of one method on one or more runs; merged across seeds.
#[derive(Debug, Clone, Default, PartialEq)]
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
    /// Per run: from the arrival of the first true sighting to the first estimate (at the
    /// evaluation's tick resolution), and the runs that never had an estimate.
    pub acquisition_s: Vec<f64>,
    pub never_acquired: usize,
}

impl Samples {
    /// No samples, with one (empty) list per horizon.
    pub fn new() -> Self {
        let per_h = || vec![Vec::new(); HORIZONS_S.len()];
        Samples {
            horizon_err_m: per_h(),
            horizon_rel_err: per_h(),
            bounce_horizon_err_m: per_h(),
            ..Samples::default()
        }
    }

    /// Appends `o`'s samples to these.
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
        self.acquisition_s.extend(o.acquisition_s);
        self.never_acquired += o.never_acquired;
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

/// Scores one method's records on one run. `n_ticks_possible` is the number of ticks the
/// method was asked about (normally [`tick_count`] of the run's duration). `without_phantom`
/// is the same method's records with the phantom reports withheld: the phantom's pull is
/// measured against them (and against the truth), so that lag or noise is not mistaken for
/// the phantom's doing.
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
    let first_seen = run
        .deliveries
        .iter()
        .filter(|d| d.kind == ObsKind::Ball)
        .map(|d| run.t_of(d.arrival))
        .min_by(f64::total_cmp);
    if let Some(seen) = first_seen {
        match records.first() {
            Some(r) => s.acquisition_s.push((r.t_s - seen).max(0.0)),
            None => s.never_acquired += 1,
        }
    }
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
    let next = run.events.iter().find(|e| e.t_s() > r.t_s);
    // Stop point: only while rolling freely towards a stop no one will interrupt.
    let moving = truth.velocity_mps[0].hypot(truth.velocity_mps[1]) > MOVING_MPS;
    if moving {
        let stop_event = run
            .events
            .iter()
            .filter(|e| e.t_s() > r.t_s)
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

// The workspace's one definition of the statistics it reports.
pub use proto::stats::{mean, quantile, rms};

/// Median and 90th percentile of a list of errors, and how many there were.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Spread {
    pub median: Option<f64>,
    pub p90: Option<f64>,
    pub n: usize,
}

impl Spread {
    /// The spread of `v`.
    pub fn of(v: &[f64]) -> Self {
        Spread {
            median: quantile(v, 0.5),
            p90: quantile(v, 0.9),
            n: v.len(),
        }
    }
}

/// "0.1", "0.2", "1.0": horizon keys as the report names them.
pub fn horizon_key(h: f64) -> String {
    if h.fract() == 0.0 {
        format!("{h:.1}")
    } else {
        format!("{h}")
    }
}

/// The accuracy figures of one method, condensed from its (pooled) samples: what the
/// accuracy report prints per scenario and method.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Summary {
    /// Share of evaluation ticks at which the method had an estimate.
    pub coverage: f64,
    pub position_score: Option<f64>,
    pub position_rmse_m: Option<f64>,
    pub position_median_m: Option<f64>,
    pub velocity_rmse_mps: Option<f64>,
    pub velocity_score: Option<f64>,
    pub direction_error_deg: Option<f64>,
    pub distance_rel_error: Option<f64>,
    /// Keyed by [`horizon_key`].
    pub horizon_error_m: BTreeMap<String, Spread>,
    pub horizon_rel_error: BTreeMap<String, Spread>,
    /// Prediction errors over windows that contain a true wall bounce.
    pub bounce_horizon_error_m: BTreeMap<String, Spread>,
    pub stop_error_m: Spread,
    pub bounce_time_error_s: Spread,
    pub bounce_miss_rate: Option<f64>,
    /// Largest displacement of the estimate towards the phantom ball (phantom scenario).
    pub phantom_pull_max_m: Option<f64>,
    pub phantom_pull_p99_m: Option<f64>,
    /// From the first true sighting's arrival to the first estimate, per run.
    pub acquisition_s: Spread,
    pub acquisition_max_s: Option<f64>,
    pub never_acquired: usize,
}

impl Summary {
    /// The figures of `s`.
    pub fn of(s: &Samples) -> Self {
        let per_h = |v: &Vec<Vec<f64>>| -> BTreeMap<String, Spread> {
            HORIZONS_S
                .iter()
                .zip(v)
                .map(|(h, x)| (horizon_key(*h), Spread::of(x)))
                .collect()
        };
        let bounce_scored = s.bounce_time_err_s.len() + s.bounce_missed;
        Summary {
            coverage: if s.ticks_possible == 0 {
                0.0
            } else {
                s.ticks as f64 / s.ticks_possible as f64
            },
            position_score: mean(&s.scores),
            position_rmse_m: rms(&s.position_err_m),
            position_median_m: quantile(&s.position_err_m, 0.5),
            velocity_rmse_mps: rms(&s.velocity_err_mps),
            velocity_score: mean(&s.velocity_scores),
            direction_error_deg: mean(&s.direction_err_deg),
            distance_rel_error: mean(&s.distance_rel_err),
            horizon_error_m: per_h(&s.horizon_err_m),
            horizon_rel_error: per_h(&s.horizon_rel_err),
            bounce_horizon_error_m: per_h(&s.bounce_horizon_err_m),
            stop_error_m: Spread::of(&s.stop_err_m),
            bounce_time_error_s: Spread::of(&s.bounce_time_err_s),
            bounce_miss_rate: (bounce_scored > 0)
                .then(|| s.bounce_missed as f64 / bounce_scored as f64),
            phantom_pull_max_m: s.phantom_pull_m.iter().copied().reduce(f64::max),
            phantom_pull_p99_m: quantile(&s.phantom_pull_m, 0.99),
            acquisition_s: Spread::of(&s.acquisition_s),
            acquisition_max_s: s.acquisition_s.iter().copied().reduce(f64::max),
            never_acquired: s.never_acquired,
        }
    }

    /// Median absolute prediction error at horizon `h` seconds.
    pub fn horizon_median(&self, h: f64) -> Option<f64> {
        self.horizon_error_m
            .get(&horizon_key(h))
            .and_then(|s| s.median)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{SimConfig, run_scenario};

    /// What a method that knew the truth would answer at `t_s`.
    fn perfect(run: &SimRun, t_s: f64) -> TickRecord {
        let truth = run.truth_at(t_s);
        TickRecord {
            t_s,
            position: truth.position_m,
            velocity: truth.velocity_mps,
            predicted: HORIZONS_S
                .iter()
                .map(|h| run.truth_at(t_s + h).position_m)
                .collect(),
            stop: None,
            first_bounce_t_s: None,
        }
    }

    #[test]
    fn the_truth_scores_perfectly() {
        let cfg = SimConfig {
            duration_s: Some(3.0),
            ..SimConfig::default()
        };
        let run = run_scenario("seed-1-across", 1, &cfg).unwrap_or_else(|e| panic!("{e}"));
        let records: Vec<TickRecord> = tick_times_s(run.duration_s)
            .map(|t| perfect(&run, t))
            .collect();
        assert_eq!(records.len(), 60);
        let s = score(&run, &records, tick_count(run.duration_s), None);
        assert_eq!(s.ticks, 60);
        assert!(s.position_err_m.iter().all(|e| *e == 0.0));
        assert!(s.scores.iter().all(|x| *x == 1.0));
        assert!(s.horizon_err_m.iter().flatten().all(|e| *e == 0.0));
        let summary = Summary::of(&s);
        assert_eq!(summary.coverage, 1.0);
        assert_eq!(summary.position_score, Some(1.0));
        assert_eq!(summary.horizon_median(1.0), Some(0.0));
        assert!(summary.phantom_pull_max_m.is_none());
    }

    #[test]
    fn merging_pools_samples() {
        let mut a = Samples::new();
        a.ticks = 2;
        a.position_err_m = vec![1.0, 2.0];
        a.horizon_err_m[3] = vec![0.5];
        let mut b = Samples::new();
        b.ticks = 1;
        b.position_err_m = vec![3.0];
        b.horizon_err_m[3] = vec![0.25];
        a.merge(b);
        assert_eq!(a.ticks, 3);
        assert_eq!(a.position_err_m, vec![1.0, 2.0, 3.0]);
        assert_eq!(a.horizon_err_m[3], vec![0.5, 0.25]);
        assert_eq!(a.horizon_err_m.len(), HORIZONS_S.len());
    }

    #[test]
    fn statistics_of_small_lists() {
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(quantile(&[f64::NAN], 0.5), None);
        assert_eq!(quantile(&[3.0, 1.0, 2.0, f64::INFINITY], 0.5), Some(2.0));
        assert_eq!(quantile(&[1.0, 2.0], 0.25), Some(1.25));
        assert_eq!(mean(&[1.0, 2.0, 6.0]), Some(3.0));
        assert_eq!(rms(&[3.0, 4.0]), Some(12.5_f64.sqrt()));
        assert_eq!(mean(&[]), None);
        assert_eq!(horizon_key(1.0), "1.0");
        assert_eq!(horizon_key(0.25), "0.25");
        assert_eq!(tick_count(0.149), 2);
        let empty = Summary::of(&Samples::new());
        assert_eq!(empty.coverage, 0.0);
        assert_eq!(empty.stop_error_m.n, 0);
        assert_eq!(empty.bounce_miss_rate, None);
    }
}
