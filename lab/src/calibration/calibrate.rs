//! Camera calibration from views of a planar chessboard (Zhang's method): a homography
//! per view, a closed-form start for the intrinsics and the poses, then Levenberg–Marquardt
//! over every parameter (see [`crate::calibration::bundle`]) minimising the reprojection error.
//!
//! Two lens models are fitted: Brown–Conrady (k1, k2, p1, p2, k3) for ordinary lenses and
//! Kannala–Brandt (k1…k4) for fisheyes. Zhang's pinhole start is poor for a fisheye, whose
//! image of a plane is far from a homography, so there the start is the equidistant model
//! (r = f θ) centred on the image with the focal length chosen by a search that makes every
//! view's board the most nearly planar.
//!
//! Views that cannot be used are kept in the result with the reason: board not found,
//! wrong number of corners, a degenerate homography, or a reprojection error that is an
//! outlier after a first fit (more than 3× the median and more than 1 px), in which case
//! the calibration is fitted again without them. Errors are reported like OpenCV's: the
//! root of the mean squared point error, per view and over all used points.

use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

pub use robot_agent::{Calibration, CalibrationError, ViewResult};

use crate::calibration::bundle::{self, Lens, Problem};
use crate::calibration::chessboard::{ChessboardError, find_chessboard};
use crate::calibration::homography;
use vision::camera::{CameraModel, Distortion, Intrinsics};
use vision::image::gray::GrayImage;

/// A view whose error exceeds this multiple of the median is an outlier…
const OUTLIER_RATIO: f64 = 3.0;
/// …provided it also exceeds this many pixels.
const OUTLIER_FLOOR_PX: f64 = 1.0;
/// Fewest usable views.
const MIN_VIEWS: usize = 2;

/// A chessboard: inner corners per row and per column, and the side of a square.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Board {
    /// Inner corners along a row.
    pub cols: usize,
    /// Inner corners along a column.
    pub rows: usize,
    /// Side of a square, metres.
    pub square_m: f64,
}

impl Board {
    /// The inner corners in the board's frame (metres, z = 0), in the detector's row-major
    /// order: corner (c, r) at (c·s, r·s, 0).
    pub fn object_points_m(&self) -> Vec<[f64; 3]> {
        (0..self.rows)
            .flat_map(|r| (0..self.cols).map(move |c| (c, r)))
            .map(|(c, r)| [c as f64 * self.square_m, r as f64 * self.square_m, 0.0])
            .collect()
    }
}

/// Which lens model to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LensModel {
    /// Pinhole with Brown–Conrady distortion.
    BrownConrady,
    /// Kannala–Brandt fisheye.
    KannalaBrandt,
}

/// One input view: its name and its detected corners (or why there are none).
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// A name to report it by, such as the file name.
    pub name: String,
    /// The board's inner corners in the image, pixels, in [`Board::object_points_m`] order.
    pub corners_px: Result<Vec<[f64; 2]>, ChessboardError>,
}

/// Detects the board in named images: the first half of a calibration from images.
pub fn detect_views(images: &[(String, GrayImage)], board: &Board) -> Vec<View> {
    images
        .iter()
        .map(|(name, image)| View {
            name: name.clone(),
            corners_px: find_chessboard(image, board.cols, board.rows),
        })
        .collect()
}

/// A view that passed the checks: its index among the inputs, its corners and homography.
struct Usable<'a> {
    index: usize,
    corners_px: &'a [[f64; 2]],
    homography: Matrix3<f64>,
}

/// Calibrates a camera of `width_px × height_px` from views of `board`, fitting every
/// distortion coefficient of `lens_model`.
#[cfg(test)]
pub fn calibrate(
    views: &[View],
    board: &Board,
    width_px: u32,
    height_px: u32,
    lens_model: LensModel,
) -> Result<Calibration, CalibrationError> {
    calibrate_with(views, board, width_px, height_px, lens_model, 4)
}

/// [`calibrate`], fitting only the first `fisheye_terms` (1 to 4) Kannala–Brandt
/// coefficients and holding the others at zero (like OpenCV's `FIX_K3`/`FIX_K4`).
///
/// Boards rarely reach a fisheye's image corners, where the higher terms are free to bend
/// the model away from the lens; fewer terms extrapolate more faithfully there. The
/// argument does not affect Brown–Conrady.
pub fn calibrate_with(
    views: &[View],
    board: &Board,
    width_px: u32,
    height_px: u32,
    lens_model: LensModel,
    fisheye_terms: usize,
) -> Result<Calibration, CalibrationError> {
    check_input(board, width_px, height_px, fisheye_terms)?;
    let lens = match lens_model {
        LensModel::BrownConrady => Lens::BrownConrady,
        LensModel::KannalaBrandt => Lens::KannalaBrandt,
    };
    let object = board.object_points_m();
    let plane: Vec<[f64; 2]> = object.iter().map(|p| [p[0], p[1]]).collect();
    let mut per_view: Vec<ViewResult> = views
        .iter()
        .map(|v| ViewResult {
            name: v.name.clone(),
            rms_px: None,
            used: false,
            reason: None,
            rotation_rad: None,
            translation_m: None,
        })
        .collect();
    let mut usable = usable_views(views, &object, &plane, &mut per_view);
    if usable.len() < MIN_VIEWS {
        return Err(CalibrationError::TooFewViews {
            usable: usable.len(),
            needed: MIN_VIEWS,
        });
    }
    let (w, h) = (f64::from(width_px), f64::from(height_px));
    let (mut intrinsics, poses) = match lens {
        Lens::BrownConrady => pinhole_start(&usable, w, h)?,
        Lens::KannalaBrandt => fisheye_start(&usable, &plane, w, h)?,
    };
    // Kannala–Brandt's k1..k4 are intrinsics 4..8.
    let fixed: Vec<usize> = match lens {
        Lens::KannalaBrandt => (4 + fisheye_terms..8).collect(),
        Lens::BrownConrady => Vec::new(),
    };
    for &k in &fixed {
        intrinsics[k] = 0.0;
    }
    let fit = Fit {
        lens,
        object: &object,
        fixed: &fixed,
    };
    let (intrinsics, poses) =
        fit.refine_without_outliers(&mut usable, intrinsics, poses, &mut per_view);
    fit.finish(&usable, &intrinsics, &poses, per_view, width_px, height_px)
}

/// The flags a calibration is asked with, checked.
fn check_input(
    board: &Board,
    width_px: u32,
    height_px: u32,
    fisheye_terms: usize,
) -> Result<(), CalibrationError> {
    if !(1..=4).contains(&fisheye_terms) {
        return Err(CalibrationError::InvalidInput(format!(
            "{fisheye_terms} fisheye terms (1 to 4)"
        )));
    }
    if !(board.square_m > 0.0 && board.square_m.is_finite()) || board.cols * board.rows < 4 {
        return Err(CalibrationError::InvalidInput(format!("board {board:?}")));
    }
    if width_px == 0 || height_px == 0 {
        return Err(CalibrationError::InvalidInput("empty image".into()));
    }
    Ok(())
}

/// The views whose board was found whole, with their homographies; each other view's
/// reason in `per_view`.
fn usable_views<'a>(
    views: &'a [View],
    object: &[[f64; 3]],
    plane: &[[f64; 2]],
    per_view: &mut [ViewResult],
) -> Vec<Usable<'a>> {
    let mut usable = Vec::new();
    for (index, view) in views.iter().enumerate() {
        let reason = match &view.corners_px {
            Err(e) => Some(format!("board not found: {e}")),
            Ok(c) if c.len() != object.len() => Some(format!(
                "{} corners, the board has {}",
                c.len(),
                object.len()
            )),
            Ok(c) => match homography::fit_homography(plane, c) {
                None => Some("degenerate homography".to_string()),
                Some(homography) => {
                    usable.push(Usable {
                        index,
                        corners_px: c,
                        homography,
                    });
                    None
                }
            },
        };
        per_view[index].reason = reason;
    }
    usable
}

/// One calibration's fixed parts: the lens, the board's points and the intrinsics held at 0.
struct Fit<'a> {
    lens: Lens,
    object: &'a [[f64; 3]],
    fixed: &'a [usize],
}

impl Fit<'_> {
    /// Fits, drops the outlying views (their reasons in `per_view`), and fits again until
    /// none is left or too few views would remain.
    fn refine_without_outliers(
        &self,
        usable: &mut Vec<Usable<'_>>,
        mut intrinsics: Vec<f64>,
        mut poses: Vec<[f64; 6]>,
        per_view: &mut [ViewResult],
    ) -> (Vec<f64>, Vec<[f64; 6]>) {
        let (lens, object, fixed) = (self.lens, self.object, self.fixed);
        // Fit, drop outliers, fit again until none is left.
        loop {
            let problem = Problem {
                lens,
                object,
                views: usable.iter().map(|u| u.corners_px).collect(),
                fixed,
            };
            (intrinsics, poses) = problem.refine(intrinsics, poses);
            let errors: Vec<f64> = usable
                .iter()
                .zip(&poses)
                .map(|(u, pose)| bundle::view_rms_px(lens, &intrinsics, pose, object, u.corners_px))
                .collect();
            let mut sorted = errors.clone();
            sorted.sort_by(f64::total_cmp);
            let median = sorted[sorted.len() / 2];
            let limit = (OUTLIER_RATIO * median).max(OUTLIER_FLOOR_PX);
            for (u, e) in usable.iter().zip(&errors) {
                per_view[u.index].rms_px = Some(*e);
            }
            let keep: Vec<bool> = errors.iter().map(|e| *e <= limit).collect();
            if keep.iter().all(|k| *k) || keep.iter().filter(|k| **k).count() < MIN_VIEWS {
                break;
            }
            for (u, e) in usable.iter().zip(&errors) {
                if *e > limit {
                    per_view[u.index].reason = Some(format!(
                        "reprojection error {e:.2} px is an outlier (median {median:.2} px)"
                    ));
                }
            }
            let mut k = keep.iter();
            usable.retain(|_| k.next().copied().unwrap_or(false));
            let mut k = keep.iter();
            poses.retain(|_| k.next().copied().unwrap_or(false));
        }
        (intrinsics, poses)
    }

    /// The calibration from the final fit: the used views' errors and poses, the overall
    /// reprojection error, and the camera model checked.
    fn finish(
        &self,
        usable: &[Usable<'_>],
        intrinsics: &[f64],
        poses: &[[f64; 6]],
        mut per_view: Vec<ViewResult>,
        width_px: u32,
        height_px: u32,
    ) -> Result<Calibration, CalibrationError> {
        let (lens, object) = (self.lens, self.object);
        let mut squared = 0.0;
        for (u, pose) in usable.iter().zip(poses) {
            let rms = bundle::view_rms_px(lens, intrinsics, pose, object, u.corners_px);
            squared += rms * rms * object.len() as f64;
            let result = &mut per_view[u.index];
            result.used = true;
            result.rotation_rad = Some([pose[0], pose[1], pose[2]]);
            result.translation_m = Some([pose[3], pose[4], pose[5]]);
        }
        let model = camera_model(lens, intrinsics, width_px, height_px);
        model.check()?;
        Ok(Calibration {
            model,
            rms_px: (squared / (usable.len() * object.len()) as f64).sqrt(),
            views_used: usable.len(),
            per_view,
        })
    }
}

/// The camera model of an intrinsics block.
fn camera_model(lens: Lens, p: &[f64], width_px: u32, height_px: u32) -> CameraModel {
    let distortion = match lens {
        Lens::BrownConrady => Distortion::BrownConrady {
            k1: p[4],
            k2: p[5],
            p1: p[6],
            p2: p[7],
            k3: p[8],
        },
        Lens::KannalaBrandt => Distortion::KannalaBrandt {
            k1: p[4],
            k2: p[5],
            k3: p[6],
            k4: p[7],
        },
    };
    CameraModel {
        intrinsics: Intrinsics {
            fx_px: p[0],
            fy_px: p[1],
            cx_px: p[2],
            cy_px: p[3],
            width_px,
            height_px,
        },
        distortion,
    }
}

/// The pose parameters (axis-angle, translation) of a homography to normalised coordinates.
fn pose_of(normalised: &Matrix3<f64>) -> Option<[f64; 6]> {
    let (r, t) = homography::pose_from_homography(normalised)?;
    Some([r[0], r[1], r[2], t[0], t[1], t[2]])
}

/// Zhang's start for the pinhole model: intrinsics in closed form (falling back to a
/// centred principal point), zero distortion, poses from K⁻¹H.
fn pinhole_start(
    usable: &[Usable],
    w: f64,
    h: f64,
) -> Result<(Vec<f64>, Vec<[f64; 6]>), CalibrationError> {
    let hs: Vec<Matrix3<f64>> = usable.iter().map(|u| u.homography).collect();
    let plausible = |k: &[f64; 4]| {
        (0.1 * w..10.0 * w).contains(&k[0])
            && (0.5..2.0).contains(&(k[0] / k[1]))
            && (0.2 * w..0.8 * w).contains(&k[2])
            && (0.2 * h..0.8 * h).contains(&k[3])
    };
    let k = homography::zhang_intrinsics(&hs, w, h)
        .filter(plausible)
        .or_else(|| homography::centred_intrinsics(&hs, w, h).filter(plausible))
        .ok_or_else(|| {
            CalibrationError::Initialisation(
                "no plausible focal length from the homographies".into(),
            )
        })?;
    let k_inverse = Matrix3::new(
        1.0 / k[0],
        0.0,
        -k[2] / k[0],
        0.0,
        1.0 / k[1],
        -k[3] / k[1],
        0.0,
        0.0,
        1.0,
    );
    let poses = hs
        .iter()
        .map(|h| pose_of(&(k_inverse * h)))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| CalibrationError::Initialisation("no pose from a homography".into()))?;
    Ok((vec![k[0], k[1], k[2], k[3], 0.0, 0.0, 0.0, 0.0, 0.0], poses))
}

/// The equidistant start for the fisheye: principal point at the image centre, the focal
/// length that best explains every view as a plane (searched on a geometric grid, then
/// refined), poses from the homographies of the rectified corners.
fn fisheye_start(
    usable: &[Usable],
    plane: &[[f64; 2]],
    w: f64,
    h: f64,
) -> Result<(Vec<f64>, Vec<[f64; 6]>), CalibrationError> {
    let centre = [0.5 * (w - 1.0), 0.5 * (h - 1.0)];
    let mut best: Option<(f64, f64)> = None;
    let consider = |f: f64, best: &mut Option<(f64, f64)>| {
        if let Some(cost) = equidistant_cost(usable, plane, centre, f)
            && best.is_none_or(|(_, c)| cost < c)
        {
            *best = Some((f, cost));
        }
    };
    let (low, high) = (0.05 * w, 3.0 * w);
    let steps = 80;
    for s in 0..=steps {
        consider(
            low * (high / low).powf(f64::from(s) / f64::from(steps)),
            &mut best,
        );
    }
    let coarse = best.map(|(f, _)| f).unwrap_or(0.5 * w);
    for s in -20..=20 {
        consider(coarse * (1.0 + 0.0025 * f64::from(s)), &mut best);
    }
    let (f, _) = best.ok_or_else(|| {
        CalibrationError::Initialisation("no focal length makes the boards planar".into())
    })?;
    let mut poses = Vec::with_capacity(usable.len());
    for u in usable {
        let rectified = rectify_equidistant(u.corners_px, centre, f)
            .ok_or_else(|| CalibrationError::Initialisation("corner beyond 90°".into()))?;
        let hn = homography::fit_homography(plane, &rectified)
            .and_then(|h| pose_of(&h))
            .ok_or_else(|| CalibrationError::Initialisation("no pose from a homography".into()))?;
        poses.push(hn);
    }
    Ok((vec![f, f, centre[0], centre[1], 0.0, 0.0, 0.0, 0.0], poses))
}

/// Corners mapped to normalised pinhole coordinates under the equidistant model with
/// focal length `f`; `None` if one lies 85° or more off the axis.
fn rectify_equidistant(corners: &[[f64; 2]], centre: [f64; 2], f: f64) -> Option<Vec<[f64; 2]>> {
    corners
        .iter()
        .map(|p| {
            let d = [(p[0] - centre[0]) / f, (p[1] - centre[1]) / f];
            let theta = d[0].hypot(d[1]);
            if theta >= 85f64.to_radians() {
                return None;
            }
            let scale = if theta > 1e-12 {
                theta.tan() / theta
            } else {
                1.0
            };
            Some([d[0] * scale, d[1] * scale])
        })
        .collect()
}

/// Sum over views of the squared pixel error of the best homography between the board and
/// the rectified corners, mapped back through the equidistant model.
fn equidistant_cost(
    usable: &[Usable],
    plane: &[[f64; 2]],
    centre: [f64; 2],
    f: f64,
) -> Option<f64> {
    let mut cost = 0.0;
    for u in usable {
        let rectified = rectify_equidistant(u.corners_px, centre, f)?;
        let hn = homography::fit_homography(plane, &rectified)?;
        for (x, observed) in plane.iter().zip(u.corners_px) {
            let m = homography::apply(&hn, *x)?;
            let r = m[0].hypot(m[1]);
            let scale = if r > 1e-12 { f * r.atan() / r } else { f };
            let p = [centre[0] + scale * m[0], centre[1] + scale * m[1]];
            cost += (p[0] - observed[0]).powi(2) + (p[1] - observed[1]).powi(2);
        }
    }
    cost.is_finite().then_some(cost)
}

#[cfg(test)]
#[path = "calibrate_tests.rs"]
mod tests;
