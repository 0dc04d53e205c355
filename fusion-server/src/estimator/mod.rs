//! The fusion core: a covariance-weighted Kalman filter over many robots' observations,
//! with a motion model that knows rolling friction and the pitch walls.
//!
//! - [`motion`]: closed-form ball flight with constant deceleration, stop, wall bounces.
//! - [`filter`]: one extended Kalman filter over [x, y, vx, vy, decel, restitution].
//! - [`tracker`]: hypotheses, gating, promotion, per-robot trust.
//! - [`fusion`]: capture-time ordering, the late-observation window, the public API.
//! - [`surface`]: the floor's decelerations and the walls' restitution, learned from every
//!   stretch and bounce the estimate is seen through.
//! - [`views`]: the robots' camera footprints, and a ball in view that is not seen.
//! - [`predict`]: path, bounces, stop point; [`spread`]: how sure each predicted point and
//!   the stop are, scaled by what [`calibration`] learns from the core's own forecasts;
//!   [`intercept`]: where a robot meets the ball.

pub mod calibration;
pub mod filter;
pub mod fusion;
pub mod intercept;
pub mod motion;
pub mod predict;
pub mod spread;
pub mod surface;
pub mod tracker;
pub mod views;

pub use fusion::{Fusion, FusionConfig, FusionCounters, Ingest, ViewReport};
pub use motion::{Bounds, MotionModel};
pub use tracker::{MotionEvent, MotionEventKind};
