//! Checks shared by the validation tests: each puts one kind of fault into a sound message
//! and asserts the exact `ValidationError` that comes back.

use super::examples::{NOW, ctx};
use proto::{Pitch, Stamp, Validate, ValidationContext, ValidationError};
use std::fmt::Debug;

pub const NON_FINITE: [f64; 3] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];

/// A setter that puts a value into one float of a message.
pub type SetF64<T> = fn(&mut T, f64);
/// An accessor for a message's row-major covariance.
pub type Cov<T> = fn(&mut T) -> &mut [f64];

pub fn assert_rejected<T: Validate + Debug>(msg: &T, ctx: &ValidationContext, reason: &str) {
    match msg.validate(ctx) {
        Err(e) => assert_eq!(e.reason(), reason, "{e} for {msg:?}"),
        Ok(()) => panic!("accepted, expected {reason}: {msg:?}"),
    }
}

pub fn assert_accepted<T: Validate + Debug>(msg: &T, ctx: &ValidationContext) {
    if let Err(e) = msg.validate(ctx) {
        panic!("rejected ({e}): {msg:?}");
    }
}

/// NaN, +inf and −inf in each float: rejected as `NonFinite` naming the field group.
pub fn check_non_finite<T: Validate + Clone + Debug>(base: &T, cases: &[(&str, SetF64<T>)]) {
    for (field, set) in cases {
        for bad in NON_FINITE {
            let mut msg = base.clone();
            set(&mut msg, bad);
            match msg.validate(&ctx()) {
                Err(ValidationError::NonFinite { field: f }) => {
                    assert_eq!(f, *field, "{bad} in {field}")
                }
                other => panic!("{bad} in {field}: {other:?}"),
            }
        }
    }
}

/// Asymmetric, indefinite, negative, zero and singular covariances are rejected; rounding
/// noise in the symmetry is not.
pub fn check_covariance<T: Validate + Clone + Debug>(base: &T, field: &str, n: usize, cov: Cov<T>) {
    let expect =
        |msg: &T, want: fn(&ValidationError) -> bool, what: &str| match msg.validate(&ctx()) {
            Err(e) if want(&e) => assert!(e.to_string().contains(field), "{e}"),
            other => panic!("{field} {what}: {other:?}"),
        };
    let asym = |e: &ValidationError| matches!(e, ValidationError::CovarianceNotSymmetric { .. });
    let not_pd =
        |e: &ValidationError| matches!(e, ValidationError::CovarianceNotPositiveDefinite { .. });

    let mut msg = base.clone();
    cov(&mut msg)[1] += 1e-3;
    expect(&msg, asym, "not symmetric");

    let mut msg = base.clone();
    cov(&mut msg)[n] *= 1.0 + 1e-12;
    assert_accepted(&msg, &ctx());

    let mut msg = base.clone();
    cov(&mut msg)[0] = -1e-3;
    expect(&msg, not_pd, "negative first diagonal");

    let mut msg = base.clone();
    let m = cov(&mut msg);
    m[n * n - 1] = -m[n * n - 1];
    expect(&msg, not_pd, "negative last diagonal");

    let mut msg = base.clone();
    cov(&mut msg).fill(0.0);
    expect(&msg, not_pd, "zero");

    // Symmetric with positive diagonal but indefinite: eigenvalues include −1e-3.
    let mut msg = base.clone();
    let m = cov(&mut msg);
    m.fill(0.0);
    for i in 0..n {
        m[i * n + i] = 1e-3;
    }
    m[1] = 2e-3;
    m[n] = 2e-3;
    expect(&msg, not_pd, "indefinite");

    // Positive semi-definite but singular (all ones, rank 1).
    let mut msg = base.clone();
    cov(&mut msg).fill(1.0);
    expect(&msg, not_pd, "singular");

    for bad in NON_FINITE {
        let mut msg = base.clone();
        cov(&mut msg)[n + 1] = bad;
        match msg.validate(&ctx()) {
            Err(ValidationError::NonFinite { field: f }) => assert_eq!(f, field),
            other => panic!("{bad} in {field}: {other:?}"),
        }
    }
}

/// A position a little beyond the tolerance is rejected, one a little within it accepted,
/// on the x side, the y side and diagonally past a corner.
pub fn check_position<T: Validate + Clone + Debug>(base: &T, set: fn(&mut T, [f64; 2])) {
    let pitch = Pitch::default();
    let (hx, hy) = (pitch.half_length_m(), pitch.half_width_m());
    let tol = ctx().max_outside_m;
    assert_eq!(tol, 1.0, "default tolerance");
    for (p, ok) in [
        ([hx + tol - 0.01, 0.0], true),
        ([hx + tol + 0.01, 0.0], false),
        ([-(hx + tol - 0.01), 0.0], true),
        ([-(hx + tol + 0.01), 0.0], false),
        ([0.0, hy + tol - 0.01], true),
        ([0.0, -(hy + tol + 0.01)], false),
        ([hx + 0.7, hy + 0.7], true),   // 0.99 m from the corner
        ([hx + 0.8, -hy - 0.8], false), // 1.13 m from the corner
        ([1e12, 0.0], false),
    ] {
        let mut msg = base.clone();
        set(&mut msg, p);
        if ok {
            assert_accepted(&msg, &ctx());
        } else {
            match msg.validate(&ctx()) {
                Err(ValidationError::OutsidePitch {
                    x_m,
                    y_m,
                    outside_m,
                }) => {
                    assert_eq!([x_m, y_m], p);
                    assert!(outside_m > tol);
                }
                other => panic!("{p:?}: {other:?}"),
            }
        }
    }
    // The tolerance is the receiver's to choose.
    let strict = ValidationContext {
        max_outside_m: 0.0,
        ..ctx()
    };
    let mut msg = base.clone();
    set(&mut msg, [hx + 0.01, 0.0]);
    assert_rejected(&msg, &strict, "outside_pitch");
}

/// Stamps more than the allowed skew before or after `now` are rejected.
pub fn check_stamp<T: Validate + Clone + Debug>(base: &T, set: fn(&mut T, Stamp)) {
    let limit = ctx().max_clock_skew_s;
    assert_eq!(limit, 10.0, "default skew");
    for (dt_s, ok) in [
        (-9.9, true),
        (9.9, true),
        (-10.1, false),
        (10.1, false),
        (-1e6, false),
    ] {
        let mut msg = base.clone();
        set(&mut msg, NOW.offset_secs(dt_s));
        if ok {
            assert_accepted(&msg, &ctx());
        } else {
            match msg.validate(&ctx()) {
                Err(ValidationError::StampOutOfRange { skew_s, limit_s }) => {
                    assert!((skew_s - dt_s).abs() < 1e-6, "{skew_s} vs {dt_s}");
                    assert_eq!(limit_s, limit);
                }
                other => panic!("{dt_s} s: {other:?}"),
            }
        }
    }
    for stamp in [Stamp(0), Stamp(u64::MAX)] {
        let mut msg = base.clone();
        set(&mut msg, stamp);
        assert_rejected(&msg, &ctx(), "stamp");
    }
}

pub fn check_version<T: Validate + Clone + Debug>(base: &T, set: fn(&mut T, u32)) {
    for found in [0, 2, u32::MAX] {
        let mut msg = base.clone();
        set(&mut msg, found);
        assert_eq!(
            msg.validate(&ctx()),
            Err(ValidationError::UnsupportedVersion {
                found,
                expected: proto::VERSION
            })
        );
    }
}

pub fn check_robot_id<T: Validate + Clone + Debug>(base: &T, set: fn(&mut T, String)) {
    let long = "m".repeat(65);
    for bad in ["", "miro 1", "a/b", "*", "**", "é", long.as_str()] {
        let mut msg = base.clone();
        set(&mut msg, bad.to_string());
        assert_eq!(
            msg.validate(&ctx()),
            Err(ValidationError::BadRobotId(bad.to_string()))
        );
    }
    for good in ["a", "MiRo_07-b", &"m".repeat(64)] {
        let mut msg = base.clone();
        set(&mut msg, good.to_string());
        assert_accepted(&msg, &ctx());
    }
}

pub fn check_out_of_range<T: Validate + Clone + Debug>(
    base: &T,
    cases: &[(&'static str, f64, SetF64<T>)],
) {
    for (field, value, set) in cases {
        let mut msg = base.clone();
        set(&mut msg, *value);
        assert_eq!(
            msg.validate(&ctx()),
            Err(ValidationError::OutOfRange {
                field,
                value: *value
            }),
            "{field} = {value}"
        );
    }
}
