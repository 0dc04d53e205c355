//! The tracks evaluation: a recorded ball track is observed by simulated robots
//! ([`crate::track_obs`]), the observations are fed in arrival order to each method, each
//! method is asked for its state every [`TICK_S`], and its answers are scored against the
//! track itself ([`score_ticks`]).
//!
//! The methods: the fusion core as the server runs it; the same core with learning off
//! (the default deceleration and restitution, fixed); and the seed's constant-velocity
//! filter ([`crate::baseline`]).

use crate::baseline::SeedBaseline;
use crate::line_fit::LineFit;
use crate::methods::{baseline_record, drive_ticks};
use crate::scenarios::for_each;
use crate::track_events::TrackEvents;
use crate::track_obs::{ObserverSetup, capture_times_s, observe};
use fusion_server::fly;
use fusion_server::{Bounds, Fusion, FusionConfig, FusionCounters, MotionEventKind, MotionModel};
use fusion_server::{Engine, EngineConfig};
use proto::{BallStatus, ModelParams, Pitch, Prediction, Stamp, WallSide};
use serde::Serialize;
use sim::Delivery;
use sim::{HORIZONS_S, TickRecord};
use tools::tracks::Track;

/// Spacing of the evaluation ticks (50 Hz).
pub const TICK_S: f64 = 0.02;
/// A state is scored for bounce timing when the track's next bounce is this close ahead.
pub const BOUNCE_WINDOW_S: f64 = 1.0;
/// The track moves faster than this (over the last [`RECENT_S`]): a `stopped` state is wrong.
pub const MOVING_MPS: f64 = 0.1;
pub const RECENT_S: f64 = 0.05;

/// A method the tracks evaluation compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum TrackMethod {
    Fusion,
    FixedPhysics,
    ConstantVelocity,
    /// A straight line fitted to the last quarter second of observations
    /// ([`crate::line_fit`]), its path reflected at the walls with the pitch's restitution
    /// and no friction: the simplest physics a reader could bolt onto constant velocity.
    ConstantVelocityReflected,
}

impl TrackMethod {
    pub const ALL: [TrackMethod; 4] = [
        TrackMethod::Fusion,
        TrackMethod::FixedPhysics,
        TrackMethod::ConstantVelocity,
        TrackMethod::ConstantVelocityReflected,
    ];

    pub fn name(self) -> &'static str {
        match self {
            TrackMethod::Fusion => "fusion",
            TrackMethod::FixedPhysics => "fixed-physics",
            TrackMethod::ConstantVelocity => "constant-velocity",
            TrackMethod::ConstantVelocityReflected => "cv-reflected",
        }
    }

    /// Whether the method predicts where the ball stops (and so is scored on it).
    pub fn predicts_stops(self) -> bool {
        matches!(self, TrackMethod::Fusion | TrackMethod::FixedPhysics)
    }

    /// Whether the method tells bounces and kicks (and so is scored on them).
    pub fn infers_events(self) -> bool {
        matches!(self, TrackMethod::Fusion | TrackMethod::FixedPhysics)
    }

    /// Whether the method predicts wall bounces (and so is scored on their timing).
    pub fn predicts_bounces(self) -> bool {
        self != TrackMethod::ConstantVelocity
    }
}

/// A core's bounce or kick within this of a track's bounce is about it; a bounce with a
/// push this close is not a clear one.
pub const EVENT_MATCH_S: f64 = 0.2;

/// A stop is scored from states at least this far from it.
pub const STOP_MIN_TO_GO_M: f64 = 0.3;

/// Two of the core's events of one kind this close are one, found again.
const SAME_EVENT_S: f64 = 0.05;

/// Within this of the track, a state has found a relocated ball.
pub const RELOCATION_FOUND_M: f64 = 0.3;

/// Where the tracks are and how they are observed.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackSetup {
    pub pitch: Pitch,
    pub observers: ObserverSetup,
}

/// The fusion core's configuration for a method: defaults on the pitch; learning off for
/// the fixed-physics method (so the default deceleration and restitution stay).
pub fn fusion_config(pitch: &Pitch, method: TrackMethod) -> FusionConfig {
    let mut cfg = FusionConfig {
        pitch: pitch.clone(),
        ..FusionConfig::default()
    };
    if method == TrackMethod::FixedPhysics {
        cfg.tracker.learn_decel = false;
        cfg.tracker.learn_restitution = false;
    }
    cfg
}

/// One method's answer at one tick.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackTick {
    pub record: TickRecord,
    /// The fused state's status (fusion methods only).
    pub status: Option<BallStatus>,
    /// The motion parameters in use (fusion methods only).
    pub model: Option<ModelParams>,
    /// The predicted wall bounces: absolute time and wall (fusion methods only).
    pub bounces: Vec<(f64, WallSide)>,
    /// The core's last bounces and inferred kicks, at track time (fusion methods only).
    pub motion_events: Vec<(f64, MotionEventKind)>,
    /// The served covariance of each predicted position (row-major 2×2, m²) and of the
    /// stop, where the method serves one.
    pub predicted_cov: Vec<Option<[f64; 4]>>,
    pub stop_cov: Option<[f64; 4]>,
}

/// The position on a predicted path `t_s` after its stamp, interpolated between samples.
fn path_at(p: &Prediction, t_s: f64) -> Option<[f64; 2]> {
    let i = p.samples.partition_point(|s| s.t_s <= t_s);
    if i == 0 {
        return p.samples.first().map(|s| s.position_m);
    }
    if i >= p.samples.len() {
        return p.samples.last().map(|s| s.position_m);
    }
    let (a, b) = (p.samples[i - 1], p.samples[i]);
    let f = (t_s - a.t_s) / (b.t_s - a.t_s);
    Some([
        a.position_m[0] + f * (b.position_m[0] - a.position_m[0]),
        a.position_m[1] + f * (b.position_m[1] - a.position_m[1]),
    ])
}

/// The covariance on a predicted path `t_s` after its stamp, interpolated between samples
/// (a mixture of two covariances is one too).
fn cov_at(p: &Prediction, t_s: f64) -> Option<[f64; 4]> {
    let i = p.samples.partition_point(|s| s.t_s <= t_s);
    if i == 0 || i >= p.samples.len() {
        let s = if i == 0 {
            p.samples.first()
        } else {
            p.samples.last()
        };
        return s.and_then(|s| s.covariance_m2);
    }
    let (a, b) = (p.samples[i - 1], p.samples[i]);
    let (ca, cb) = (a.covariance_m2?, b.covariance_m2?);
    let f = (t_s - a.t_s) / (b.t_s - a.t_s);
    Some(std::array::from_fn(|k| ca[k] + f * (cb[k] - ca[k])))
}

/// The squared Mahalanobis distance of `err` under `cov` (infinite for a covariance that is
/// not positive definite), and the 2σ radius: twice the square root of the larger
/// eigenvalue.
pub fn mahalanobis(err: [f64; 2], cov: [f64; 4]) -> (f64, f64) {
    let (a, b, d) = (cov[0], 0.5 * (cov[1] + cov[2]), cov[3]);
    let det = a * d - b * b;
    let half_trace = 0.5 * (a + d);
    let lambda_max = half_trace + (half_trace * half_trace - det).max(0.0).sqrt();
    let radius = 2.0 * lambda_max.max(0.0).sqrt();
    if a <= 0.0 || det <= 0.0 {
        return (f64::INFINITY, radius);
    }
    let d2 = (d * err[0] * err[0] - 2.0 * b * err[0] * err[1] + a * err[1] * err[1]) / det;
    (d2, radius)
}

/// The fused state at `at` as the server would publish it, as a tick record.
fn fusion_tick(f: &Fusion, at: Stamp, t_s: f64) -> Option<TrackTick> {
    let state = f.ball_state(at)?;
    // The state refers to its own stamp (never earlier than `at`).
    let lead_s = state.stamp.secs_since(at);
    let predicted = HORIZONS_S
        .iter()
        .map(|h| path_at(&state.prediction, h - lead_s))
        .collect::<Option<Vec<_>>>()?;
    let first_bounce_t_s = state
        .prediction
        .bounces
        .first()
        .map(|b| t_s + lead_s + b.t_s);
    let stop = state
        .prediction
        .stop
        .map(|s| (t_s + lead_s + s.t_s, s.position_m));
    let predicted_cov = HORIZONS_S
        .iter()
        .map(|h| cov_at(&state.prediction, h - lead_s))
        .collect();
    let stop_cov = state.prediction.stop.and_then(|s| s.covariance_m2);
    Some(TrackTick {
        record: TickRecord {
            t_s,
            position: state.position_m,
            velocity: state.velocity_mps,
            predicted,
            stop,
            first_bounce_t_s,
        },
        status: Some(state.status),
        model: Some(state.model),
        bounces: state
            .prediction
            .bounces
            .iter()
            .map(|b| (t_s + lead_s + b.t_s, b.wall))
            .collect(),
        motion_events: f
            .motion_events()
            .map(|(at_e, kind)| (t_s + at_e.secs_since(at), kind))
            .collect(),
        predicted_cov,
        stop_cov,
    })
}

/// One method's answers over a track, and the core's counters (fusion methods).
#[derive(Debug, Clone, PartialEq)]
pub struct MethodRun {
    pub ticks: Vec<TrackTick>,
    pub counters: Option<FusionCounters>,
}

/// Runs `method` over `deliveries`, asking at `ticks_s` (seconds after `start`).
pub fn run_method(
    method: TrackMethod,
    pitch: &Pitch,
    deliveries: &[Delivery],
    start: Stamp,
    ticks_s: &[f64],
) -> MethodRun {
    let all = |_: &Delivery| true;
    let ticks = ticks_s.iter().copied();
    match method {
        TrackMethod::Fusion | TrackMethod::FixedPhysics => {
            // Through the server's engine, as `replay` feeds it: its checks, and the clock
            // correction a skewed robot gets.
            let mut engine = Engine::new(EngineConfig {
                fusion: fusion_config(pitch, method),
                ..EngineConfig::default()
            });
            let ticks = drive_ticks(
                deliveries,
                start,
                ticks,
                all,
                &mut engine,
                |e, d| {
                    let _ = e.observation_decoded(None, d.obs.clone(), d.arrival);
                },
                |e, t_s| fusion_tick(e.fusion(), start.offset_secs(t_s), t_s),
            );
            MethodRun {
                ticks,
                counters: Some(engine.fusion().counters()),
            }
        }
        TrackMethod::ConstantVelocity => {
            let mut baseline = SeedBaseline::default();
            let ticks = drive_ticks(
                deliveries,
                start,
                ticks,
                all,
                &mut baseline,
                |b, d| b.ingest(d.arrival, &d.obs),
                |b, t_s| {
                    Some(TrackTick {
                        record: baseline_record(b, start.offset_secs(t_s), t_s)?,
                        status: None,
                        model: None,
                        bounces: Vec::new(),
                        motion_events: Vec::new(),
                        predicted_cov: Vec::new(),
                        stop_cov: None,
                    })
                },
            );
            MethodRun {
                ticks,
                counters: None,
            }
        }
        TrackMethod::ConstantVelocityReflected => {
            let model = MotionModel {
                decel_mps2: 0.0,
                restitution: pitch.wall_restitution,
                tangential_retention: 1.0,
                ..MotionModel::default()
            };
            let bounds = Bounds::from_pitch(pitch);
            let mut line = LineFit::default();
            let ticks = drive_ticks(
                deliveries,
                start,
                ticks,
                all,
                &mut line,
                |l, d| l.ingest(&d.obs),
                |l, t_s| {
                    let (position, velocity) = l.at(start.offset_secs(t_s))?;
                    let position = inside(position, &bounds);
                    let mut bounces = Vec::new();
                    let mut predicted = Vec::new();
                    for (k, h) in HORIZONS_S.iter().enumerate() {
                        let f = fly(position, velocity, *h, &model, &bounds);
                        predicted.push(f.position);
                        if k + 1 == HORIZONS_S.len() {
                            bounces = f.hits().map(|b| (t_s + b.t_s, b.wall)).collect();
                        }
                    }
                    let record = TickRecord {
                        t_s,
                        position,
                        velocity,
                        predicted,
                        stop: None,
                        first_bounce_t_s: bounces.first().map(|b| b.0),
                    };
                    Some(TrackTick {
                        record,
                        status: None,
                        model: None,
                        bounces,
                        motion_events: Vec::new(),
                        predicted_cov: Vec::new(),
                        stop_cov: None,
                    })
                },
            );
            MethodRun {
                ticks,
                counters: None,
            }
        }
    }
}

/// `p` moved inside the walls' bounds.
fn inside(p: [f64; 2], b: &Bounds) -> [f64; 2] {
    [p[0].clamp(b.x_min, b.x_max), p[1].clamp(b.y_min, b.y_max)]
}

/// Raw samples of one method on one or more tracks; merged across tracks and seeds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrackSamples {
    pub ticks: usize,
    pub ticks_possible: usize,
    pub now_err_m: Vec<f64>,
    /// Per horizon of [`HORIZONS_S`]: errors where the track covers t + h ...
    pub horizon_err_m: Vec<Vec<f64>>,
    /// ... and the windows left out because something pushed the ball within them.
    pub pushed_windows: Vec<usize>,
    pub bounce_time_err_s: Vec<f64>,
    pub bounce_missed: usize,
    /// States while the track moved faster than [`MOVING_MPS`], and those of them `stopped`.
    pub moving_states: usize,
    pub stopped_while_moving: usize,
    /// Per push of a ball the method had `stopped`: seconds from the track first moving
    /// faster than [`MOVING_MPS`] to the method's first state that is not `stopped`.
    pub onset_lag_s: Vec<f64>,
    /// Per track: seconds from its start to the method's first estimate.
    pub first_estimate_s: Vec<f64>,
    /// Per track: the motion parameters at its end.
    pub final_model: Vec<ModelParams>,
    pub observations_applied: u64,
    pub outside_walls: u64,
    /// Per relocation (a ball reappearing after a break): seconds from the first capture
    /// of it to the first state within [`RELOCATION_FOUND_M`] of it...
    pub relocation_found_s: Vec<f64>,
    /// ... and the relocations no state came within that of before the next break.
    pub relocations_not_found: usize,
    /// The track's wall bounces with no course change within [`EVENT_MATCH_S`] (fusion methods),
    /// those the core went through as bounces, and those it took for kicks.
    pub clear_bounces: usize,
    pub bounces_recognised: usize,
    pub bounces_taken_for_kicks: usize,
    /// Kicks the core inferred, those with neither a course change nor a bounce of the
    /// track near, and its bounces (fusion methods).
    pub kicks_inferred: usize,
    pub kicks_unprompted: usize,
    pub bounces_seen: usize,
    /// States of a moving ball whose next stop is at least [`STOP_MIN_TO_GO_M`] away with
    /// nothing changing its course before: how far the predicted stop is from it, and that
    /// over the distance still to go.
    pub stop_err_m: Vec<f64>,
    pub stop_rel_err: Vec<f64>,
    /// ... and those states that predicted no stop.
    pub stop_not_predicted: usize,
    /// Errors per phase ([`Phase`]) and horizon of [`HORIZONS_S`].
    pub phase_err_m: [Vec<Vec<f64>>; 3],
    /// Per horizon of [`HORIZONS_S`], where the method serves a covariance: each state's
    /// (squared Mahalanobis distance of the true position, 2σ radius in metres) ...
    pub horizon_d2: Vec<Vec<(f64, f64)>>,
    /// ... the same per phase ([`Phase`]) and horizon ...
    pub phase_d2: [Vec<Vec<(f64, f64)>>; 3],
    /// ... and of the true stop, for the states the stop error is scored at.
    pub stop_d2: Vec<(f64, f64)>,
}

/// The horizon the phases are scored at.
pub const PHASE_HORIZON_S: f64 = 2.0;
/// A state this soon after a push is in its first moments.
pub const AFTER_PUSH_S: f64 = 0.5;

/// What a state's window holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Within [`AFTER_PUSH_S`] of a push's end: the kick's speed still being learned.
    AfterPush = 0,
    /// A wall bounce within the window.
    AcrossBounce = 1,
    /// Neither: the ball rolls (or slides) freely, perhaps to a stop.
    Free = 2,
}

impl Phase {
    pub const ALL: [Phase; 3] = [Phase::AfterPush, Phase::AcrossBounce, Phase::Free];

    pub fn name(self) -> &'static str {
        match self {
            Phase::AfterPush => "first 0.5 s after a push",
            Phase::AcrossBounce => "across a wall bounce",
            Phase::Free => "no bounce ahead",
        }
    }
}

impl TrackSamples {
    pub fn new() -> Self {
        TrackSamples {
            horizon_err_m: vec![Vec::new(); HORIZONS_S.len()],
            pushed_windows: vec![0; HORIZONS_S.len()],
            horizon_d2: vec![Vec::new(); HORIZONS_S.len()],
            phase_err_m: std::array::from_fn(|_| vec![Vec::new(); HORIZONS_S.len()]),
            phase_d2: std::array::from_fn(|_| vec![Vec::new(); HORIZONS_S.len()]),
            ..TrackSamples::default()
        }
    }

    pub fn merge(&mut self, o: &TrackSamples) {
        self.ticks += o.ticks;
        self.ticks_possible += o.ticks_possible;
        self.now_err_m.extend(&o.now_err_m);
        for k in 0..HORIZONS_S.len() {
            self.horizon_err_m[k].extend(&o.horizon_err_m[k]);
            self.pushed_windows[k] += o.pushed_windows[k];
        }
        self.bounce_time_err_s.extend(&o.bounce_time_err_s);
        self.bounce_missed += o.bounce_missed;
        self.moving_states += o.moving_states;
        self.stopped_while_moving += o.stopped_while_moving;
        self.onset_lag_s.extend(&o.onset_lag_s);
        self.first_estimate_s.extend(&o.first_estimate_s);
        self.final_model.extend(&o.final_model);
        self.observations_applied += o.observations_applied;
        self.outside_walls += o.outside_walls;
        self.relocation_found_s.extend(&o.relocation_found_s);
        self.relocations_not_found += o.relocations_not_found;
        self.clear_bounces += o.clear_bounces;
        self.bounces_recognised += o.bounces_recognised;
        self.bounces_taken_for_kicks += o.bounces_taken_for_kicks;
        self.kicks_inferred += o.kicks_inferred;
        self.kicks_unprompted += o.kicks_unprompted;
        self.bounces_seen += o.bounces_seen;
        self.stop_err_m.extend(&o.stop_err_m);
        self.stop_rel_err.extend(&o.stop_rel_err);
        self.stop_not_predicted += o.stop_not_predicted;
        for k in 0..HORIZONS_S.len() {
            self.horizon_d2[k].extend(&o.horizon_d2[k]);
            for p in 0..3 {
                self.phase_err_m[p][k].extend(&o.phase_err_m[p][k]);
                self.phase_d2[p][k].extend(&o.phase_d2[p][k]);
            }
        }
        self.stop_d2.extend(&o.stop_d2);
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Per relocation of `track`: seconds from the first capture at or after it (`captures_s`
/// sorted, track time) to the first state within [`RELOCATION_FOUND_M`] of the track, or
/// `None` when no state was before the ball's next break or the track's end.
pub fn relocation_delays(
    track: &Track,
    captures_s: &[f64],
    ticks: &[TrackTick],
) -> Vec<Option<f64>> {
    let relocations = track.relocations_s();
    let mut out = Vec::new();
    for (k, t_r) in relocations.iter().enumerate() {
        let until = relocations.get(k + 1).copied().unwrap_or(f64::INFINITY);
        let Some(seen) = captures_s.get(captures_s.partition_point(|t| t < t_r)) else {
            continue;
        };
        if *seen >= until {
            continue;
        }
        let found = ticks
            .iter()
            .filter(|t| t.record.t_s >= *seen && t.record.t_s < until)
            .find(|t| {
                track
                    .position_at(t.record.t_s)
                    .is_some_and(|p| dist(p, t.record.position) <= RELOCATION_FOUND_M)
            });
        out.push(found.map(|t| t.record.t_s - seen));
    }
    out
}

/// Scores one method's answers against the track.
pub fn score_ticks(
    track: &Track,
    events: &TrackEvents,
    method: TrackMethod,
    run: &MethodRun,
    ticks_possible: usize,
    captures_s: &[f64],
) -> TrackSamples {
    let mut s = TrackSamples::new();
    s.ticks = run.ticks.len();
    s.ticks_possible = ticks_possible;
    for tick in &run.ticks {
        let r = &tick.record;
        let Some(now) = track.position_at(r.t_s) else {
            continue;
        };
        s.now_err_m.push(dist(r.position, now));
        for (k, h) in HORIZONS_S.iter().enumerate() {
            let t_f = r.t_s + h;
            let Some(future) = track.position_at(t_f) else {
                continue;
            };
            if events.course_changed_between(r.t_s, t_f) {
                s.pushed_windows[k] += 1;
                continue;
            }
            let err = dist(r.predicted[k], future);
            s.horizon_err_m[k].push(err);
            let after_push = events
                .pushes
                .iter()
                .any(|(a, b)| *a <= r.t_s && r.t_s - b <= AFTER_PUSH_S);
            let phase = if after_push {
                Phase::AfterPush
            } else if events.bounces.iter().any(|b| b.t_s > r.t_s && b.t_s <= t_f) {
                Phase::AcrossBounce
            } else {
                Phase::Free
            };
            s.phase_err_m[phase as usize][k].push(err);
            if let Some(Some(cov)) = tick.predicted_cov.get(k) {
                let e = [future[0] - r.predicted[k][0], future[1] - r.predicted[k][1]];
                let m = mahalanobis(e, *cov);
                s.horizon_d2[k].push(m);
                s.phase_d2[phase as usize][k].push(m);
            }
        }
        if method.predicts_bounces()
            && let Some(b) = events.next_bounce(r.t_s)
            && b.t_s - r.t_s <= BOUNCE_WINDOW_S
            && !events.course_changed_between(r.t_s, b.t_s)
        {
            // The first predicted bounce off the same wall: a bounce the track's detection
            // missed (too glancing) must not be taken for this one.
            match tick.bounces.iter().find(|(_, wall)| *wall == b.wall) {
                Some((predicted, _)) => s.bounce_time_err_s.push((predicted - b.t_s).abs()),
                None => s.bounce_missed += 1,
            }
        }
        if method.predicts_stops()
            && recent_speed(track, r.t_s).is_some_and(|v| v > MOVING_MPS)
            && let Some((t_stop, p_stop)) = events.next_stop(r.t_s)
            && !events.course_changed_between(r.t_s, t_stop)
            && dist(now, p_stop) >= STOP_MIN_TO_GO_M
        {
            match r.stop {
                Some((_, predicted)) => {
                    let err = dist(predicted, p_stop);
                    s.stop_err_m.push(err);
                    s.stop_rel_err.push(err / dist(now, p_stop));
                    if let Some(cov) = tick.stop_cov {
                        let e = [p_stop[0] - predicted[0], p_stop[1] - predicted[1]];
                        s.stop_d2.push(mahalanobis(e, cov));
                    }
                }
                None => s.stop_not_predicted += 1,
            }
        }
        if let Some(status) = tick.status
            && recent_speed(track, r.t_s).is_some_and(|v| v > MOVING_MPS)
        {
            s.moving_states += 1;
            if status == BallStatus::Stopped {
                s.stopped_while_moving += 1;
            }
        }
    }
    s.onset_lag_s = onset_lags(track, events, &run.ticks);
    if method.infers_events() {
        score_motion_events(events, &run.ticks, &mut s);
    }
    for d in relocation_delays(track, captures_s, &run.ticks) {
        match d {
            Some(d) => s.relocation_found_s.push(d),
            None => s.relocations_not_found += 1,
        }
    }
    if let Some(first) = run.ticks.first() {
        s.first_estimate_s.push(first.record.t_s - track.start_s());
    }
    s.final_model.extend(run.ticks.last().and_then(|t| t.model));
    if let Some(c) = run.counters {
        s.observations_applied = c.applied;
        s.outside_walls = c.outside_walls;
    }
    s
}

/// The core's bounces and kicks over the track (each once, though many ticks list it),
/// matched to the track's bounces.
fn score_motion_events(events: &TrackEvents, ticks: &[TrackTick], s: &mut TrackSamples) {
    // The same event read at two ticks may differ: a late observation makes the core run
    // again from before it, and find the kick a sighting earlier or later.
    let mut seen: Vec<(f64, MotionEventKind)> = Vec::new();
    for e in ticks.iter().flat_map(|t| &t.motion_events) {
        if !seen
            .iter()
            .any(|x| x.1 == e.1 && (x.0 - e.0).abs() < SAME_EVENT_S)
        {
            seen.push(*e);
        }
    }
    let near = |kind: MotionEventKind, t_s: f64| {
        seen.iter()
            .any(|e| e.1 == kind && (e.0 - t_s).abs() <= EVENT_MATCH_S)
    };
    s.kicks_inferred = seen.iter().filter(|e| e.1 == MotionEventKind::Kick).count();
    s.bounces_seen = seen.len() - s.kicks_inferred;
    s.kicks_unprompted = seen
        .iter()
        .filter(|e| {
            e.1 == MotionEventKind::Kick
                && !events.course_changed_between(e.0 - EVENT_MATCH_S, e.0 + EVENT_MATCH_S)
                && !events
                    .bounces
                    .iter()
                    .any(|b| (b.t_s - e.0).abs() <= EVENT_MATCH_S)
        })
        .count();
    for b in &events.bounces {
        if events.course_changed_between(b.t_s - EVENT_MATCH_S, b.t_s + EVENT_MATCH_S) {
            continue;
        }
        s.clear_bounces += 1;
        let kicked = near(MotionEventKind::Kick, b.t_s);
        if kicked {
            s.bounces_taken_for_kicks += 1;
        } else if near(MotionEventKind::Bounce, b.t_s) {
            s.bounces_recognised += 1;
        }
    }
}

/// The track's speed over the last [`RECENT_S`] before `t_s`: causal, so that a kick does
/// not show as motion before it happens (a centred smoothing would).
fn recent_speed(track: &Track, t_s: f64) -> Option<f64> {
    let (now, then) = (track.position_at(t_s)?, track.position_at(t_s - RECENT_S)?);
    Some(dist(now, then) / RECENT_S)
}

/// For every push of a ball whose last state before it was `stopped`: from the track's
/// first tick faster than [`MOVING_MPS`] to the first state that is not `stopped`.
fn onset_lags(track: &Track, events: &TrackEvents, ticks: &[TrackTick]) -> Vec<f64> {
    let mut out = Vec::new();
    for (from, _) in &events.pushes {
        let i = ticks.partition_point(|t| t.record.t_s < *from);
        let Some(before) = i.checked_sub(1).and_then(|k| ticks.get(k)) else {
            continue;
        };
        if before.status != Some(BallStatus::Stopped) {
            continue;
        }
        let moving =
            |t: &&TrackTick| recent_speed(track, t.record.t_s).is_some_and(|v| v > MOVING_MPS);
        let Some(on) = ticks[i..].iter().find(moving) else {
            continue;
        };
        let t_on = on.record.t_s;
        if let Some(seen) = ticks[i..]
            .iter()
            .find(|t| t.record.t_s >= t_on && t.status.is_some_and(|s| s != BallStatus::Stopped))
        {
            out.push(seen.record.t_s - t_on);
        }
    }
    out
}

/// One track and observation seed, scored for every method.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackRun {
    pub track: String,
    pub seed: u64,
    pub duration_s: f64,
    pub bounces: usize,
    pub pushes: usize,
    pub observations: usize,
    /// Track samples outside the pitch (a wrong `--pitch` or `--origin` shows here).
    pub samples_outside: usize,
    pub methods: Vec<(TrackMethod, TrackSamples)>,
}

/// The ticks of a track: every [`TICK_S`] after its start, up to its end.
pub fn tick_times_s(track: &Track) -> Vec<f64> {
    let n = (track.duration_s() / TICK_S + 1e-9).floor() as usize;
    (1..=n)
        .map(|k| track.start_s() + k as f64 * TICK_S)
        .filter(|t| track.covers(*t))
        .collect()
}

/// Observes `track` with `seed` and scores every method on it.
pub fn evaluate_track(track: &Track, setup: &TrackSetup, seed: u64) -> TrackRun {
    let start = sim::SimConfig::default().start;
    let deliveries = observe(track, &setup.pitch, &setup.observers, seed, start);
    let bounds = Bounds::from_pitch(&setup.pitch);
    let events = TrackEvents::of(track, &bounds, setup.pitch.ball_radius_m);
    let ticks = tick_times_s(track);
    let captures_s = capture_times_s(&deliveries, &setup.observers, start);
    let methods = TrackMethod::ALL
        .iter()
        .map(|m| {
            let run = run_method(*m, &setup.pitch, &deliveries, start, &ticks);
            let s = score_ticks(track, &events, *m, &run, ticks.len(), &captures_s);
            (*m, s)
        })
        .collect();
    TrackRun {
        track: track.name.clone(),
        seed,
        duration_s: track.duration_s(),
        bounces: events.bounces.len(),
        pushes: events.pushes.len(),
        observations: deliveries.len(),
        samples_outside: track
            .samples
            .iter()
            .filter(|s| setup.pitch.outside_distance_m(s.position_m) > 0.0)
            .count(),
        methods,
    }
}

/// Every track × seed (`0..seeds`) on `jobs` threads, with a progress line on stderr; the
/// runs in track order, then seed order.
pub fn evaluate_tracks(
    tracks: &[Track],
    setup: &TrackSetup,
    seeds: u64,
    jobs: usize,
) -> anyhow::Result<Vec<TrackRun>> {
    setup.observers.check()?;
    let work: Vec<(usize, u64)> = (0..tracks.len())
        .flat_map(|i| (0..seeds).map(move |s| (i, s)))
        .collect();
    let mut runs = for_each(
        &work,
        jobs,
        |(i, seed)| format!("{} seed {seed}", tracks[*i].name),
        |(i, seed)| Ok((*i, evaluate_track(&tracks[*i], setup, *seed))),
    )?;
    runs.sort_by_key(|(i, r)| (*i, r.seed));
    Ok(runs.into_iter().map(|(_, r)| r).collect())
}

#[cfg(test)]
mod tests;
