//! The camera renderer: what a MiRo camera sees of the pitch, the walls, the room, the
//! ball and other MiRos, through the simulator's own fisheye lens, with per-frame ground
//! truth about the ball.
//!
//! It is a ray caster built for speed on one core: the camera-frame ray of every pixel is
//! computed once per lens ([`CameraRig`]) and each frame only rotates it into the field.
//! The floor, walls and room are intersected analytically for every pixel; the ball and
//! the robots only inside their image bounding boxes. Shading is Lambert plus ambient from
//! one distant light, with soft contact shadows under the ball and the robots, a carpet
//! texture, a brightness falloff towards the pitch's corners and lens vignetting. Sensor
//! noise comes from a seeded generator, so the same inputs and seed give the same bytes.

use crate::head::{FieldPose, body_pose, camera_pose};
use crate::lens::LensModel;
use crate::render_objects::{BBox, BallObj, RobotObj, ball_obj, robot_obj};
use crate::render_scene::{BallTruth, FloorTexture, Frame, Scene};
use crate::rng::Rng;
use crate::vec3::{V3, mul_vec, norm, sub, transpose, unit};
use proto::{Camera, HeadJoints, Pose2, WallSide};

/// A lens with its per-pixel ray table and the scene's static textures: build once, render
/// many frames.
#[derive(Debug, Clone)]
pub struct CameraRig {
    lens: LensModel,
    /// Unit ray in the camera frame and the vignetting factor, per pixel, row-major.
    rays: Vec<[f32; 4]>,
    floor: FloorTexture,
}

/// Brightness at the image's corners relative to its centre.
const CORNER_VIGNETTE: f64 = 0.72;

impl CameraRig {
    pub fn new(lens: LensModel) -> Self {
        let corner_sin = lens
            .ray([0.0, 0.0])
            .map_or(1.0, |d| (d[2].acos() / crate::lens::THETA_DIVISOR).sin());
        let mut rays = Vec::with_capacity(lens.width as usize * lens.height as usize);
        for y in 0..lens.height {
            for x in 0..lens.width {
                let px = [f64::from(x) + 0.5, f64::from(y) + 0.5];
                rays.push(match lens.ray(px) {
                    Some(d) => {
                        let s = (d[2].acos() / crate::lens::THETA_DIVISOR).sin() / corner_sin;
                        let v = 1.0 - (1.0 - CORNER_VIGNETTE) * s * s;
                        [d[0] as f32, d[1] as f32, d[2] as f32, v as f32]
                    }
                    None => [0.0, 0.0, 1.0, 0.0],
                });
            }
        }
        CameraRig {
            lens,
            rays,
            floor: FloorTexture::carpet(),
        }
    }

    pub fn lens(&self) -> &LensModel {
        &self.lens
    }
}

/// Renders one camera whose optical frame is `camera` (field←camera, optical centre).
/// `frame_seed` selects this frame's noise; the ball truth is `None` without a ball.
pub fn render(
    rig: &CameraRig,
    scene: &Scene,
    camera: &FieldPose,
    frame_seed: u64,
) -> (Frame, Option<BallTruth>) {
    let lens = &rig.lens;
    let cam_from_field = transpose(&camera.field_from_local);
    let env = Env::new(scene, camera, &rig.floor);
    let ball = scene
        .ball_m
        .map(|b| ball_obj(lens, &cam_from_field, camera.origin_m, b, scene));
    let robots: Vec<RobotObj> = scene
        .robots
        .iter()
        .filter_map(|r| robot_obj(lens, &cam_from_field, camera.origin_m, r))
        .collect();
    let r = to_f32_mat(&camera.field_from_local);
    let scale = pixel_scale(scene);
    let sigma = scene.noise_sigma.max(0.0) as f32;
    let mut rng = Rng::stream(scene.seed, "render", frame_seed);
    let (w, h) = (lens.width as usize, lens.height as usize);
    let mut rgb = vec![0u8; 3 * w * h];
    let mut counts = BallCounts::default();
    let mut active: Vec<&RobotObj> = Vec::with_capacity(robots.len());
    for y in 0..h {
        active.clear();
        active.extend(robots.iter().filter(|o| o.bbox.has_row(y)));
        let ball_row = ball.as_ref().filter(|b| b.bbox.has_row(y));
        for x in 0..w {
            let i = y * w + x;
            let [rx, ry, rz, vig] = rig.rays[i];
            let d = [
                r[0][0] * rx + r[0][1] * ry + r[0][2] * rz,
                r[1][0] * rx + r[1][1] * ry + r[1][2] * rz,
                r[2][0] * rx + r[2][1] * ry + r[2][2] * rz,
            ];
            let ball_here = ball_row.filter(|b| b.bbox.has_col(x));
            let colour = if ball_here.is_some() || active.iter().any(|o| o.bbox.has_col(x)) {
                trace_objects(&env, d, ball_here, &active, x, y, &mut counts)
            } else {
                env.shade(d)
            };
            let out = &mut rgb[3 * i..3 * i + 3];
            for c in 0..3 {
                let mut v = colour[c] * vig * scale[c];
                if sigma > 0.0 {
                    v += sigma * gauss(&mut rng);
                }
                out[c] = (v + 0.5).clamp(0.0, 255.0) as u8;
            }
        }
    }
    let frame = Frame {
        width: lens.width,
        height: lens.height,
        rgb,
    };
    let truth = scene
        .ball_m
        .map(|b| ball_truth(lens, &cam_from_field, camera.origin_m, b, scene, &counts));
    (frame, truth)
}

/// Both cameras of a robot at `pose` with head joints `head`: `[left, right]`. The robot's
/// own body is not drawn (its cameras look forward, away from it); `scene.robots` should
/// hold only the others.
pub fn render_robot_cameras(
    rig: &CameraRig,
    scene: &Scene,
    pose: Pose2,
    head: HeadJoints,
    frame_seed: u64,
) -> [(Frame, Option<BallTruth>); 2] {
    [Camera::Left, Camera::Right].map(|camera| {
        let k = u64::from(camera == Camera::Right);
        let seed = frame_seed.wrapping_mul(2).wrapping_add(k);
        render(rig, scene, &camera_pose(pose, head, camera), seed)
    })
}

/// 8-bit levels per unit of linear radiance, per channel.
fn pixel_scale(scene: &Scene) -> [f32; 3] {
    let l = &scene.lighting;
    l.gain_rgb.map(|g| (255.0 * l.exposure * g) as f32)
}

/// A Gaussian-like draw (mean 0, variance 1) from one 64-bit word: the sum of four
/// 16-bit uniforms (Irwin–Hall), far cheaper than Box–Muller and ample for sensor noise.
#[inline]
pub(crate) fn gauss(rng: &mut Rng) -> f32 {
    let u = rng.next_u64();
    let s = (u & 0xFFFF) + ((u >> 16) & 0xFFFF) + ((u >> 32) & 0xFFFF) + (u >> 48);
    (s as f32 / 65536.0 - 2.0) * 1.732_050_8
}

pub(crate) fn to_f32_mat(m: &[[f64; 3]; 3]) -> [[f32; 3]; 3] {
    m.map(|row| row.map(|v| v as f32))
}

pub(crate) fn to_f32(v: V3) -> [f32; 3] {
    v.map(|x| x as f32)
}

#[derive(Debug, Default)]
struct BallCounts {
    silhouette: usize,
    visible: usize,
    occluded_by_robot: bool,
}

/// The nearest of the ball and the robots along `d`, or the environment behind them.
fn trace_objects(
    env: &Env,
    d: [f32; 3],
    ball: Option<&BallObj>,
    robots: &[&RobotObj],
    x: usize,
    y: usize,
    counts: &mut BallCounts,
) -> [f32; 3] {
    let floor_t = if d[2] < 0.0 {
        -env.c[2] / d[2]
    } else {
        f32::INFINITY
    };
    let ball_t = ball
        .and_then(|b| b.hit(env.c, d))
        .filter(|&t| t <= floor_t + 1e-4);
    let mut best: Option<(f32, &RobotObj, usize)> = None;
    for o in robots.iter().filter(|o| o.bbox.contains(x, y)) {
        if let Some((t, part)) = o.hit(env.c, d)
            && best.is_none_or(|(bt, _, _)| t < bt)
        {
            best = Some((t, o, part));
        }
    }
    if let Some(tb) = ball_t {
        counts.silhouette += 1;
        match best {
            Some((tr, _, _)) if tr < tb => counts.occluded_by_robot = true,
            _ => {
                counts.visible += 1;
                return ball.map_or([0.0; 3], |b| b.shade(env, d, tb));
            }
        }
    }
    match best {
        Some((t, o, part)) if t < floor_t => o.shade(env, d, t, part),
        _ => env.shade(d),
    }
}

fn ball_truth(
    lens: &LensModel,
    cam_from_field: &[[f64; 3]; 3],
    camera_m: V3,
    ball_m: V3,
    scene: &Scene,
    counts: &BallCounts,
) -> BallTruth {
    let v = mul_vec(cam_from_field, sub(ball_m, camera_m));
    let range_m = norm(v);
    BallTruth {
        in_frame: counts.silhouette > 0,
        visible_fraction: if counts.silhouette > 0 {
            counts.visible as f64 / counts.silhouette as f64
        } else {
            0.0
        },
        occluded_by_robot: counts.occluded_by_robot,
        center_px: lens.project(v),
        radius_px: apparent_radius_px(lens, v, scene.pitch.ball_radius_m),
        visible_px: counts.visible,
        silhouette_px: counts.silhouette,
        world_m: ball_m,
        range_m,
    }
}

/// Radius of the circle with the area of a sphere's silhouette: half its radial extent
/// (the lens stretches or squeezes along the radius) times half its tangential extent,
/// geometric mean, times the pixel aspect.
pub fn apparent_radius_px(lens: &LensModel, centre_cam_m: V3, radius_m: f64) -> f64 {
    let dist = norm(centre_cam_m);
    if dist <= radius_m {
        return f64::INFINITY;
    }
    let u = unit(centre_cam_m);
    let alpha = (radius_m / dist).asin();
    let theta_c = u[2].clamp(-1.0, 1.0).acos();
    let radial = 0.5 * (lens.radius_px(theta_c + alpha) - lens.radius_px(theta_c - alpha));
    let theta_p = (theta_c.cos() * alpha.cos()).clamp(-1.0, 1.0).acos();
    let per_sin = if theta_p.sin() > 1e-9 {
        lens.radius_px(theta_p) / theta_p.sin()
    } else {
        2.0 * lens.f_px / crate::lens::THETA_DIVISOR
    };
    let tangential = per_sin * alpha.sin();
    (radial * tangential * lens.aspect).max(0.0).sqrt()
}

/// Linear reflectances of the static scene.
const CARPET: [f32; 3] = [0.34, 0.42, 0.35];
const WALL: [f32; 3] = [0.86, 0.86, 0.83];
const WALL_RIM: [f32; 3] = [0.55, 0.55, 0.55];
const ORANGE_MARK: [f32; 3] = [0.92, 0.38, 0.07];
const RED_MARK: [f32; 3] = [0.78, 0.10, 0.08];
const BLUE_MARK: [f32; 3] = [0.10, 0.22, 0.65];
const ROOM_WALL: [f32; 3] = [0.62, 0.58, 0.52];
const ROOM_PANEL: [f32; 3] = [0.36, 0.30, 0.26];
const ROOM_FLOOR: [f32; 3] = [0.42, 0.41, 0.40];
const SKIRTING: [f32; 3] = [0.22, 0.21, 0.20];
const CEILING: [f32; 3] = [0.85, 0.85, 0.85];
/// The pitch's walls are this high.
pub const WALL_HEIGHT_M: f64 = 0.10;
/// The room around the pitch: this much larger on each side, this high.
const ROOM_MARGIN_M: f32 = 1.6;
const ROOM_HEIGHT_M: f32 = 2.6;
/// Floor texels per metre (4 mm texels).
const TEXELS_PER_M: f32 = 250.0;

/// A soft dark disc on the floor: the contact shadow of the ball or a robot.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shadow {
    pub xy: [f32; 2],
    pub inv_two_sigma2: f32,
    pub reach2: f32,
    pub strength: f32,
}

/// Per-frame constants of the static scene, in `f32` for the per-pixel work.
pub(crate) struct Env<'a> {
    pub c: [f32; 3],
    hx: f32,
    hy: f32,
    wall_h: f32,
    walls: [bool; 4],
    pub light: [f32; 3],
    pub ambient: f32,
    pub diffuse: f32,
    falloff: f32,
    floor: &'a FloorTexture,
    shadows: Vec<Shadow>,
}

impl<'a> Env<'a> {
    fn new(scene: &Scene, camera: &FieldPose, floor: &'a FloorTexture) -> Self {
        let l = &scene.lighting;
        let light = to_f32(unit(l.light_dir));
        let p = &scene.pitch;
        let mut shadows = Vec::new();
        let lift = |h: f32| {
            [
                -light[0] / light[2].max(0.2) * h,
                -light[1] / light[2].max(0.2) * h,
            ]
        };
        if let Some(b) = scene.ball_m {
            let r = p.ball_radius_m as f32;
            let z = b[2] as f32;
            let sigma = 0.45 * r + 0.3 * (z - r).max(0.0);
            let off = lift(0.5 * r);
            shadows.push(Shadow {
                xy: [b[0] as f32 + off[0], b[1] as f32 + off[1]],
                inv_two_sigma2: 1.0 / (2.0 * sigma * sigma),
                reach2: (4.0 * sigma) * (4.0 * sigma),
                strength: 0.65 / (1.0 + 8.0 * (z - r).max(0.0)),
            });
        }
        for rb in &scene.robots {
            let o = body_pose(rb.pose).point([0.0, 0.0, 0.0]);
            let off = lift(0.05);
            let sigma = 0.085;
            shadows.push(Shadow {
                xy: [o[0] as f32 + off[0], o[1] as f32 + off[1]],
                inv_two_sigma2: 1.0 / (2.0 * sigma * sigma),
                reach2: (3.5 * sigma) * (3.5 * sigma),
                strength: 0.55,
            });
        }
        Env {
            c: to_f32(camera.origin_m),
            hx: p.half_length_m() as f32,
            hy: p.half_width_m() as f32,
            wall_h: WALL_HEIGHT_M as f32,
            walls: [
                WallSide::XMax,
                WallSide::XMin,
                WallSide::YMax,
                WallSide::YMin,
            ]
            .map(|s| p.has_wall(s)),
            light,
            ambient: l.ambient as f32,
            diffuse: (1.0 - l.ambient) as f32,
            falloff: l.falloff as f32,
            floor,
            shadows,
        }
    }

    /// Lambert plus ambient for a surface with unit normal `n`.
    #[inline]
    pub fn lambert(&self, n: [f32; 3]) -> f32 {
        let ndl = n[0] * self.light[0] + n[1] * self.light[1] + n[2] * self.light[2];
        self.ambient + self.diffuse * ndl.max(0.0)
    }

    /// Radiance along `d` from the floor, the walls or the room (no ball, no robots).
    #[inline]
    pub fn shade(&self, d: [f32; 3]) -> [f32; 3] {
        let c = self.c;
        let tx = exit_t(c[0], d[0], self.hx);
        let ty = exit_t(c[1], d[1], self.hy);
        let floor_t = if d[2] < 0.0 {
            -c[2] / d[2]
        } else {
            f32::INFINITY
        };
        let (tw, side) = if tx < ty {
            (tx, if d[0] > 0.0 { 0 } else { 1 })
        } else {
            (ty, if d[1] > 0.0 { 2 } else { 3 })
        };
        if floor_t <= tw {
            return self.floor_colour(c[0] + floor_t * d[0], c[1] + floor_t * d[1]);
        }
        let z = c[2] + tw * d[2];
        if self.walls[side] && z <= self.wall_h {
            let along = if side < 2 {
                c[1] + tw * d[1]
            } else {
                c[0] + tw * d[0]
            };
            return self.wall_colour(side, along, z);
        }
        self.room(d)
    }

    fn floor_colour(&self, x: f32, y: f32) -> [f32; 3] {
        let tex = self.floor.sample(x * TEXELS_PER_M, y * TEXELS_PER_M);
        let (u, v) = (x / self.hx, y / self.hy);
        let spot = 1.0 - self.falloff * 0.5 * (u * u + v * v);
        let mut k = tex * spot * self.lambert([0.0, 0.0, 1.0]);
        // Faint lines: the halfway line and the centre circle.
        let r = (x * x + y * y).sqrt();
        if x.abs() < 0.008 || (r - 0.3).abs() < 0.008 {
            k *= 1.15;
        }
        for s in &self.shadows {
            let (dx, dy) = (x - s.xy[0], y - s.xy[1]);
            let d2 = dx * dx + dy * dy;
            if d2 < s.reach2 {
                k *= 1.0 - s.strength * (-d2 * s.inv_two_sigma2).exp();
            }
        }
        CARPET.map(|a| a * k)
    }

    /// A pitch wall's inner face; `along` is the coordinate along the wall.
    fn wall_colour(&self, side: usize, along: f32, z: f32) -> [f32; 3] {
        let n = match side {
            0 => [-1.0, 0.0, 0.0],
            1 => [1.0, 0.0, 0.0],
            2 => [0.0, -1.0, 0.0],
            _ => [0.0, 1.0, 0.0],
        };
        let k = self.lambert(n) * (0.8 + 2.0 * z).min(1.0);
        let paint = if z > self.wall_h - 0.008 {
            WALL_RIM
        } else if side < 2 {
            // Goal ends: coloured posts either side of the goal mouth.
            let a = along.abs();
            if (0.30..0.36).contains(&a) {
                if side == 0 { ORANGE_MARK } else { RED_MARK }
            } else {
                WALL
            }
        } else {
            // Side walls: a coloured band near each corner.
            let a = along.abs();
            if a > self.hx - 0.45 && a < self.hx - 0.2 && (0.035..0.065).contains(&z) {
                if along > 0.0 { ORANGE_MARK } else { BLUE_MARK }
            } else {
                WALL
            }
        };
        paint.map(|p| p * k)
    }

    /// The room around the pitch: a box with panelled walls, a grey floor and a ceiling.
    fn room(&self, d: [f32; 3]) -> [f32; 3] {
        let c = self.c;
        let (rx, ry) = (self.hx + ROOM_MARGIN_M, self.hy + ROOM_MARGIN_M);
        let tx = exit_t(c[0], d[0], rx);
        let ty = exit_t(c[1], d[1], ry);
        let tz = if d[2] > 0.0 {
            (ROOM_HEIGHT_M - c[2]) / d[2]
        } else if d[2] < 0.0 {
            -c[2] / d[2]
        } else {
            f32::INFINITY
        };
        let spot = 0.75 * (self.ambient + self.diffuse * 0.7);
        if tz <= tx.min(ty) {
            if d[2] > 0.0 {
                return CEILING;
            }
            let (x, y) = (c[0] + tz * d[0], c[1] + tz * d[1]);
            let tex = self.floor.sample(x * 90.0 + 131.0, y * 90.0);
            return ROOM_FLOOR.map(|a| a * tex * spot);
        }
        let (t, along) = if tx < ty {
            (tx, c[1] + tx * d[1])
        } else {
            (ty, c[0] + ty * d[0])
        };
        let z = c[2] + t * d[2];
        let paint = if z < 0.08 {
            SKIRTING
        } else if z < 0.9 && (along + 10.0).rem_euclid(1.7) < 0.6 {
            ROOM_PANEL
        } else {
            ROOM_WALL
        };
        let k = spot * (0.8 + 0.1 * z);
        paint.map(|p| p * k)
    }
}

/// Ray parameter where `o + t·d` (one coordinate) leaves the slab |x| ≤ half.
#[inline]
fn exit_t(o: f32, d: f32, half: f32) -> f32 {
    if d > 0.0 {
        (half - o) / d
    } else if d < 0.0 {
        (-half - o) / d
    } else {
        f32::INFINITY
    }
}

impl BBox {
    #[inline]
    fn has_row(&self, y: usize) -> bool {
        (self.y0..self.y1).contains(&y)
    }

    #[inline]
    fn has_col(&self, x: usize) -> bool {
        (self.x0..self.x1).contains(&x)
    }

    #[inline]
    fn contains(&self, x: usize, y: usize) -> bool {
        self.has_row(y) && self.has_col(x)
    }
}
