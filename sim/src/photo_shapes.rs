//! What [`crate::photo_synth`] paints: carpet textures, a shaded ball of any
//! [`BallDesign`], things that hide part of it and things that look a little like it.

use crate::photo_synth::{BallDesign, CarpetTexture, PhotoProfile};
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

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn scaled_sum(a: [f64; 3], ka: f64, b: [f64; 3], kb: f64) -> [f64; 3] {
    [
        a[0] * ka + b[0] * kb,
        a[1] * ka + b[1] * kb,
        a[2] * ka + b[2] * kb,
    ]
}

/// Two unit vectors making a right-handed frame with the unit vector `axis`.
fn tangent_basis(axis: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let helper = if axis[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = normalise(cross(axis, helper));
    (u, cross(axis, u))
}

/// A uniformly random direction.
fn random_direction(rng: &mut Rng) -> [f64; 3] {
    loop {
        let v = [rng.normal(), rng.normal(), rng.normal()];
        if dot(v, v) > 1e-6 {
            return normalise(v);
        }
    }
}

/// A uniformly random rotation (rows of its matrix), from a random unit quaternion.
fn random_rotation(rng: &mut Rng) -> [[f64; 3]; 3] {
    let (w, x, y, z) = loop {
        let q = [rng.normal(), rng.normal(), rng.normal(), rng.normal()];
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        if n > 1e-6 {
            break (q[0] / n, q[1] / n, q[2] / n, q[3] / n);
        }
    };
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

fn rotate(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// The twelve unit vertices of an icosahedron (a football's pentagon centres).
fn icosahedron() -> Vec<[f64; 3]> {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v = Vec::new();
    for &a in &[-1.0, 1.0] {
        for &b in &[-g, g] {
            v.push(normalise([0.0, a, b]));
            v.push(normalise([a, b, 0.0]));
            v.push(normalise([b, 0.0, a]));
        }
    }
    v
}

/// The twelve patch centres of a football (an icosahedron's vertices), turned at random.
fn patch_centres(rng: &mut Rng) -> Vec<[f64; 3]> {
    let (yaw, pitch) = (rng.range(0.0, 6.3), rng.range(0.0, 6.3));
    icosahedron()
        .into_iter()
        .map(|p| {
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

/// A region of the ball's surface, as a set of unit surface normals `n` (camera axes: x
/// right, y down, z towards the camera).
#[derive(Debug, Clone, PartialEq)]
enum Mark {
    /// A round cap: `dot(n, centre) > cos_radius`.
    Cap { centre: [f64; 3], cos_radius: f64 },
    /// A convex spherical polygon with great-circle sides: `dot(n, centre) > cos_bound`
    /// (a cap holding it) and `dot(n, e) <= 0` for each side's plane normal `e`.
    Polygon {
        centre: [f64; 3],
        cos_bound: f64,
        sides: Vec<[f64; 3]>,
    },
    /// A blob with a wavy rim: within the angle `radius_rad · (1 + Σ amp · cos(k · θ +
    /// phase))` of `centre`, `θ` the azimuth about `centre` in the tangent basis `(u, v)`.
    Blob {
        centre: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        radius_rad: f64,
        wobble: [(f64, f64, f64); 2],
    },
    /// A band along a wavy circle about `axis`: `|dot(n, axis) - offset(φ)| < half_width`,
    /// `offset(φ) = offset + amp · sin(k · φ + phase)` with `(amp, k, phase)` = `wave` and
    /// `φ` the azimuth about `axis` in the tangent basis `(u, v)`; `k` is whole, so the band
    /// closes on itself.
    Band {
        axis: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        offset: f64,
        half_width: f64,
        wave: (f64, f64, f64),
    },
    /// A seam: within `half_width` (a sine) of the great circle with normal `normal`, on
    /// the arc between two ends (`dot(n, t) >= 0` for each end's tangent `t` pointing
    /// along the arc).
    Arc {
        normal: [f64; 3],
        ends: [[f64; 3]; 2],
        half_width: f64,
    },
}

impl Mark {
    fn contains(&self, n: [f64; 3]) -> bool {
        match self {
            Mark::Cap { centre, cos_radius } => dot(n, *centre) > *cos_radius,
            Mark::Polygon {
                centre,
                cos_bound,
                sides,
            } => dot(n, *centre) > *cos_bound && sides.iter().all(|&e| dot(n, e) <= 0.0),
            Mark::Blob {
                centre,
                u,
                v,
                radius_rad,
                wobble,
            } => {
                let c = dot(n, *centre);
                if c <= 0.0 {
                    return false;
                }
                let theta = dot(n, *v).atan2(dot(n, *u));
                let k: f64 = wobble
                    .iter()
                    .map(|&(amp, k, phase)| amp * (k * theta + phase).cos())
                    .sum();
                c.clamp(-1.0, 1.0).acos() < radius_rad * (1.0 + k)
            }
            Mark::Band {
                axis,
                u,
                v,
                offset,
                half_width,
                wave: (amp, k, phase),
            } => {
                let phi = dot(n, *v).atan2(dot(n, *u));
                (dot(n, *axis) - offset - amp * (k * phi + phase).sin()).abs() < *half_width
            }
            Mark::Arc {
                normal,
                ends,
                half_width,
            } => dot(n, *normal).abs() < *half_width && ends.iter().all(|&t| dot(n, t) >= 0.0),
        }
    }

    /// A great-circle seam from `a` to `b` (unit vectors less than 180° apart).
    fn arc(a: [f64; 3], b: [f64; 3], half_width: f64) -> Mark {
        let normal = normalise(cross(a, b));
        Mark::Arc {
            normal,
            ends: [cross(normal, a), cross(b, normal)],
            half_width,
        }
    }

    /// A band about `axis` (see [`Mark::Band`]).
    fn band(axis: [f64; 3], offset: f64, half_width: f64, wave: (f64, f64, f64)) -> Mark {
        let (u, v) = tangent_basis(axis);
        Mark::Band {
            axis,
            u,
            v,
            offset,
            half_width,
            wave,
        }
    }

    /// A blob of about `radius_rad` about `centre` with a random wavy rim of `lobes`
    /// bulges, up to `wobble` of the radius.
    fn blob(centre: [f64; 3], radius_rad: f64, lobes: f64, wobble: f64, rng: &mut Rng) -> Mark {
        let (u, v) = tangent_basis(centre);
        let tau = std::f64::consts::TAU;
        Mark::Blob {
            centre,
            u,
            v,
            radius_rad,
            wobble: [
                (rng.range(0.3, 1.0) * wobble, lobes, rng.range(0.0, tau)),
                (
                    rng.range(0.0, 0.4) * wobble,
                    2.0 * lobes - 1.0,
                    rng.range(0.0, tau),
                ),
            ],
        }
    }
}

/// How the ball is painted: a body colour and marks over it.
#[derive(Debug, Clone, PartialEq)]
pub struct BallPaint {
    /// The design the paint was drawn for.
    pub design: BallDesign,
    /// The body's reflectance, 0..1 per channel.
    pub albedo: [f64; 3],
    /// Marks over the body, each with its reflectance; a later mark covers an earlier one.
    marks: Vec<(Mark, [f64; 3])>,
}

/// A white of reflectance 0.82–0.95, a little warm or cool.
fn white(rng: &mut Rng) -> [f64; 3] {
    hsv_to_rgb(
        rng.range(0.0, 360.0),
        rng.range(0.0, 0.06),
        rng.range(0.82, 0.95),
    )
}

/// A black of reflectance 0.03–0.1.
fn black(rng: &mut Rng) -> [f64; 3] {
    let v = rng.range(0.03, 0.1);
    [v, v, v * rng.range(0.9, 1.15)]
}

impl BallPaint {
    /// A random paint of `design`, the coloured designs taking their colour from `profile`.
    pub fn draw(design: BallDesign, profile: &PhotoProfile, rng: &mut Rng) -> Self {
        let tau = std::f64::consts::TAU;
        let profile_colour = |rng: &mut Rng| {
            hsv_to_rgb(
                rng.range(profile.hue_deg[0], profile.hue_deg[1]),
                rng.range(profile.saturation[0], profile.saturation[1]),
                rng.range(profile.value[0], profile.value[1]),
            )
        };
        let mut marks = Vec::new();
        let albedo = match design {
            BallDesign::Plain => {
                if rng.chance(profile.plain_neutral_chance) {
                    if rng.chance(0.5) {
                        white(rng)
                    } else {
                        hsv_to_rgb(
                            rng.range(0.0, 360.0),
                            rng.range(0.0, 0.3),
                            rng.range(0.04, 0.14),
                        )
                    }
                } else {
                    profile_colour(rng)
                }
            }
            BallDesign::Patches => {
                let albedo = profile_colour(rng);
                let centres = patch_centres(rng);
                let cos_radius = rng.range(0.93, 0.96);
                for centre in centres {
                    marks.push((Mark::Cap { centre, cos_radius }, [0.9, 0.9, 0.9]));
                }
                albedo
            }
            BallDesign::Classic => {
                let body = white(rng);
                let ink = black(rng);
                let turn = random_rotation(rng);
                let centres: Vec<[f64; 3]> = icosahedron()
                    .into_iter()
                    .map(|p| rotate(&turn, p))
                    .collect();
                // A true truncated icosahedron's pentagons reach about 20° from their
                // centres; printed balls often draw them a little larger.
                let radius_rad = rng.range(19.0, 24.0_f64).to_radians();
                // Each pentagon's corners, pointing at its five neighbours.
                let corners: Vec<Vec<([f64; 3], usize)>> = centres
                    .iter()
                    .map(|&p| {
                        let (u, v) = tangent_basis(p);
                        let mut around: Vec<(f64, [f64; 3], usize)> = centres
                            .iter()
                            .enumerate()
                            .filter(|&(_, &q)| dot(p, q) > 0.3 && dot(p, q) < 0.99)
                            .map(|(j, &q)| {
                                let t = normalise(scaled_sum(q, 1.0, p, -dot(p, q)));
                                let corner =
                                    normalise(scaled_sum(p, radius_rad.cos(), t, radius_rad.sin()));
                                (dot(q, v).atan2(dot(q, u)), corner, j)
                            })
                            .collect();
                        around.sort_by(|a, b| a.0.total_cmp(&b.0));
                        around.into_iter().map(|(_, c, j)| (c, j)).collect()
                    })
                    .collect();
                if rng.chance(0.6) {
                    // Seams between the white hexagons: the middle of each edge of the
                    // icosahedron, from one pentagon's corner to the next one's.
                    let seam = [rng.range(0.12, 0.35); 3];
                    let half_width = rng.range(0.008, 0.02);
                    for (i, around) in corners.iter().enumerate() {
                        for &(a, j) in around {
                            if j <= i {
                                continue;
                            }
                            let back = corners[j].iter().find(|&&(_, k)| k == i);
                            if let Some(&(b, _)) = back {
                                marks.push((Mark::arc(a, b, half_width), seam));
                            }
                        }
                    }
                }
                for (&centre, around) in centres.iter().zip(&corners) {
                    let sides = (0..around.len())
                        .map(|k| {
                            let e = normalise(cross(around[k].0, around[(k + 1) % around.len()].0));
                            if dot(e, centre) > 0.0 {
                                e.map(|c| -c)
                            } else {
                                e
                            }
                        })
                        .collect();
                    let cos_bound = (radius_rad + 0.01).cos();
                    marks.push((
                        Mark::Polygon {
                            centre,
                            cos_bound,
                            sides,
                        },
                        ink,
                    ));
                }
                body
            }
            BallDesign::WhiteBlackPanels => {
                let body = white(rng);
                let ink = black(rng);
                let turn = random_rotation(rng);
                let s = 1.0 / 3f64.sqrt();
                let (centres, radius_rad, lobes) = if rng.chance(0.7) {
                    let octahedron = vec![
                        [1.0, 0.0, 0.0],
                        [-1.0, 0.0, 0.0],
                        [0.0, 1.0, 0.0],
                        [0.0, -1.0, 0.0],
                        [0.0, 0.0, 1.0],
                        [0.0, 0.0, -1.0],
                    ];
                    (octahedron, rng.range(0.4, 0.58), 4.0)
                } else {
                    let tetrahedron = vec![[s, s, s], [s, -s, -s], [-s, s, -s], [-s, -s, s]];
                    (tetrahedron, rng.range(0.55, 0.8), 3.0)
                };
                let wobble = rng.range(0.05, 0.25);
                for c in centres {
                    let centre = rotate(&turn, c);
                    let r = radius_rad * rng.range(0.8, 1.15);
                    marks.push((Mark::blob(centre, r, lobes, wobble, rng), ink));
                }
                body
            }
            BallDesign::Modern => {
                let body = white(rng);
                let saturated = |rng: &mut Rng| {
                    hsv_to_rgb(
                        rng.range(0.0, 360.0),
                        rng.range(0.7, 1.0),
                        rng.range(0.5, 0.95),
                    )
                };
                let first = saturated(rng);
                let second = if rng.chance(0.5) {
                    saturated(rng)
                } else {
                    first
                };
                let outline = rng.chance(0.5).then(|| {
                    let v = rng.range(0.04, 0.2);
                    ([v, v, v * rng.range(0.9, 1.4)], rng.range(0.015, 0.035))
                });
                for k in 0..2 + rng.index(2) {
                    let axis = random_direction(rng);
                    let offset = rng.range(-0.5, 0.5);
                    let half_width = rng.range(0.06, 0.18);
                    let wave = (
                        rng.range(0.0, 0.3),
                        (1 + rng.index(3)) as f64,
                        rng.range(0.0, tau),
                    );
                    if let Some((dark, extra)) = outline {
                        marks.push((Mark::band(axis, offset, half_width + extra, wave), dark));
                    }
                    let colour = if k % 2 == 0 { first } else { second };
                    marks.push((Mark::band(axis, offset, half_width, wave), colour));
                }
                body
            }
            BallDesign::Yellow => {
                let (hue, s, v) = (
                    rng.range(48.0, 58.0),
                    rng.range(0.75, 1.0),
                    rng.range(0.8, 1.0),
                );
                let body = hsv_to_rgb(hue, s, v);
                let panel = hsv_to_rgb(hue - rng.range(0.0, 10.0), s, v * rng.range(0.6, 0.8));
                for _ in 0..2 + rng.index(3) {
                    let r = rng.range(0.3, 0.55);
                    let centre = random_direction(rng);
                    marks.push((Mark::blob(centre, r, 3.0, 0.2, rng), panel));
                }
                let line = if rng.chance(0.5) {
                    black(rng)
                } else {
                    hsv_to_rgb(
                        rng.range(210.0, 250.0),
                        rng.range(0.5, 1.0),
                        rng.range(0.1, 0.3),
                    )
                };
                let half_width = rng.range(0.012, 0.028);
                for _ in 0..3 + rng.index(3) {
                    let axis = random_direction(rng);
                    let wave = (
                        rng.range(0.05, 0.35),
                        (1 + rng.index(3)) as f64,
                        rng.range(0.0, tau),
                    );
                    let offset = rng.range(-0.6, 0.6);
                    marks.push((Mark::band(axis, offset, half_width, wave), line));
                }
                body
            }
        };
        BallPaint {
            design,
            albedo,
            marks,
        }
    }

    /// The reflectance at the unit surface normal `n`.
    pub fn albedo_at(&self, n: [f64; 3]) -> [f64; 3] {
        self.marks
            .iter()
            .rev()
            .find(|(mark, _)| mark.contains(n))
            .map_or(self.albedo, |&(_, colour)| colour)
    }
}

/// The unit surface normal of a ball of radius `r_px` seen at `(dx_px, dy_px)` from its
/// centre (on the rim beyond it).
fn normal_at(dx_px: f64, dy_px: f64, r_px: f64) -> [f64; 3] {
    let (nx, ny) = (
        (dx_px / r_px).clamp(-1.0, 1.0),
        (dy_px / r_px).clamp(-1.0, 1.0),
    );
    normalise([nx, ny, (1.0 - nx * nx - ny * ny).max(0.0).sqrt()])
}

/// A shaded ball of radius `r` at `centre`: a soft contact shadow under it, Lambert
/// shading from a random light above, ambient light, a specular highlight, anti-aliased
/// rim. A patterned paint is sampled four times a pixel, so its marks' edges are smooth.
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
    const SUBSAMPLES: [(f64, f64); 4] =
        [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)];
    for y in (cy - r - 1.0).floor() as i64..=(cy + r + 1.0).ceil() as i64 {
        for x in (cx - r - 1.0).floor() as i64..=(cx + r + 1.0).ceil() as i64 {
            let (dx, dy) = (x as f64 - cx, y as f64 - cy);
            let d = dx.hypot(dy);
            let coverage = (r + 0.5 - d).clamp(0.0, 1.0);
            if coverage <= 0.0 {
                continue;
            }
            let n = normal_at(dx, dy, r);
            let albedo = if paint.marks.is_empty() {
                paint.albedo
            } else {
                let mut sum = [0.0; 3];
                for (ox, oy) in SUBSAMPLES {
                    let a = paint.albedo_at(normal_at(dx + ox, dy + oy, r));
                    sum = scaled_sum(sum, 1.0, a, 0.25);
                }
                sum
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

/// Paints over a box of a photo (`[x_min, y_min, x_max, y_max]`, pixels, widened by a
/// fifth of its size and 2 px): each pixel inside becomes a blend of the pixels just
/// outside the box on its row and its column, weighted by nearness, so a real ball in a
/// background photo is replaced by its surroundings before a painted one is put in.
pub fn erase_box(frame: &mut Frame, box_px: [f64; 4]) {
    let (w, h) = (frame.width as i64, frame.height as i64);
    if w < 3 || h < 3 {
        return;
    }
    let [x0, y0, x1, y1] = box_px;
    let (mx, my) = (0.2 * (x1 - x0) + 2.0, 0.2 * (y1 - y0) + 2.0);
    // The first and last rows and columns kept: the border the fill is made from.
    let left = ((x0 - mx).floor() as i64).clamp(0, w - 1);
    let right = ((x1 + mx).ceil() as i64).clamp(0, w - 1);
    let top = ((y0 - my).floor() as i64).clamp(0, h - 1);
    let bottom = ((y1 + my).ceil() as i64).clamp(0, h - 1);
    if right - left < 2 || bottom - top < 2 {
        return;
    }
    let at = |f: &Frame, x: i64, y: i64| {
        let i = 3 * (y as usize * f.width as usize + x as usize);
        [
            f64::from(f.rgb[i]),
            f64::from(f.rgb[i + 1]),
            f64::from(f.rgb[i + 2]),
        ]
    };
    let source = frame.clone();
    for y in top + 1..bottom {
        for x in left + 1..right {
            let (l, r) = (at(&source, left, y), at(&source, right, y));
            let (t, b) = (at(&source, x, top), at(&source, x, bottom));
            let (dl, dr) = ((x - left) as f64, (right - x) as f64);
            let (dt, db) = ((y - top) as f64, (bottom - y) as f64);
            // Each border pixel weighs by the inverse of its distance.
            let weights = [1.0 / dl, 1.0 / dr, 1.0 / dt, 1.0 / db];
            let sum: f64 = weights.iter().sum();
            let i = 3 * (y as usize * frame.width as usize + x as usize);
            for c in 0..3 {
                let v =
                    (weights[0] * l[c] + weights[1] * r[c] + weights[2] * t[c] + weights[3] * b[c])
                        / sum;
                frame.rgb[i + c] = v.round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}
