//! Local perspective views: a fisheye frame resampled around one blob as a virtual pinhole
//! camera looking straight at it.
//!
//! A ball imaged near the edge of a 120° fisheye is an ellipse (squeezed along the radius by
//! up to 40 %), which a circular Hough transform cannot fit and a HOG filter trained on round
//! balls does not recognise. A sphere seen by a pinhole camera looking straight at it is
//! exactly a circle. So each blob is looked at through a virtual camera with the same
//! optical centre, its axis along the ray through the blob, and a focal length matching the
//! lens's scale there: the ball is round, of about the same size in pixels as in the frame,
//! wherever it is in the image. Circles found in the view map back to rays, and to frame
//! pixels, through the calibrated model.

use crate::camera::CameraModel;
use crate::colour::hsv::MaskLut;
use crate::image::{ImageError, Mask, RgbImage};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Largest half-side of a view, pixels: bounds the resampling cost of a big blob.
pub const MAX_HALF_SIDE_PX: u32 = 56;

/// A virtual pinhole camera around one direction of a calibrated camera.
#[derive(Debug, Clone)]
pub struct LocalView {
    /// Rotates view-frame vectors into the camera frame.
    camera_from_view: Rotation3<f64>,
    /// Focal length of the view, pixels.
    f_px: f64,
    /// The view is `side × side` pixels with its axis through the centre pixel.
    half_side: u32,
    /// For each view pixel, row-major, where it falls in the frame (NaN where nowhere).
    map: Vec<[f32; 2]>,
    /// Frame pixels per view pixel at the centre: 1 unless the blob was too big for a
    /// view of full resolution.
    scale: f64,
}

impl LocalView {
    /// A view looking at frame pixel `centre_px`, covering about `half_extent_px` frame
    /// pixels on each side, at most [`MAX_HALF_SIDE_PX`] view pixels (a bigger extent is
    /// seen at a coarser scale). `None` where the model cannot unproject the centre.
    #[cfg(test)]
    pub fn new(model: &CameraModel, centre_px: [f64; 2], half_extent_px: f64) -> Option<Self> {
        Self::fitting(model, centre_px, half_extent_px, MAX_HALF_SIDE_PX)
    }

    /// As [`LocalView::new`], with at most `max_half_side_px` view pixels each side of the
    /// centre: an extent bigger than that is seen through a shorter focal length, so the
    /// whole blob is in the view ([`LocalView::scale`] says by how much).
    pub fn fitting(
        model: &CameraModel,
        centre_px: [f64; 2],
        half_extent_px: f64,
        max_half_side_px: u32,
    ) -> Option<Self> {
        let axis = Vector3::from(model.unproject(centre_px)?);
        // Keep the view upright: its x axis is the camera's x made perpendicular to the axis.
        let x0 = Vector3::x() - axis * axis.x;
        let x_axis = if x0.norm() > 1e-6 {
            x0.normalize()
        } else {
            Vector3::y().cross(&axis).normalize()
        };
        let y_axis = axis.cross(&x_axis);
        let camera_from_view =
            Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x_axis, y_axis, axis]));
        // The lens's scale at the centre: frame pixels per radian, across and along the
        // view's axes; the view's focal length is their geometric mean.
        let step = 1e-3;
        let scale = |dir: Vector3<f64>| -> Option<f64> {
            let a = model.project((axis + dir * step).into())?;
            let b = model.project((axis - dir * step).into())?;
            Some((a[0] - b[0]).hypot(a[1] - b[1]) / (2.0 * step))
        };
        let (sx, sy) = (scale(x_axis)?, scale(y_axis)?);
        let f_px = (sx * sy).sqrt();
        if !(f_px.is_finite() && f_px > 0.0) {
            return None;
        }
        let stretch = sx.max(sy) / sx.min(sy);
        let max_half = max_half_side_px.clamp(4, MAX_HALF_SIDE_PX);
        let wanted = half_extent_px * stretch;
        let scale = (wanted / f64::from(max_half)).max(1.0);
        let f_px = f_px / scale;
        let half_side = ((wanted / scale).ceil() as u32).clamp(4, max_half);
        let side = 2 * half_side + 1;
        let mut map = Vec::with_capacity((side * side) as usize);
        let h = f64::from(half_side);
        for j in 0..side {
            for i in 0..side {
                let v = Vector3::new(f64::from(i) - h, f64::from(j) - h, f_px);
                let p = model.project((camera_from_view * v).into());
                map.push(p.map_or([f32::NAN; 2], |p| [p[0] as f32, p[1] as f32]));
            }
        }
        Some(LocalView {
            camera_from_view,
            f_px,
            half_side,
            map,
            scale,
        })
    }

    /// Frame pixels per view pixel at the view's centre (1 for a full-resolution view).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Side of the view, pixels.
    pub fn side(&self) -> u32 {
        2 * self.half_side + 1
    }

    /// The camera-frame unit ray through a view pixel.
    pub fn ray(&self, view_px: [f64; 2]) -> [f64; 3] {
        let h = f64::from(self.half_side);
        let v = Vector3::new(view_px[0] - h, view_px[1] - h, self.f_px);
        (self.camera_from_view * v.normalize()).into()
    }

    /// The half-angle a circle of `radius_px` centred at `view_px` subtends: the angle
    /// between the rays through its centre and through its rim, averaged over four rim
    /// points.
    pub fn angular_radius_rad(&self, view_px: [f64; 2], radius_px: f64) -> f64 {
        let c = Vector3::from(self.ray(view_px));
        let mut sum = 0.0;
        for (du, dv) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
            let e =
                Vector3::from(self.ray([view_px[0] + du * radius_px, view_px[1] + dv * radius_px]));
            sum += c.angle(&e);
        }
        sum / 4.0
    }

    /// The mask seen through the view: set where the bilinear interpolation of the frame's
    /// mask is at least one half (off the frame counts as unset). Nearest-pixel sampling
    /// would turn a frame pixel's edge into a step of two or three view pixels where the view
    /// magnifies, which bends the rim's normals and loosens its fit.
    pub fn sample_mask(&self, mask: &Mask) -> Result<Mask, ImageError> {
        let (w, h) = (mask.width() as isize, mask.height() as isize);
        let src = mask.data();
        let at = |x: isize, y: isize| -> f32 {
            if x >= 0 && y >= 0 && x < w && y < h && src[(y * w + x) as usize] != 0 {
                1.0
            } else {
                0.0
            }
        };
        let data = self
            .map
            .iter()
            .map(|&[u, v]| {
                if !(u.is_finite() && v.is_finite()) || u < -1.0 || v < -1.0 {
                    return 0;
                }
                let (x0, y0) = (u.floor(), v.floor());
                let (fx, fy) = (u - x0, v - y0);
                let (x0, y0) = (x0 as isize, y0 as isize);
                let top = at(x0, y0) + (at(x0 + 1, y0) - at(x0, y0)) * fx;
                let bottom = at(x0, y0 + 1) + (at(x0 + 1, y0 + 1) - at(x0, y0 + 1)) * fx;
                u8::from(top + (bottom - top) * fy >= 0.5)
            })
            .collect();
        Mask::new(self.side(), self.side(), data)
    }

    /// The colour mask of the frame seen through the view: each view pixel's nearest frame
    /// pixel through `lut` (off the frame is unset).
    pub fn sample_lut(&self, image: &RgbImage, lut: &MaskLut) -> Result<Mask, ImageError> {
        let (w, h) = (image.width() as usize, image.height() as usize);
        let src = image.data();
        let data = self
            .map
            .iter()
            .map(|&[u, v]| {
                let (x, y) = ((u + 0.5).floor(), (v + 0.5).floor());
                if x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h {
                    let i = 3 * (y as usize * w + x as usize);
                    u8::from(lut.accepts(src[i], src[i + 1], src[i + 2]))
                } else {
                    0
                }
            })
            .collect();
        Mask::new(self.side(), self.side(), data)
    }

    /// The frame seen through the view (bilinear; off the frame repeats the edge).
    pub fn sample_rgb(&self, image: &RgbImage) -> Result<RgbImage, ImageError> {
        let (w, h) = (image.width() as usize, image.height() as usize);
        let src = image.data();
        let mut data = Vec::with_capacity(self.map.len() * 3);
        for &[u, v] in &self.map {
            if !(u.is_finite() && v.is_finite()) {
                data.extend_from_slice(&[0, 0, 0]);
                continue;
            }
            let x = u.clamp(0.0, (w - 1) as f32);
            let y = v.clamp(0.0, (h - 1) as f32);
            let (x0, y0) = (x.floor() as usize, y.floor() as usize);
            let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
            let (fx, fy) = (x - x0 as f32, y - y0 as f32);
            for c in 0..3 {
                let at = |xx: usize, yy: usize| f32::from(src[3 * (yy * w + xx) + c]);
                let top = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * fx;
                let bottom = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * fx;
                data.push((top + (bottom - top) * fy + 0.5) as u8);
            }
        }
        RgbImage::new(self.side(), self.side(), data)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::camera::{Distortion, Intrinsics};

    fn fisheye() -> CameraModel {
        CameraModel {
            intrinsics: Intrinsics {
                fx_px: 344.0,
                fy_px: 343.0,
                cx_px: 322.0,
                cy_px: 178.0,
                width_px: 640,
                height_px: 360,
            },
            distortion: Distortion::KannalaBrandt {
                k1: -0.1,
                k2: 0.0,
                k3: 0.0,
                k4: 0.0,
            },
        }
    }

    /// The frame mask of a sphere seen in direction `centre` with angular radius `alpha`.
    fn silhouette(model: &CameraModel, centre: Vector3<f64>, alpha: f64) -> Mask {
        let mut mask = Mask::zeros(640, 360).unwrap();
        for y in 0..360 {
            for x in 0..640 {
                if let Some(r) = model.unproject([f64::from(x), f64::from(y)])
                    && Vector3::from(r).angle(&centre) <= alpha
                {
                    mask.set(x, y, true);
                }
            }
        }
        mask
    }

    /// The circles the default Hough transform finds in `mask` seen through `view`.
    fn circles_in_view(view: &LocalView, mask: &Mask) -> Vec<crate::circle::Circle> {
        let local = view.sample_mask(mask).unwrap();
        crate::colour::hough::detect(
            local.data(),
            local.width() as usize,
            local.height() as usize,
            &Default::default(),
        )
        .unwrap()
    }

    /// A sphere near the image edge is an ellipse in the frame and a circle in the view.
    #[test]
    fn a_sphere_at_the_edge_is_round_in_its_local_view() {
        let model = fisheye();
        let centre = Vector3::new(-1.6, 0.3, 1.0).normalize();
        let alpha: f64 = 0.06;
        let mask = silhouette(&model, centre, alpha);
        let centre_px = model.project(centre.into()).unwrap();
        let view = LocalView::new(&model, centre_px, 30.0).unwrap();
        let circles = circles_in_view(&view, &mask);
        let c = circles[0];
        let ray = Vector3::from(view.ray(c.center_px));
        assert!(
            ray.angle(&centre) < 0.004,
            "centre off by {} rad",
            ray.angle(&centre)
        );
        let a = view.angular_radius_rad(c.center_px, c.radius_px);
        assert!(
            (a - alpha).abs() < 0.1 * alpha,
            "angular radius {a} against {alpha}"
        );
        // In the frame the same silhouette is clearly not round.
        let frame_circles =
            crate::colour::hough::detect(mask.data(), 640, 360, &Default::default()).unwrap();
        let fits_frame = frame_circles.iter().any(|f| {
            let r = Vector3::from(model.unproject(f.center_px).unwrap());
            r.angle(&centre) < 0.004 && f.score > c.score
        });
        assert!(
            !fits_frame,
            "the frame's ellipse fits a circle better than the view's circle"
        );
    }

    /// A close ball near the edge of the fisheye fills a view that magnifies the frame: its
    /// rim must still be smooth enough for the circle fit.
    #[test]
    fn a_close_ball_at_the_edge_is_found_in_its_view() {
        let model = fisheye();
        let centre = Vector3::new(1.3, 0.5, 1.0).normalize();
        let alpha: f64 = 0.1;
        let mask = silhouette(&model, centre, alpha);
        let centre_px = model.project(centre.into()).unwrap();
        let view = LocalView::new(&model, centre_px, 40.0).unwrap();
        let circles = circles_in_view(&view, &mask);
        let c = circles.first().expect("no circle in the view");
        assert!(c.score > 0.75, "{c:?}");
        let a = view.angular_radius_rad(c.center_px, c.radius_px);
        assert!((a - alpha).abs() < 0.03 * alpha, "angular radius {a}");
    }

    #[test]
    fn the_view_maps_back_to_the_frame() {
        let model = fisheye();
        let view = LocalView::new(&model, [100.0, 250.0], 20.0).unwrap();
        let h = f64::from(view.side() / 2);
        let back = model.project(view.ray([h, h])).unwrap();
        assert!(
            (back[0] - 100.0).abs() < 1e-6 && (back[1] - 250.0).abs() < 1e-6,
            "{back:?}"
        );
        let image = RgbImage::filled(640, 360, [10, 20, 30]).unwrap();
        let local = view.sample_rgb(&image).unwrap();
        assert_eq!(local.pixel(3, 3), Some([10, 20, 30]));
    }
}
