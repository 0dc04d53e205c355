//! A deterministic simulated robot-football world, for scoring the team ball filter
//! against ground truth.
//!
//! The world is deliberately not the filter's model: the ball skids then rolls with drag,
//! every wall bounce draws its own restitution, robot bodies deflect it, and observers
//! report the way a MiRo's agent would (two outward-looking cameras, range-dependent noise
//! along the view ray, a wandering self-localisation error, occlusion, false positives from
//! other robots' white tops, dropouts, out-of-order latency). Same (scenario, seed, config)
//! → the same run, bit for bit; there are no clock reads, time is simulated.
//!
//! `run_scenario` produces a whole `SimRun`; `World` steps the same world incrementally for
//! a live caller. [`camera_footprints`] gives the floor each observing camera reports the
//! ball from (field of view, the detector's range, bodies in the way) through the instants
//! a simulated robot's status speaks for. [`render_robot_cameras`] draws what a MiRo's
//! cameras see through the sim's own fisheye [`LensModel`] (placed by the [`default_head`]
//! chain), with per-frame ball ground truth; [`calibration_views`] renders chessboard views
//! with their true corners; [`synth_photo`] makes randomised labelled photos of a ball
//! through a cheap camera. [`score()`] scores a method's estimates against a run's ground
//! truth; [`TruthLogBuilder`] carries a run's ground truth through a match log and rebuilds
//! the run.
//! This crate never depends on `fusion-server`.
//!
//! This root is the crate's front door: the modules behind it are private.
//!
//! ```
//! use sim::{SimConfig, run_scenario};
//!
//! // The seed's first scenario, two seconds of it: the same seed gives the same run.
//! let cfg = SimConfig { duration_s: Some(2.0), ..SimConfig::default() };
//! let run = run_scenario("seed-1-across", 7, &cfg).expect("a known scenario");
//! assert!(!run.truth.is_empty() && !run.deliveries.is_empty());
//! let again = run_scenario("seed-1-across", 7, &cfg).expect("a known scenario");
//! assert_eq!(run.deliveries.len(), again.deliveries.len());
//! assert!(run_scenario("no-such-scenario", 7, &cfg).is_err());
//! ```

mod camera_effects;
mod camera_world;
mod chessboard;
mod footprint;
mod head;
mod kicks;
mod latency;
mod lens;
mod noise;
mod observer;
mod photo_shapes;
mod photo_synth;
mod physics;
mod render;
mod render_objects;
mod render_scene;
mod rng;
mod robots;
mod run;
mod scenario;
mod score;
mod seed_scenarios;
mod truth_log;
mod types;
mod vec2;
mod vec3;
mod world;

#[cfg(test)]
mod observation_tests;
#[cfg(test)]
mod render_tests;
#[cfg(test)]
mod scenario_tests;
#[cfg(test)]
mod truth_log_tests;

pub use camera_world::{CameraWorld, CameraWorldConfig, patterned_ball};
pub use chessboard::{Chessboard, calibration_views, render_chessboard};
pub use footprint::{Moment, camera_footprints};
pub use head::default_head;
pub use latency::LatencyProfile;
pub use lens::LensModel;
pub use photo_shapes::erase_box;
pub use photo_synth::{Background, BallDesign, PhotoProfile, SynthPhoto, synth_photo};
pub use render::{CameraRig, render_robot_cameras};
pub use render_scene::{BallLook, BallPattern, BallTruth, Frame, Lighting, RobotBody, Scene};
pub use rng::Rng;
pub use run::{SimRun, run_scenario};
pub use score::{
    BOUNCE_LOOKAHEAD_S, HORIZONS_S, Samples, Spread, Summary, TICK_S, TickRecord, horizon_key,
    mean, quantile, rms, score, tick_count, tick_times_s,
};
pub use truth_log::{
    TOPICS as TRUTH_TOPICS, TruthLogBuilder, TruthLogError, truth_messages, truth_schemas,
};
pub use types::{
    BallEvent, BallPhase, Delivery, ObsKind, RobotTrack, SimStats, TrueParams, TruthSample,
};
pub use world::World;

/// Public constants of the world's models, for documentation and evaluation code.
pub mod model {
    pub use crate::latency::{BASE_RANGE_S, CAP_S, JITTER_MEAN_S};
    pub use crate::noise::{
        CAMERA_HEIGHT_M, CAMERA_YAW_RAD, HALF_FOV_RAD, MAX_RANGE_M, MIN_RANGE_M,
        POSE_SIGMA_THETA_RAD, POSE_SIGMA_XY_M, POSE_TAU_S, SIGMA_AZIM_RAD, SIGMA_ELEV_RAD,
        detection_probability_at,
    };
    pub use crate::observer::{DROPOUT_P, FRAME_RATE_HZ, PHANTOM_P};
    pub use crate::physics::{BOUNCE_RESLIDE_RATIO, ROBOT_RESTITUTION, SLIDE_TO_ROLL_RATIO};
    pub use crate::robots::{MAX_SPEED_MPS, ROBOT_RADIUS_M};
}

use proto::{Pitch, Stamp};
use thiserror::Error;

/// The seed dissertation's six scenarios (one observer).
pub const SEED_SCENARIOS: [&str; 6] = [
    "seed-1-across",
    "seed-2-away",
    "seed-3-towards",
    "seed-4-front",
    "seed-5-behind",
    "seed-6-front-diagonal",
];

/// Team scenarios (three to five moving observers).
pub const TEAM_SCENARIOS: [&str; 7] = [
    "team-rally",
    "corner",
    "occluded-pass",
    "phantom",
    "late-packets",
    "kick-restart",
    "match",
];

/// The seed's lone robot with a slow perception loop (5 Hz, 10 Hz).
pub const SLOW_ROBOT_SCENARIOS: [&str; 2] = ["single-slow-robot", "single-slow-robot-10hz"];

/// Every scenario name, seed scenarios first.
pub fn scenario_names() -> Vec<&'static str> {
    SEED_SCENARIOS
        .iter()
        .chain(TEAM_SCENARIOS.iter())
        .chain(SLOW_ROBOT_SCENARIOS.iter())
        .copied()
        .collect()
}

/// How to run the world.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    pub pitch: Pitch,
    /// Physics step (the ball's integration is exact within a step; 1 ms keeps robot
    /// contacts from tunnelling).
    pub physics_dt_s: f64,
    /// Rate of the recorded ground truth.
    pub truth_rate_hz: f64,
    /// Fraction of observers (rounded down) whose reported covariance is scaled by ¼ or 4,
    /// alternately, while their actual noise is unchanged.
    pub misreport_fraction: f64,
    /// 0 = synchronised clocks; else each robot's clock offset is uniform in ±this.
    pub clock_offset_max_s: f64,
    /// Overrides the scenario's length (`match` defaults to 60 s).
    pub duration_s: Option<f64>,
    /// Epoch of t = 0.
    pub start: Stamp,
    /// Robots in a `match` (default five); other scenarios have their own cast.
    pub team_size: Option<usize>,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            pitch: Pitch::default(),
            physics_dt_s: 0.001,
            truth_rate_hz: 100.0,
            misreport_fraction: 0.25,
            clock_offset_max_s: 0.0,
            duration_s: None,
            // 2026-01-01T00:00:00Z.
            start: Stamp(1_767_225_600 * 1_000_000_000),
            team_size: None,
        }
    }
}

impl SimConfig {
    fn check(&self) -> Result<(), SimError> {
        let bad = |what: &str| Err(SimError::InvalidConfig(what.to_string()));
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !(positive(self.physics_dt_s) && self.physics_dt_s <= 0.01) {
            return bad("physics_dt_s must be in (0, 0.01]");
        }
        if !positive(self.truth_rate_hz) {
            return bad("truth_rate_hz must be positive");
        }
        if self.team_size.is_some_and(|n| !(1..=32).contains(&n)) {
            return bad("team_size must be in 1..=32");
        }
        if !(0.0..=1.0).contains(&self.misreport_fraction) {
            return bad("misreport_fraction must be in 0..=1");
        }
        if !(self.clock_offset_max_s.is_finite() && self.clock_offset_max_s >= 0.0) {
            return bad("clock_offset_max_s must be ≥ 0");
        }
        if let Some(d) = self.duration_s
            && !(d.is_finite() && d >= 0.0)
        {
            return bad("duration_s must be ≥ 0");
        }
        let p = &self.pitch;
        if !(positive(p.length_m) && positive(p.width_m) && positive(p.ball_radius_m)) {
            return bad("pitch sizes must be positive");
        }
        Ok(())
    }
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimError {
    #[error("unknown scenario {name:?} (known: {})", known.join(", "))]
    UnknownScenario {
        name: String,
        known: Vec<&'static str>,
    },
    #[error("invalid sim config: {0}")]
    InvalidConfig(String),
}
