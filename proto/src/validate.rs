//! Validation of inbound messages at the boundary, with one error kind per way of being wrong.

use crate::keys::is_valid_id;
use crate::{BallState, Observation, Pitch, Prediction, RobotStatus, Stamp, VERSION};
use thiserror::Error;

/// Why an inbound message was rejected. `reason()` gives a stable label for metrics.
#[derive(Debug, Error, PartialEq)]
pub enum ValidationError {
    #[error("unsupported version {found} (expected {expected})")]
    UnsupportedVersion { found: u32, expected: u32 },
    #[error("field {field} is not finite")]
    NonFinite { field: &'static str },
    #[error("robot id {0:?} is not 1..=64 characters of A-Z a-z 0-9 _ -")]
    BadRobotId(String),
    #[error("covariance {field} is not symmetric")]
    CovarianceNotSymmetric { field: &'static str },
    #[error("covariance {field} is not positive definite")]
    CovarianceNotPositiveDefinite { field: &'static str },
    #[error("confidence {0} is outside 0..=1")]
    ConfidenceOutOfRange(f64),
    #[error("position ({x_m:.2}, {y_m:.2}) m is {outside_m:.2} m outside the pitch")]
    OutsidePitch { x_m: f64, y_m: f64, outside_m: f64 },
    #[error("stamp is {skew_s:.3} s from the receiver's clock (limit {limit_s} s)")]
    StampOutOfRange { skew_s: f64, limit_s: f64 },
    #[error("field {field} is out of range: {value}")]
    OutOfRange { field: &'static str, value: f64 },
    #[error("field {field} has {count} entries (limit {limit})")]
    TooMany {
        field: &'static str,
        count: usize,
        limit: usize,
    },
    #[error("field {field} is {bytes} bytes long (limit {limit})")]
    TooLong {
        field: &'static str,
        bytes: usize,
        limit: usize,
    },
    #[error("{0}")]
    NotAnImage(&'static str),
}

/// Most stage timings a [`RobotStatus`] may carry.
pub const MAX_STATUS_TIMINGS: usize = 32;
/// Longest stage name of a timing, in bytes.
pub const MAX_STAGE_NAME_BYTES: usize = 64;
/// Most camera footprints a [`RobotStatus`] may carry.
pub const MAX_STATUS_FOOTPRINTS: usize = 4;
/// Most corners of one footprint polygon.
pub const MAX_FOOTPRINT_POINTS: usize = 64;

impl ValidationError {
    /// A short stable label for counting rejections by reason.
    pub fn reason(&self) -> &'static str {
        match self {
            ValidationError::UnsupportedVersion { .. } => "version",
            ValidationError::NonFinite { .. } => "non_finite",
            ValidationError::BadRobotId(_) => "robot_id",
            ValidationError::CovarianceNotSymmetric { .. } => "covariance_asymmetric",
            ValidationError::CovarianceNotPositiveDefinite { .. } => "covariance_not_pd",
            ValidationError::ConfidenceOutOfRange(_) => "confidence",
            ValidationError::OutsidePitch { .. } => "outside_pitch",
            ValidationError::StampOutOfRange { .. } => "stamp",
            ValidationError::OutOfRange { .. } => "out_of_range",
            ValidationError::TooMany { .. } => "too_many",
            ValidationError::TooLong { .. } => "too_long",
            ValidationError::NotAnImage(_) => "not_jpeg",
        }
    }
}

/// What the receiver knows when it validates: the pitch, its own clock, and its tolerances.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationContext {
    pub pitch: Pitch,
    /// The receiver's clock at reception, passed in (validation never reads a clock).
    pub now: Stamp,
    /// Largest accepted |stamp − now|.
    pub max_clock_skew_s: f64,
    /// Largest accepted distance of a position outside the pitch rectangle.
    pub max_outside_m: f64,
}

impl ValidationContext {
    pub fn new(pitch: Pitch, now: Stamp) -> Self {
        ValidationContext {
            pitch,
            now,
            max_clock_skew_s: 10.0,
            max_outside_m: 1.0,
        }
    }

    pub(crate) fn check_stamp(&self, stamp: Stamp) -> Result<(), ValidationError> {
        let skew_s = stamp.secs_since(self.now);
        if skew_s.abs() > self.max_clock_skew_s {
            return Err(ValidationError::StampOutOfRange {
                skew_s,
                limit_s: self.max_clock_skew_s,
            });
        }
        Ok(())
    }

    fn check_position(&self, p: [f64; 2]) -> Result<(), ValidationError> {
        let outside_m = self.pitch.outside_distance_m(p);
        if outside_m > self.max_outside_m {
            return Err(ValidationError::OutsidePitch {
                x_m: p[0],
                y_m: p[1],
                outside_m,
            });
        }
        Ok(())
    }
}

/// Checks an inbound message against the receiver's context.
pub trait Validate {
    fn validate(&self, ctx: &ValidationContext) -> Result<(), ValidationError>;
}

pub(crate) fn check_version(found: u32) -> Result<(), ValidationError> {
    if found != VERSION {
        return Err(ValidationError::UnsupportedVersion {
            found,
            expected: VERSION,
        });
    }
    Ok(())
}

pub(crate) fn check_finite(field: &'static str, values: &[f64]) -> Result<(), ValidationError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(ValidationError::NonFinite { field })
    }
}

pub(crate) fn check_robot_id(id: &str) -> Result<(), ValidationError> {
    if is_valid_id(id) {
        Ok(())
    } else {
        Err(ValidationError::BadRobotId(id.to_string()))
    }
}

/// Symmetric (to a relative tolerance) and positive definite (Cholesky succeeds).
fn check_covariance<const N: usize>(field: &'static str, m: &[f64]) -> Result<(), ValidationError> {
    check_finite(field, m)?;
    let scale = m.iter().fold(0.0_f64, |a, v| a.max(v.abs())).max(1e-300);
    for i in 0..N {
        for j in (i + 1)..N {
            if (m[i * N + j] - m[j * N + i]).abs() > 1e-9 * scale {
                return Err(ValidationError::CovarianceNotSymmetric { field });
            }
        }
    }
    // Cholesky on the lower triangle.
    let mut l = [[0.0_f64; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let mut sum = m[i * N + j];
            for (lik, ljk) in l[i][..j].iter().zip(&l[j][..j]) {
                sum -= lik * ljk;
            }
            if i == j {
                if sum <= 0.0 || !sum.is_finite() {
                    return Err(ValidationError::CovarianceNotPositiveDefinite { field });
                }
                l[i][i] = sum.sqrt();
            } else {
                l[i][j] = sum / l[j][j];
            }
        }
    }
    Ok(())
}

pub(crate) fn check_count(
    field: &'static str,
    count: usize,
    limit: usize,
) -> Result<(), ValidationError> {
    if count <= limit {
        Ok(())
    } else {
        Err(ValidationError::TooMany {
            field,
            count,
            limit,
        })
    }
}

/// The caps on every variable-length field of a status, checked first (cheapest, and a
/// huge status must not cost a walk over its contents).
fn check_status_sizes(s: &RobotStatus) -> Result<(), ValidationError> {
    check_count("timings", s.timings.len(), MAX_STATUS_TIMINGS)?;
    if let Some(t) = s
        .timings
        .iter()
        .find(|t| t.stage.len() > MAX_STAGE_NAME_BYTES)
    {
        return Err(ValidationError::TooLong {
            field: "timings.stage",
            bytes: t.stage.len(),
            limit: MAX_STAGE_NAME_BYTES,
        });
    }
    check_count("footprints", s.footprints.len(), MAX_STATUS_FOOTPRINTS)?;
    check_count("cameras", s.cameras.len(), MAX_STATUS_FOOTPRINTS)?;
    for f in &s.footprints {
        check_count(
            "footprints.polygon_m",
            f.polygon_m.len(),
            MAX_FOOTPRINT_POINTS,
        )?;
    }
    Ok(())
}

pub(crate) fn check_range(
    field: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
) -> Result<(), ValidationError> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(ValidationError::OutOfRange { field, value })
    }
}

impl Validate for Observation {
    fn validate(&self, ctx: &ValidationContext) -> Result<(), ValidationError> {
        check_version(self.version)?;
        check_robot_id(&self.robot_id)?;
        check_finite("position_m", &self.position_m)?;
        check_finite("confidence", &[self.confidence])?;
        let pose = &self.robot_pose;
        check_finite("robot_pose", &[pose.x_m, pose.y_m, pose.theta_rad])?;
        if let Some(px) = &self.pixel {
            check_finite("pixel", &[px.u_px, px.v_px, px.radius_px])?;
        }
        check_covariance::<2>("covariance_m2", &self.covariance_m2)?;
        if !(0.0..=1.0).contains(&self.confidence) {
            return Err(ValidationError::ConfidenceOutOfRange(self.confidence));
        }
        ctx.check_position(self.position_m)?;
        ctx.check_position([pose.x_m, pose.y_m])?;
        ctx.check_stamp(self.stamp)
    }
}

impl Validate for RobotStatus {
    fn validate(&self, ctx: &ValidationContext) -> Result<(), ValidationError> {
        check_version(self.version)?;
        check_robot_id(&self.robot_id)?;
        check_status_sizes(self)?;
        let pose = &self.pose;
        check_finite("pose", &[pose.x_m, pose.y_m, pose.theta_rad])?;
        let head = &self.head;
        check_finite("head", &[head.lift_rad, head.yaw_rad, head.pitch_rad])?;
        check_finite("fps", &[self.fps])?;
        for t in &self.timings {
            check_finite("timings", &[t.ms])?;
            check_range("timings", t.ms, 0.0, 1e6)?;
        }
        for c in &self.cameras {
            c.validate()?;
        }
        for f in &self.footprints {
            for p in &f.polygon_m {
                check_finite("footprints", p)?;
            }
        }
        check_covariance::<3>("pose_covariance", &self.pose_covariance)?;
        check_range("fps", self.fps, 0.0, 1e4)?;
        ctx.check_position([pose.x_m, pose.y_m])?;
        ctx.check_stamp(self.stamp)
    }
}

impl Validate for Prediction {
    fn validate(&self, ctx: &ValidationContext) -> Result<(), ValidationError> {
        check_version(self.version)?;
        check_finite("horizon_s", &[self.horizon_s])?;
        check_range("horizon_s", self.horizon_s, 0.0, 3600.0)?;
        for s in &self.samples {
            check_finite("samples", &[s.t_s, s.position_m[0], s.position_m[1]])?;
            check_finite("samples", &s.velocity_mps)?;
            if let Some(c) = &s.covariance_m2 {
                check_covariance::<2>("samples.covariance_m2", c)?;
            }
            ctx.check_position(s.position_m)?;
        }
        for b in &self.bounces {
            check_finite("bounces", &[b.t_s, b.position_m[0], b.position_m[1]])?;
        }
        if let Some(stop) = &self.stop {
            check_finite("stop", &[stop.t_s, stop.position_m[0], stop.position_m[1]])?;
            check_range("stop.t_s", stop.t_s, 0.0, 3600.0)?;
            if let Some(c) = &stop.covariance_m2 {
                check_covariance::<2>("stop.covariance_m2", c)?;
            }
        }
        ctx.check_stamp(self.stamp)
    }
}

impl Validate for BallState {
    fn validate(&self, ctx: &ValidationContext) -> Result<(), ValidationError> {
        check_version(self.version)?;
        check_finite("position_m", &self.position_m)?;
        check_finite("velocity_mps", &self.velocity_mps)?;
        check_covariance::<4>("covariance", &self.covariance)?;
        for id in &self.contributors {
            check_robot_id(id)?;
        }
        check_finite("existence", &[self.existence])?;
        check_range("existence", self.existence, 0.0, 1.0)?;
        let m = &self.model;
        check_finite(
            "model",
            &[
                m.rolling_decel_mps2,
                m.wall_restitution,
                m.tangential_retention,
                m.slide_decel_mps2,
            ],
        )?;
        check_range("model.wall_restitution", m.wall_restitution, 0.0, 1.0)?;
        check_range(
            "model.tangential_retention",
            m.tangential_retention,
            0.0,
            1.0,
        )?;
        check_range("model.slide_decel_mps2", m.slide_decel_mps2, 0.0, 100.0)?;
        check_range("model.rolling_decel_mps2", m.rolling_decel_mps2, 0.0, 100.0)?;
        ctx.check_position(self.position_m)?;
        ctx.check_stamp(self.stamp)?;
        self.prediction.validate(ctx)
    }
}

impl Validate for Pitch {
    fn validate(&self, _ctx: &ValidationContext) -> Result<(), ValidationError> {
        check_version(self.version)?;
        check_finite(
            "pitch",
            &[
                self.length_m,
                self.width_m,
                self.wall_restitution,
                self.ball_radius_m,
            ],
        )?;
        check_range("length_m", self.length_m, 0.1, 1000.0)?;
        check_range("width_m", self.width_m, 0.1, 1000.0)?;
        check_range("wall_restitution", self.wall_restitution, 0.0, 1.0)?;
        check_range("ball_radius_m", self.ball_radius_m, 0.001, 0.5)?;
        check_range(
            "ball_radius_m",
            2.0 * self.ball_radius_m,
            0.0,
            self.length_m.min(self.width_m),
        )
    }
}
