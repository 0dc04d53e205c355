//! What [`crate::photo_synth`] paints: carpet textures, a shaded ball, things that hide
//! part of it and things that look a little like it.

use crate::photo_synth::{CarpetTexture, PhotoProfile};
use crate::render_scene::{Frame, hsv_to_rgb};
use crate::rng::Rng;

/// A carpet's brightness pattern, about 1 on average.
#[derive(Debug, Clone)]
pub struct Texture {
    kind: CarpetTexture,
    /// Value-noise octaves: (period in pixels, amplitude, lattice seed).
    octaves: Vec<(f64, f64, u64)>,
    grain: f64,
    grain_seed: u64,
    /// Stripes: direction, period and contrast.
    stripe_dir: [f64; 2],
    stripe_period_px: f64,
    stripe_contrast: f64,
}

/// A well-mixed hash of integers to [-1, 1).
fn hash(seed: u64, a: i64, b: i64) -> f64 {
    let mut z = seed
        ^ (a as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (b as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

fn smooth(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

impl Texture {
    pub fn new(kind: CarpetTexture, rng: &mut Rng) -> Self {
        let octaves = [64.0, 16.0, 4.0]
            .iter()
            .map(|&p| {
                (
                    p * rng.range(0.7, 1.4),
                    rng.range(0.02, 0.08),
                    rng.next_u64(),
                )
            })
            .collect();
        let a = rng.range(0.0, std::f64::consts::PI);
        Texture {
            kind,
            octaves,
            grain: rng.range(0.02, 0.08),
            grain_seed: rng.next_u64(),
            stripe_dir: [a.cos(), a.sin()],
            stripe_period_px: rng.range(20.0, 90.0),
            stripe_contrast: rng.range(0.05, 0.15),
        }
    }

    /// The brightness factor at pixel `(x, y)`.
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let mut k = 1.0;
        match self.kind {
            CarpetTexture::Blotches => {
                for &(period, amp, seed) in &self.octaves {
                    let (u, v) = (x / period, y / period);
                    let (i, j) = (u.floor() as i64, v.floor() as i64);
                    let (fx, fy) = (smooth(u - u.floor()), smooth(v - v.floor()));
                    let top = hash(seed, i, j) + (hash(seed, i + 1, j) - hash(seed, i, j)) * fx;
                    let bottom = hash(seed, i, j + 1)
                        + (hash(seed, i + 1, j + 1) - hash(seed, i, j + 1)) * fx;
                    k += amp * (top + (bottom - top) * fy);
                }
            }
            CarpetTexture::Stripes => {
                let s = (x * self.stripe_dir[0] + y * self.stripe_dir[1]) / self.stripe_period_px;
                k += self.stripe_contrast * if s.rem_euclid(1.0) < 0.5 { 1.0 } else { -1.0 };
            }
        }
        k + self.grain * hash(self.grain_seed, x as i64, y as i64)
    }
}

/// How the ball is painted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallPaint {
    /// Reflectance, 0..1 per channel.
    pub albedo: [f64; 3],
    /// White patches like a football's.
    pub patches: bool,
}

/// Blends `colour` (0..1) into the pixel at `(x, y)` with weight `alpha`.
fn blend(frame: &mut Frame, x: i64, y: i64, colour: [f64; 3], alpha: f64) {
    if x < 0 || y < 0 || x >= i64::from(frame.width) || y >= i64::from(frame.height) {
        return;
    }
    let i = 3 * (y as usize * frame.width as usize + x as usize);
    for (px, c) in frame.rgb[i..i + 3].iter_mut().zip(colour) {
        let old = f64::from(*px);
        let new = 255.0 * c.clamp(0.0, 1.0);
        *px = (old + (new - old) * alpha.clamp(0.0, 1.0) + 0.5) as u8;
    }
}

/// Scales the pixel at `(x, y)` by `k`.
fn darken(frame: &mut Frame, x: i64, y: i64, k: f64) {
    if x < 0 || y < 0 || x >= i64::from(frame.width) || y >= i64::from(frame.height) {
        return;
    }
    let i = 3 * (y as usize * frame.width as usize + x as usize);
    for c in 0..3 {
        frame.rgb[i + c] = (f64::from(frame.rgb[i + c]) * k + 0.5).clamp(0.0, 255.0) as u8;
    }
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
    v.map(|c| c / n)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The twelve patch centres of a football (an icosahedron's vertices), turned at random.
fn patch_centres(rng: &mut Rng) -> Vec<[f64; 3]> {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v = Vec::new();
    for &a in &[-1.0, 1.0] {
        for &b in &[-g, g] {
            v.push([0.0, a, b]);
            v.push([a, b, 0.0]);
            v.push([b, 0.0, a]);
        }
    }
    let (yaw, pitch) = (rng.range(0.0, 6.3), rng.range(0.0, 6.3));
    v.into_iter()
        .map(|p| {
            let p = normalise(p);
            let (x, z) = (
                p[0] * yaw.cos() - p[2] * yaw.sin(),
                p[0] * yaw.sin() + p[2] * yaw.cos(),
            );
            let (y, z) = (
                p[1] * pitch.cos() - z * pitch.sin(),
                p[1] * pitch.sin() + z * pitch.cos(),
            );
            [x, y, z]
        })
        .collect()
}

/// A shaded ball of radius `r` at `centre`: a soft contact shadow under it, Lambert
/// shading from a random light above, ambient light, a specular highlight, anti-aliased
/// rim.
pub fn ball(frame: &mut Frame, centre: [f64; 2], r: f64, paint: &BallPaint, rng: &mut Rng) {
    let [cx, cy] = centre;
    // Contact shadow: a dark ellipse where the ball meets the floor.
    let shadow = rng.range(0.45, 0.85);
    let (sx, sy) = (1.1 * r, 0.35 * r);
    let scy = cy + 0.9 * r;
    for y in (scy - sy).floor() as i64..=(scy + sy).ceil() as i64 {
        for x in (cx - sx).floor() as i64..=(cx + sx).ceil() as i64 {
            let e = ((x as f64 - cx) / sx).powi(2) + ((y as f64 - scy) / sy).powi(2);
            if e < 1.0 {
                darken(frame, x, y, shadow + (1.0 - shadow) * e);
            }
        }
    }
    let light = normalise([
        rng.range(-0.7, 0.7),
        rng.range(-1.0, -0.2),
        rng.range(0.3, 1.0),
    ]);
    let ambient = rng.range(0.25, 0.6);
    let specular = rng.range(0.0, 0.6);
    let shininess = rng.range(8.0, 40.0);
    let half = normalise([light[0], light[1], light[2] + 1.0]);
    let patches = if paint.patches {
        patch_centres(rng)
    } else {
        Vec::new()
    };
    let patch_cos = rng.range(0.93, 0.96);
    for y in (cy - r - 1.0).floor() as i64..=(cy + r + 1.0).ceil() as i64 {
        for x in (cx - r - 1.0).floor() as i64..=(cx + r + 1.0).ceil() as i64 {
            let (dx, dy) = (x as f64 - cx, y as f64 - cy);
            let d = dx.hypot(dy);
            let coverage = (r + 0.5 - d).clamp(0.0, 1.0);
            if coverage <= 0.0 {
                continue;
            }
            let (nx, ny) = ((dx / r).clamp(-1.0, 1.0), (dy / r).clamp(-1.0, 1.0));
            let n = normalise([nx, ny, (1.0 - nx * nx - ny * ny).max(0.0).sqrt()]);
            let albedo = if patches.iter().any(|&p| dot(p, n) > patch_cos) {
                [0.9, 0.9, 0.9]
            } else {
                paint.albedo
            };
            let diffuse = ambient + (1.0 - ambient) * dot(n, light).max(0.0);
            let spec = specular * dot(n, half).max(0.0).powf(shininess);
            blend(frame, x, y, albedo.map(|a| a * diffuse + spec), coverage);
        }
    }
}

/// Something in front of the ball hiding up to 40 % of it: a robot's white, grey or dark
/// body edge, a straight-edged slab from one side.
pub fn occluder(frame: &mut Frame, centre: [f64; 2], r: f64, rng: &mut Rng) {
    let v = [0.95, 0.6, 0.15][rng.index(3)] * rng.range(0.85, 1.0);
    let colour = [v, v, v];
    let a = rng.range(0.0, std::f64::consts::TAU);
    let normal = [a.cos(), a.sin()];
    // The slab covers the half-plane beyond `reach` from the ball's centre along `normal`.
    let reach = r * rng.range(0.25, 0.9);
    let extent = (3.0 * r).ceil() as i64;
    let (cx, cy) = (centre[0].round() as i64, centre[1].round() as i64);
    for y in cy - extent..=cy + extent {
        for x in cx - extent..=cx + extent {
            let along = (x as f64 - centre[0]) * normal[0] + (y as f64 - centre[1]) * normal[1];
            if along > reach {
                blend(frame, x, y, colour, (along - reach + 0.5).clamp(0.0, 1.0));
            }
        }
    }
}

/// A look-alike: an orange bar or stripe (a wall marking, a cone's side), a pale orange
/// blob (a hand, a leg), or a white or grey disc (a robot's head from behind).
pub fn distractor(frame: &mut Frame, profile: &PhotoProfile, rng: &mut Rng) {
    let (w, h) = (f64::from(frame.width), f64::from(frame.height));
    let c = [rng.range(0.0, w), rng.range(0.0, h)];
    let size = rng.range(3.0, 0.25 * w.min(h));
    let kind = rng.index(3);
    let (colour, half_w, half_h) = match kind {
        0 => (
            hsv_to_rgb(
                rng.range(profile.hue_deg[0], profile.hue_deg[1]),
                rng.range(0.6, 1.0),
                rng.range(0.5, 1.0),
            ),
            size,
            size / rng.range(2.5, 8.0),
        ),
        1 => (
            hsv_to_rgb(
                rng.range(10.0, 30.0),
                rng.range(0.25, 0.5),
                rng.range(0.5, 0.9),
            ),
            size,
            size / rng.range(1.4, 2.5),
        ),
        _ => {
            let v = rng.range(0.5, 1.0);
            ([v, v, v * rng.range(0.9, 1.05)], size, size)
        }
    };
    let a = rng.range(0.0, std::f64::consts::PI);
    let (ca, sa) = (a.cos(), a.sin());
    let reach = half_w.max(half_h).ceil() as i64 + 1;
    let (ix, iy) = (c[0].round() as i64, c[1].round() as i64);
    for y in iy - reach..=iy + reach {
        for x in ix - reach..=ix + reach {
            let (dx, dy) = (x as f64 - c[0], y as f64 - c[1]);
            let (u, v) = (dx * ca + dy * sa, -dx * sa + dy * ca);
            let inside = if kind == 0 {
                // A bar: a rectangle.
                (half_w - u.abs()).min(half_h - v.abs()) + 0.5
            } else {
                // An ellipse or a disc.
                (1.0 - ((u / half_w).powi(2) + (v / half_h).powi(2)).sqrt()) * half_w.min(half_h)
                    + 0.5
            };
            if inside > 0.0 {
                blend(frame, x, y, colour, inside.min(1.0));
            }
        }
    }
}
