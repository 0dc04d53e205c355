//! Randomised labelled photos for training and testing a ball detector far beyond the
//! renderer's own look: a shaded ball (one of several [`BallDesign`]s: plain, orange with
//! white patches, the classic black-and-white football, white with black panels, a modern
//! white ball with coloured bands, a yellow ball with dark lines; a highlight, partly
//! hidden) on a procedural carpet or on a given background (a real photo, a rendered pitch
//! frame), with look-alikes beside it, then a cheap camera's faults
//! ([`crate::camera_effects`]): white balance, exposure, gamma, defocus, motion blur and
//! noise. JPEG artefacts are the writer's part (the caller encodes at
//! [`SynthPhoto::jpeg_quality`]).
//!
//! Two [`PhotoProfile`]s are defined. `train` is what a classifier may learn from;
//! `heldout` draws from other ranges (a striped carpet texture, stronger colour casts,
//! heavier noise and blur, other image sizes, other ball hues, another mix of designs), so
//! a score on it says how the detector does on pictures unlike anything it was tuned or
//! trained on. [`PhotoProfile::with_designs`] restricts either to some designs, so a whole
//! kind of ball can be held out (train on every design but `classic`, test on `classic`).

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

/// How a ball is painted; each photo's ball draws one from its profile's weighted
/// [`PhotoProfile::designs`]. Every design is shaded, rimmed, shadowed and occluded alike.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BallDesign {
    /// One colour all over: a hue, saturation and value of the profile's ranges, or (at the
    /// profile's [`PhotoProfile::plain_neutral_chance`]) near-white or near-black.
    Plain,
    /// The profile's coloured ball with twelve round white patches (at an icosahedron's
    /// vertices).
    Patches,
    /// The classic football: a white body with twelve black pentagons, sometimes thin dark
    /// seams between its white hexagons.
    Classic,
    /// A white ball with four or six large black panels of wavy outline (like RoboCup
    /// humanoid-league balls).
    WhiteBlackPanels,
    /// A modern match ball: white with two or three curved bands in one or two saturated
    /// colours, sometimes outlined dark.
    Modern,
    /// A yellow ball with darker yellow panels and thin dark curved lines (like the RoboCup
    /// middle-size league's yellow FIFA ball).
    Yellow,
}

impl BallDesign {
    /// Every design, in the order of their names' listing.
    pub const ALL: [BallDesign; 6] = [
        BallDesign::Plain,
        BallDesign::Patches,
        BallDesign::Classic,
        BallDesign::WhiteBlackPanels,
        BallDesign::Modern,
        BallDesign::Yellow,
    ];

    /// The design's name, as the command line and the manifests spell it.
    pub fn name(&self) -> &'static str {
        match self {
            BallDesign::Plain => "plain",
            BallDesign::Patches => "patches",
            BallDesign::Classic => "classic",
            BallDesign::WhiteBlackPanels => "white-black-panels",
            BallDesign::Modern => "modern",
            BallDesign::Yellow => "yellow",
        }
    }

    /// The design called `name` (as [`BallDesign::name`] spells it; case and surrounding
    /// blanks are ignored, `_` stands for `-`).
    pub fn named(name: &str) -> Option<Self> {
        let wanted = name.trim().to_ascii_lowercase().replace('_', "-");
        Self::ALL.into_iter().find(|d| d.name() == wanted)
    }
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
    /// The coloured ball's hue (degrees), saturation and value ([`BallDesign::Plain`] and
    /// [`BallDesign::Patches`]; the other designs have their own colours).
    pub hue_deg: [f64; 2],
    pub saturation: [f64; 2],
    pub value: [f64; 2],
    /// The ball designs drawn from, with their relative weights (one drawn per ball;
    /// weights need not add up to 1; no positive weight paints every ball plain).
    pub designs: Vec<(BallDesign, f64)>,
    /// Share of [`BallDesign::Plain`] balls painted near-white or near-black (half each)
    /// instead of the profile's hue.
    pub plain_neutral_chance: f64,
    /// Share of balls partly hidden (up to 40 % of the disc).
    pub occlusion_chance: f64,
    /// Share of balls held under the camera: big (a fifth to half the photo's height),
    /// near the middle of the bottom edge and cut by it, as a robot sees the ball it
    /// dribbles.
    pub held_chance: f64,
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
            sizes_px: &[(224, 224), (320, 240), (640, 360), (800, 600), (1280, 720)],
            ball_chance: 0.8,
            radius_px: [2.0, 48.0],
            hue_deg: [8.0, 34.0],
            saturation: [0.55, 1.0],
            value: [0.6, 1.0],
            // Coloured balls (plain or patched) are half of the balls, as the orange ball is
            // still the commonest; every other design is 10–15 % of them.
            designs: vec![
                (BallDesign::Plain, 0.35),
                (BallDesign::Patches, 0.15),
                (BallDesign::Classic, 0.15),
                (BallDesign::WhiteBlackPanels, 0.1),
                (BallDesign::Modern, 0.1),
                (BallDesign::Yellow, 0.15),
            ],
            plain_neutral_chance: 0.15,
            occlusion_chance: 0.15,
            held_chance: 0.06,
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
            // Another mix: more patched and classic balls, more near-white and near-black
            // plain ones.
            designs: vec![
                (BallDesign::Plain, 0.3),
                (BallDesign::Patches, 0.2),
                (BallDesign::Classic, 0.2),
                (BallDesign::WhiteBlackPanels, 0.1),
                (BallDesign::Modern, 0.1),
                (BallDesign::Yellow, 0.1),
            ],
            plain_neutral_chance: 0.2,
            occlusion_chance: 0.2,
            held_chance: 0.0,
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

    /// This profile drawing only `designs`, each at its weight here (a design this profile
    /// gives no positive weight gets the mean of its positive weights, or 1 when there are
    /// none); repeats count once. An empty list keeps the profile's designs.
    pub fn with_designs(&self, designs: &[BallDesign]) -> PhotoProfile {
        if designs.is_empty() {
            return self.clone();
        }
        let positive: Vec<f64> = self
            .designs
            .iter()
            .map(|&(_, w)| w)
            .filter(|&w| w > 0.0)
            .collect();
        let mean = if positive.is_empty() {
            1.0
        } else {
            positive.iter().sum::<f64>() / positive.len() as f64
        };
        let mut chosen: Vec<(BallDesign, f64)> = Vec::new();
        for &d in designs {
            if chosen.iter().any(|&(c, _)| c == d) {
                continue;
            }
            let w = self
                .designs
                .iter()
                .filter(|&&(c, w)| c == d && w > 0.0)
                .map(|&(_, w)| w)
                .sum::<f64>();
            chosen.push((d, if w > 0.0 { w } else { mean }));
        }
        PhotoProfile {
            designs: chosen,
            ..self.clone()
        }
    }

    /// The designs drawn with a positive weight, in the profile's order.
    pub fn drawn_designs(&self) -> Vec<BallDesign> {
        let mut out: Vec<BallDesign> = Vec::new();
        for &(d, w) in &self.designs {
            if w > 0.0 && !out.contains(&d) {
                out.push(d);
            }
        }
        out
    }

    /// One design drawn by weight ([`BallDesign::Plain`] when no weight is positive).
    fn draw_design(&self, rng: &mut Rng) -> BallDesign {
        let total: f64 = self.designs.iter().map(|&(_, w)| w.max(0.0)).sum();
        let mut left = rng.range(0.0, total.max(0.0));
        let mut last = BallDesign::Plain;
        for &(d, w) in &self.designs {
            if w <= 0.0 {
                continue;
            }
            if left < w {
                return d;
            }
            left -= w;
            last = d;
        }
        last
    }
}

/// A labelled ball: its box in output pixels, `[x_min, y_min, x_max, y_max]` (the disc,
/// clipped to the photo), its radius and how it is painted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallLabel {
    pub box_px: [f64; 4],
    pub radius_px: f64,
    /// How the ball is painted.
    pub design: BallDesign,
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
        // (No draw for a profile that never holds the ball, so its photos stay as they were.)
        let held = profile.held_chance > 0.0 && rng.chance(profile.held_chance);
        let (r, cx, cy) = if held {
            let (fw, fh) = (f64::from(w), f64::from(h));
            let r = rng.range(0.2, 0.5) * fh;
            let cx = fw * (0.5 + rng.range(-0.2, 0.2));
            (r, cx, fh - 1.0 + r * rng.range(-0.3, 0.5))
        } else {
            let (lo, hi) = (profile.radius_px[0].ln(), profile.radius_px[1].ln());
            let r = rng.range(lo, hi).exp().min(0.45 * f64::from(w.min(h)));
            let cx = rng.range(0.0, f64::from(w - 1));
            let cy = rng.range(0.0, f64::from(h - 1));
            (r, cx, cy)
        };
        let design = profile.draw_design(&mut rng);
        let look = crate::photo_shapes::BallPaint::draw(design, profile, &mut rng);
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
            design,
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
