//! Small builders for Foxglove's primitives: colours, poses, lines and covariance ellipses.

use foxglove::messages::{
    Color, LinePrimitive, Point3, Pose, Quaternion, Timestamp, Vector3, line_primitive,
};
use proto::Stamp;

/// Points on a drawn ellipse.
const ELLIPSE_POINTS: usize = 36;

pub fn timestamp(stamp: Stamp) -> Timestamp {
    let sec = u32::try_from(stamp.0 / 1_000_000_000).unwrap_or(u32::MAX);
    Timestamp::new(sec, (stamp.0 % 1_000_000_000) as u32)
}

pub const fn rgba(r: f64, g: f64, b: f64, a: f64) -> Color {
    Color { r, g, b, a }
}

pub fn point(x: f64, y: f64, z: f64) -> Point3 {
    Point3 { x, y, z }
}

pub fn vector(x: f64, y: f64, z: f64) -> Vector3 {
    Vector3 { x, y, z }
}

/// A pose at `(x, y, z)` turned by `yaw_rad` about z.
pub fn pose(x: f64, y: f64, z: f64, yaw_rad: f64) -> Pose {
    let half = yaw_rad / 2.0;
    Pose {
        position: Some(vector(x, y, z)),
        orientation: Some(Quaternion {
            x: 0.0,
            y: 0.0,
            z: half.sin(),
            w: half.cos(),
        }),
    }
}

/// A pose at `(x, y, z)` with x along `direction` (any 3-vector, not zero).
pub fn pose_along(x: f64, y: f64, z: f64, direction: [f64; 2]) -> Pose {
    pose(x, y, z, direction[1].atan2(direction[0]))
}

pub fn identity() -> Pose {
    pose(0.0, 0.0, 0.0, 0.0)
}

/// A line through `points` at height `z_m`: a strip, or a loop when `closed`.
pub fn line(
    points: &[[f64; 2]],
    z_m: f64,
    closed: bool,
    thickness_m: f64,
    color: Color,
) -> LinePrimitive {
    let kind = if closed {
        line_primitive::Type::LineLoop
    } else {
        line_primitive::Type::LineStrip
    };
    LinePrimitive {
        r#type: kind as i32,
        pose: Some(identity()),
        thickness: thickness_m,
        scale_invariant: false,
        points: points.iter().map(|p| point(p[0], p[1], z_m)).collect(),
        color: Some(color),
        colors: Vec::new(),
        indices: Vec::new(),
    }
}

/// The `k_sigma` ellipse of a 2×2 covariance (row-major) around `centre`, as points; none
/// when the matrix is not a usable covariance.
pub fn ellipse(centre: [f64; 2], cov: [f64; 4], k_sigma: f64) -> Option<Vec<[f64; 2]>> {
    let (a, b, d) = (cov[0], 0.5 * (cov[1] + cov[2]), cov[3]);
    if !(a.is_finite() && b.is_finite() && d.is_finite()) {
        return None;
    }
    // Eigenvalues of [[a, b], [b, d]] and the direction of the larger one.
    let mean = 0.5 * (a + d);
    let spread = (0.25 * (a - d).powi(2) + b * b).sqrt();
    let (l1, l2) = (mean + spread, mean - spread);
    if l2 < 0.0 || l1 <= 0.0 {
        return None;
    }
    let angle = 0.5 * (2.0 * b).atan2(a - d);
    let (r1, r2) = (k_sigma * l1.sqrt(), k_sigma * l2.sqrt());
    let (c, s) = (angle.cos(), angle.sin());
    Some(
        (0..ELLIPSE_POINTS)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / ELLIPSE_POINTS as f64;
                let (u, v) = (r1 * t.cos(), r2 * t.sin());
                [centre[0] + c * u - s * v, centre[1] + s * u + c * v]
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_ellipse_has_its_axes_along_the_covariance() {
        // σx = 0.2, σy = 0.1: the 2σ ellipse reaches 0.4 along x and 0.2 along y.
        let e = ellipse([1.0, -1.0], [0.04, 0.0, 0.0, 0.01], 2.0).expect("usable");
        let max_x = e.iter().map(|p| p[0] - 1.0).fold(f64::MIN, f64::max);
        let max_y = e.iter().map(|p| p[1] + 1.0).fold(f64::MIN, f64::max);
        assert!((max_x - 0.4).abs() < 1e-9, "{max_x}");
        assert!((max_y - 0.2).abs() < 0.01, "{max_y}");
        // Rotated 45°: the long axis along x = y.
        let e = ellipse([0.0, 0.0], [0.025, 0.015, 0.015, 0.025], 1.0).expect("usable");
        let far = e
            .iter()
            .max_by(|p, q| p[0].hypot(p[1]).total_cmp(&q[0].hypot(q[1])))
            .expect("points");
        assert!((far[0].abs() - far[1].abs()).abs() < 1e-9 && far[0] * far[1] > 0.0);
        assert!((far[0].hypot(far[1]) - 0.2).abs() < 1e-9);
    }

    #[test]
    fn unusable_covariances_draw_nothing() {
        assert!(ellipse([0.0, 0.0], [f64::NAN, 0.0, 0.0, 1.0], 2.0).is_none());
        assert!(ellipse([0.0, 0.0], [1.0, 2.0, 2.0, 1.0], 2.0).is_none());
        assert!(ellipse([0.0, 0.0], [-1.0, 0.0, 0.0, -1.0], 2.0).is_none());
    }

    #[test]
    fn stamps_become_seconds_and_nanoseconds() {
        let t = timestamp(Stamp(1_700_000_000_123_456_789));
        assert_eq!((t.sec(), t.nsec()), (1_700_000_000, 123_456_789));
    }
}
