//! The non-linear refinement of a calibration: Levenberg–Marquardt over the intrinsics,
//! the distortion and every view's pose, minimising the squared reprojection error.
//!
//! The parameter vector is the intrinsics block (fx, fy, cx, cy, then the distortion
//! coefficients) followed by six parameters per view (axis-angle rotation in radians,
//! translation in board units), both taking board coordinates to the camera frame. Each
//! view's residuals depend only on the intrinsics and its own pose, so the normal equations
//! are assembled block by block from per-view Jacobians, taken by central differences.

use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

/// Which distortion model the intrinsics block carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Lens {
    /// fx, fy, cx, cy, k1, k2, p1, p2, k3.
    BrownConrady,
    /// fx, fy, cx, cy, k1, k2, k3, k4.
    KannalaBrandt,
}

/// Most Levenberg–Marquardt iterations.
const MAX_ITERATIONS: usize = 200;
/// Stop when an accepted step lowers the cost by less than this fraction.
const COST_TOLERANCE: f64 = 1e-12;

/// Projects a board point through a pose and the intrinsics, without the validity checks
/// of [`vision::camera::CameraModel::project`]: the optimiser must see a finite, smooth
/// residual even at a poor starting point.
pub(crate) fn project(
    lens: Lens,
    intrinsics: &[f64],
    rotation: &Rotation3<f64>,
    translation: &Vector3<f64>,
    point: [f64; 3],
) -> [f64; 2] {
    let p = rotation * Vector3::new(point[0], point[1], point[2]) + translation;
    let (fx, fy, cx, cy) = (intrinsics[0], intrinsics[1], intrinsics[2], intrinsics[3]);
    let d = &intrinsics[4..];
    let m = match lens {
        Lens::BrownConrady => {
            let (x, y) = (p[0] / p[2], p[1] / p[2]);
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
            [
                x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x),
                y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y,
            ]
        }
        Lens::KannalaBrandt => {
            let rho = p[0].hypot(p[1]);
            let theta = rho.atan2(p[2]);
            let t2 = theta * theta;
            let theta_d = theta * (1.0 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))));
            if rho > 1e-12 {
                [theta_d * p[0] / rho, theta_d * p[1] / rho]
            } else {
                [p[0] / p[2], p[1] / p[2]]
            }
        }
    };
    [fx * m[0] + cx, fy * m[1] + cy]
}

/// The residuals (projected − observed, pixels; u then v per point) of one view.
pub(crate) fn view_residuals(
    lens: Lens,
    intrinsics: &[f64],
    pose: &[f64; 6],
    object: &[[f64; 3]],
    observed: &[[f64; 2]],
) -> Vec<f64> {
    let rotation = Rotation3::new(Vector3::new(pose[0], pose[1], pose[2]));
    let translation = Vector3::new(pose[3], pose[4], pose[5]);
    object
        .iter()
        .zip(observed)
        .flat_map(|(x, o)| {
            let p = project(lens, intrinsics, &rotation, &translation, *x);
            [p[0] - o[0], p[1] - o[1]]
        })
        .collect()
}

/// The root-mean-square point error of one view, pixels: √(mean of squared distances).
pub(crate) fn view_rms_px(
    lens: Lens,
    intrinsics: &[f64],
    pose: &[f64; 6],
    object: &[[f64; 3]],
    observed: &[[f64; 2]],
) -> f64 {
    let r = view_residuals(lens, intrinsics, pose, object, observed);
    (r.iter().map(|v| v * v).sum::<f64>() / object.len().max(1) as f64).sqrt()
}

/// A calibration problem: the board's points and each view's observed corners.
#[derive(Debug)]
pub(crate) struct Problem<'a> {
    pub lens: Lens,
    pub object: &'a [[f64; 3]],
    pub views: Vec<&'a [[f64; 2]]>,
    /// Indices of intrinsics held at their starting values.
    pub fixed: &'a [usize],
}

impl Problem<'_> {
    fn cost(&self, intrinsics: &[f64], poses: &[[f64; 6]]) -> f64 {
        self.views
            .iter()
            .zip(poses)
            .flat_map(|(o, pose)| view_residuals(self.lens, intrinsics, pose, self.object, o))
            .map(|v| v * v)
            .sum()
    }

    /// Refines intrinsics and poses from a starting point; returns the refined values.
    pub(crate) fn refine(
        &self,
        mut intrinsics: Vec<f64>,
        mut poses: Vec<[f64; 6]>,
    ) -> (Vec<f64>, Vec<[f64; 6]>) {
        let ni = intrinsics.len();
        let n = ni + 6 * poses.len();
        let mut cost = self.cost(&intrinsics, &poses);
        if !cost.is_finite() {
            return (intrinsics, poses);
        }
        let mut damping = 1e-3;
        for _ in 0..MAX_ITERATIONS {
            let (a, g) = self.normal_equations(&intrinsics, &poses, n);
            let mut accepted = false;
            while damping < 1e12 {
                let mut m = a.clone();
                for k in 0..n {
                    m[(k, k)] += damping * a[(k, k)].max(1e-9);
                }
                let Some(step) = m.cholesky().map(|c| c.solve(&(-&g))) else {
                    damping *= 4.0;
                    continue;
                };
                let mut trial_i = intrinsics.clone();
                for (k, v) in trial_i.iter_mut().enumerate() {
                    *v += step[k];
                }
                let mut trial_p = poses.clone();
                for (v, pose) in trial_p.iter_mut().enumerate() {
                    for (k, x) in pose.iter_mut().enumerate() {
                        *x += step[ni + 6 * v + k];
                    }
                }
                let trial_cost = self.cost(&trial_i, &trial_p);
                if trial_cost.is_finite() && trial_cost < cost {
                    let decrease = (cost - trial_cost) / cost.max(f64::MIN_POSITIVE);
                    intrinsics = trial_i;
                    poses = trial_p;
                    cost = trial_cost;
                    damping = (damping / 3.0).max(1e-12);
                    accepted = decrease > COST_TOLERANCE;
                    break;
                }
                damping *= 4.0;
            }
            if !accepted {
                break;
            }
        }
        (intrinsics, poses)
    }

    /// JᵀJ and Jᵀr, assembled from each view's Jacobian blocks.
    fn normal_equations(
        &self,
        intrinsics: &[f64],
        poses: &[[f64; 6]],
        n: usize,
    ) -> (DMatrix<f64>, DVector<f64>) {
        let ni = intrinsics.len();
        let mut a = DMatrix::<f64>::zeros(n, n);
        let mut g = DVector::<f64>::zeros(n);
        for (v, (observed, pose)) in self.views.iter().zip(poses).enumerate() {
            let r = view_residuals(self.lens, intrinsics, pose, self.object, observed);
            let mut columns: Vec<Vec<f64>> = Vec::with_capacity(ni + 6);
            for k in 0..ni {
                let h = 1e-6 * (1.0 + intrinsics[k].abs());
                let mut plus = intrinsics.to_vec();
                let mut minus = intrinsics.to_vec();
                plus[k] += h;
                minus[k] -= h;
                let rp = view_residuals(self.lens, &plus, pose, self.object, observed);
                let rm = view_residuals(self.lens, &minus, pose, self.object, observed);
                columns.push(
                    rp.iter()
                        .zip(&rm)
                        .map(|(p, m)| (p - m) / (2.0 * h))
                        .collect(),
                );
            }
            for k in 0..6 {
                let h = 1e-6 * (1.0 + pose[k].abs());
                let (mut plus, mut minus) = (*pose, *pose);
                plus[k] += h;
                minus[k] -= h;
                let rp = view_residuals(self.lens, intrinsics, &plus, self.object, observed);
                let rm = view_residuals(self.lens, intrinsics, &minus, self.object, observed);
                columns.push(
                    rp.iter()
                        .zip(&rm)
                        .map(|(p, m)| (p - m) / (2.0 * h))
                        .collect(),
                );
            }
            // Global index of local column c.
            let index = |c: usize| if c < ni { c } else { ni + 6 * v + (c - ni) };
            for (c1, col1) in columns.iter().enumerate() {
                g[index(c1)] += col1.iter().zip(&r).map(|(j, r)| j * r).sum::<f64>();
                for (c2, col2) in columns.iter().enumerate().skip(c1) {
                    let dot: f64 = col1.iter().zip(col2).map(|(x, y)| x * y).sum();
                    a[(index(c1), index(c2))] += dot;
                    if c1 != c2 {
                        a[(index(c2), index(c1))] += dot;
                    }
                }
            }
        }
        // Held parameters get a unit diagonal and no coupling, so their step is zero.
        for &k in self.fixed.iter().filter(|&&k| k < ni) {
            for j in 0..n {
                a[(k, j)] = 0.0;
                a[(j, k)] = 0.0;
            }
            a[(k, k)] = 1.0;
            g[k] = 0.0;
        }
        (a, g)
    }
}
