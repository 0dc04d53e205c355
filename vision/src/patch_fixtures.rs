//! Synthetic candidate patches for the filter stages' tests: shaded balls on varied
//! backgrounds, and the things the filter must reject (edges, corners, stripes, arcs,
//! elongated ellipses, rectangles, textures, pale rounded shapes shaded differently).
//!
//! Each sample is painted into a 64×64 frame and cut out with [`extract`] around the
//! candidate circle the Hough stage would report, so the tests exercise the real
//! extraction path.

#![allow(clippy::unwrap_used)]

use crate::check::patch::{Patch, PatchConfig, extract};
use crate::image::RgbImage;
use proto::rng::SplitMix64;

/// Side of the painted frame, pixels.
const FRAME_PX: u32 = 64;

/// The ball's colour, fully lit.
pub const BALL_RGB: [f64; 3] = [235.0, 120.0, 30.0];

/// A frame painted pixel by pixel.
struct Frame {
    rgb: Vec<[f64; 3]>,
}

impl Frame {
    /// A random background: flat, gradient, stripes or checks, in greenish or greyish
    /// colours.
    fn background(rng: &mut SplitMix64) -> Self {
        let base = [
            40.0 + 120.0 * rng.next_f64(),
            60.0 + 120.0 * rng.next_f64(),
            40.0 + 120.0 * rng.next_f64(),
        ];
        let kind = rng.below(4);
        let contrast = 10.0 + 30.0 * rng.next_f64();
        let period = 6.0 + 20.0 * rng.next_f64();
        let angle = std::f64::consts::PI * rng.next_f64();
        let (s, c) = angle.sin_cos();
        let mut rgb = Vec::new();
        for y in 0..FRAME_PX {
            for x in 0..FRAME_PX {
                let (xf, yf) = (f64::from(x), f64::from(y));
                let u = c * xf + s * yf;
                let d = match kind {
                    0 => 0.0,
                    1 => contrast * (u / 64.0 - 0.5),
                    2 => contrast * (u / period * std::f64::consts::TAU).sin().signum() / 2.0,
                    _ => {
                        let cell = ((xf / period).floor() + (yf / period).floor()) as i64;
                        contrast * if cell % 2 == 0 { 0.5 } else { -0.5 }
                    }
                };
                rgb.push(base.map(|v| v + d));
            }
        }
        Self { rgb }
    }

    /// Blends `colour(x, y)` with coverage `alpha(x, y)` in [0, 1] over the frame.
    fn paint(&mut self, alpha: impl Fn(f64, f64) -> f64, colour: impl Fn(f64, f64) -> [f64; 3]) {
        for y in 0..FRAME_PX {
            for x in 0..FRAME_PX {
                let (xf, yf) = (f64::from(x), f64::from(y));
                let a = alpha(xf, yf).clamp(0.0, 1.0);
                if a > 0.0 {
                    let p = &mut self.rgb[(y * FRAME_PX + x) as usize];
                    let c = colour(xf, yf);
                    for k in 0..3 {
                        p[k] = (1.0 - a) * p[k] + a * c[k];
                    }
                }
            }
        }
    }

    /// The frame with uniform noise of amplitude `noise` added, as an image.
    fn finish(self, noise: f64, rng: &mut SplitMix64) -> RgbImage {
        let data = self
            .rgb
            .iter()
            .flat_map(|p| {
                p.map(|v| (v + noise * (2.0 * rng.next_f64() - 1.0)).clamp(0.0, 255.0) as u8)
            })
            .collect();
        RgbImage::new(FRAME_PX, FRAME_PX, data).unwrap()
    }
}

/// Coverage of a disc with an anti-aliased rim.
fn disc(cx: f64, cy: f64, r: f64) -> impl Fn(f64, f64) -> f64 {
    move |x, y| r + 0.5 - (x - cx).hypot(y - cy)
}

/// A frame holding a shaded ball, with the Hough circle reported for it (slightly off).
pub fn ball_frame(rng: &mut SplitMix64) -> (RgbImage, [f64; 2], f64) {
    let mut frame = Frame::background(rng);
    let r = 8.0 + 12.0 * rng.next_f64();
    let c = FRAME_PX as f64 / 2.0;
    let (cx, cy) = (
        c + 4.0 * rng.next_f64() - 2.0,
        c + 4.0 * rng.next_f64() - 2.0,
    );
    // Light from a random direction above the ball: Lambertian shading plus ambient.
    let (lx, ly) = (rng.next_f64() - 0.5, rng.next_f64() - 0.5);
    let lz = 0.8;
    let ln = (lx * lx + ly * ly + lz * lz).sqrt();
    let gain = 0.8 + 0.3 * rng.next_f64();
    frame.paint(disc(cx, cy, r), |x, y| {
        let (nx, ny) = ((x - cx) / r, (y - cy) / r);
        let nz = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
        let lambert = ((nx * lx + ny * ly + nz * lz) / ln).max(0.0);
        BALL_RGB.map(|v| (v * gain * (0.45 + 0.55 * lambert)).min(255.0))
    });
    let noise = 12.0 * rng.next_f64();
    let image = frame.finish(noise, rng);
    let off = 0.1 * r;
    let seen = [
        cx + off * (2.0 * rng.next_f64() - 1.0),
        cy + off * (2.0 * rng.next_f64() - 1.0),
    ];
    (image, seen, r * (0.92 + 0.16 * rng.next_f64()))
}

/// A frame holding something that is not a ball, with a candidate circle on it.
pub fn non_ball_frame(rng: &mut SplitMix64) -> (RgbImage, [f64; 2], f64) {
    let mut frame = Frame::background(rng);
    let r = 8.0 + 12.0 * rng.next_f64();
    let c = FRAME_PX as f64 / 2.0;
    let angle = std::f64::consts::PI * rng.next_f64();
    let (s, co) = angle.sin_cos();
    // Coordinates in a frame rotated by `angle` about the centre.
    let rot = move |x: f64, y: f64| (co * (x - c) + s * (y - c), -s * (x - c) + co * (y - c));
    let shade = 0.6 + 0.4 * rng.next_f64();
    let colour = BALL_RGB.map(|v| v * shade);
    let flat = move |_: f64, _: f64| colour;
    let offset = r * (rng.next_f64() - 0.5);
    match rng.below(8) {
        0 => frame.paint(move |x, y| rot(x, y).0 - offset + 0.5, flat),
        1 => frame.paint(
            move |x, y| {
                let (u, v) = rot(x, y);
                (u - offset + 0.5).min(v - offset + 0.5)
            },
            flat,
        ),
        2 => {
            let period = 0.5 * r + r * rng.next_f64();
            frame.paint(
                move |x, y| {
                    let u = rot(x, y).0 / period;
                    if u - u.floor() < 0.5 { 1.0 } else { 0.0 }
                },
                flat,
            )
        }
        3 => {
            // An arc of a larger circle crossing the window.
            let big = 2.0 * r + 2.0 * r * rng.next_f64();
            let (ax, ay) = (c + (big - 0.3 * r) * co, c + (big - 0.3 * r) * s);
            frame.paint(move |x, y| 1.5 - ((x - ax).hypot(y - ay) - big).abs(), flat)
        }
        4 => {
            let minor = r * (0.3 + 0.25 * rng.next_f64());
            frame.paint(
                move |x, y| {
                    let (u, v) = rot(x, y);
                    let q = (u / r).hypot(v / minor);
                    (1.0 - q) * minor + 0.5
                },
                flat,
            )
        }
        5 => {
            let (hw, hh) = (
                r * (0.9 + 0.4 * rng.next_f64()),
                r * (0.5 + 0.3 * rng.next_f64()),
            );
            frame.paint(
                move |x, y| {
                    let (u, v) = rot(x, y);
                    (hw - u.abs()).min(hh - v.abs()) + 0.5
                },
                flat,
            )
        }
        6 => {
            let cells = 2.0 + 5.0 * rng.next_f64();
            let seed = rng.next_u64();
            frame.paint(
                move |x, y| {
                    let (i, j) = ((x / cells) as u64, (y / cells) as u64);
                    let h = SplitMix64::new(seed ^ (i * 977 + j * 131)).next_f64();
                    if h < 0.5 { 1.0 } else { 0.0 }
                },
                move |_, _| colour,
            )
        }
        _ => {
            // A pale rounded square lit flat or from the side, not like a sphere.
            let grey = 170.0 + 80.0 * rng.next_f64();
            let side = rng.next_f64() < 0.5;
            frame.paint(
                move |x, y| {
                    let (u, v) = rot(x, y);
                    let q = ((u / r).powi(4) + (v / r).powi(4)).powf(0.25);
                    (1.0 - q) * r + 0.5
                },
                move |x, _| {
                    let g = if side {
                        grey * (0.7 + 0.3 * (x - c) / r)
                    } else {
                        grey
                    };
                    [g, g, g * 0.97]
                },
            )
        }
    }
    let noise = 12.0 * rng.next_f64();
    (frame.finish(noise, rng), [c, c], r)
}

/// `n` positive and `m` negative patches from seeded scenes.
pub fn patches(n: usize, m: usize, seed: u64) -> (Vec<Patch>, Vec<Patch>) {
    let mut rng = SplitMix64::new(seed);
    let cfg = PatchConfig::default();
    let pos = (0..n)
        .map(|_| {
            let (img, c, r) = ball_frame(&mut rng);
            extract(&img, c, r, &cfg).unwrap()
        })
        .collect();
    let neg = (0..m)
        .map(|_| {
            let (img, c, r) = non_ball_frame(&mut rng);
            extract(&img, c, r, &cfg).unwrap()
        })
        .collect();
    (pos, neg)
}
