//! Test fixtures of the calibration tests: the chessboard photographs and synthetic
//! renders of a chessboard through a known camera.

#![allow(clippy::unwrap_used)]

use std::path::Path;
use std::sync::OnceLock;

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::calibration::calibrate::Board;
use vision::camera::{CameraModel, Distortion, Intrinsics};
use vision::image::gray::GrayImage;

/// The names of the chessboard photographs in `robot-agent/tests/data/chessboard-photos`.
pub fn photo_names() -> Vec<&'static str> {
    vec![
        "left01.jpg",
        "left02.jpg",
        "left03.jpg",
        "left04.jpg",
        "left05.jpg",
        "left06.jpg",
        "left07.jpg",
        "left08.jpg",
        "left09.jpg",
        "left11.jpg",
        "left12.jpg",
        "left13.jpg",
        "left14.jpg",
    ]
}

/// One chessboard photograph.
pub fn photo(name: &str) -> GrayImage {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../robot-agent/tests/data/chessboard-photos")
        .join(name);
    robot_agent::load_gray(&path).unwrap()
}

/// A synthetic calibration scene: a camera, a board and the rendered views with the true
/// corner positions.
#[derive(Debug)]
pub struct Scene {
    pub camera: CameraModel,
    pub board: Board,
    /// (name, image, true corners in row-major board order).
    pub views: Vec<(String, GrayImage, Vec<[f64; 2]>)>,
}

/// Grey levels of the render.
const BLACK: f32 = 35.0;
const WHITE: f32 = 215.0;
const BACKGROUND: f32 = 110.0;
/// Supersampling per axis.
const SUPERSAMPLING: usize = 4;

/// A deterministic Gaussian noise source (xorshift64* and Box–Muller).
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn gaussian(&mut self) -> f64 {
        let (a, b) = (self.uniform(), self.uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

/// The rays of the pixel corners (u − ½, v − ½) for u in 0..=width, v in 0..=height.
fn corner_rays(camera: &CameraModel) -> Vec<Vector3<f64>> {
    let (w, h) = (camera.intrinsics.width_px, camera.intrinsics.height_px);
    let mut rays = Vec::with_capacity(((w + 1) * (h + 1)) as usize);
    for v in 0..=h {
        for u in 0..=w {
            let ray = camera
                .unproject([f64::from(u) - 0.5, f64::from(v) - 0.5])
                .unwrap();
            rays.push(Vector3::from(ray));
        }
    }
    rays
}

/// Intensity of the board (or background) seen along a ray.
fn shade(
    ray: &Vector3<f64>,
    board: &Board,
    board_from_camera: &(Matrix3<f64>, Vector3<f64>),
) -> f32 {
    let (r, t) = board_from_camera;
    // The ray's origin and direction in board coordinates; intersect z = 0.
    let origin = t;
    let direction = r * ray;
    if direction[2].abs() < 1e-12 {
        return BACKGROUND;
    }
    let s = -origin[2] / direction[2];
    if s <= 0.0 {
        return BACKGROUND;
    }
    let x = (origin[0] + s * direction[0]) / board.square_m;
    let y = (origin[1] + s * direction[1]) / board.square_m;
    let (cols, rows) = (board.cols as f64, board.rows as f64);
    if x < -1.5 || y < -1.5 || x > cols + 0.5 || y > rows + 0.5 {
        return BACKGROUND;
    }
    if x < -1.0 || y < -1.0 || x > cols || y > rows {
        return WHITE;
    }
    if (x.floor() + y.floor()).rem_euclid(2.0) == 0.0 {
        BLACK
    } else {
        WHITE
    }
}

/// Renders a board at a pose (camera from board) with 4×4 supersampling per pixel and
/// Gaussian noise of `noise` grey levels.
pub fn render(
    camera: &CameraModel,
    rays: &[Vector3<f64>],
    board: &Board,
    rotation: &Matrix3<f64>,
    translation: &Vector3<f64>,
    noise: f64,
    seed: u64,
) -> GrayImage {
    let (w, h) = (
        camera.intrinsics.width_px as usize,
        camera.intrinsics.height_px as usize,
    );
    let inverse = (rotation.transpose(), -(rotation.transpose() * translation));
    let mut noise_source = Noise(seed | 1);
    let mut data = vec![0.0; w * h];
    let n = SUPERSAMPLING as f64;
    for v in 0..h {
        for u in 0..w {
            let (r00, r10) = (&rays[v * (w + 1) + u], &rays[v * (w + 1) + u + 1]);
            let (r01, r11) = (
                &rays[(v + 1) * (w + 1) + u],
                &rays[(v + 1) * (w + 1) + u + 1],
            );
            let mut sum = 0.0;
            for sy in 0..SUPERSAMPLING {
                for sx in 0..SUPERSAMPLING {
                    let (a, b) = ((sx as f64 + 0.5) / n, (sy as f64 + 0.5) / n);
                    let ray = r00 * ((1.0 - a) * (1.0 - b))
                        + r10 * (a * (1.0 - b))
                        + r01 * ((1.0 - a) * b)
                        + r11 * (a * b);
                    sum += shade(&ray, board, &inverse);
                }
            }
            let value = sum / (n * n) as f32 + (noise * noise_source.gaussian()) as f32;
            data[v * w + u] = value.clamp(0.0, 255.0);
        }
    }
    GrayImage::new(w as u32, h as u32, data).unwrap()
}

/// Poses looking at the board from varied directions: the board centre placed on the ray
/// of a target pixel (as a fraction of the image size) at a distance, tilted about x and y
/// and rolled, angles in degrees.
const POSES: [([f64; 2], f64, [f64; 3]); 12] = [
    ([0.5, 0.5], 1.0, [0.0, 0.0, 0.0]),
    ([0.3, 0.3], 1.0, [25.0, -20.0, 10.0]),
    ([0.7, 0.3], 1.0, [20.0, 25.0, -8.0]),
    ([0.3, 0.7], 1.0, [-25.0, -15.0, 5.0]),
    ([0.7, 0.7], 1.0, [-20.0, 25.0, -12.0]),
    ([0.5, 0.5], 0.75, [35.0, 0.0, 90.0]),
    ([0.5, 0.5], 0.8, [0.0, 40.0, 3.0]),
    ([0.4, 0.55], 0.9, [-30.0, 30.0, 20.0]),
    ([0.6, 0.45], 0.9, [30.0, -30.0, -20.0]),
    ([0.45, 0.4], 1.2, [10.0, 10.0, 45.0]),
    ([0.55, 0.5], 0.9, [-15.0, -35.0, -30.0]),
    ([0.5, 0.45], 0.7, [15.0, 15.0, 180.0]),
];

/// Renders the scene of a camera: 12 views of a 9×6 board with 3 cm squares, at distances
/// scaled by `distance_m` so that the board fills a good part of the image.
pub fn scene(camera: CameraModel, distance_m: f64, noise: f64) -> Scene {
    let board = Board {
        cols: 9,
        rows: 6,
        square_m: 0.03,
    };
    let rays = corner_rays(&camera);
    let object = board.object_points_m();
    let centre = Vector3::new(4.0 * board.square_m, 2.5 * board.square_m, 0.0);
    let (w, h) = (
        f64::from(camera.intrinsics.width_px),
        f64::from(camera.intrinsics.height_px),
    );
    let views = POSES
        .iter()
        .enumerate()
        .map(|(k, (target, distance, [ax, ay, roll]))| {
            let direction =
                Vector3::from(camera.unproject([target[0] * w, target[1] * h]).unwrap());
            let rotation =
                Rotation3::from_euler_angles(ax.to_radians(), ay.to_radians(), roll.to_radians())
                    .into_inner();
            let translation = direction * (distance * distance_m) - rotation * centre;
            let image = render(
                &camera,
                &rays,
                &board,
                &rotation,
                &translation,
                noise,
                7 + k as u64,
            );
            let corners: Vec<[f64; 2]> = object
                .iter()
                .map(|p| {
                    let q = rotation * Vector3::from(*p) + translation;
                    camera.project([q[0], q[1], q[2]]).unwrap()
                })
                .collect();
            for c in &corners {
                assert!(
                    c[0] > 8.0 && c[1] > 8.0 && c[0] < w - 9.0 && c[1] < h - 9.0,
                    "view {k}: corner {c:?} off the image"
                );
            }
            (format!("render{k:02}"), image, corners)
        })
        .collect();
    Scene {
        camera,
        board,
        views,
    }
}

/// A 640×480 camera with strong barrel distortion.
pub fn barrel_camera() -> CameraModel {
    CameraModel {
        intrinsics: Intrinsics {
            fx_px: 520.0,
            fy_px: 515.0,
            cx_px: 328.4,
            cy_px: 236.7,
            width_px: 640,
            height_px: 480,
        },
        distortion: Distortion::BrownConrady {
            k1: -0.28,
            k2: 0.09,
            p1: 0.001,
            p2: -0.0005,
            k3: -0.012,
        },
    }
}

/// A 640×360 fisheye with about 120° horizontal field of view.
pub fn fisheye_camera() -> CameraModel {
    CameraModel {
        intrinsics: Intrinsics {
            fx_px: 300.0,
            fy_px: 301.0,
            cx_px: 322.5,
            cy_px: 178.2,
            width_px: 640,
            height_px: 360,
        },
        distortion: Distortion::KannalaBrandt {
            k1: -0.02,
            k2: 0.004,
            k3: -0.002,
            k4: 0.0005,
        },
    }
}

/// The barrel scene, rendered once per test process.
pub fn barrel_scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| scene(barrel_camera(), 0.55, 2.0))
}

/// The fisheye scene, rendered once per test process.
pub fn fisheye_scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| scene(fisheye_camera(), 0.3, 2.0))
}
