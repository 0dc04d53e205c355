//! Plain 3D vectors over `[f64; 3]` and 3×3 rotations, for the camera renderer.
//!
//! The renderer needs a handful of operations only; a linear-algebra crate would be a
//! heavier dependency than the code it saves.

pub type V3 = [f64; 3];

/// A 3×3 matrix, row-major: `m[row][col]`.
pub type Mat3 = [[f64; 3]; 3];

pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn scale(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}

pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// Unit vector along `a`, or `a` itself when it is (almost) zero.
pub fn unit(a: V3) -> V3 {
    let n = norm(a);
    if n > 1e-300 { scale(a, 1.0 / n) } else { a }
}

/// `m · v`.
pub fn mul_vec(m: &Mat3, v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// `a · b`.
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    out
}

pub fn transpose(m: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (r, row) in m.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            out[c][r] = *v;
        }
    }
    out
}

/// Rotation about x by `a` (right-handed: y turns towards z).
pub fn rot_x(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

/// Rotation about y by `a` (right-handed: z turns towards x, so x turns towards −z).
pub fn rot_y(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

/// Rotation about z by `a` (right-handed: x turns towards y).
pub fn rot_z(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: V3, b: V3) -> bool {
        norm(sub(a, b)) < 1e-12
    }

    #[test]
    fn rotations_follow_the_right_hand_rule() {
        let h = std::f64::consts::FRAC_PI_2;
        assert!(close(mul_vec(&rot_z(h), [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]));
        assert!(close(mul_vec(&rot_y(h), [1.0, 0.0, 0.0]), [0.0, 0.0, -1.0]));
        assert!(close(mul_vec(&rot_x(h), [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]));
        assert!(close(
            cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            [0.0, 0.0, 1.0]
        ));
    }

    #[test]
    fn transpose_inverts_a_rotation() {
        let r = mul(&rot_z(0.3), &mul(&rot_y(-0.7), &rot_x(1.1)));
        let p = mul(&transpose(&r), &r);
        for (i, row) in p.iter().enumerate() {
            assert!(close(*row, IDENTITY[i]));
        }
        assert!(close(unit([3.0, 0.0, 4.0]), [0.6, 0.0, 0.8]));
        assert!(close(
            add([1.0, 2.0, 3.0], scale([1.0, 1.0, 1.0], 2.0)),
            [3.0, 4.0, 5.0]
        ));
    }
}
