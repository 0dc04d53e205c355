//! The renderer's moving objects, the ball and other MiRos, prepared once per frame: their
//! shapes in `f32` and their bounding boxes in the image.

use crate::head::{body_pose, camera_pose, head_pose};
use crate::lens::LensModel;
use crate::render::{Env, to_f32, to_f32_mat};
use crate::render_scene::{BallPattern, RobotBody, Scene};
use crate::vec3::{Mat3, V3, cross, mul_vec, norm, scale, sub, transpose, unit};
use proto::Camera;

/// Pixels `x0..x1` × `y0..y1` of the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct BBox {
    pub x0: usize,
    pub x1: usize,
    pub y0: usize,
    pub y1: usize,
}

/// The image box holding a sphere's silhouette (with a margin), `None` when the sphere is
/// outside the image. Projects points around the silhouette's cone, slightly widened so
/// the polygon through them encloses the true outline.
pub(crate) fn sphere_bbox(
    lens: &LensModel,
    cam_from_field: &Mat3,
    camera_m: V3,
    centre_m: V3,
    radius_m: f64,
) -> Option<BBox> {
    const N: usize = 24;
    let full = BBox {
        x0: 0,
        x1: lens.width as usize,
        y0: 0,
        y1: lens.height as usize,
    };
    let v = mul_vec(cam_from_field, sub(centre_m, camera_m));
    let dist = norm(v);
    if dist <= radius_m * 1.05 {
        return Some(full);
    }
    let u = unit(v);
    let alpha = ((radius_m / dist).asin() / (std::f64::consts::PI / N as f64).cos()).min(1.5);
    let helper = if u[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = unit(cross(u, helper));
    let e2 = cross(u, e1);
    let (sa, ca) = alpha.sin_cos();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for k in 0..N {
        let (s, c) = (std::f64::consts::TAU * k as f64 / N as f64).sin_cos();
        let dir = [0, 1, 2].map(|i| ca * u[i] + sa * (c * e1[i] + s * e2[i]));
        let p = lens.project(dir)?;
        for i in 0..2 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let clamp = |v: f64, max: u32| v.clamp(0.0, f64::from(max)) as usize;
    let b = BBox {
        x0: clamp(lo[0].floor() - 2.0, lens.width),
        x1: clamp(hi[0].ceil() + 2.0, lens.width),
        y0: clamp(lo[1].floor() - 2.0, lens.height),
        y1: clamp(hi[1].ceil() + 2.0, lens.height),
    };
    (b.x0 < b.x1 && b.y0 < b.y1).then_some(b)
}

/// The ball, ready to intersect and shade.
#[derive(Debug, Clone)]
pub(crate) struct BallObj {
    centre: [f32; 3],
    radius: f32,
    colour: [f32; 3],
    patches: bool,
    /// An empty box when the ball is out of the image.
    pub bbox: BBox,
}

const EMPTY: BBox = BBox {
    x0: 0,
    x1: 0,
    y0: 0,
    y1: 0,
};

pub(crate) fn ball_obj(
    lens: &LensModel,
    cam_from_field: &Mat3,
    camera_m: V3,
    ball_m: V3,
    scene: &Scene,
) -> BallObj {
    let radius = scene.pitch.ball_radius_m;
    BallObj {
        centre: to_f32(ball_m),
        radius: radius as f32,
        colour: to_f32(scene.ball_look.colour_rgb),
        patches: scene.ball_look.pattern == BallPattern::Patches,
        bbox: sphere_bbox(lens, cam_from_field, camera_m, ball_m, radius).unwrap_or(EMPTY),
    }
}

/// Unit directions of an icosahedron's vertices: where the patterned ball's patches sit.
const PATCHES: [[f32; 3]; 12] = {
    const A: f32 = 0.525_731_1;
    const B: f32 = 0.850_650_8;
    [
        [0.0, A, B],
        [0.0, A, -B],
        [0.0, -A, B],
        [0.0, -A, -B],
        [A, B, 0.0],
        [A, -B, 0.0],
        [-A, B, 0.0],
        [-A, -B, 0.0],
        [B, 0.0, A],
        [-B, 0.0, A],
        [B, 0.0, -A],
        [-B, 0.0, -A],
    ]
};
/// cos of a patch's angular radius (22°).
const PATCH_COS: f32 = 0.927_183_9;
const PATCH_WHITE: [f32; 3] = [0.92, 0.92, 0.9];

impl BallObj {
    /// Nearest intersection along the unit ray `o + t·d`.
    #[inline]
    pub fn hit(&self, o: [f32; 3], d: [f32; 3]) -> Option<f32> {
        sphere_hit(o, d, self.centre, self.radius)
    }

    pub fn shade(&self, env: &Env, d: [f32; 3], t: f32) -> [f32; 3] {
        let o = env.c;
        let inv_r = 1.0 / self.radius;
        let n = [0, 1, 2].map(|i| (o[i] + t * d[i] - self.centre[i]) * inv_r);
        let paint = if self.patches && PATCHES.iter().any(|p| dot3(*p, n) > PATCH_COS) {
            PATCH_WHITE
        } else {
            self.colour
        };
        // Lambert, a little light bounced up from the floor, and a soft highlight.
        let k = env.lambert(n) + 0.08 * (-n[2]).max(0.0);
        let h = unit3([0, 1, 2].map(|i| env.light[i] - d[i]));
        let spec = 0.12 * env.diffuse * dot3(h, n).max(0.0).powi(32);
        paint.map(|p| p * k + spec)
    }
}

/// One rounded part of a MiRo: an ellipsoid with a paint.
#[derive(Debug, Clone, Copy)]
struct Part {
    centre: [f32; 3],
    local_from_field: [[f32; 3]; 3],
    inv_axes: [f32; 3],
    paint: Paint,
}

#[derive(Debug, Clone, Copy)]
enum Paint {
    /// White above the body's middle, grey below.
    Body,
    Plain([f32; 3]),
    /// White, with dark discs where the cameras are.
    Head([[f32; 3]; 2]),
}

const WHITE: [f32; 3] = [0.88, 0.88, 0.86];
const GREY: [f32; 3] = [0.50, 0.51, 0.53];
const DARK: [f32; 3] = [0.12, 0.12, 0.13];
const EYE: [f32; 3] = [0.06, 0.06, 0.07];
const EYE_RADIUS_M: f32 = 0.014;

/// Another MiRo, ready to intersect and shade.
#[derive(Debug, Clone)]
pub(crate) struct RobotObj {
    parts: [Part; 4],
    pub bbox: BBox,
}

/// Bounding sphere of a MiRo, relative to the body frame, for the image box.
const BOUND_CENTRE_M: V3 = [0.02, 0.0, 0.17];
const BOUND_RADIUS_M: f64 = 0.23;

pub(crate) fn robot_obj(
    lens: &LensModel,
    cam_from_field: &Mat3,
    camera_m: V3,
    robot: &RobotBody,
) -> Option<RobotObj> {
    let body = body_pose(robot.pose);
    let bbox = sphere_bbox(
        lens,
        cam_from_field,
        camera_m,
        body.point(BOUND_CENTRE_M),
        BOUND_RADIUS_M,
    )?;
    let head = head_pose(robot.pose, robot.head);
    let eyes = [Camera::Left, Camera::Right]
        .map(|c| to_f32(camera_pose(robot.pose, robot.head, c).origin_m));
    let body_rot = to_f32_mat(&transpose(&body.field_from_local));
    let lift_joint = body.point(proto::miro::LIFT_JOINT_IN_BODY_M);
    let neck_mid = scale(crate::vec3::add(lift_joint, head.origin_m), 0.5);
    let identity = to_f32_mat(&crate::vec3::IDENTITY);
    let sphere = |centre: V3, r: f32, paint: Paint| Part {
        centre: to_f32(centre),
        local_from_field: identity,
        inv_axes: [1.0 / r; 3],
        paint,
    };
    Some(RobotObj {
        parts: [
            Part {
                centre: to_f32(body.point([0.0, 0.0, 0.115])),
                local_from_field: body_rot,
                inv_axes: [1.0 / 0.13, 1.0 / 0.095, 1.0 / 0.07],
                paint: Paint::Body,
            },
            // The dark underside between the wheels.
            Part {
                centre: to_f32(body.point([0.0, 0.0, 0.045])),
                local_from_field: body_rot,
                inv_axes: [1.0 / 0.10, 1.0 / 0.088, 1.0 / 0.045],
                paint: Paint::Plain(DARK),
            },
            sphere(neck_mid, 0.035, Paint::Plain(GREY)),
            sphere(head.point([0.01, 0.0, 0.035]), 0.055, Paint::Head(eyes)),
        ],
        bbox,
    })
}

impl RobotObj {
    /// Nearest intersection along the unit ray and which part it hit.
    #[inline]
    pub fn hit(&self, o: [f32; 3], d: [f32; 3]) -> Option<(f32, usize)> {
        let mut best: Option<(f32, usize)> = None;
        for (k, p) in self.parts.iter().enumerate() {
            if let Some(t) = ellipsoid_hit(p, o, d)
                && best.is_none_or(|(bt, _)| t < bt)
            {
                best = Some((t, k));
            }
        }
        best
    }

    pub fn shade(&self, env: &Env, d: [f32; 3], t: f32, part: usize) -> [f32; 3] {
        let p = &self.parts[part];
        let hit = [0, 1, 2].map(|i| env.c[i] + t * d[i]);
        let rel = [0, 1, 2].map(|i| hit[i] - p.centre[i]);
        let local = mat_vec(&p.local_from_field, rel);
        // Gradient of the implicit surface, back in the field frame.
        let gl = [0, 1, 2].map(|i| local[i] * p.inv_axes[i] * p.inv_axes[i]);
        let n = unit3(mat_t_vec(&p.local_from_field, gl));
        let paint = match p.paint {
            Paint::Body => {
                if local[2] * p.inv_axes[2] > -0.15 {
                    WHITE
                } else {
                    GREY
                }
            }
            Paint::Plain(c) => c,
            Paint::Head(eyes) => {
                let near = eyes.iter().any(|e| {
                    let q = [0, 1, 2].map(|i| hit[i] - e[i]);
                    dot3(q, q) < EYE_RADIUS_M * EYE_RADIUS_M
                });
                if near { EYE } else { WHITE }
            }
        };
        let k = env.lambert(n) + 0.06 * (-n[2]).max(0.0);
        paint.map(|c| c * k)
    }
}

#[inline]
fn ellipsoid_hit(p: &Part, o: [f32; 3], d: [f32; 3]) -> Option<f32> {
    let rel = [0, 1, 2].map(|i| o[i] - p.centre[i]);
    let ol = mat_vec(&p.local_from_field, rel);
    let dl = mat_vec(&p.local_from_field, d);
    let os = [0, 1, 2].map(|i| ol[i] * p.inv_axes[i]);
    let ds = [0, 1, 2].map(|i| dl[i] * p.inv_axes[i]);
    let a = dot3(ds, ds);
    let b = dot3(os, ds);
    let c = dot3(os, os) - 1.0;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / a;
    (t > 0.0).then_some(t)
}

/// Nearest positive `t` with |o + t·d − centre| = r, for a unit `d`.
#[inline]
pub(crate) fn sphere_hit(o: [f32; 3], d: [f32; 3], centre: [f32; 3], r: f32) -> Option<f32> {
    let oc = [0, 1, 2].map(|i| o[i] - centre[i]);
    let b = dot3(oc, d);
    let c = dot3(oc, oc) - r * r;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    (t > 0.0).then_some(t)
}

#[inline]
fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn unit3(a: [f32; 3]) -> [f32; 3] {
    let n = dot3(a, a).sqrt().max(1e-30);
    a.map(|v| v / n)
}

#[inline]
fn mat_vec(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    [dot3(m[0], v), dot3(m[1], v), dot3(m[2], v)]
}

/// `mᵀ · v`.
#[inline]
fn mat_t_vec(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|i| m[0][i] * v[0] + m[1][i] * v[1] + m[2][i] * v[2])
}
