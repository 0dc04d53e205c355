//! Plain 2D vector helpers over `[f64; 2]` (the wire's representation of floor points).

use std::f64::consts::{PI, TAU};

pub type V2 = [f64; 2];

pub fn add(a: V2, b: V2) -> V2 {
    [a[0] + b[0], a[1] + b[1]]
}

pub fn sub(a: V2, b: V2) -> V2 {
    [a[0] - b[0], a[1] - b[1]]
}

pub fn scale(a: V2, k: f64) -> V2 {
    [a[0] * k, a[1] * k]
}

/// `a + k·b`.
pub fn axpy(a: V2, k: f64, b: V2) -> V2 {
    [a[0] + k * b[0], a[1] + k * b[1]]
}

pub fn dot(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

pub fn norm(a: V2) -> f64 {
    a[0].hypot(a[1])
}

pub fn dist(a: V2, b: V2) -> f64 {
    norm(sub(a, b))
}

/// Unit vector along `a`, or `fallback` when `a` is (almost) zero.
pub fn unit_or(a: V2, fallback: V2) -> V2 {
    let n = norm(a);
    if n > 1e-12 {
        scale(a, 1.0 / n)
    } else {
        fallback
    }
}

/// The unit vector at angle `theta` from +x.
pub fn from_angle(theta: f64) -> V2 {
    let (s, c) = theta.sin_cos();
    [c, s]
}

pub fn angle(a: V2) -> f64 {
    a[1].atan2(a[0])
}

/// `a` rotated counter-clockwise by `theta`.
pub fn rotate(a: V2, theta: f64) -> V2 {
    let (s, c) = theta.sin_cos();
    [c * a[0] - s * a[1], s * a[0] + c * a[1]]
}

/// `a` rotated by +90°.
pub fn perp(a: V2) -> V2 {
    [-a[1], a[0]]
}

pub fn lerp(a: V2, b: V2, f: f64) -> V2 {
    [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f]
}

/// An angle wrapped into (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let mut w = a % TAU;
    if w > PI {
        w -= TAU;
    } else if w <= -PI {
        w += TAU;
    }
    w
}

/// Interpolates angles along the shorter arc.
pub fn lerp_angle(a: f64, b: f64, f: f64) -> f64 {
    wrap_angle(a + wrap_angle(b - a) * f)
}

/// Distance from `p` to the segment `a`–`b`, and where along it (0..1) the closest point is.
pub fn segment_distance(a: V2, b: V2, p: V2) -> (f64, f64) {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let f = if len2 > 0.0 {
        (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (dist(axpy(a, f, ab), p), f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_and_angles() {
        let r = rotate([1.0, 0.0], PI / 2.0);
        assert!((r[0]).abs() < 1e-12 && (r[1] - 1.0).abs() < 1e-12);
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-3.5 * PI) - 0.5 * PI).abs() < 1e-12);
        assert!((lerp_angle(3.0, -3.0, 0.5).abs() - PI).abs() < 1e-9);
        assert_eq!(perp([1.0, 2.0]), [-2.0, 1.0]);
    }

    #[test]
    fn segment_distance_clamps_to_the_ends() {
        let (d, f) = segment_distance([0.0, 0.0], [2.0, 0.0], [1.0, 0.5]);
        assert!((d - 0.5).abs() < 1e-12 && (f - 0.5).abs() < 1e-12);
        let (d, f) = segment_distance([0.0, 0.0], [2.0, 0.0], [3.0, 0.0]);
        assert!((d - 1.0).abs() < 1e-12 && f == 1.0);
        assert_eq!(unit_or([0.0, 0.0], [1.0, 0.0]), [1.0, 0.0]);
    }
}
