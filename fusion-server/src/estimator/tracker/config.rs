//! The tracker's settings.

use crate::estimator::filter::ProcessNoise;
use crate::estimator::motion::MotionModel;
use crate::estimator::surface::SurfaceConfig;
use crate::estimator::views::ViewConfig;

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
    /// A sighting no track accepts restarts a hypothesis seen once, up to this long before,
    /// as a ball moving from that sighting to this one (two-point initiation), if the speed
    /// that implies is at most `pair_max_speed_mps`; the closest such pairing wins...
    pub pair_max_dt_s: f64,
    pub pair_max_speed_mps: f64,
    /// ... and its velocity has this much uncertainty beyond the two sightings' own.
    pub pair_velocity_slack_mps: f64,
    pub max_tracks: usize,
    /// A hypothesis with no observation for this long is dropped.
    pub candidate_ttl_s: f64,
    /// Support is counted over this recent window, stretched to hold `promote_min_hits`
    /// frames of the slowest robot that saw the hypothesis, up to `promote_window_max_s`.
    pub promote_window_s: f64,
    pub promote_window_max_s: f64,
    pub promote_min_hits: usize,
    /// One robot alone confirms a first hypothesis with as many sightings as it captures
    /// frames in this time (at least `promote_min_hits`, at most twice that)...
    pub lone_confirm_s: f64,
    /// ... or takes over from a silent estimate with as many as it captures in this time...
    pub lone_takeover_s: f64,
    /// ... seen in at least this share of the frames it captured since its first sighting.
    pub lone_min_detection_ratio: f64,
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
    /// no robot reports, or too softly for the gate to refuse): its velocity is
    /// re-initialised from them and it gets the same extra process noise as after a takeover.
    pub surprises_for_kick: usize,
    /// Two surprising updates whose d² sum to this are already a clear kick.
    pub onset_chi2: f64,
    /// A change of course at a wall, in the way a bounce changes it, is a bounce the flight
    /// did not foresee rather than a kick ([`super::at_wall`]).
    pub bounces_at_walls: bool,
    /// Learn the floor's decelerations / the walls' restitution and tangential retention
    /// from the estimate's stretches and bounces ([`SurfaceConfig`]); off, the base model's
    /// values are used as they are.
    pub learn_decel: bool,
    pub learn_restitution: bool,
    pub surface: SurfaceConfig,
    /// After a kick or a bounce the ball slides: its filter does not learn the rolling
    /// deceleration then...
    pub learn_quiet_s: f64,
    /// ... nor below this speed (the stop dominates).
    pub learn_min_speed_mps: f64,
    /// Base motion model; its deceleration and restitution are the starting values.
    pub motion: MotionModel,
    pub noise: ProcessNoise,
    /// Extra white-acceleration density per (m/s)² of speed.
    pub accel_speed_gain: f64,
    /// White-acceleration density near robots and just after a kick.
    pub near_robot_accel_m2ps3: f64,
    /// EWMA weight of one observation in a robot's trust estimate.
    pub trust_alpha: f64,
    pub trust_range: (f64, f64),
    /// Negative information from the robots' camera footprints.
    pub views: ViewConfig,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        TrackerConfig {
            gate_chi2: 11.83,
            max_innovation_m: 0.6,
            spawn_velocity_sigma_mps: 1.5,
            pair_max_dt_s: 0.45,
            pair_max_speed_mps: 8.0,
            pair_velocity_slack_mps: 0.3,
            max_tracks: 6,
            candidate_ttl_s: 0.6,
            promote_window_s: 0.4,
            promote_window_max_s: 1.0,
            promote_min_hits: 3,
            lone_confirm_s: 0.3,
            lone_takeover_s: 0.25,
            lone_min_detection_ratio: 0.75,
            main_silence_s: 0.5,
            outlier_rate_max: 0.1,
            near_robot_m: 0.4,
            kick_boost_s: 0.2,
            surprise_chi2: 5.99,
            surprises_for_kick: 3,
            onset_chi2: 24.0,
            bounces_at_walls: true,
            learn_decel: true,
            learn_restitution: true,
            surface: SurfaceConfig::default(),
            learn_quiet_s: 0.4,
            learn_min_speed_mps: 0.12,
            motion: MotionModel::default(),
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
            views: ViewConfig::default(),
        }
    }
}
