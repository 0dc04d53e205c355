//! What the camera renderer draws: the scene description, its lighting, the ball's look,
//! the rendered frame and the ball's ground truth.

use crate::rng::Rng;
use proto::{HeadJoints, Pitch, Pose2};

/// A rendered image: row-major RGB8, `3 · width · height` bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

impl Frame {
    /// The pixel at column `x`, row `y` (panics outside the image, like slice indexing).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// How the ball's surface is painted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BallPattern {
    /// One colour all over.
    #[default]
    Plain,
    /// The colour with twelve round white patches (at an icosahedron's vertices), which
    /// break up the ball's outline in a colour mask.
    Patches,
}

/// The ball's colour (linear RGB reflectance, 0..1) and pattern.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallLook {
    pub colour_rgb: [f64; 3],
    pub pattern: BallPattern,
}

impl BallLook {
    /// A plain ball of the given hue (degrees), saturation and value (0..1).
    pub fn from_hsv(hue_deg: f64, saturation: f64, value: f64) -> Self {
        BallLook {
            colour_rgb: hsv_to_rgb(hue_deg, saturation, value),
            pattern: BallPattern::Plain,
        }
    }
}

impl Default for BallLook {
    /// The orange ball: hue 25°, saturation 0.85.
    fn default() -> Self {
        BallLook::from_hsv(25.0, 0.85, 0.95)
    }
}

/// HSV (hue in degrees) to RGB, all in 0..1.
pub fn hsv_to_rgb(hue_deg: f64, s: f64, v: f64) -> [f64; 3] {
    let h = hue_deg.rem_euclid(360.0) / 60.0;
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let m = v - c;
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    [r + m, g + m, b + m]
}

/// Light and camera response. A pixel's value is `reflectance · illumination · exposure ·
/// gain · 255` before noise; changing `exposure` or `gain_rgb` models an auto-exposure
/// step or a white-balance drift between frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lighting {
    pub exposure: f64,
    /// Per-channel gain (white balance).
    pub gain_rgb: [f64; 3],
    /// Direction towards the (distant) main light, field frame; need not be unit length.
    pub light_dir: [f64; 3],
    /// Share of light that comes from everywhere (0..1); the rest is the main light.
    pub ambient: f64,
    /// How much darker the pitch's corners are than its centre (0 = uniform, 0.3 = 30 %).
    pub falloff: f64,
}

impl Default for Lighting {
    fn default() -> Self {
        Lighting {
            exposure: 1.0,
            gain_rgb: [1.0, 1.0, 1.0],
            light_dir: [0.4, 0.3, 1.0],
            ambient: 0.35,
            falloff: 0.25,
        }
    }
}

/// Another MiRo in the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotBody {
    pub pose: Pose2,
    pub head: HeadJoints,
}

/// Everything the renderer draws besides the lens.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub pitch: Pitch,
    /// The ball's centre (z = radius when it lies on the floor), or no ball.
    pub ball_m: Option<[f64; 3]>,
    pub ball_look: BallLook,
    /// Other MiRos (the observing robot's own body is never in its cameras' view).
    pub robots: Vec<RobotBody>,
    pub lighting: Lighting,
    /// Standard deviation of the sensor noise, in 8-bit levels (0 = noiseless).
    pub noise_sigma: f64,
    /// Seeds the sensor noise (with each frame's own seed).
    pub seed: u64,
}

impl Default for Scene {
    fn default() -> Self {
        Scene {
            pitch: Pitch::default(),
            ball_m: None,
            ball_look: BallLook::default(),
            robots: Vec::new(),
            lighting: Lighting::default(),
            noise_sigma: 2.0,
            seed: 0,
        }
    }
}

/// What the renderer knows about the ball in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallTruth {
    /// Some of the ball's silhouette lies in the image (whether or not it is occluded).
    pub in_frame: bool,
    /// Visible ball pixels over the ball pixels there would be with nothing in front
    /// (0 when the silhouette misses the image).
    pub visible_fraction: f64,
    /// A robot hides at least one ball pixel.
    pub occluded_by_robot: bool,
    /// The ball centre imaged through the lens (may lie outside the image); `None` when
    /// it is behind the camera.
    pub center_px: Option<[f64; 2]>,
    /// Radius of a circle with the silhouette's area, from the ball's angular radius
    /// through the lens (not counted from pixels, so it holds at the image edge too).
    pub radius_px: f64,
    /// Pixels where the ball is the nearest surface.
    pub visible_px: usize,
    /// Pixels inside the ball's silhouette, occluded or not.
    pub silhouette_px: usize,
    pub world_m: [f64; 3],
    /// Optical centre to ball centre.
    pub range_m: f64,
}

impl BallTruth {
    /// The ball's box `[x_min, y_min, x_max, y_max]` (pixels) when it is fair to label: in
    /// the frame, its whole disc inside the `width_px`×`height_px` image and more than 90 %
    /// of it visible. `None` otherwise (out of view, cut by the edge or mostly hidden).
    pub fn full_view_box_px(&self, width_px: u32, height_px: u32) -> Option<[f64; 4]> {
        let c = self.center_px?;
        let r = self.radius_px;
        let inside = c[0] - r > 0.0
            && c[1] - r > 0.0
            && c[0] + r < f64::from(width_px) - 1.0
            && c[1] + r < f64::from(height_px) - 1.0;
        (self.in_frame && inside && self.visible_fraction > 0.9).then_some([
            c[0] - r,
            c[1] - r,
            c[0] + r,
            c[1] + r,
        ])
    }
}

/// Tileable carpet-like luminance, ~1 on average, generated once per rig.
#[derive(Debug, Clone)]
pub(crate) struct FloorTexture {
    lum: Vec<f32>,
}

/// Texels per side (a power of two, so tiling is a mask).
const TEX_SIZE: usize = 512;
const TEX_MASK: i32 = TEX_SIZE as i32 - 1;

impl FloorTexture {
    /// Value noise summed over octaves from 1 m blobs down to single-texel grain; low
    /// contrast, like a carpet under even light.
    pub(crate) fn carpet() -> Self {
        let mut rng = Rng::stream(0xC0FFEE, "floor-texture", 0);
        let mut lum = vec![1.0f32; TEX_SIZE * TEX_SIZE];
        for (period, amp) in [(256usize, 0.05), (64, 0.04), (16, 0.035), (4, 0.03)] {
            let n = TEX_SIZE / period;
            let lattice: Vec<f64> = (0..n * n).map(|_| rng.range(-1.0, 1.0)).collect();
            for (i, v) in lum.iter_mut().enumerate() {
                let (x, y) = (i % TEX_SIZE, i / TEX_SIZE);
                let (gx, gy) = (x / period, y / period);
                let fx = smooth((x % period) as f64 / period as f64);
                let fy = smooth((y % period) as f64 / period as f64);
                let at = |a: usize, b: usize| lattice[(b % n) * n + (a % n)];
                let top = at(gx, gy) + (at(gx + 1, gy) - at(gx, gy)) * fx;
                let bot = at(gx, gy + 1) + (at(gx + 1, gy + 1) - at(gx, gy + 1)) * fx;
                *v += (amp * (top + (bot - top) * fy)) as f32;
            }
        }
        for v in &mut lum {
            *v += (0.06 * rng.range(-1.0, 1.0)) as f32;
        }
        FloorTexture { lum }
    }

    /// Bilinear lookup at texel coordinates (any real values; the texture tiles).
    #[inline]
    pub(crate) fn sample(&self, u: f32, v: f32) -> f32 {
        let (fu, fv) = (u.floor(), v.floor());
        let (au, av) = (u - fu, v - fv);
        let (iu, iv) = (fu as i32, fv as i32);
        let at = |a: i32, b: i32| {
            self.lum[((b & TEX_MASK) as usize) * TEX_SIZE + (a & TEX_MASK) as usize]
        };
        let top = at(iu, iv) + (at(iu + 1, iv) - at(iu, iv)) * au;
        let bot = at(iu, iv + 1) + (at(iu + 1, iv + 1) - at(iu, iv + 1)) * au;
        top + (bot - top) * av
    }
}

fn smooth(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hsv_conversion_hits_the_primaries_and_the_default_orange() {
        assert_eq!(hsv_to_rgb(0.0, 1.0, 1.0), [1.0, 0.0, 0.0]);
        assert_eq!(hsv_to_rgb(120.0, 1.0, 1.0), [0.0, 1.0, 0.0]);
        assert_eq!(hsv_to_rgb(240.0, 1.0, 0.5), [0.0, 0.0, 0.5]);
        let [r, g, b] = BallLook::default().colour_rgb;
        assert!(r > g && g > b && b > 0.1);
    }

    #[test]
    fn carpet_is_low_contrast_and_tiles() {
        let t = FloorTexture::carpet();
        let mean = t.lum.iter().map(|&v| f64::from(v)).sum::<f64>() / t.lum.len() as f64;
        assert!((mean - 1.0).abs() < 0.05, "{mean}");
        assert!(t.lum.iter().all(|&v| (0.7..1.3).contains(&v)));
        assert_eq!(t.sample(3.0, 7.0), t.sample(3.0 + 512.0, 7.0 - 1024.0));
    }
}
