//! Keeps the served path's covariance honest on the motion the ball really has.
//!
//! [`super::spread`] flies the filter's uncertainty through the motion model; where the
//! ball does what the model does not say (drag that grows with speed, a rail that turns it,
//! a floor that is not the one learned), that spread is too narrow, and where the model
//! is cautious, too wide. So the core checks its own forecasts: every
//! [`FORECAST_EVERY_S`] it keeps the served position and covariance at each of
//! [`HORIZONS_S`], and when a sighting arrives that far ahead it measures where the
//! sighting fell in the forecast's region (d² with the sighting's own covariance added).
//! One scale per horizon (and per phase: within [`AFTER_KICK_S`] of a kick or a new
//! estimate, or not) is the 95th percentile of the last [`WINDOW`] of those d² over the
//! 95 % bound, so that 95 % regions hold 95 % of sightings; the served covariances are
//! multiplied by it. Until a horizon has [`TRUSTED_AFTER`] scores its scale is drawn
//! towards the shorter horizon's (the first horizon's towards 1, the flight's own
//! spread) in proportion. A forecast made before a kick the tracker infers is dropped, and scores are
//! committed only [`CONFIRM_S`] after their sighting, so a kick found a few frames late
//! does not count against the flight (the ball was pushed, the path could not know).
//! Pure: time is passed in.

use nalgebra::Matrix2;
use proto::Prediction;
use std::collections::VecDeque;
use std::sync::Arc;

/// Horizons the forecasts are scored at, seconds.
pub const HORIZONS_S: [f64; 6] = [0.1, 0.25, 0.5, 1.0, 1.5, 2.0];
const N: usize = HORIZONS_S.len();
/// A forecast is kept this often.
pub const FORECAST_EVERY_S: f64 = 0.1;
/// A sighting scores a forecast's horizon when it comes within this after it (the
/// forecast's point moved on at its velocity to the sighting's time).
const SCORE_WITHIN_S: f64 = 0.12;
/// A score counts once this long has passed after its sighting with no kick inferred.
pub const CONFIRM_S: f64 = 0.2;
/// Scores are committed in batches this far apart.
const COMMIT_EVERY_S: f64 = 0.3;
/// Forecasts made this soon after a kick (or a new estimate) have their own scale.
pub const AFTER_KICK_S: f64 = 0.5;
/// Sightings whose variance is more than this share of the forecast's do not score it.
const MAX_SIGHTING_SHARE: f64 = 0.25;
/// The squared Mahalanobis distance within which a 2-D Gaussian holds 95 % of its mass.
pub const D2_95: f64 = 5.991;
/// Scores kept per phase and horizon; the scale is their 95th percentile's.
pub const WINDOW: usize = 200;
/// Scores before a horizon's scale is taken at its word.
pub const TRUSTED_AFTER: usize = 40;
/// The scale stays within these (a forecast region is never shrunk below a quarter of
/// the flight's own spread, nor blown up past 25 times it).
const SCALE_RANGE: (f64, f64) = (0.25, 25.0);

/// A forecast's phase: just after a kick or a new estimate (the kick's speed still being
/// learned), or not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    AfterKick = 0,
    Settled = 1,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Point {
    position: [f64; 2],
    velocity: [f64; 2],
    covariance: [f64; 4],
}

#[derive(Debug, Clone, PartialEq)]
struct Forecast {
    t0_s: f64,
    /// The estimate (track id) it was made from.
    track: u64,
    phase: Phase,
    points: [Option<Point>; N],
    scored: [bool; N],
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Score {
    sighting_t_s: f64,
    phase: Phase,
    horizon: usize,
    /// d² of the sighting against the forecast's own covariance (with the sighting's).
    d2: f64,
}

/// The learned scales and the forecasts still to be scored.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The newest scores' d², per phase and horizon (oldest first; shared between the
    /// tracker's snapshots until one of them scores) ...
    d2: Arc<[[VecDeque<f32>; N]; 2]>,
    /// ... and the scale they make.
    scale: [[f64; N]; 2],
    forecasts: VecDeque<Forecast>,
    pending: VecDeque<Score>,
    last_forecast_s: f64,
    scores: u64,
    misses: u64,
}

impl Default for Calibration {
    fn default() -> Self {
        Calibration {
            d2: Arc::new(std::array::from_fn(|_| {
                std::array::from_fn(|_| VecDeque::with_capacity(WINDOW))
            })),
            scale: [[1.0; N]; 2],
            forecasts: VecDeque::new(),
            pending: VecDeque::new(),
            last_forecast_s: f64::NEG_INFINITY,
            scores: 0,
            misses: 0,
        }
    }
}

impl Calibration {
    /// True when a forecast should be kept at `t_s`.
    pub fn due(&self, t_s: f64) -> bool {
        t_s - self.last_forecast_s >= FORECAST_EVERY_S || t_s < self.last_forecast_s
    }

    /// Keeps the forecast `prediction` (its samples at [`HORIZONS_S`], with covariances
    /// before any scale) made at `t0_s` from estimate `track`.
    pub fn forecast(&mut self, t0_s: f64, track: u64, phase: Phase, prediction: &Prediction) {
        let mut points = [None; N];
        for (k, h) in HORIZONS_S.iter().enumerate() {
            points[k] = prediction
                .samples
                .iter()
                .find(|s| (s.t_s - h).abs() < 1e-6)
                .and_then(|s| {
                    Some(Point {
                        position: s.position_m,
                        velocity: s.velocity_mps,
                        covariance: s.covariance_m2?,
                    })
                });
        }
        self.last_forecast_s = t0_s;
        self.forecasts.push_back(Forecast {
            t0_s,
            track,
            phase,
            points,
            scored: [false; N],
        });
    }

    /// A sighting `z` (covariance `r`) of estimate `track` at `t_s`: scores the forecasts
    /// it falls due for, and commits the scores old enough to stand.
    pub fn sighting(&mut self, t_s: f64, track: u64, z: [f64; 2], r: &Matrix2<f64>) {
        let last = HORIZONS_S[N - 1] + SCORE_WITHIN_S;
        while self
            .forecasts
            .front()
            .is_some_and(|f| t_s - f.t0_s > last || f.track != track)
        {
            self.forecasts.pop_front();
        }
        for f in self.forecasts.iter_mut().filter(|f| f.track == track) {
            for (k, h) in HORIZONS_S.iter().enumerate() {
                let late = t_s - f.t0_s - h;
                if f.scored[k] || late < 0.0 {
                    continue;
                }
                f.scored[k] = true;
                let Some(p) = f.points[k] else { continue };
                if late > SCORE_WITHIN_S {
                    continue;
                }
                let at = [
                    p.position[0] + p.velocity[0] * late,
                    p.position[1] + p.velocity[1] * late,
                ];
                let forecast = Matrix2::new(
                    p.covariance[0],
                    p.covariance[1],
                    p.covariance[2],
                    p.covariance[3],
                );
                // A sighting much less sure than the forecast says little about it: the
                // region of the two together holds it whatever the forecast's scale.
                if r.trace() > MAX_SIGHTING_SHARE * forecast.trace() {
                    continue;
                }
                let Some(inv) = (forecast + r).try_inverse() else {
                    continue;
                };
                let e = nalgebra::Vector2::new(z[0] - at[0], z[1] - at[1]);
                let d2 = (e.transpose() * inv * e)[(0, 0)];
                self.pending.push_back(Score {
                    sighting_t_s: t_s,
                    phase: f.phase,
                    horizon: k,
                    d2,
                });
            }
        }
        self.commit(t_s);
    }

    /// The estimate was kicked at `onset_s`: what was forecast before cannot be scored,
    /// nor what was seen since.
    pub fn kicked(&mut self, onset_s: f64) {
        self.forecasts.clear();
        self.pending.retain(|p| p.sighting_t_s < onset_s);
    }

    /// Commits the scores [`CONFIRM_S`] old, in batches at most [`COMMIT_EVERY_S`] apart
    /// (the windows are shared with the tracker's snapshots: each batch copies them once).
    fn commit(&mut self, now_s: f64) {
        if self
            .pending
            .front()
            .is_none_or(|p| now_s - p.sighting_t_s < CONFIRM_S + COMMIT_EVERY_S)
        {
            return;
        }
        let windows = Arc::make_mut(&mut self.d2);
        let mut touched = [false; 2];
        while let Some(p) = self
            .pending
            .front()
            .filter(|p| now_s - p.sighting_t_s >= CONFIRM_S)
            .copied()
        {
            self.pending.pop_front();
            self.scores += 1;
            self.misses += u64::from(p.d2 > self.scale[p.phase as usize][p.horizon] * D2_95);
            let window = &mut windows[p.phase as usize][p.horizon];
            if window.len() == WINDOW {
                window.pop_front();
            }
            window.push_back(p.d2 as f32);
            touched[p.phase as usize] = true;
        }
        // Each horizon's scale leans on the one before while it has few scores: a flight
        // that misses at 1 s misses at 2 s as well.
        for phase in (0..2).filter(|p| touched[*p]) {
            let mut prior = 1.0;
            for (scale, window) in self.scale[phase].iter_mut().zip(&windows[phase]) {
                *scale = scale_of(window, prior);
                prior = *scale;
            }
        }
    }

    /// The scale for a point `h_s` ahead: interpolated between horizons (from 1 at no
    /// horizon to the first), the last one's beyond it.
    pub fn scale(&self, phase: Phase, h_s: f64) -> f64 {
        let l = self.scale[phase as usize].map(f64::ln);
        let log = if h_s <= HORIZONS_S[0] {
            l[0] * (h_s / HORIZONS_S[0]).max(0.0)
        } else if h_s >= HORIZONS_S[N - 1] {
            l[N - 1]
        } else {
            let k = HORIZONS_S.partition_point(|h| *h <= h_s) - 1;
            let f = (h_s - HORIZONS_S[k]) / (HORIZONS_S[k + 1] - HORIZONS_S[k]);
            l[k] + (l[k + 1] - l[k]) * f
        };
        log.exp()
    }

    /// Multiplies every covariance of `prediction` by its horizon's scale.
    pub fn apply(&self, phase: Phase, prediction: &mut Prediction) {
        for s in &mut prediction.samples {
            let k = self.scale(phase, s.t_s);
            if let Some(c) = &mut s.covariance_m2 {
                c.iter_mut().for_each(|v| *v *= k);
            }
        }
        if let Some(stop) = &mut prediction.stop {
            let k = self.scale(phase, stop.t_s);
            if let Some(c) = &mut stop.covariance_m2 {
                c.iter_mut().for_each(|v| *v *= k);
            }
        }
    }

    /// Scores committed, and of them the sightings outside the 95 % region the scale of
    /// the time drew.
    pub fn counts(&self) -> (u64, u64) {
        (self.scores, self.misses)
    }

    /// The scales per phase, by horizon.
    pub fn scales(&self, phase: Phase) -> [f64; N] {
        self.scale[phase as usize]
    }
}

/// The scale a window of d² makes: its 95th percentile over [`D2_95`], drawn towards
/// `prior` while the window holds fewer than [`TRUSTED_AFTER`].
fn scale_of(window: &VecDeque<f32>, prior: f64) -> f64 {
    if window.is_empty() {
        return prior;
    }
    let mut values: Vec<f32> = window.iter().copied().collect();
    let k = ((values.len() as f64 * 0.95).ceil() as usize).clamp(1, values.len()) - 1;
    let (_, q95, _) = values.select_nth_unstable_by(k, f32::total_cmp);
    let wanted = (f64::from(*q95) / D2_95).clamp(SCALE_RANGE.0, SCALE_RANGE.1);
    let trust = (window.len() as f64 / TRUSTED_AFTER as f64).min(1.0);
    (trust * wanted.ln() + (1.0 - trust) * prior.ln()).exp()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use proto::{PathSample, Stamp};

    /// A forecast of a ball at rest at the origin, each point with variance `var` per axis.
    fn at_rest(var: f64) -> Prediction {
        let mut samples = vec![PathSample {
            t_s: 0.0,
            position_m: [0.0, 0.0],
            velocity_mps: [0.0, 0.0],
            covariance_m2: Some([var, 0.0, 0.0, var]),
        }];
        for h in HORIZONS_S {
            samples.push(PathSample {
                t_s: h,
                ..samples[0]
            });
        }
        Prediction {
            version: proto::VERSION,
            stamp: Stamp::from_secs_f64(0.0),
            horizon_s: 2.0,
            samples,
            bounces: Vec::new(),
            stop: None,
        }
    }

    /// Feeds sightings scattered with standard deviation `sd` about the origin while
    /// forecasts claim `var`; returns the learned scales.
    fn learn(var: f64, sd: f64, kick_every_s: Option<f64>) -> Calibration {
        let mut c = Calibration::default();
        let mut rng = proto::rng::Rng::new(7);
        let r = Matrix2::identity() * 1e-8;
        let p = at_rest(var);
        let mut t = 0.0;
        let mut next_kick = kick_every_s.unwrap_or(f64::INFINITY);
        while t < 600.0 {
            if c.due(t) {
                c.forecast(t, 1, Phase::Settled, &p);
            }
            c.sighting(t, 1, [sd * rng.normal(), sd * rng.normal()], &r);
            if t >= next_kick {
                c.kicked(t);
                next_kick += kick_every_s.unwrap_or(f64::INFINITY);
            }
            t += 0.02;
        }
        c
    }

    #[test]
    fn a_forecast_too_sure_is_widened_and_one_too_wide_narrowed_to_hold_95_percent() {
        // True variance 0.04 m² (sd 0.2): d² scales by 0.04 / (scale · var).
        let narrow = learn(0.01, 0.2, None);
        for s in narrow.scales(Phase::Settled) {
            assert!(
                (3.0..5.5).contains(&s),
                "scale {s} for a forecast 4× too sure"
            );
        }
        let wide = learn(0.09, 0.2, None);
        for s in wide.scales(Phase::Settled) {
            assert!(
                (0.33..0.6).contains(&s),
                "scale {s} for a forecast 2.25× too wide"
            );
        }
        // The other phase was never scored.
        assert_eq!(narrow.scales(Phase::AfterKick), [1.0; N]);
        let (n, miss) = narrow.counts();
        assert!(n > 10_000);
        let share = miss as f64 / n as f64;
        assert!((0.03..0.08).contains(&share), "{share}");
    }

    #[test]
    fn forecasts_from_before_a_kick_are_not_scored() {
        // Kicked every 0.15 s: no forecast reaches its 0.25 s horizon.
        let c = learn(0.01, 0.2, Some(0.15));
        let s = c.scales(Phase::Settled);
        assert!(s[0] > 2.0, "the 0.1 s horizon still learns: {s:?}");
        // The others, never scored, lean on it.
        assert!(s[1..].iter().all(|v| *v == s[0]), "{s:?}");
    }

    #[test]
    fn another_estimate_drops_the_old_ones_forecasts_and_scales_interpolate() {
        let mut c = Calibration::default();
        c.forecast(0.0, 1, Phase::Settled, &at_rest(1e-4));
        let r = Matrix2::identity() * 1e-6;
        c.sighting(0.1, 2, [1.0, 1.0], &r);
        c.sighting(0.5, 2, [1.0, 1.0], &r);
        assert_eq!(c.counts(), (0, 0));
        c.scale[1] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0].map(f64::exp);
        assert!((c.scale(Phase::Settled, 0.175).ln() - 0.5).abs() < 1e-9);
        assert!((c.scale(Phase::Settled, 9.0).ln() - 5.0).abs() < 1e-9);
        assert!((c.scale(Phase::Settled, 0.0) - 1.0).abs() < 1e-9);
        let mut p = at_rest(1.0);
        c.apply(Phase::Settled, &mut p);
        let last = p.samples.last().unwrap().covariance_m2.unwrap();
        assert!((last[0] - 5f64.exp()).abs() < 1e-9);
    }
}
