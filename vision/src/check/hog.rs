//! Histogram of oriented gradients (Dalal and Triggs 2005) of a 32×32 candidate patch: the
//! feature vector of the ball classifier.
//!
//! The layout follows the descriptor the classifier was first designed with (288 features):
//!
//! - gradients by the centred difference [-1, 0, 1] in x and y, the patch's edge pixels
//!   repeated beyond its border;
//! - unsigned orientations in [0°, 180°) (a ball is bright or dark against its background
//!   depending on the scene; the sign of the contrast carries no information), 8 bins
//!   centred at 0°, 22.5°, …, 157.5°, each gradient voting its magnitude into its two
//!   nearest bins with linear weights (wrapping from 157.5° to 0°);
//! - 8×8-pixel cells (4×4 of them), 2×2-cell blocks with a stride of one cell (3×3
//!   blocks), each block's 32 values normalised by L2-Hys: L2-normalised, clipped at 0.2,
//!   L2-normalised again, which keeps one strong edge from drowning the rest.
//!
//! Output order: block row, block column, cell row in the block, cell column in the block,
//! orientation bin. A bin centred at 0° holds horizontal gradients (vertical edges).
//!
//! The orientation comes from a polynomial arctangent (error below 0.001°) instead of
//! `atan2`, which keeps the whole descriptor at a few microseconds per patch.

use crate::check::patch::{PATCH_SIDE_PX, Patch};

/// Orientation bins over [0°, 180°).
pub const BINS: usize = 8;

// Bin indices wrap with a mask.
const _: () = assert!(BINS.is_power_of_two());

/// Side of a cell, pixels.
pub const CELL_PX: usize = 8;

/// Cells per patch side.
pub const CELLS: usize = PATCH_SIDE_PX / CELL_PX;

/// Blocks per patch side (2×2-cell blocks, stride one cell).
pub const BLOCKS: usize = CELLS - 1;

/// Length of the descriptor: 3×3 blocks × 4 cells × 8 bins.
pub const HOG_LEN: usize = BLOCKS * BLOCKS * 4 * BINS;

/// Clipping level of the L2-Hys normalisation.
const HYS_CLIP: f32 = 0.2;

/// Guards the block normalisation of a flat block (squared, added to the squared norm).
const NORM_EPS_SQ: f32 = 1e-10;

/// The HOG descriptor of a patch.
pub type HogDescriptor = [f32; HOG_LEN];

/// Arctangent of `t` in [0, 1], radians; a minimax polynomial with an error below 1e-5 rad.
fn atan_unit(t: f32) -> f32 {
    let t2 = t * t;
    t * (0.999_866 + t2 * (-0.330_299_5 + t2 * (0.180_141 + t2 * (-0.085_133 + t2 * 0.020_835_1))))
}

/// Unsigned orientation of the gradient (gx, gy) in bins: a value in [0, 8], 0 and 8 both
/// meaning 0°. Written with selects rather than branches so that a row vectorises.
fn orientation_bins(gx: f32, gy: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    // Fold into the upper half plane: unsigned orientations identify g and −g.
    let gx = if gy < 0.0 { -gx } else { gx };
    let (ax, ay) = (gx.abs(), gy.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // A zero gradient gets orientation 0; its magnitude (0) makes its vote vanish.
    let a = atan_unit(lo / hi.max(f32::MIN_POSITIVE));
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if gx < 0.0 { PI - a } else { a };
    a * (BINS as f32 / PI)
}

/// Per-cell orientation histograms, `[cell_y][cell_x][bin]` flattened.
fn cell_histograms(patch: &Patch) -> [f32; CELLS * CELLS * BINS] {
    const N: usize = PATCH_SIDE_PX;
    let g = patch.grey();
    let mut hist = [0.0f32; CELLS * CELLS * BINS];
    let (mut gx, mut gy) = ([0.0f32; N], [0.0f32; N]);
    let (mut magnitude, mut bin_pos) = ([0.0f32; N], [0.0f32; N]);
    for (y, row) in g.chunks_exact(N).enumerate() {
        let up = &g[y.saturating_sub(1) * N..][..N];
        let down = &g[(y + 1).min(N - 1) * N..][..N];
        gx[0] = row[1] - row[0];
        for x in 1..N - 1 {
            gx[x] = row[x + 1] - row[x - 1];
        }
        gx[N - 1] = row[N - 1] - row[N - 2];
        for x in 0..N {
            gy[x] = down[x] - up[x];
        }
        let cells = &mut hist[(y / CELL_PX) * CELLS * BINS..][..CELLS * BINS];
        for x in 0..N {
            magnitude[x] = (gx[x] * gx[x] + gy[x] * gy[x]).sqrt();
            bin_pos[x] = orientation_bins(gx[x], gy[x]);
        }
        for x in 0..N {
            let (magnitude, pos) = (magnitude[x], bin_pos[x]);
            // `pos` is in [0, 8]; 8 wraps to bin 0 through the mask.
            let lower = pos as usize;
            let frac = pos - lower as f32;
            let cell = (x / CELL_PX) * BINS;
            cells[cell + (lower & (BINS - 1))] += magnitude * (1.0 - frac);
            cells[cell + ((lower + 1) & (BINS - 1))] += magnitude * frac;
        }
    }
    hist
}

/// L2-Hys normalisation of one block in place.
fn l2_hys(block: &mut [f32]) {
    let norm = |b: &[f32]| (b.iter().map(|v| v * v).sum::<f32>() + NORM_EPS_SQ).sqrt();
    let n = norm(block);
    for v in block.iter_mut() {
        *v = (*v / n).min(HYS_CLIP);
    }
    let n = norm(block);
    for v in block.iter_mut() {
        *v /= n;
    }
}

/// The HOG descriptor of a patch (see the module documentation for the layout).
pub fn hog(patch: &Patch) -> HogDescriptor {
    let hist = cell_histograms(patch);
    let mut out = [0.0f32; HOG_LEN];
    let block_len = 4 * BINS;
    for by in 0..BLOCKS {
        for bx in 0..BLOCKS {
            let start = (by * BLOCKS + bx) * block_len;
            let block = &mut out[start..start + block_len];
            for cy in 0..2 {
                for cx in 0..2 {
                    let cell = ((by + cy) * CELLS + bx + cx) * BINS;
                    let dst = (cy * 2 + cx) * BINS;
                    block[dst..dst + BINS].copy_from_slice(&hist[cell..cell + BINS]);
                }
            }
            l2_hys(block);
        }
    }
    out
}

/// Index in the descriptor of (block row, block column, cell row in block, cell column in
/// block, bin); exposed so that tests and tools can read the layout.
#[cfg(test)]
pub fn index(block_y: usize, block_x: usize, cell_y: usize, cell_x: usize, bin: usize) -> usize {
    (((block_y * BLOCKS + block_x) * 2 + cell_y) * 2 + cell_x) * BINS + bin
}

#[cfg(test)]
#[path = "hog_tests.rs"]
mod tests;
