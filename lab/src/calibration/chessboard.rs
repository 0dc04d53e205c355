//! Chessboard inner-corner detection for camera calibration.
//!
//! The detector looks for X-junctions, not for squares: on a strongly distorted or blurred
//! photograph the squares' outlines bend and merge, but the point where four squares meet
//! stays a sharp saddle of the intensity. The steps are
//!
//! 1. a ChESS-style ring response (Bennett & Lasenby, 2014) on a lightly smoothed image:
//!    16 samples on a circle around each pixel; an X-junction makes opposite samples equal
//!    and samples a quarter turn apart opposite, which edges, blobs and flat areas do not;
//! 2. non-maximum suppression into a list of candidates, strongest first;
//! 3. grid growing from a seed candidate: two neighbours give the grid's local axes, then
//!    each known corner predicts its neighbours by linear extrapolation along rows and
//!    columns, which follows the curvature of barrel distortion one step at a time;
//! 4. the grown grid must contain exactly one complete `cols × rows` window (a larger board
//!    would contain several, a smaller one none);
//! 5. sub-pixel refinement of each corner: the gradient at every point of a window around a
//!    saddle is orthogonal to the vector from the saddle to that point, which gives a 2×2
//!    linear system, iterated (the method of OpenCV's `cornerSubPix`).
//!
//! The corners come out in OpenCV's order: `rows` rows of `cols` corners, with the grid
//! axes oriented so that the column direction runs left to right where it can and the row
//! direction turns clockwise from it in the image (y down), which is the orientation of a
//! board seen from its front with object points (c·s, r·s, 0).

use thiserror::Error;

use vision::image::gray::GrayImage;

/// Radius of the ring of samples of the corner response, pixels. Squares must be at least
/// about twice as wide.
const RING_RADIUS_PX: f64 = 5.0;
/// Number of samples on the ring (a multiple of 4).
const RING_SAMPLES: usize = 16;
/// Standard deviation of the smoothing before the response, pixels.
const SMOOTHING_SIGMA_PX: f64 = 1.0;
/// Half-width of the non-maximum suppression window, pixels.
const NMS_RADIUS_PX: i64 = 3;
/// Candidates whose response is below this fraction of the strongest are dropped.
const RESPONSE_FRACTION: f32 = 0.06;
/// Largest number of candidates kept, strongest first.
const MAX_CANDIDATES: usize = 800;
/// Number of strongest candidates tried as seeds of the grid.
const MAX_SEEDS: usize = 30;
/// A predicted corner must have a candidate within this fraction of the local grid step.
const SEARCH_FRACTION: f64 = 0.35;

/// Why no chessboard was found.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ChessboardError {
    /// The requested board is too small to be oriented.
    #[error("a board needs at least 2×2 inner corners and 3 in one direction, got {cols}×{rows}")]
    InvalidBoardSize {
        /// Inner corners per row.
        cols: usize,
        /// Inner corners per column.
        rows: usize,
    },
    /// The image is too small to hold a board.
    #[error("the {width_px}×{height_px} px image is too small")]
    ImageTooSmall {
        /// Image width, pixels.
        width_px: u32,
        /// Image height, pixels.
        height_px: u32,
    },
    /// Fewer corner-like points than the board has corners.
    #[error("found {found} corner-like points, the board has {needed} corners")]
    TooFewCorners {
        /// Candidates found.
        found: usize,
        /// Corners on the board.
        needed: usize,
    },
    /// The corners do not form a complete grid of the requested size.
    #[error(
        "no complete {cols}×{rows} grid: the largest grid found has {found} corners \
         spanning {found_cols}×{found_rows}"
    )]
    GridIncomplete {
        /// Inner corners per row requested.
        cols: usize,
        /// Inner corners per column requested.
        rows: usize,
        /// Corners in the largest grid grown.
        found: usize,
        /// Its extent along its first axis.
        found_cols: usize,
        /// Its extent along its second axis.
        found_rows: usize,
    },
    /// The grid holds the requested board in more than one place: the board is larger.
    #[error(
        "a {cols}×{rows} window fits the grid found in {placements} places: the board is larger"
    )]
    Ambiguous {
        /// Inner corners per row requested.
        cols: usize,
        /// Inner corners per column requested.
        rows: usize,
        /// Number of places.
        placements: usize,
    },
}

/// A candidate corner: integer pixel position and response.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    position_px: [f64; 2],
    response: f32,
}

/// Finds the inner corners of a chessboard with `cols × rows` inner corners.
///
/// Returns `cols × rows` pixel positions, row-major (see the module documentation for the
/// orientation), refined to sub-pixel accuracy.
pub fn find_chessboard(
    image: &GrayImage,
    cols: usize,
    rows: usize,
) -> Result<Vec<[f64; 2]>, ChessboardError> {
    if cols < 2 || rows < 2 || cols.max(rows) < 3 {
        return Err(ChessboardError::InvalidBoardSize { cols, rows });
    }
    let margin = (RING_RADIUS_PX.ceil() as u32 + 2) * 2;
    if image.width() <= 2 * margin || image.height() <= 2 * margin {
        return Err(ChessboardError::ImageTooSmall {
            width_px: image.width(),
            height_px: image.height(),
        });
    }
    let smoothed = image.gaussian_blur(SMOOTHING_SIGMA_PX);
    let response = corner_response(&smoothed);
    let candidates = local_maxima(&response, image.width(), image.height());
    let needed = cols * rows;
    if candidates.len() < needed {
        return Err(ChessboardError::TooFewCorners {
            found: candidates.len(),
            needed,
        });
    }
    let positions: Vec<[f64; 2]> = candidates.iter().map(|c| c.position_px).collect();
    let mut best_error = None;
    let mut best_size = 0;
    for seed in 0..candidates.len().min(MAX_SEEDS) {
        let Some(grid) = grow_grid(&positions, seed, cols.max(rows)) else {
            continue;
        };
        match extract_board(&grid, cols, rows) {
            Ok(corners) => {
                let corners = orient(corners, cols, rows);
                return Ok(refine_corners(image, &corners, cols, rows));
            }
            Err(error) => {
                if matches!(error, ChessboardError::Ambiguous { .. }) {
                    return Err(error);
                }
                if grid.cells.len() > best_size {
                    best_size = grid.cells.len();
                    best_error = Some(error);
                }
            }
        }
    }
    Err(best_error.unwrap_or(ChessboardError::GridIncomplete {
        cols,
        rows,
        found: 0,
        found_cols: 0,
        found_rows: 0,
    }))
}

/// The ChESS response at every pixel (zero near the border): the sum over the four pairs
/// of perpendicular diameters of |I₀ + I₈ − I₄ − I₁₂| (large at an X-junction), minus the
/// sum of |Iₙ − Iₙ₊₈| over opposite samples (large on an edge), minus 16 × the difference
/// between the ring mean and the local mean (large on a blob or a line end).
fn corner_response(image: &GrayImage) -> Vec<f32> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let offsets: Vec<[f64; 2]> = (0..RING_SAMPLES)
        .map(|n| {
            let angle = std::f64::consts::TAU * n as f64 / RING_SAMPLES as f64;
            [RING_RADIUS_PX * angle.cos(), RING_RADIUS_PX * angle.sin()]
        })
        .collect();
    let border = RING_RADIUS_PX.ceil() as usize + 1;
    let mut response = vec![0.0; w * h];
    let quarter = RING_SAMPLES / 4;
    let half = RING_SAMPLES / 2;
    let mut ring = [0.0_f32; RING_SAMPLES];
    for y in border..h - border {
        for x in border..w - border {
            for (sample, offset) in ring.iter_mut().zip(&offsets) {
                *sample = image.bilinear(x as f64 + offset[0], y as f64 + offset[1]);
            }
            let sum: f32 = (0..quarter)
                .map(|n| {
                    (ring[n] + ring[n + half] - ring[n + quarter] - ring[n + 3 * quarter]).abs()
                })
                .sum();
            let diff: f32 = (0..half).map(|n| (ring[n] - ring[n + half]).abs()).sum();
            let ring_mean = ring.iter().sum::<f32>() / RING_SAMPLES as f32;
            let mut local = 0.0;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    local += image.clamped(x as i64 + dx, y as i64 + dy);
                }
            }
            let mean = (ring_mean - local / 9.0).abs();
            response[y * w + x] = sum - diff - RING_SAMPLES as f32 * mean;
        }
    }
    response
}

/// Local maxima of the response above a fraction of the strongest, strongest first.
fn local_maxima(response: &[f32], width: u32, height: u32) -> Vec<Candidate> {
    let (w, h) = (i64::from(width), i64::from(height));
    let strongest = response.iter().copied().fold(0.0_f32, f32::max);
    if strongest <= 0.0 {
        return Vec::new();
    }
    let threshold = RESPONSE_FRACTION * strongest;
    let mut candidates = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let value = response[(y * w + x) as usize];
            if value <= threshold {
                continue;
            }
            let mut is_max = true;
            'window: for dy in -NMS_RADIUS_PX..=NMS_RADIUS_PX {
                for dx in -NMS_RADIUS_PX..=NMS_RADIUS_PX {
                    let (nx, ny) = (x + dx, y + dy);
                    if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= w || ny >= h {
                        continue;
                    }
                    let other = response[(ny * w + nx) as usize];
                    // Ties go to the first pixel in raster order.
                    if other > value || (other == value && (dy, dx) < (0, 0)) {
                        is_max = false;
                        break 'window;
                    }
                }
            }
            if is_max {
                candidates.push(Candidate {
                    position_px: [x as f64, y as f64],
                    response: value,
                });
            }
        }
    }
    candidates.sort_by(|a, b| b.response.total_cmp(&a.response));
    candidates.truncate(MAX_CANDIDATES);
    candidates
}

/// A grid grown from a seed: candidate indices by integer grid coordinates.
#[derive(Debug, Default)]
struct Grid {
    cells: std::collections::HashMap<(i32, i32), [f64; 2]>,
}

impl Grid {
    fn get(&self, i: i32, j: i32) -> Option<[f64; 2]> {
        self.cells.get(&(i, j)).copied()
    }

    /// The extent of the grid: minimum and maximum of both coordinates.
    fn bounds(&self) -> (i32, i32, i32, i32) {
        let mut b = (i32::MAX, i32::MIN, i32::MAX, i32::MIN);
        for &(i, j) in self.cells.keys() {
            b = (b.0.min(i), b.1.max(i), b.2.min(j), b.3.max(j));
        }
        b
    }
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

/// The index of the unused candidate nearest to `target` within `radius`.
fn nearest(positions: &[[f64; 2]], used: &[bool], target: [f64; 2], radius: f64) -> Option<usize> {
    positions
        .iter()
        .enumerate()
        .filter(|(k, _)| !used[*k])
        .map(|(k, p)| (k, norm(sub(*p, target))))
        .filter(|(_, d)| *d <= radius)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k)
}

/// Grows a grid from candidate `seed`; `None` if the seed has no two neighbours at roughly
/// right angles. Growth stops at `4 × largest` cells along either axis.
fn grow_grid(positions: &[[f64; 2]], seed: usize, largest: usize) -> Option<Grid> {
    let origin = positions[seed];
    let mut by_distance: Vec<(usize, f64)> = positions
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != seed)
        .map(|(k, p)| (k, norm(sub(*p, origin))))
        .filter(|(_, d)| *d > 2.0 * RING_RADIUS_PX * 0.6)
        .collect();
    by_distance.sort_by(|a, b| a.1.total_cmp(&b.1));
    let &(first, first_distance) = by_distance.first()?;
    let axis = sub(positions[first], origin);
    let (second, _) = by_distance.iter().take(12).copied().find(|&(k, d)| {
        let other = sub(positions[k], origin);
        let cos = (axis[0] * other[0] + axis[1] * other[1]) / (first_distance * d);
        cos.abs() < 0.6 && d < 2.0 * first_distance
    })?;
    let mut grid = Grid::default();
    let mut used = vec![false; positions.len()];
    for (cell, k) in [((0, 0), seed), ((1, 0), first), ((0, 1), second)] {
        grid.cells.insert(cell, positions[k]);
        used[k] = true;
    }
    let limit = 2 * largest as i32 + 2;
    let mut changed = true;
    while changed {
        changed = false;
        let mut cells: Vec<(i32, i32)> = grid.cells.keys().copied().collect();
        cells.sort_unstable();
        for (i, j) in cells {
            for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let target = (i + di, j + dj);
                if grid.cells.contains_key(&target)
                    || target.0.abs() > limit
                    || target.1.abs() > limit
                {
                    continue;
                }
                let Some(step) = grid_step(&grid, (i, j), (di, dj)) else {
                    continue;
                };
                let Some(here) = grid.get(i, j) else {
                    continue;
                };
                let predicted = [here[0] + step[0], here[1] + step[1]];
                let radius = SEARCH_FRACTION * norm(step);
                if let Some(k) = nearest(positions, &used, predicted, radius) {
                    used[k] = true;
                    grid.cells.insert(target, positions[k]);
                    changed = true;
                }
            }
        }
    }
    Some(grid)
}

/// The expected step from cell `at` to its neighbour in direction `d`: the previous step
/// along the same line if known, else the parallel step in an adjacent line.
fn grid_step(grid: &Grid, at: (i32, i32), d: (i32, i32)) -> Option<[f64; 2]> {
    let here = grid.get(at.0, at.1)?;
    if let Some(previous) = grid.get(at.0 - d.0, at.1 - d.1) {
        return Some(sub(here, previous));
    }
    let perpendicular = (d.1, d.0);
    for sign in [1, -1] {
        let side = (at.0 + sign * perpendicular.0, at.1 + sign * perpendicular.1);
        if let (Some(a), Some(b)) = (
            grid.get(side.0, side.1),
            grid.get(side.0 + d.0, side.1 + d.1),
        ) {
            return Some(sub(b, a));
        }
    }
    None
}

/// The single complete `cols × rows` window of the grid (in either orientation) as
/// row-major corners, or why there is none.
fn extract_board(grid: &Grid, cols: usize, rows: usize) -> Result<Vec<[f64; 2]>, ChessboardError> {
    let (i0, i1, j0, j1) = grid.bounds();
    let mut found = Vec::new();
    let shapes = if cols == rows {
        vec![false]
    } else {
        vec![false, true]
    };
    for transposed in shapes {
        let (ni, nj) = if transposed {
            (rows, cols)
        } else {
            (cols, rows)
        };
        for a in i0..=i1 - ni as i32 + 1 {
            for b in j0..=j1 - nj as i32 + 1 {
                let corners: Option<Vec<[f64; 2]>> = (0..rows)
                    .flat_map(|r| (0..cols).map(move |c| (c as i32, r as i32)))
                    .map(|(c, r)| {
                        if transposed {
                            grid.get(a + r, b + c)
                        } else {
                            grid.get(a + c, b + r)
                        }
                    })
                    .collect();
                if let Some(corners) = corners {
                    found.push(corners);
                }
            }
        }
    }
    match found.len() {
        1 => Ok(found.swap_remove(0)),
        0 => Err(ChessboardError::GridIncomplete {
            cols,
            rows,
            found: grid.cells.len(),
            found_cols: (i1 - i0 + 1).max(0) as usize,
            found_rows: (j1 - j0 + 1).max(0) as usize,
        }),
        placements => Err(ChessboardError::Ambiguous {
            cols,
            rows,
            placements,
        }),
    }
}

/// Puts row-major corners into the canonical orientation: the row direction (along
/// increasing column index) crossed with the column direction is positive in the image's
/// y-down frame, i.e. the board is seen from its front, and rows run left to right (or,
/// for a board turned by a right angle, downwards).
fn orient(corners: Vec<[f64; 2]>, cols: usize, rows: usize) -> Vec<[f64; 2]> {
    let at = |c: usize, r: usize, corners: &[[f64; 2]]| corners[r * cols + c];
    let along = sub(at(cols - 1, 0, &corners), at(0, 0, &corners));
    let across = sub(at(0, rows - 1, &corners), at(0, 0, &corners));
    let mut corners = corners;
    if along[0] * across[1] - along[1] * across[0] < 0.0 {
        corners = (0..rows)
            .rev()
            .flat_map(|r| (0..cols).map(move |c| (c, r)))
            .map(|(c, r)| at(c, r, &corners))
            .collect();
    }
    let along = sub(at(cols - 1, 0, &corners), at(0, 0, &corners));
    if along[0] < 0.0 || (along[0] == 0.0 && along[1] < 0.0) {
        corners.reverse();
    }
    corners
}

/// Refines every corner of a row-major grid; the window of each is sized from the distance
/// to its nearest grid neighbour so that it never reaches the neighbouring junctions.
fn refine_corners(
    image: &GrayImage,
    corners: &[[f64; 2]],
    cols: usize,
    rows: usize,
) -> Vec<[f64; 2]> {
    (0..rows)
        .flat_map(|r| (0..cols).map(move |c| (c, r)))
        .map(|(c, r)| {
            let here = corners[r * cols + c];
            let mut spacing = f64::INFINITY;
            for (dc, dr) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (nc, nr) = (c as i64 + dc, r as i64 + dr);
                if (0..cols as i64).contains(&nc) && (0..rows as i64).contains(&nr) {
                    let other = corners[nr as usize * cols + nc as usize];
                    spacing = spacing.min(norm(sub(other, here)));
                }
            }
            let half_window = (0.4 * spacing).floor().clamp(2.0, 7.0) as i64;
            refine_saddle(image, here, half_window)
        })
        .collect()
}

/// Sub-pixel position of the X-junction near `start`: iterates q = (Σ w g gᵀ)⁻¹ Σ w g gᵀ p
/// over the pixels p of a window around q, with g the image gradient at p and w a Gaussian
/// weight, until q moves by less than 0.001 px. Returns `start` if the system is singular
/// or q leaves the window.
pub fn refine_saddle(image: &GrayImage, start: [f64; 2], half_window: i64) -> [f64; 2] {
    let sigma = 0.7 * half_window as f64;
    let mut q = start;
    for _ in 0..30 {
        let (mut a00, mut a01, mut a11, mut b0, mut b1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for dy in -half_window..=half_window {
            for dx in -half_window..=half_window {
                let (x, y) = (q[0] + dx as f64, q[1] + dy as f64);
                let gx = 0.5 * f64::from(image.bilinear(x + 1.0, y) - image.bilinear(x - 1.0, y));
                let gy = 0.5 * f64::from(image.bilinear(x, y + 1.0) - image.bilinear(x, y - 1.0));
                let w = (-((dx * dx + dy * dy) as f64) / (2.0 * sigma * sigma)).exp();
                let (gxx, gxy, gyy) = (w * gx * gx, w * gx * gy, w * gy * gy);
                a00 += gxx;
                a01 += gxy;
                a11 += gyy;
                b0 += gxx * x + gxy * y;
                b1 += gxy * x + gyy * y;
            }
        }
        let det = a00 * a11 - a01 * a01;
        if det.is_nan() || det.abs() <= 1e-9 * (a00 * a11).abs().max(1e-30) {
            return start;
        }
        let next = [(a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det];
        if !next.iter().all(|v| v.is_finite()) || norm(sub(next, start)) > half_window as f64 {
            return start;
        }
        let moved = norm(sub(next, q));
        q = next;
        if moved < 1e-3 {
            break;
        }
    }
    q
}

#[cfg(test)]
#[path = "chessboard_tests.rs"]
mod tests;
