//! What the floor and the walls do to the ball, learned from the estimate's own sightings.
//!
//! Four numbers describe them: the rolling deceleration, the sliding deceleration just after
//! a kick, and the normal (restitution) and tangential shares of the speed a wall returns.
//! Each is a weighted mean of *samples*, every one measured by a least-squares fit to the
//! sightings of the main track between events:
//!
//! - a **bounce**: a line fitted to the sightings before the wall and one to those after
//!   (the known deceleration taken out), met where the two normal coordinates cross; the
//!   ratio of the normal speeds there is the restitution, that of the tangential speeds the
//!   tangential retention, each with the variance the fits give it;
//! - a **roll**: a parabola fitted per axis to the sightings of a free stretch (after the
//!   slide that follows a kick or a bounce, up to the next event or the stop), its
//!   acceleration against the velocity is the rolling deceleration;
//! - a **slide**: the same over the first moments after a kick, while the ball still slides.
//!
//! The bounce's crossing also says where that wall stands: where the ball's centre turns,
//! a few centimetres inside or outside where the configured pitch puts it (a table measured
//! roughly, a ball of another size, a camera's distortion near the edge). Each wall's offset
//! is learned like the four numbers, and the flights turn there.
//!
//! The walls' two numbers and the slide are used as they are learned, by every hypothesis.
//! The rolling deceleration is also learned stretch by stretch by the estimate's own filter
//! (which follows a floor whose friction changes with speed); this one, the floor's over all
//! stretches, is where a new estimate starts when there is none to carry it over from, and
//! what the bounce fits take out of the sightings.
//!
//! The mean starts at a prior with the weight of its stated uncertainty and never forgets
//! it: no random walk, so nothing drifts when no sample comes, and one sample moves the
//! mean by its weight's share only. A sample far from the mean (beyond `huber_k` of the
//! combined spread) counts with a Huber weight that shrinks as it goes farther, so a few
//! biased bounces (off a robot, a corner, a mis-detected frame) cannot drag the walls'
//! value; samples outside physical bounds are refused and counted. The sum of weights is
//! capped, so that a floor that truly changes is followed over the last hundreds of samples.
//!
//! Sightings enter the fits only when they are at least `commit_delay_s` old, so that a kick
//! found late (a change point some sightings back) takes its sightings out of the stretch
//! before it. Pure: time comes in with the sightings and events.

use super::motion::MotionModel;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use slide_end::{KickRun, MAX_RUN, ratio_sample};
use std::collections::VecDeque;

/// Settings of the learning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceConfig {
    /// Uncertainty of the starting values (their prior weight is 1/σ²).
    pub decel_sigma_mps2: f64,
    pub slide_sigma_mps2: f64,
    /// Uncertainty of the share of the kick's speed at which the slide ends.
    pub roll_ratio_sigma: f64,
    pub restitution_sigma: f64,
    pub tangential_sigma: f64,
    /// Sightings this close to an event belong to neither side of it.
    pub guard_s: f64,
    /// A bounce is measured from the sightings this long before and after it.
    pub bounce_window_s: f64,
    /// Only bounces met at this normal speed or more teach the restitution, and only those
    /// with this much tangential speed teach the tangential retention.
    pub bounce_min_speed_mps: f64,
    /// The two fits must cross within this time of the predicted bounce...
    pub bounce_max_shift_s: f64,
    /// ... within this distance of the wall, and this far from any other wall.
    pub bounce_max_offset_m: f64,
    /// Uncertainty of where the walls stand (the pitch's size as configured): where the
    /// ball's centre turns at each wall is learned from the bounces, within
    /// ±`wall_max_offset_m` of it.
    pub wall_sigma_m: f64,
    pub wall_max_offset_m: f64,
    /// After a bounce the ball may slide for a moment: rolls are fitted from this long
    /// after it, plus `settle_per_mps_s` per m/s of speed.
    pub settle_after_bounce_s: f64,
    pub settle_per_mps_s: f64,
    /// After a kick: this long after the slide's predicted end.
    pub settle_after_kick_s: f64,
    /// A roll needs this many sightings over this span, at this speed at both ends.
    pub roll_min_sightings: u32,
    pub roll_min_span_s: f64,
    pub roll_min_speed_mps: f64,
    /// A longer stretch is measured in parts of this span.
    pub roll_max_span_s: f64,
    /// The slide is fitted over at most this long after a kick.
    pub slide_max_span_s: f64,
    /// Sightings enter the fits only once this old.
    pub commit_delay_s: f64,
    /// Each sample's spread is at least this (per parameter: deceleration m/s²,
    /// restitution, tangential retention): what differs from one bounce or one stretch of
    /// floor to the next.
    pub decel_sample_floor_mps2: f64,
    pub ratio_sample_floor: f64,
    /// A ball this close to a robot may be touched: its stretch starts over.
    pub touch_m: f64,
    /// A stretch whose parabola leaves residuals beyond this χ² per degree of freedom, or
    /// bends sideways by more than its 3σ and this, was not one free roll: no sample.
    pub max_chi2_dof: f64,
    pub max_side_accel_mps2: f64,
    /// Huber threshold, in combined standard deviations.
    pub huber_k: f64,
    /// The weight of the samples is capped at this many samples at the floor spread.
    pub max_samples_weight: f64,
}

impl Default for SurfaceConfig {
    fn default() -> Self {
        SurfaceConfig {
            decel_sigma_mps2: 0.1,
            slide_sigma_mps2: 1.5,
            roll_ratio_sigma: 0.1,
            restitution_sigma: 0.15,
            tangential_sigma: 0.1,
            guard_s: 0.025,
            bounce_window_s: 0.4,
            bounce_min_speed_mps: 0.15,
            bounce_max_shift_s: 0.08,
            bounce_max_offset_m: 0.12,
            wall_sigma_m: 0.03,
            wall_max_offset_m: 0.12,
            settle_after_bounce_s: 0.05,
            settle_per_mps_s: 0.02,
            settle_after_kick_s: 0.15,
            roll_min_sightings: 8,
            roll_min_span_s: 0.12,
            roll_min_speed_mps: 0.08,
            roll_max_span_s: 4.0,
            slide_max_span_s: 0.3,
            commit_delay_s: 0.5,
            decel_sample_floor_mps2: 0.02,
            ratio_sample_floor: 0.04,
            touch_m: 0.2,
            max_chi2_dof: 4.0,
            max_side_accel_mps2: 0.2,
            huber_k: 2.0,
            max_samples_weight: 300.0,
        }
    }
}

/// One learned number: its mean, the variance of that mean, and how many samples made it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Learned {
    pub mean: f64,
    pub variance: f64,
    pub samples: u32,
}

/// Physical bounds of one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Limits {
    /// Samples outside are refused.
    sample: (f64, f64),
    /// The mean is kept inside.
    mean: (f64, f64),
    sample_floor: f64,
}

/// A prior-anchored, Huber-weighted running mean.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Estimate {
    prior: f64,
    prior_weight: f64,
    sum_w: f64,
    sum_wx: f64,
    samples: u32,
    refused: u32,
    limits: Limits,
    /// A sample still being measured: (value, weight), counted in the mean until replaced.
    tentative: Option<(f64, f64)>,
}

impl Estimate {
    fn new(prior: f64, prior_sigma: f64, limits: Limits) -> Self {
        Estimate {
            prior: prior.clamp(limits.mean.0, limits.mean.1),
            prior_weight: 1.0 / prior_sigma.max(1e-9).powi(2),
            sum_w: 0.0,
            sum_wx: 0.0,
            samples: 0,
            refused: 0,
            limits,
            tentative: None,
        }
    }

    fn mean(&self) -> f64 {
        let (tx, tw) = self.tentative.unwrap_or((0.0, 0.0));
        let m = (self.prior * self.prior_weight + self.sum_wx + tw * tx)
            / (self.prior_weight + self.sum_w + tw);
        m.clamp(self.limits.mean.0, self.limits.mean.1)
    }

    fn variance(&self) -> f64 {
        let tw = self.tentative.map_or(0.0, |(_, w)| w);
        1.0 / (self.prior_weight + self.sum_w + tw)
    }

    /// The weight sample `x` of variance `var` would get (0 when it is refused).
    fn weight(&self, x: f64, var: f64, cfg: &SurfaceConfig) -> Option<(f64, f64)> {
        let (lo, hi) = self.limits.sample;
        if !x.is_finite() || !var.is_finite() || !(lo..=hi).contains(&x) {
            return None;
        }
        let var = var.max(self.limits.sample_floor.powi(2));
        let settled = Estimate {
            tentative: None,
            ..*self
        };
        let r = (x - settled.mean()).abs() / (var + settled.variance()).sqrt();
        let huber = if r > cfg.huber_k {
            cfg.huber_k / r
        } else {
            1.0
        };
        Some((x, huber / var))
    }

    fn set_tentative(&mut self, sample: Option<(f64, f64)>, cfg: &SurfaceConfig) {
        self.tentative = sample.and_then(|(x, var)| self.weight(x, var, cfg));
    }

    fn learned(&self) -> Learned {
        Learned {
            mean: self.mean(),
            variance: self.variance(),
            samples: self.samples,
        }
    }

    /// Adds sample `x` of variance `var`; false when it is refused.
    fn add(&mut self, x: f64, var: f64, cfg: &SurfaceConfig) -> bool {
        self.tentative = None;
        let Some((x, w)) = self.weight(x, var, cfg) else {
            self.refused = self.refused.saturating_add(1);
            return false;
        };
        self.sum_w += w;
        self.sum_wx += w * x;
        let cap = cfg.max_samples_weight / self.limits.sample_floor.powi(2);
        if self.sum_w > cap {
            let k = cap / self.sum_w;
            self.sum_w *= k;
            self.sum_wx *= k;
        }
        self.samples = self.samples.saturating_add(1);
        true
    }
}

/// One sighting of the main track: time, position and its weight (1/variance per axis).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Seen {
    t_s: f64,
    z: [f64; 2],
    w: f64,
    /// Already in the roll and slide fits (kept only as a bounce's raw material).
    committed: bool,
}

/// Weighted sums for a least-squares fit in time around `t0_s` (positions around `z0`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Moments {
    t0_s: f64,
    z0: [f64; 2],
    n: u32,
    first_s: f64,
    last_s: f64,
    /// Σ w τᵏ, k = 0..4.
    s: [f64; 5],
    /// Per axis Σ w τᵏ x, k = 0..2.
    x: [[f64; 3]; 2],
    /// Per axis Σ w x².
    xx: [f64; 2],
}

/// A fit's value, velocity and acceleration at its reference time, with the variances of
/// the velocity and acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Fit {
    p: [f64; 2],
    v: [f64; 2],
    a: [f64; 2],
    /// Variance of `p`.
    var_p: [f64; 2],
    var_v: [f64; 2],
    var_a: [f64; 2],
    /// The residuals' χ² per degree of freedom (1 when they scatter as stated).
    chi2_dof: f64,
}

impl Moments {
    fn new(t0_s: f64, z0: [f64; 2]) -> Self {
        Moments {
            t0_s,
            z0,
            n: 0,
            first_s: f64::INFINITY,
            last_s: f64::NEG_INFINITY,
            s: [0.0; 5],
            x: [[0.0; 3]; 2],
            xx: [0.0; 2],
        }
    }

    fn of<'a>(t0_s: f64, seen: impl IntoIterator<Item = &'a Seen>) -> Option<Self> {
        let mut it = seen.into_iter().peekable();
        let z0 = it.peek()?.z;
        let mut m = Moments::new(t0_s, z0);
        for s in it {
            m.add(s);
        }
        Some(m)
    }

    fn add(&mut self, s: &Seen) {
        let tau = s.t_s - self.t0_s;
        let mut p = s.w;
        for k in 0..5 {
            self.s[k] += p;
            p *= tau;
        }
        for axis in 0..2 {
            let x = s.z[axis] - self.z0[axis];
            self.x[axis][0] += s.w * x;
            self.x[axis][1] += s.w * tau * x;
            self.x[axis][2] += s.w * tau * tau * x;
            self.xx[axis] += s.w * x * x;
        }
        self.n += 1;
        self.first_s = self.first_s.min(s.t_s);
        self.last_s = self.last_s.max(s.t_s);
    }

    fn span_s(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.last_s - self.first_s
        }
    }

    /// x(τ) = p + v τ + a τ²/2 per axis.
    fn quadratic(&self) -> Option<Fit> {
        if self.n < 5 {
            return None;
        }
        let s = &self.s;
        let n = Matrix3::new(
            s[0],
            s[1],
            s[2] / 2.0,
            s[1],
            s[2],
            s[3] / 2.0,
            s[2] / 2.0,
            s[3] / 2.0,
            s[4] / 4.0,
        );
        let inv = n.try_inverse()?;
        let mut fit = Fit::default_at(self.z0);
        let mut chi2 = 0.0;
        for axis in 0..2 {
            let x = &self.x[axis];
            let b = Vector3::new(x[0], x[1], x[2] / 2.0);
            let beta = inv * b;
            chi2 += (self.xx[axis] - beta.dot(&b)).max(0.0);
            fit.p[axis] += beta[0];
            fit.v[axis] = beta[1];
            fit.a[axis] = beta[2];
            fit.var_p[axis] = inv[(0, 0)];
            fit.var_v[axis] = inv[(1, 1)];
            fit.var_a[axis] = inv[(2, 2)];
        }
        Some(fit.scaled(chi2, 2.0 * (f64::from(self.n) - 3.0)))
    }

    /// x(τ) = p + v τ + a τ²/2 per axis with `a` known.
    fn linear(&self, a: [f64; 2]) -> Option<Fit> {
        if self.n < 3 {
            return None;
        }
        let s = &self.s;
        let inv = Matrix2::new(s[0], s[1], s[1], s[2]).try_inverse()?;
        let mut fit = Fit::default_at(self.z0);
        let mut chi2 = 0.0;
        for (axis, &acc) in a.iter().enumerate() {
            let x = &self.x[axis];
            let h = acc / 2.0;
            let b = Vector2::new(x[0] - h * s[2], x[1] - h * s[3]);
            let xx = self.xx[axis] - 2.0 * h * x[2] + h * h * s[4];
            let beta = inv * b;
            chi2 += (xx - beta.dot(&b)).max(0.0);
            fit.p[axis] += beta[0];
            fit.v[axis] = beta[1];
            fit.a[axis] = acc;
            fit.var_p[axis] = inv[(0, 0)];
            fit.var_v[axis] = inv[(1, 1)];
        }
        Some(fit.scaled(chi2, 2.0 * (f64::from(self.n) - 2.0)))
    }

    /// The straight-line fit with the deceleration `decel` taken out along its own motion.
    fn decelerating_line(&self, decel_mps2: f64) -> Option<Fit> {
        let free = self.linear([0.0, 0.0])?;
        let speed = free.v[0].hypot(free.v[1]);
        if speed < 1e-6 {
            return Some(free);
        }
        let a = [
            -decel_mps2 * free.v[0] / speed,
            -decel_mps2 * free.v[1] / speed,
        ];
        self.linear(a)
    }
}

impl Fit {
    fn default_at(z0: [f64; 2]) -> Self {
        Fit {
            p: z0,
            v: [0.0; 2],
            a: [0.0; 2],
            var_p: [0.0; 2],
            var_v: [0.0; 2],
            var_a: [0.0; 2],
            chi2_dof: 1.0,
        }
    }

    /// Scales the variances by the residuals' χ² per degree of freedom when the sightings
    /// scatter more than their stated covariances say (never less).
    fn scaled(mut self, chi2: f64, dof: f64) -> Self {
        self.chi2_dof = if dof > 0.0 { chi2 / dof } else { 1.0 };
        let k = self.chi2_dof.max(1.0);
        for axis in 0..2 {
            self.var_p[axis] *= k;
            self.var_v[axis] *= k;
            self.var_a[axis] *= k;
        }
        self
    }

    fn velocity_at(&self, tau_s: f64) -> [f64; 2] {
        [self.v[0] + self.a[0] * tau_s, self.v[1] + self.a[1] * tau_s]
    }

    fn position_at(&self, tau_s: f64) -> [f64; 2] {
        [
            self.p[0] + self.v[0] * tau_s + 0.5 * self.a[0] * tau_s * tau_s,
            self.p[1] + self.v[1] * tau_s + 0.5 * self.a[1] * tau_s * tau_s,
        ]
    }
}

/// A wall bounce whose after-side is still being seen.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PendingBounce {
    t_s: f64,
    axis: usize,
    wall_m: f64,
    /// Sign of the normal velocity going in.
    inward: f64,
    before: Fit,
    /// The wall's learned offset when the bounce was taken (`wall_m` includes it).
    offset_m: f64,
    /// The after-side starts here (later than `t_s` when the bounce was found in the
    /// sightings after the flight had foreseen it too early).
    after_from_s: f64,
}

/// A wall hit as the tracker's flight met it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BounceEvent {
    pub t_s: f64,
    /// Normal axis: 0 for x walls, 1 for y walls.
    pub axis: usize,
    /// The wall's coordinate on that axis (the ball centre's limit).
    pub wall_m: f64,
    /// The normal velocity going in (its sign says which way the wall is).
    pub normal_velocity_in_mps: f64,
    /// The hit lies near another wall: a corner, where the two fits cannot be told apart.
    pub corner: bool,
}

/// Samples taken and refused, per parameter.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SurfaceCounts {
    pub rolls: u32,
    pub slides: u32,
    pub bounces: u32,
    pub tangential: u32,
    /// Bounces and stretches that gave no sample (too few sightings, fits that do not meet
    /// at the wall, values outside physical bounds).
    pub refused: u32,
}

/// The learned floor and walls, and the fits in progress.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    cfg: SurfaceConfig,
    learn_floor: bool,
    learn_walls: bool,
    rolling: Estimate,
    /// The share of the kick's speed at which a kicked ball starts to roll...
    roll_ratio: Estimate,
    /// ... measured from the sightings after the last kick.
    kick_run: Option<KickRun>,
    slide: Estimate,
    restitution: Estimate,
    tangential: Estimate,
    /// How far each wall (in the order of `WallSide::ALL`) stands outside where the pitch
    /// puts it (negative: inside).
    walls: [Estimate; 4],
    /// Sightings not yet committed to the fits (younger than `commit_delay_s`), and the
    /// last `bounce_window_s` of committed ones: the bounce fits' raw material.
    recent: VecDeque<Seen>,
    /// Sightings before this time belong to an earlier stretch.
    from_s: f64,
    /// The current roll, from `roll_from_s`.
    roll: Option<Moments>,
    roll_from_s: f64,
    /// Sightings in `roll` when its tentative sample was last measured.
    tentative_at_n: u32,
    /// The slide after the last kick, over [`slide_from_s`, `slide_until_s`].
    slide_fit: Option<Moments>,
    slide_from_s: f64,
    slide_until_s: f64,
    pending: Option<PendingBounce>,
    /// The last bounce taken: time, axis, wall.
    last_bounce: Option<(f64, usize, f64)>,
    refused: u32,
    /// Bumped whenever a learned value changes...
    version: u64,
    /// ... and whenever the restitution or a wall's place does.
    walls_version: u64,
}

/// The sightings after a kick are searched for the slide's end for at most this long.
const KICK_RUN_MAX_S: f64 = 2.0;

/// The smallest spread one bounce's crossing is taken to have.
const WALL_SAMPLE_FLOOR_M: f64 = 0.01;

/// The side of `WallSide::ALL` a ball moving with normal velocity sign `inward` along
/// `axis` meets.
fn side_of(axis: usize, inward: f64) -> usize {
    2 * axis + usize::from(inward < 0.0)
}

/// At most this many sightings wait for the fits (a flood commits them early), and at most
/// this many committed ones are kept for a bounce's before-side.
const MAX_RECENT: usize = 512;

impl Surface {
    /// Starting from `base`'s values; `learn_floor` / `learn_walls` say whether samples of
    /// the decelerations / the walls are taken at all.
    pub fn new(
        base: &MotionModel,
        cfg: SurfaceConfig,
        learn_floor: bool,
        learn_walls: bool,
    ) -> Self {
        let ratio = |floor: f64| Limits {
            sample: (-0.05, 1.2),
            mean: (0.05, 1.0),
            sample_floor: floor,
        };
        let decel = Limits {
            sample: (-0.5, 6.0),
            mean: (0.005, 5.0),
            sample_floor: cfg.decel_sample_floor_mps2,
        };
        Surface {
            learn_floor,
            learn_walls,
            roll_ratio: Estimate::new(
                base.roll_ratio,
                cfg.roll_ratio_sigma,
                Limits {
                    sample: (0.2, 0.98),
                    mean: (0.3, 0.95),
                    sample_floor: 0.02,
                },
            ),
            kick_run: None,
            rolling: Estimate::new(base.decel_mps2, cfg.decel_sigma_mps2, decel),
            slide: Estimate::new(base.slide_decel_mps2, cfg.slide_sigma_mps2, decel),
            restitution: Estimate::new(
                base.restitution,
                cfg.restitution_sigma,
                ratio(cfg.ratio_sample_floor),
            ),
            tangential: Estimate::new(
                base.tangential_retention,
                cfg.tangential_sigma,
                ratio(cfg.ratio_sample_floor),
            ),
            walls: [(); 4].map(|_| {
                Estimate::new(
                    0.0,
                    cfg.wall_sigma_m,
                    Limits {
                        sample: (-cfg.wall_max_offset_m, cfg.wall_max_offset_m),
                        mean: (-cfg.wall_max_offset_m, cfg.wall_max_offset_m),
                        sample_floor: WALL_SAMPLE_FLOOR_M,
                    },
                )
            }),
            cfg,
            recent: VecDeque::new(),
            from_s: f64::NEG_INFINITY,
            roll: None,
            roll_from_s: f64::INFINITY,
            tentative_at_n: 0,
            slide_fit: None,
            slide_from_s: f64::INFINITY,
            slide_until_s: f64::NEG_INFINITY,
            pending: None,
            last_bounce: None,
            refused: 0,
            version: 0,
            walls_version: 0,
        }
    }

    /// `base` with the learned values.
    pub fn model(&self, base: &MotionModel) -> MotionModel {
        MotionModel {
            decel_mps2: self.rolling.mean(),
            slide_decel_mps2: self.slide.mean().max(self.rolling.mean()),
            roll_ratio: self.roll_ratio.mean(),
            restitution: self.restitution.mean(),
            tangential_retention: self.tangential.mean(),
            ..*base
        }
    }

    pub fn rolling_decel(&self) -> Learned {
        self.rolling.learned()
    }

    pub fn slide_decel(&self) -> Learned {
        self.slide.learned()
    }

    /// The share of the kick's speed at which a kicked ball starts to roll.
    pub fn roll_ratio(&self) -> Learned {
        self.roll_ratio.learned()
    }

    pub fn restitution(&self) -> Learned {
        self.restitution.learned()
    }

    pub fn tangential_retention(&self) -> Learned {
        self.tangential.learned()
    }

    /// Where the ball's centre turns at each wall (in the order of `WallSide::ALL`),
    /// outside (positive) or inside the pitch's configured bounds.
    pub fn wall_offsets_m(&self) -> [f64; 4] {
        self.walls.map(|w| w.mean())
    }

    /// Bounces that measured where a wall stands, per side.
    pub fn wall_samples(&self) -> [u32; 4] {
        self.walls.map(|w| w.samples)
    }

    pub fn counts(&self) -> SurfaceCounts {
        SurfaceCounts {
            rolls: self.rolling.samples,
            slides: self.slide.samples,
            bounces: self.restitution.samples,
            tangential: self.tangential.samples,
            refused: self
                .refused
                .saturating_add(self.rolling.refused)
                .saturating_add(self.slide.refused)
                .saturating_add(self.restitution.refused)
                .saturating_add(self.tangential.refused),
        }
    }

    /// Changes whenever a learned value does.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Changes whenever the learned restitution or a wall's place does.
    pub fn walls_version(&self) -> u64 {
        self.walls_version
    }

    /// A sighting of the main track at `t_s` (positions `z`, variance per axis `var_m2`),
    /// whose filter now moves at `speed_mps`.
    pub fn sighting(&mut self, t_s: f64, z: [f64; 2], var_m2: f64, speed_mps: f64) {
        if !(self.learn_floor || self.learn_walls) || t_s < self.from_s {
            return;
        }
        if !(var_m2 > 0.0 && var_m2.is_finite() && z.iter().all(|v| v.is_finite())) {
            return;
        }
        self.recent.push_back(Seen {
            t_s,
            z,
            w: 1.0 / var_m2,
            committed: false,
        });
        self.commit(t_s - self.cfg.commit_delay_s);
        if let Some(b) = self.pending
            && t_s > b.t_s + self.cfg.bounce_window_s
        {
            self.finish_bounce(b.t_s + self.cfg.bounce_window_s);
        }
        if t_s > self.slide_until_s && self.slide_until_s > self.slide_from_s {
            self.commit(self.slide_until_s);
            self.finish_slide();
        }
        if self
            .kick_run
            .as_ref()
            .is_some_and(|r| t_s - self.cfg.commit_delay_s > r.until_s)
        {
            self.finish_kick_run();
        }
        if speed_mps < self.cfg.roll_min_speed_mps && self.roll_from_s.is_finite() {
            // Stopping: the stretch ends here (a parabola does not fit a stop).
            self.commit(t_s);
            self.finish_roll();
            self.roll_from_s = f64::INFINITY;
        }
    }

    /// The main track met a wall.
    pub fn bounce(&mut self, e: BounceEvent) {
        if !(self.learn_floor || self.learn_walls) {
            return;
        }
        if self.last_bounce.is_some_and(|(t, axis, wall)| {
            axis == e.axis && (wall - e.wall_m).abs() < 1e-6 && e.t_s - t < self.cfg.bounce_window_s
        }) {
            // The same wall again at once: the estimate, pulled back over the wall by a
            // sighting, met it twice for one bounce.
            return;
        }
        self.last_bounce = Some((e.t_s, e.axis, e.wall_m));
        let later = self.end_stretch(e.t_s);
        let window = self.cfg.bounce_window_s;
        let before = Moments::of(
            e.t_s,
            self.recent
                .iter()
                .filter(|s| s.t_s >= e.t_s - window && s.t_s >= self.from_s),
        );
        let before = before
            .filter(|m| m.n >= 3 && m.span_s() >= 0.02)
            .and_then(|m| m.decelerating_line(self.rolling.mean()));
        let speed_in = e.normal_velocity_in_mps.abs();
        self.pending = match before {
            Some(before) if !e.corner && speed_in > 0.0 => Some(PendingBounce {
                t_s: e.t_s,
                axis: e.axis,
                wall_m: e.wall_m,
                inward: e.normal_velocity_in_mps.signum(),
                before,
                offset_m: self.walls[side_of(e.axis, e.normal_velocity_in_mps)].mean(),
                after_from_s: e.t_s + self.cfg.guard_s,
            }),
            _ => {
                self.refused = self.refused.saturating_add(1);
                None
            }
        };
        self.recent = later;
        self.from_s = e.t_s + self.cfg.guard_s;
        let speed_out = speed_in * self.restitution.mean();
        self.roll_from_s =
            e.t_s + self.cfg.settle_after_bounce_s + self.cfg.settle_per_mps_s * speed_out;
    }

    /// The main track's sightings showed a bounce its flight did not foresee: at a wall the
    /// flight put elsewhere (or one it met earlier than the ball did), or with another share
    /// of the speed than learned. When the flight met the same wall moments ago, that bounce
    /// is this one: its after-side starts after this one.
    pub fn bounce_found(&mut self, e: BounceEvent) {
        let window = self.cfg.bounce_window_s;
        if let Some(p) = self.pending.as_mut()
            && p.axis == e.axis
            && (p.wall_m - e.wall_m).abs() < 1e-6
            && (e.t_s - p.t_s).abs() < window
        {
            p.after_from_s = p.after_from_s.max(e.t_s + self.cfg.guard_s);
            return;
        }
        if self.last_bounce.is_some_and(|(t, axis, wall)| {
            axis == e.axis && (wall - e.wall_m).abs() < 1e-6 && (e.t_s - t).abs() < window
        }) {
            // Taken already, and measured or refused since (or not learned at all).
            self.last_bounce = None;
        }
        self.bounce(e);
    }

    /// The main track was kicked at `t_s` (found now, perhaps some sightings later) and
    /// moves at `speed_mps`.
    pub fn kick(&mut self, t_s: f64, speed_mps: f64) {
        if !(self.learn_floor || self.learn_walls) {
            return;
        }
        let later = self.end_stretch(t_s);
        self.pending = None;
        self.recent = later;
        self.from_s = t_s + self.cfg.guard_s;
        let (slide, roll) = (self.slide.mean(), self.rolling.mean());
        let slide_s = if slide > roll {
            (1.0 - self.roll_ratio.mean()) * speed_mps / slide
        } else {
            0.0
        };
        self.slide_from_s = self.from_s;
        self.slide_until_s = t_s + slide_s.clamp(0.0, self.cfg.slide_max_span_s).max(0.1);
        self.slide_fit = None;
        self.roll_from_s = t_s + slide_s + self.cfg.settle_after_kick_s;
        // The slide's end is looked for until well after it is expected.
        self.kick_run = (slide_s > 0.0 && speed_mps.is_finite()).then(|| KickRun {
            t_s,
            until_s: t_s + (2.0 * slide_s + 0.4).min(KICK_RUN_MAX_S),
            seen: Vec::new(),
        });
    }

    /// A new ball (the estimate switched to another hypothesis, or a robot touches it):
    /// the stretches start over at `t_s`; what was learned stays.
    pub fn restart(&mut self, t_s: f64) {
        if t_s >= self.from_s {
            // What was seen before is a stretch of its own.
            self.end_stretch(t_s);
        }
        self.pending = None;
        self.recent.clear();
        self.roll = None;
        self.slide_fit = None;
        self.slide_from_s = f64::INFINITY;
        self.slide_until_s = f64::NEG_INFINITY;
        self.kick_run = None;
        self.from_s = t_s;
        self.roll_from_s = t_s + self.cfg.settle_after_kick_s;
    }

    /// Ends the current stretch just before an event at `t_s`: what is left of it is fitted.
    /// Returns the sightings already seen after the event (a kick found late), which start
    /// the next stretch.
    fn end_stretch(&mut self, t_s: f64) -> VecDeque<Seen> {
        let (cut, resume) = (t_s - self.cfg.guard_s, t_s + self.cfg.guard_s);
        let later = self
            .recent
            .iter()
            .filter(|s| s.t_s >= resume && !s.committed)
            .copied()
            .collect();
        self.recent.retain(|s| s.t_s < cut);
        self.commit(cut);
        if let Some(b) = self.pending {
            self.finish_bounce(cut.min(b.t_s + self.cfg.bounce_window_s));
        }
        if self.slide_until_s > self.slide_from_s {
            self.finish_slide();
        }
        self.finish_roll();
        self.finish_kick_run();
        later
    }

    /// Moves the sightings up to `until_s` from `recent` into the roll and slide fits,
    /// keeping the last bounce window of them for a bounce's before-side.
    fn commit(&mut self, until_s: f64) {
        let keep_from = until_s - self.cfg.bounce_window_s;
        // The committed sightings are always a prefix of `recent` (it is committed from the
        // front, and only uncommitted ones join it): start after them, so that a flood,
        // whose bounce window holds thousands, costs no more per sighting than a trickle.
        let mut i = self.recent.partition_point(|s| s.committed);
        while i < self.recent.len() {
            let s = self.recent[i];
            let committed = s.t_s <= until_s || self.recent.len() - i > MAX_RECENT;
            if !committed {
                break;
            }
            if !s.committed {
                if self
                    .roll
                    .is_some_and(|r| s.t_s - r.first_s > self.cfg.roll_max_span_s)
                {
                    // A long stretch is measured in parts, so that it teaches while it lasts.
                    self.finish_roll();
                }
                if s.t_s >= self.roll_from_s && self.learn_floor {
                    if self.roll.is_none() {
                        self.tentative_at_n = 0;
                    }
                    self.roll
                        .get_or_insert_with(|| Moments::new(s.t_s, s.z))
                        .add(&s);
                }
                if let Some(run) = self.kick_run.as_mut()
                    && s.t_s >= run.t_s + self.cfg.guard_s
                    && s.t_s <= run.until_s
                    && run.seen.len() < MAX_RUN
                {
                    run.seen.push(s);
                }
                if s.t_s >= self.slide_from_s && s.t_s <= self.slide_until_s && self.learn_floor {
                    self.slide_fit
                        .get_or_insert_with(|| Moments::new(s.t_s, s.z))
                        .add(&s);
                }
                self.recent[i].committed = true;
            }
            i += 1;
        }
        // Of the committed, the last bounce window's are kept, and at most MAX_RECENT of them.
        while self
            .recent
            .front()
            .is_some_and(|s| s.committed && (s.t_s < keep_from || i > MAX_RECENT))
        {
            self.recent.pop_front();
            i -= 1;
        }
        self.update_tentative();
    }

    fn finish_roll(&mut self) {
        let Some(m) = self.roll.take() else {
            return;
        };
        self.rolling.tentative = None;
        match roll_sample(&m, &self.cfg) {
            Some(Some((decel, var))) => {
                let added = self.rolling.add(decel, var, &self.cfg);
                self.version += u64::from(added);
            }
            Some(None) => self.refused = self.refused.saturating_add(1),
            None => {}
        }
    }

    /// While a stretch lasts, its fit so far counts as a tentative sample (replaced as it
    /// grows, and by the final one when it ends), so that a long roll teaches at once.
    fn update_tentative(&mut self) {
        let Some(m) = self.roll else {
            return;
        };
        if m.n < self.tentative_at_n + TENTATIVE_EVERY {
            return;
        }
        self.tentative_at_n = m.n;
        let sample = roll_sample(&m, &self.cfg).flatten();
        let before = self.rolling.mean();
        self.rolling.set_tentative(sample, &self.cfg);
        if self.rolling.mean() != before {
            self.version += 1;
        }
    }

    fn finish_slide(&mut self) {
        self.slide_from_s = f64::INFINITY;
        self.slide_until_s = f64::NEG_INFINITY;
        let Some(m) = self.slide_fit.take() else {
            return;
        };
        if m.n < 6 || m.span_s() < 0.08 {
            return;
        }
        let Some(fit) = m.quadratic() else {
            return;
        };
        let mid = 0.5 * (m.first_s + m.last_s) - m.t0_s;
        let v = fit.velocity_at(mid);
        let speed = v[0].hypot(v[1]);
        if speed < 0.3 {
            return;
        }
        let Some((decel, var)) = straight_decel(&fit, v, &self.cfg) else {
            self.refused = self.refused.saturating_add(1);
            return;
        };
        if self.slide.add(decel, var, &self.cfg) {
            self.version += 1;
        }
    }

    /// Measures where the last kick's slide ended, from the sightings since it.
    fn finish_kick_run(&mut self) {
        let Some(run) = self.kick_run.take() else {
            return;
        };
        if !self.learn_floor {
            return;
        }
        if let Some((r, var)) = ratio_sample(&run, self.rolling.mean())
            && self.roll_ratio.add(r, var, &self.cfg)
        {
            self.version += 1;
        }
    }

    /// Measures the pending bounce from the sightings after it, up to `until_s`.
    fn finish_bounce(&mut self, until_s: f64) {
        let Some(b) = self.pending.take() else {
            return;
        };
        let c = self.cfg;
        let after = Moments::of(
            b.t_s,
            self.recent
                .iter()
                .filter(|s| s.t_s >= b.after_from_s && s.t_s <= until_s),
        )
        .filter(|m| m.n >= 3 && m.span_s() >= 0.02)
        .and_then(|m| m.decelerating_line(self.rolling.mean()));
        let sample = after.and_then(|after| bounce_sample(&b, &after, &c));
        let Some(((normal, tangential), (at_m, var_at))) = sample else {
            self.refused = self.refused.saturating_add(1);
            return;
        };
        if !self.learn_walls {
            return;
        }
        let side = side_of(b.axis, b.inward);
        let offset = b.offset_m + (at_m - b.wall_m) * b.inward;
        if self.walls[side].add(offset, var_at, &c) {
            self.version += 1;
            self.walls_version += 1;
        }
        if self.restitution.add(normal.0, normal.1, &c) {
            self.version += 1;
            self.walls_version += 1;
        }
        if let Some((x, var)) = tangential
            && self.tangential.add(x, var, &c)
        {
            self.version += 1;
        }
    }
}

/// Re-evaluate a growing stretch's tentative sample after this many more sightings.
const TENTATIVE_EVERY: u32 = 8;

/// The rolling deceleration a stretch measures: none when it is too short to say,
/// `Some(None)` when it says nothing trustworthy (refused), else the sample and variance.
fn roll_sample(m: &Moments, c: &SurfaceConfig) -> Option<Option<(f64, f64)>> {
    if m.n < c.roll_min_sightings || m.span_s() < c.roll_min_span_s {
        return None;
    }
    Some(roll_fit(m, c))
}

fn roll_fit(m: &Moments, c: &SurfaceConfig) -> Option<(f64, f64)> {
    let fit = m.quadratic()?;
    let mid = 0.5 * (m.first_s + m.last_s) - m.t0_s;
    let v = fit.velocity_at(mid);
    let speed = v[0].hypot(v[1]);
    let ends = [m.first_s - m.t0_s, m.last_s - m.t0_s].map(|tau| {
        let v = fit.velocity_at(tau);
        v[0].hypot(v[1])
    });
    // The stretch ends when the filter says the ball is this slow: the fit must agree
    // that it still moved at both ends (half of it, for the noise in either).
    let slowest = 0.5 * c.roll_min_speed_mps;
    if speed < c.roll_min_speed_mps || ends.iter().any(|s| *s < slowest) {
        return None;
    }
    straight_decel(&fit, v, c)
}

/// The deceleration against velocity `v` of a parabola fitted to a straight stretch, and its
/// variance; none when the stretch was not straight and smooth (a bounce or a touch nobody
/// reported inside it): residuals far beyond the sightings' noise, or a sideways
/// acceleration.
fn straight_decel(fit: &Fit, v: [f64; 2], c: &SurfaceConfig) -> Option<(f64, f64)> {
    if fit.chi2_dof > c.max_chi2_dof {
        return None;
    }
    let speed = v[0].hypot(v[1]);
    let u = [v[0] / speed, v[1] / speed];
    let decel = -(fit.a[0] * u[0] + fit.a[1] * u[1]);
    let var = fit.var_a[0] * u[0] * u[0] + fit.var_a[1] * u[1] * u[1];
    let side = fit.a[1] * u[0] - fit.a[0] * u[1];
    let var_side = fit.var_a[0] * u[1] * u[1] + fit.var_a[1] * u[0] * u[0];
    if side.abs() > 3.0 * var_side.sqrt() + c.max_side_accel_mps2 {
        return None;
    }
    Some((decel, var))
}

/// Restitution and (when the ball came in at a slant) tangential retention, each with its
/// variance, from the fits before and after a bounce; none when they do not describe one
/// bounce at the wall.
#[allow(clippy::type_complexity)]
fn bounce_sample(
    b: &PendingBounce,
    after: &Fit,
    c: &SurfaceConfig,
) -> Option<(((f64, f64), Option<(f64, f64)>), (f64, f64))> {
    let (k, j) = (b.axis, 1 - b.axis);
    let before = &b.before;
    // Where the two normal tracks cross, near the predicted bounce (τ = 0).
    let dv = before.v[k] - after.v[k];
    if dv.abs() < 1e-6 {
        return None;
    }
    let tau = (after.p[k] - before.p[k]) / dv;
    if tau.abs() > c.bounce_max_shift_s {
        return None;
    }
    let at = before.position_at(tau);
    if (at[k] - b.wall_m).abs() > c.bounce_max_offset_m {
        return None;
    }
    let v_in = before.velocity_at(tau);
    let v_out = after.velocity_at(tau);
    // In towards the wall, out away from it.
    if v_in[k] * b.inward <= 0.0 || v_out[k] * b.inward >= 0.0 {
        return None;
    }
    if v_in[k].abs() < c.bounce_min_speed_mps {
        return None;
    }
    let e = -v_out[k] / v_in[k];
    let var_e = (after.var_v[k] + e * e * before.var_v[k]) / (v_in[k] * v_in[k]);
    let tangential = (v_in[j].abs() >= c.bounce_min_speed_mps).then(|| {
        let r = v_out[j] / v_in[j];
        let var = (after.var_v[j] + r * r * before.var_v[j]) / (v_in[j] * v_in[j]);
        (r, var)
    });
    // Where the centre turned, and how well the two fits place it.
    let var_at = before.var_p[k] + after.var_p[k];
    Some((((e, var_e), tangential), (at[k], var_at)))
}

mod slide_end;
#[cfg(test)]
mod tests;
