//! Rendered chessboard views for calibrating the simulated cameras, with the true pixel
//! position of every inner corner.
//!
//! The agent calibrates the sim's lens from these as it would a real camera's from
//! photographs, so the lens stays the sim's secret. Edges are anti-aliased (pixels that
//! straddle an edge are supersampled 4×4) and sensor noise is added, so a corner finder
//! has to work for its sub-pixel accuracy.

use crate::lens::LensModel;
use crate::render::gauss;
use crate::render_scene::Frame;
use crate::rng::Rng;
use crate::vec3::{Mat3, V3, add, cross, dot, mul, mul_vec, rot_x, rot_z, unit};

/// A printed chessboard: `inner_cols × inner_rows` inner corners, so one more square each
/// way, on white card with a margin around the squares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chessboard {
    pub inner_cols: usize,
    pub inner_rows: usize,
    pub square_m: f64,
    pub margin_m: f64,
}

impl Default for Chessboard {
    /// 9 × 6 inner corners (10 × 7 squares) of 25 mm, with a 15 mm white margin.
    fn default() -> Self {
        Chessboard {
            inner_cols: 9,
            inner_rows: 6,
            square_m: 0.025,
            margin_m: 0.015,
        }
    }
}

/// Where the board is relative to the camera. The board frame has its origin at the
/// centre of the squares, x along a row of corners, y down the rows, z into the board
/// (away from the camera when the camera sees its face).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardPose {
    pub camera_from_board: Mat3,
    pub origin_m: V3,
}

impl Chessboard {
    /// Inner corners in the board frame, row-major along rows of `inner_cols` (OpenCV's
    /// order for a `(inner_cols, inner_rows)` pattern).
    pub fn corners_board_m(&self) -> Vec<V3> {
        let s = self.square_m;
        let hc = (self.inner_cols as f64 - 1.0) / 2.0;
        let hr = (self.inner_rows as f64 - 1.0) / 2.0;
        (0..self.inner_rows)
            .flat_map(|i| {
                (0..self.inner_cols).map(move |j| [(j as f64 - hc) * s, (i as f64 - hr) * s, 0.0])
            })
            .collect()
    }

    /// Reflectance at board coordinates, or `None` off the card.
    fn paint(&self, x: f64, y: f64) -> Option<f32> {
        let s = self.square_m;
        let (half_w, half_h) = (
            (self.inner_cols + 1) as f64 * s / 2.0,
            (self.inner_rows + 1) as f64 * s / 2.0,
        );
        if x.abs() > half_w + self.margin_m || y.abs() > half_h + self.margin_m {
            return None;
        }
        if x.abs() >= half_w || y.abs() >= half_h {
            return Some(WHITE);
        }
        let a = ((x + half_w) / s).floor() as i64;
        let b = ((y + half_h) / s).floor() as i64;
        Some(if (a + b) % 2 == 0 { BLACK } else { WHITE })
    }
}

const WHITE: f32 = 0.82;
const BLACK: f32 = 0.07;

/// The inner corners' true pixel positions (row-major), `None` if any is not imaged.
pub fn board_corners_px(
    lens: &LensModel,
    board: &Chessboard,
    pose: &BoardPose,
) -> Option<Vec<[f64; 2]>> {
    board
        .corners_board_m()
        .into_iter()
        .map(|p| lens.project(add(pose.origin_m, mul_vec(&pose.camera_from_board, p))))
        .collect()
}

/// Renders the board at `pose` in front of a plain grey background, with Gaussian noise of
/// `noise_sigma` 8-bit levels drawn from `seed`. Returns the frame and the inner corners'
/// true pixel positions (`None` if some corner is not imaged at all).
pub fn render_chessboard(
    lens: &LensModel,
    board: &Chessboard,
    pose: &BoardPose,
    noise_sigma: f64,
    seed: u64,
) -> (Frame, Option<Vec<[f64; 2]>>) {
    let (w, h) = (lens.width as usize, lens.height as usize);
    // Board-frame normal (towards −z) and plane offset, in the camera frame.
    let normal = [0, 1, 2].map(|i| pose.camera_from_board[i][2]);
    let plane_d = dot(normal, pose.origin_m);
    let sample = |px: [f64; 2]| -> f32 {
        let Some(d) = lens.ray(px) else {
            return 0.0;
        };
        let back = 0.30 + 0.08 * (px[0] / f64::from(lens.width)) as f32;
        let dn = dot(d, normal);
        if dn.abs() < 1e-9 {
            return back;
        }
        let t = plane_d / dn;
        if t <= 0.0 {
            return back;
        }
        let rel = [0, 1, 2].map(|i| t * d[i] - pose.origin_m[i]);
        // Board coordinates: the rotation's columns are the board axes.
        let bx = (0..3).map(|i| pose.camera_from_board[i][0] * rel[i]).sum();
        let by = (0..3).map(|i| pose.camera_from_board[i][1] * rel[i]).sum();
        let light = 0.75 + 0.25 * dn.abs() as f32;
        board.paint(bx, by).map_or(back, |p| p * light)
    };
    // Samples at pixel corners; a pixel whose four corners agree is uniform.
    let corners: Vec<f32> = (0..=h)
        .flat_map(|y| (0..=w).map(move |x| (x, y)))
        .map(|(x, y)| sample([x as f64, y as f64]))
        .collect();
    let mut rng = Rng::stream(seed, "chessboard", 0);
    let sigma = noise_sigma.max(0.0) as f32;
    let mut rgb = vec![0u8; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            let c = [
                corners[y * (w + 1) + x],
                corners[y * (w + 1) + x + 1],
                corners[(y + 1) * (w + 1) + x],
                corners[(y + 1) * (w + 1) + x + 1],
            ];
            let uniform = c.iter().all(|&v| (v - c[0]).abs() < 0.02);
            let value = if uniform {
                c.iter().sum::<f32>() / 4.0
            } else {
                supersample(&sample, x, y)
            };
            for k in 0..3 {
                let mut v = value * 255.0;
                if sigma > 0.0 {
                    v += sigma * gauss(&mut rng);
                }
                rgb[3 * (y * w + x) + k] = (v + 0.5).clamp(0.0, 255.0) as u8;
            }
        }
    }
    let frame = Frame {
        width: lens.width,
        height: lens.height,
        rgb,
    };
    (frame, board_corners_px(lens, board, pose))
}

/// Mean of 4×4 samples spread over pixel (x, y).
fn supersample(sample: &impl Fn([f64; 2]) -> f32, x: usize, y: usize) -> f32 {
    let mut sum = 0.0;
    for j in 0..4 {
        for i in 0..4 {
            sum += sample([
                x as f64 + (f64::from(i) + 0.5) / 4.0,
                y as f64 + (f64::from(j) + 0.5) / 4.0,
            ]);
        }
    }
    sum / 16.0
}

/// Inner corners stay at least this far inside the image in calibration views.
pub const VIEW_MARGIN_PX: f64 = 12.0;

/// `count` varied board poses for calibrating `lens`: the board's centre aimed at each
/// cell of a 3×3 grid over the image in turn (corners and edges included) with jitter,
/// 0.15–0.5 m away, tilted up to 45° about a random in-plane axis and rolled up to ±25°,
/// the whole card inside the image, every inner corner at least [`VIEW_MARGIN_PX`] inside
/// it and the squares at least 6 px apart. Views that cannot be placed after many draws fall back to a frontal
/// view, so the result always has `count` poses.
pub fn calibration_views(lens: &LensModel, count: usize, seed: u64) -> Vec<BoardPose> {
    let board = Chessboard::default();
    let mut rng = Rng::stream(seed, "calibration-views", 0);
    (0..count)
        .map(|k| {
            let cell = [(k % 3) as f64, ((k / 3) % 3) as f64];
            (0..400)
                .find_map(|_| {
                    let pose = random_pose(lens, &mut rng, cell);
                    acceptable(lens, &board, &pose).then_some(pose)
                })
                .unwrap_or(BoardPose {
                    camera_from_board: crate::vec3::IDENTITY,
                    origin_m: [0.0, 0.0, 0.3],
                })
        })
        .collect()
}

fn random_pose(lens: &LensModel, rng: &mut Rng, cell: [f64; 2]) -> BoardPose {
    let (w, h) = (f64::from(lens.width), f64::from(lens.height));
    let target = [
        w * (cell[0] + rng.range(0.1, 0.9)) / 3.0,
        h * (cell[1] + rng.range(0.1, 0.9)) / 3.0,
    ];
    let dir = lens.ray(target).unwrap_or([0.0, 0.0, 1.0]);
    let dist = rng.range(0.15, 0.5);
    // Facing the camera square-on along `dir`: board z along the line of sight, board x
    // as close to the image's x as it can be.
    let z = dir;
    let x = unit(cross([0.0, 1.0, 0.0], z));
    let y = cross(z, x);
    let facing: Mat3 = [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]];
    let tilt = rng.range(0.0, 45f64.to_radians());
    let axis = rng.range(0.0, std::f64::consts::TAU);
    let tilt_rot = mul(&rot_z(axis), &mul(&rot_x(tilt), &rot_z(-axis)));
    let roll = rot_z(rng.range(-25f64.to_radians(), 25f64.to_radians()));
    BoardPose {
        camera_from_board: mul(&facing, &mul(&tilt_rot, &roll)),
        origin_m: [dir[0] * dist, dir[1] * dist, dir[2] * dist],
    }
}

fn acceptable(lens: &LensModel, board: &Chessboard, pose: &BoardPose) -> bool {
    let Some(px) = board_corners_px(lens, board, pose) else {
        return false;
    };
    // The camera must see the board's face at no more than 70° off its normal.
    let normal = [0, 1, 2].map(|i| pose.camera_from_board[i][2]);
    let facing = dot(normal, unit(pose.origin_m));
    let spaced = px.windows(2).enumerate().all(|(k, p)| {
        (k + 1) % board.inner_cols == 0 || (p[1][0] - p[0][0]).hypot(p[1][1] - p[0][1]) >= 6.0
    });
    // The whole card shows, so a corner finder sees every square with white around it.
    let hw = (board.inner_cols + 1) as f64 * board.square_m / 2.0 + board.margin_m;
    let hh = (board.inner_rows + 1) as f64 * board.square_m / 2.0 + board.margin_m;
    let card_inside = (0..16).all(|k| {
        let a = std::f64::consts::TAU * f64::from(k) / 16.0;
        // Points round the card's edge (a square's outline traced by angle).
        let (c, s) = (a.cos(), a.sin());
        let m = c.abs().max(s.abs());
        let edge = [hw * c / m, hh * s / m, 0.0];
        let p = add(pose.origin_m, mul_vec(&pose.camera_from_board, edge));
        lens.project(p).is_some_and(|q| lens.contains(q, 2.0))
    });
    facing > 20f64.to_radians().sin()
        && spaced
        && card_inside
        && px.iter().all(|&p| lens.contains(p, VIEW_MARGIN_PX))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Bilinear grey level at a pixel position (pixel centres at +0.5).
    fn grey(f: &Frame, p: [f64; 2]) -> f64 {
        let (x, y) = (p[0] - 0.5, p[1] - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (ax, ay) = (x - x0, y - y0);
        let at = |i: f64, j: f64| f64::from(f.pixel(i as u32, j as u32)[0]);
        let top = at(x0, y0) * (1.0 - ax) + at(x0 + 1.0, y0) * ax;
        let bot = at(x0, y0 + 1.0) * (1.0 - ax) + at(x0 + 1.0, y0 + 1.0) * ax;
        top * (1.0 - ay) + bot * ay
    }

    #[test]
    fn corners_sit_where_the_squares_meet() {
        let lens = LensModel::miro();
        let board = Chessboard::default();
        for (n, pose) in calibration_views(&lens, 6, 3).iter().enumerate() {
            let (frame, corners) = render_chessboard(&lens, &board, pose, 0.0, 1);
            let corners = corners.unwrap();
            assert_eq!(corners.len(), 54);
            let pts = board.corners_board_m();
            let q = 0.3 * board.square_m;
            for (k, (c, p)) in corners.iter().zip(&pts).enumerate() {
                // The four quadrants around a corner, sampled on the board itself.
                let quad = [(-q, -q), (q, -q), (q, q), (-q, q)].map(|(dx, dy)| {
                    let b = add(
                        pose.origin_m,
                        mul_vec(&pose.camera_from_board, [p[0] + dx, p[1] + dy, 0.0]),
                    );
                    grey(&frame, lens.project(b).unwrap())
                });
                // The top-left square is black, and the pattern flips from corner to corner.
                let (i, j) = (k / board.inner_cols, k % board.inner_cols);
                let [dark_a, light_a, dark_b, light_b] = if (i + j) % 2 == 0 {
                    quad
                } else {
                    [quad[1], quad[0], quad[3], quad[2]]
                };
                assert!(dark_a < 90.0 && dark_b < 90.0, "view {n}: {quad:?}");
                assert!(light_a > 120.0 && light_b > 120.0, "view {n}: {quad:?}");
                // A corner is point-symmetric: opposite points on a small ring agree.
                let asym: f64 = (0..8)
                    .map(|k| {
                        let a = f64::from(k) * std::f64::consts::PI / 8.0;
                        let v = [2.0 * a.cos(), 2.0 * a.sin()];
                        (grey(&frame, [c[0] + v[0], c[1] + v[1]])
                            - grey(&frame, [c[0] - v[0], c[1] - v[1]]))
                        .abs()
                    })
                    .sum::<f64>()
                    / 8.0;
                assert!(asym < 20.0, "view {n}, corner {c:?}: asymmetry {asym}");
            }
        }
    }

    #[test]
    fn calibration_views_are_varied_and_keep_corners_inside() {
        let lens = LensModel::miro();
        let board = Chessboard::default();
        let views = calibration_views(&lens, 18, 11);
        assert_eq!(views.len(), 18);
        let (mut cells, mut max_tilt, mut dists) = ([false; 9], 0.0f64, Vec::new());
        for v in &views {
            let px = board_corners_px(&lens, &board, v).unwrap();
            assert!(px.iter().all(|&p| lens.contains(p, VIEW_MARGIN_PX)));
            let mid = px[px.len() / 2];
            let cell = ((mid[0] / 640.0 * 3.0) as usize).min(2)
                + 3 * ((mid[1] / 360.0 * 3.0) as usize).min(2);
            cells[cell] = true;
            let normal = [0, 1, 2].map(|i| v.camera_from_board[i][2]);
            max_tilt = max_tilt.max(dot(normal, unit(v.origin_m)).acos());
            dists.push(crate::vec3::norm(v.origin_m));
        }
        assert!(cells.iter().filter(|&&c| c).count() >= 7, "{cells:?}");
        assert!(max_tilt > 30f64.to_radians(), "{}", max_tilt.to_degrees());
        let (lo, hi) = dists
            .iter()
            .fold((9.0f64, 0.0f64), |(a, b), &d| (a.min(d), b.max(d)));
        assert!(
            lo < 0.32 && hi > 0.4 && lo >= 0.15 && hi <= 0.5,
            "{lo} {hi}"
        );
        assert_eq!(views, calibration_views(&lens, 18, 11));
    }

    #[test]
    fn noise_follows_the_seed() {
        let lens = LensModel::miro();
        let pose = calibration_views(&lens, 1, 5)[0];
        let board = Chessboard::default();
        let a = render_chessboard(&lens, &board, &pose, 2.0, 1);
        assert_eq!(a, render_chessboard(&lens, &board, &pose, 2.0, 1));
        assert_ne!(a.0, render_chessboard(&lens, &board, &pose, 2.0, 2).0);
    }
}
