//! Randomised labelled photos for training and testing a ball detector far beyond the
//! renderer's own look: a shaded ball (any orange, plain or with white patches, a
//! highlight, partly hidden) on a procedural carpet or on a given background (a real photo,
//! a rendered pitch frame), with look-alikes beside it, then a cheap camera's faults
//! ([`crate::camera_effects`]): white balance, exposure, gamma, defocus, motion blur and
//! noise. JPEG artefacts are the writer's part (the caller encodes at
//! [`SynthPhoto::jpeg_quality`]).
//!
//! Two [`PhotoProfile`]s are defined. `train` is what a classifier may learn from;
//! `heldout` draws from other ranges (a striped carpet texture, stronger colour casts,
//! heavier noise and blur, other image sizes, other ball hues), so a score on it says how
//! the detector does on pictures unlike anything it was tuned or trained on.

use crate::camera_effects::{ToneCurve, add_noise, box_blur, crop_resize, motion_blur};
use crate::render_scene::{Frame, hsv_to_rgb};
use crate::rng::Rng;

/// How a procedural carpet is textured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CarpetTexture {
    /// Smooth blotches at several scales and a fine grain.
    Blotches,
    /// Mown stripes along a random direction with a fine grain.
    Stripes,
}

/// The ranges every random choice is drawn from.
#[derive(Debug, Clone, PartialEq)]
pub struct PhotoProfile {
    pub name: &'static str,
    /// Output sizes, one drawn per photo.
    pub sizes_px: &'static [(u32, u32)],
    /// Share of photos with a ball.
    pub ball_chance: f64,
    /// Ball radius in output pixels, drawn log-uniformly.
    pub radius_px: [f64; 2],
    /// The ball's hue (degrees), saturation and value.
    pub hue_deg: [f64; 2],
    pub saturation: [f64; 2],
    pub value: [f64; 2],
    /// Share of balls with white patches.
    pub patches_chance: f64,
    /// Share of balls partly hidden (up to 40 % of the disc).
    pub occlusion_chance: f64,
    /// Look-alikes per photo (orange bars, pale-orange skin-like blobs, white discs).
    pub distractors: [usize; 2],
    pub texture: CarpetTexture,
    /// Carpet hue (degrees), saturation and value.
    pub carpet_hue_deg: [f64; 2],
    pub carpet_saturation: [f64; 2],
    pub carpet_value: [f64; 2],
    /// Log-normal spread of the red and blue gains against green (white balance).
    pub white_balance_sigma: f64,
    /// Overall gain.
    pub exposure: [f64; 2],
    pub gamma: [f64; 2],
    /// Read noise, 8-bit levels.
    pub noise_sigma: [f64; 2],
    /// Motion blur length, output pixels (0 for none).
    pub motion_blur_px: [f64; 2],
    /// Share of photos slightly out of focus (a 1 px box blur).
    pub defocus_chance: f64,
    /// JPEG quality range; `None` writes lossless PNG.
    pub jpeg_quality: Option<[u8; 2]>,
}

impl PhotoProfile {
    /// What a classifier may be trained on.
    pub fn train() -> Self {
        PhotoProfile {
            name: "train",
            sizes_px: &[(224, 224), (320, 240), (640, 360)],
            ball_chance: 0.8,
            radius_px: [2.0, 48.0],
            hue_deg: [8.0, 34.0],
            saturation: [0.55, 1.0],
            value: [0.6, 1.0],
            patches_chance: 0.2,
            occlusion_chance: 0.15,
            distractors: [0, 3],
            texture: CarpetTexture::Blotches,
            carpet_hue_deg: [85.0, 160.0],
            carpet_saturation: [0.25, 0.8],
            carpet_value: [0.25, 0.7],
            white_balance_sigma: 0.12,
            exposure: [0.7, 1.35],
            gamma: [0.8, 1.25],
            noise_sigma: [0.0, 6.0],
            motion_blur_px: [0.0, 4.0],
            defocus_chance: 0.3,
            jpeg_quality: Some([50, 95]),
        }
    }

    /// Ranges a trained classifier has not seen: another texture, stronger casts, more
    /// noise and blur, other sizes and hues at the ends of the orange range.
    pub fn heldout() -> Self {
        PhotoProfile {
            name: "heldout",
            sizes_px: &[(224, 224), (400, 300), (640, 480)],
            ball_chance: 0.75,
            radius_px: [2.0, 60.0],
            hue_deg: [5.0, 38.0],
            saturation: [0.5, 1.0],
            value: [0.5, 1.0],
            patches_chance: 0.25,
            occlusion_chance: 0.2,
            distractors: [0, 4],
            texture: CarpetTexture::Stripes,
            carpet_hue_deg: [75.0, 175.0],
            carpet_saturation: [0.15, 0.85],
            carpet_value: [0.2, 0.75],
            white_balance_sigma: 0.15,
            exposure: [0.6, 1.45],
            gamma: [0.75, 1.3],
            noise_sigma: [1.0, 9.0],
            motion_blur_px: [0.0, 6.0],
            defocus_chance: 0.4,
            jpeg_quality: Some([35, 90]),
        }
    }

    /// The profile called `name`.
    pub fn named(name: &str) -> Option<Self> {
        match name {
            "train" => Some(Self::train()),
            "heldout" => Some(Self::heldout()),
            _ => None,
        }
    }
}

/// A labelled ball: its box in output pixels, `[x_min, y_min, x_max, y_max]` (the disc,
/// clipped to the photo), and its radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallLabel {
    pub box_px: [f64; 4],
    pub radius_px: f64,
}

/// One randomised photo.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthPhoto {
    pub frame: Frame,
    pub balls: Vec<BallLabel>,
    /// Quality to encode the photo at; `None` for a lossless file.
    pub jpeg_quality: Option<u8>,
}

/// What the ball is drawn on.
#[derive(Debug, Clone, Copy)]
pub enum Background<'a> {
    /// A procedural carpet and wall of the profile's colours.
    Carpet,
    /// A random window of this picture, resized to the output size.
    Picture(&'a Frame),
}

fn draw(rng: &mut Rng, range: [f64; 2]) -> f64 {
    rng.range(range[0], range[1])
}

/// Photo number `index` of `profile` with seed `seed`, on `background`.
pub fn synth_photo(
    profile: &PhotoProfile,
    background: Background<'_>,
    seed: u64,
    index: u64,
) -> SynthPhoto {
    let mut rng = Rng::stream(seed, profile.name, index);
    let (w, h) = profile.sizes_px[rng.index(profile.sizes_px.len())];
    let mut frame = match background {
        Background::Carpet => carpet(profile, w, h, &mut rng),
        Background::Picture(picture) => random_window(picture, w, h, &mut rng),
    };
    for _ in
        0..rng.index(profile.distractors[1] - profile.distractors[0] + 1) + profile.distractors[0]
    {
        crate::photo_shapes::distractor(&mut frame, profile, &mut rng);
    }
    let mut balls = Vec::new();
    if rng.chance(profile.ball_chance) {
        let (lo, hi) = (profile.radius_px[0].ln(), profile.radius_px[1].ln());
        let r = rng.range(lo, hi).exp().min(0.45 * f64::from(w.min(h)));
        let cx = rng.range(0.0, f64::from(w - 1));
        let cy = rng.range(0.0, f64::from(h - 1));
        let look = crate::photo_shapes::BallPaint {
            albedo: hsv_to_rgb(
                draw(&mut rng, profile.hue_deg),
                draw(&mut rng, profile.saturation),
                draw(&mut rng, profile.value),
            ),
            patches: rng.chance(profile.patches_chance),
        };
        crate::photo_shapes::ball(&mut frame, [cx, cy], r, &look, &mut rng);
        if rng.chance(profile.occlusion_chance) {
            crate::photo_shapes::occluder(&mut frame, [cx, cy], r, &mut rng);
        }
        let clip = |v: f64, max: u32| v.clamp(0.0, f64::from(max - 1));
        balls.push(BallLabel {
            box_px: [
                clip(cx - r, w),
                clip(cy - r, h),
                clip(cx + r, w),
                clip(cy + r, h),
            ],
            radius_px: r,
        });
    }
    camera(&mut frame, profile, &mut rng);
    let jpeg_quality = profile.jpeg_quality.map(|[lo, hi]| {
        let q = rng.range(f64::from(lo), f64::from(hi) + 1.0);
        (q as u8).clamp(lo, hi)
    });
    SynthPhoto {
        frame,
        balls,
        jpeg_quality,
    }
}

/// The camera's faults, in the order light meets them: blur, then the sensor's noise, then
/// the processing's white balance, exposure and gamma.
fn camera(frame: &mut Frame, profile: &PhotoProfile, rng: &mut Rng) {
    let blur = draw(rng, profile.motion_blur_px);
    if blur >= 1.0 && rng.chance(0.6) {
        *frame = motion_blur(frame, blur, rng.range(0.0, std::f64::consts::PI));
    }
    if rng.chance(profile.defocus_chance) {
        *frame = box_blur(frame, 1);
    }
    let sigma = draw(rng, profile.noise_sigma);
    add_noise(frame, sigma, 0.5 * sigma, rng);
    let exposure = draw(rng, profile.exposure);
    let s = profile.white_balance_sigma;
    ToneCurve {
        gain_rgb: [
            exposure * (s * rng.normal()).exp(),
            exposure,
            exposure * (s * rng.normal()).exp(),
        ],
        gamma: draw(rng, profile.gamma),
        contrast: rng.range(0.85, 1.15),
    }
    .apply(frame);
}

/// A random window of `picture` with the output's shape, between a third of the picture
/// and all of it, resized to `w × h`.
fn random_window(picture: &Frame, w: u32, h: u32, rng: &mut Rng) -> Frame {
    let (pw, ph) = (f64::from(picture.width), f64::from(picture.height));
    let aspect = f64::from(w) / f64::from(h);
    let full_w = pw.min(ph * aspect);
    let scale = rng.range(0.35, 1.0);
    let (ww, wh) = (full_w * scale, full_w * scale / aspect);
    let x0 = rng.range(0.0, (pw - ww).max(0.0));
    let y0 = rng.range(0.0, (ph - wh).max(0.0));
    crop_resize(picture, [x0, y0, ww, wh], w, h)
}

/// A procedural view of a carpeted floor: a wall band at the top (sometimes none), the
/// carpet below with its texture and a white line or two.
fn carpet(profile: &PhotoProfile, w: u32, h: u32, rng: &mut Rng) -> Frame {
    let base = hsv_to_rgb(
        draw(rng, profile.carpet_hue_deg),
        draw(rng, profile.carpet_saturation),
        draw(rng, profile.carpet_value),
    );
    let wall_rgb = if rng.chance(0.5) {
        let v = rng.range(0.6, 0.95);
        [v, v, v * rng.range(0.92, 1.05)]
    } else {
        hsv_to_rgb(
            rng.range(0.0, 360.0),
            rng.range(0.0, 0.5),
            rng.range(0.2, 0.9),
        )
    };
    let horizon = if rng.chance(0.3) {
        -1.0
    } else {
        rng.range(0.0, 0.45) * f64::from(h)
    };
    let texture = crate::photo_shapes::Texture::new(profile.texture, rng);
    let lines: Vec<([f64; 2], [f64; 2], f64)> = (0..rng.index(3))
        .map(|_| {
            let p = [
                rng.range(0.0, f64::from(w)),
                rng.range(horizon.max(0.0), f64::from(h)),
            ];
            let a = rng.range(0.0, std::f64::consts::PI);
            (p, [a.cos(), a.sin()], rng.range(1.0, 4.0))
        })
        .collect();
    let light_slope = rng.range(-0.4, 0.4) / f64::from(w);
    let mut rgb = Vec::with_capacity(3 * (w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (xf, yf) = (f64::from(x), f64::from(y));
            let colour = if yf < horizon {
                wall_rgb
            } else {
                let on_line = lines.iter().any(|&(p, d, width)| {
                    ((xf - p[0]) * d[1] - (yf - p[1]) * d[0]).abs() < 0.5 * width
                });
                if on_line {
                    [0.85, 0.85, 0.85]
                } else {
                    let k = texture.at(xf, yf) * (1.0 + light_slope * (xf - f64::from(w) / 2.0));
                    base.map(|c| c * k)
                }
            };
            rgb.extend(colour.map(|c| (255.0 * c.clamp(0.0, 1.0) + 0.5) as u8));
        }
    }
    Frame {
        width: w,
        height: h,
        rgb,
    }
}

#[cfg(test)]
#[path = "photo_synth_tests.rs"]
mod tests;
