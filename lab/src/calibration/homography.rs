//! Plane-to-image homographies and the closed-form start of a camera calibration: the
//! normalised direct linear transform, Zhang's intrinsics from several homographies of a
//! planar target, and a board's pose from one homography.
//!
//! Z. Zhang, "A flexible new technique for camera calibration", IEEE TPAMI 22(11), 2000;
//! R. Hartley, "In defense of the eight-point algorithm", IEEE TPAMI 19(6), 1997.

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};

/// Two singular values of the DLT system this far apart (relative to the largest) mean the
/// points do not determine a homography: fewer than four in general position.
const RANK_TOLERANCE: f64 = 1e-9;

/// The similarity that moves points to their centroid and scales their mean distance from
/// it to √2 (Hartley's normalisation), or `None` if all points coincide.
fn normalisation(points: &[[f64; 2]]) -> Option<Matrix3<f64>> {
    let n = points.len() as f64;
    let mean = points
        .iter()
        .fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    let spread = points
        .iter()
        .map(|p| (p[0] - mean[0]).hypot(p[1] - mean[1]))
        .sum::<f64>()
        / n;
    if !(spread > 0.0 && spread.is_finite()) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / spread;
    Some(Matrix3::new(
        s,
        0.0,
        -s * mean[0],
        0.0,
        s,
        -s * mean[1],
        0.0,
        0.0,
        1.0,
    ))
}

fn transform(h: &Matrix3<f64>, p: [f64; 2]) -> [f64; 2] {
    let q = h * Vector3::new(p[0], p[1], 1.0);
    [q[0] / q[2], q[1] / q[2]]
}

/// Applies a homography to a point; `None` if it maps to infinity.
pub fn apply(h: &Matrix3<f64>, p: [f64; 2]) -> Option<[f64; 2]> {
    let q = transform(h, p);
    q.iter().all(|v| v.is_finite()).then_some(q)
}

/// The homography H with dst ≃ H src, by the normalised DLT (least squares on the
/// algebraic error), scaled so that H₃₃ = 1 where possible.
///
/// `None` with fewer than four correspondences, when the points are degenerate (collinear
/// or coincident, so that the solution is not unique) or when the result is singular.
pub fn fit_homography(src: &[[f64; 2]], dst: &[[f64; 2]]) -> Option<Matrix3<f64>> {
    if src.len() != dst.len() || src.len() < 4 {
        return None;
    }
    let ts = normalisation(src)?;
    let td = normalisation(dst)?;
    let rows = (2 * src.len()).max(9);
    let mut a = DMatrix::<f64>::zeros(rows, 9);
    for (k, (s, d)) in src.iter().zip(dst).enumerate() {
        let [x, y] = transform(&ts, *s);
        let [u, v] = transform(&td, *d);
        let r = 2 * k;
        for (c, value) in [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u]
            .iter()
            .enumerate()
        {
            a[(r, c)] = *value;
        }
        for (c, value) in [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, -v]
            .iter()
            .enumerate()
        {
            a[(r + 1, c)] = *value;
        }
    }
    let svd = a.svd(false, true);
    let v_t = svd.v_t.as_ref()?;
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    let largest = svd.singular_values[order[order.len() - 1]];
    if svd.singular_values[order[1]] <= RANK_TOLERANCE * largest {
        return None;
    }
    let h = v_t.row(order[0]);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let h = td.try_inverse()? * hn * ts;
    let scale = if h[(2, 2)].abs() > 1e-12 * h.norm() {
        h[(2, 2)]
    } else {
        h.norm()
    };
    let h = h / scale;
    (h.iter().all(|v| v.is_finite()) && h.determinant().abs() > 1e-15 * h.norm().powi(3))
        .then_some(h)
}

/// The pose of a plane (z = 0 in its own frame) from the homography H ≃ [r₁ r₂ t] that maps
/// its points to normalised image coordinates: the rotation as an axis-angle vector
/// (radians) and the translation, both taking plane coordinates to the camera frame. The
/// sign is chosen to put the plane in front of the camera and the rotation is the nearest
/// true rotation to [r₁ r₂ r₁×r₂].
pub fn pose_from_homography(h: &Matrix3<f64>) -> Option<([f64; 3], [f64; 3])> {
    let (h1, h2, h3) = (h.column(0), h.column(1), h.column(2));
    let mut lambda = 2.0 / (h1.norm() + h2.norm());
    if h3[2] < 0.0 {
        lambda = -lambda;
    }
    let r1 = h1 * lambda;
    let r2 = h2 * lambda;
    let t = h3 * lambda;
    let r3 = r1.cross(&r2);
    let m = Matrix3::from_columns(&[r1.into_owned(), r2.into_owned(), r3]);
    let svd = m.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        return None;
    }
    if !r.iter().all(|v| v.is_finite()) {
        return None;
    }
    r = Rotation3::from_matrix_unchecked(r).into_inner();
    let axis = Rotation3::from_matrix_unchecked(r).scaled_axis();
    Some(([axis[0], axis[1], axis[2]], [t[0], t[1], t[2]]))
}

/// The pixel scaling used to condition the intrinsics solutions: pixel offsets from the
/// image centre divided by the larger image side.
fn conditioning(width_px: f64, height_px: f64) -> (Matrix3<f64>, f64) {
    let s = width_px.max(height_px);
    let t = Matrix3::new(
        1.0 / s,
        0.0,
        -0.5 * (width_px - 1.0) / s,
        0.0,
        1.0 / s,
        -0.5 * (height_px - 1.0) / s,
        0.0,
        0.0,
        1.0,
    );
    (t, s)
}

/// Zhang's closed-form intrinsics [fx, fy, cx, cy] (pixels) from the homographies of three
/// or more views of a plane, with zero skew imposed (one more linear constraint on the
/// image of the absolute conic B). `None` with fewer than three views, or when B is not
/// positive definite (noise, distortion or near-parallel views).
pub fn zhang_intrinsics(
    homographies: &[Matrix3<f64>],
    width_px: f64,
    height_px: f64,
) -> Option<[f64; 4]> {
    if homographies.len() < 3 {
        return None;
    }
    let (t, s) = conditioning(width_px, height_px);
    let mut v = DMatrix::<f64>::zeros(2 * homographies.len() + 1, 6);
    for (k, h) in homographies.iter().enumerate() {
        let h = t * h;
        let h = h / h.norm();
        let vij = |i: usize, j: usize| {
            let (a, b) = (h.column(i), h.column(j));
            [
                a[0] * b[0],
                a[0] * b[1] + a[1] * b[0],
                a[1] * b[1],
                a[2] * b[0] + a[0] * b[2],
                a[2] * b[1] + a[1] * b[2],
                a[2] * b[2],
            ]
        };
        let (v12, v11, v22) = (vij(0, 1), vij(0, 0), vij(1, 1));
        for c in 0..6 {
            v[(2 * k, c)] = v12[c];
            v[(2 * k + 1, c)] = v11[c] - v22[c];
        }
    }
    // Zero skew: B₁₂ = 0, weighted like the other rows.
    v[(2 * homographies.len(), 1)] = 1.0;
    let svd = v.svd(false, true);
    let v_t = svd.v_t.as_ref()?;
    let smallest = svd.singular_values.imin();
    let b = v_t.row(smallest);
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let denominator = b11 * b22 - b12 * b12;
    let v0 = (b12 * b13 - b11 * b23) / denominator;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda * b11 / denominator).sqrt();
    let u0 = -b13 * alpha * alpha / lambda;
    let k = [alpha * s, beta * s, u0 * s, v0 * s];
    let k = [
        k[0],
        k[1],
        k[2] + 0.5 * (width_px - 1.0),
        k[3] + 0.5 * (height_px - 1.0),
    ];
    (k.iter().all(|x| x.is_finite()) && k[0] > 0.0 && k[1] > 0.0).then_some(k)
}

/// Focal lengths [fx, fy, cx, cy] from homographies with the principal point fixed at the
/// image centre and zero skew: the two orthogonality constraints of each view are linear
/// in 1/fx² and 1/fy². Works from one view and is what to fall back on when
/// [`zhang_intrinsics`] fails.
pub fn centred_intrinsics(
    homographies: &[Matrix3<f64>],
    width_px: f64,
    height_px: f64,
) -> Option<[f64; 4]> {
    let (t, s) = conditioning(width_px, height_px);
    let mut a = DMatrix::<f64>::zeros(2 * homographies.len(), 2);
    let mut rhs = DMatrix::<f64>::zeros(2 * homographies.len(), 1);
    for (k, h) in homographies.iter().enumerate() {
        let h = t * h;
        let h = h / h.norm();
        let (h1, h2) = (h.column(0), h.column(1));
        a[(2 * k, 0)] = h1[0] * h2[0];
        a[(2 * k, 1)] = h1[1] * h2[1];
        rhs[(2 * k, 0)] = -h1[2] * h2[2];
        a[(2 * k + 1, 0)] = h1[0] * h1[0] - h2[0] * h2[0];
        a[(2 * k + 1, 1)] = h1[1] * h1[1] - h2[1] * h2[1];
        rhs[(2 * k + 1, 0)] = -(h1[2] * h1[2] - h2[2] * h2[2]);
    }
    let solution = a.svd(true, true).solve(&rhs, 1e-12).ok()?;
    let (inv_fx2, inv_fy2) = (solution[(0, 0)], solution[(1, 0)]);
    let focal = |inv: f64| (inv > 0.0).then(|| s / inv.sqrt());
    let (fx, fy) = match (focal(inv_fx2), focal(inv_fy2)) {
        (Some(fx), Some(fy)) => (fx, fy),
        // One axis poorly constrained: assume square pixels.
        (Some(f), None) | (None, Some(f)) => (f, f),
        (None, None) => return None,
    };
    let k = [fx, fy, 0.5 * (width_px - 1.0), 0.5 * (height_px - 1.0)];
    k.iter().all(|x| x.is_finite()).then_some(k)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn recovers_a_homography_and_rejects_collinear_points() {
        let h = Matrix3::new(1.2, 0.1, 30.0, -0.05, 0.9, 12.0, 1e-4, 2e-4, 1.0);
        let src: Vec<[f64; 2]> = (0..12)
            .map(|k| [f64::from(k % 4) * 10.0, f64::from(k / 4) * 7.0])
            .collect();
        let dst: Vec<[f64; 2]> = src.iter().map(|p| apply(&h, *p).unwrap()).collect();
        let fitted = fit_homography(&src, &dst).unwrap();
        assert!((fitted - h).norm() < 1e-9 * h.norm());
        let line: Vec<[f64; 2]> = (0..6).map(|k| [f64::from(k), 2.0 * f64::from(k)]).collect();
        assert!(fit_homography(&line, &line).is_none());
        assert!(fit_homography(&src[..3], &dst[..3]).is_none());
    }
}
