//! Tests of the HOG descriptor: flat patches, mirror symmetry, edge orientations, block
//! normalisation, and agreement with a slow reference using `atan2`.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::patch_fixtures::patches;
use approx::assert_abs_diff_eq;

#[test]
fn a_uniform_patch_has_an_all_zero_descriptor() {
    let d = hog(&Patch::from_fn(|_, _| 0.37).unwrap());
    assert!(d.iter().all(|&v| v == 0.0));
}

/// The descriptor index of the left–right mirror of a feature.
fn mirrored_index(i: usize) -> usize {
    let bin = i % BINS;
    let cx = (i / BINS) % 2;
    let cy = (i / (2 * BINS)) % 2;
    let bx = (i / (4 * BINS)) % BLOCKS;
    let by = i / (4 * BINS * BLOCKS);
    index(by, BLOCKS - 1 - bx, cy, 1 - cx, (BINS - bin) % BINS)
}

#[test]
fn a_mirrored_patch_gives_the_mirrored_descriptor() {
    let (pos, neg) = patches(3, 3, 11);
    for p in pos.iter().chain(&neg) {
        let d = hog(p);
        let m = hog(&p.mirrored());
        assert!(d.iter().any(|&v| v > 0.0));
        for i in 0..HOG_LEN {
            assert_abs_diff_eq!(m[mirrored_index(i)], d[i], epsilon = 1e-4);
        }
    }
}

/// Sum over the descriptor of each orientation bin.
fn per_bin(d: &HogDescriptor) -> [f32; BINS] {
    let mut out = [0.0; BINS];
    for (i, v) in d.iter().enumerate() {
        out[i % BINS] += v;
    }
    out
}

#[test]
fn edges_vote_for_their_gradient_orientation() {
    let vertical = hog(&Patch::from_fn(|x, _| if x < 13 { 0.2 } else { 0.9 }).unwrap());
    let bins = per_bin(&vertical);
    let total: f32 = bins.iter().sum();
    assert!(bins[0] > 0.99 * total, "{bins:?}");
    let horizontal = hog(&Patch::from_fn(|_, y| if y < 20 { 0.8 } else { 0.1 }).unwrap());
    let bins = per_bin(&horizontal);
    let total: f32 = bins.iter().sum();
    assert!(bins[4] > 0.99 * total, "{bins:?}");
    // A 45° diagonal edge (gradient along x = y) lands in bin 2 (45°).
    let diagonal = hog(&Patch::from_fn(|x, y| if x + y < 31 { 0.0 } else { 1.0 }).unwrap());
    let bins = per_bin(&diagonal);
    assert!(bins[2] > 0.9 * bins.iter().sum::<f32>(), "{bins:?}");
}

#[test]
fn blocks_are_unit_length_and_clipped() {
    let (pos, _) = patches(2, 0, 5);
    for p in &pos {
        let d = hog(p);
        for block in d.chunks_exact(4 * BINS) {
            let norm: f32 = block.iter().map(|v| v * v).sum::<f32>().sqrt();
            assert_abs_diff_eq!(norm, 1.0, epsilon = 1e-3);
            assert!(block.iter().all(|&v| (0.0..=1.0).contains(&v)));
        }
    }
}

/// The descriptor computed the obvious way, with `atan2` and no shortcuts.
fn reference(p: &Patch) -> Vec<f32> {
    let n = 32i64;
    let at =
        |x: i64, y: i64| f64::from(p.at(x.clamp(0, n - 1) as usize, y.clamp(0, n - 1) as usize));
    let mut cells = vec![[0.0f64; BINS]; 16];
    for y in 0..n {
        for x in 0..n {
            let gx = at(x + 1, y) - at(x - 1, y);
            let gy = at(x, y + 1) - at(x, y - 1);
            let mag = gx.hypot(gy);
            let deg = gy.atan2(gx).to_degrees().rem_euclid(180.0);
            let pos = deg / 22.5;
            let lo = pos.floor();
            let cell = &mut cells[(y / 8 * 4 + x / 8) as usize];
            cell[lo as usize % BINS] += mag * (1.0 - (pos - lo));
            cell[(lo as usize + 1) % BINS] += mag * (pos - lo);
        }
    }
    let mut out = Vec::new();
    for by in 0..3 {
        for bx in 0..3 {
            let mut block: Vec<f64> = Vec::new();
            for cy in 0..2 {
                for cx in 0..2 {
                    block.extend(cells[(by + cy) * 4 + bx + cx]);
                }
            }
            let norm = (block.iter().map(|v| v * v).sum::<f64>() + 1e-10).sqrt();
            block.iter_mut().for_each(|v| *v = (*v / norm).min(0.2));
            let norm = (block.iter().map(|v| v * v).sum::<f64>() + 1e-10).sqrt();
            out.extend(block.iter().map(|v| (*v / norm) as f32));
        }
    }
    out
}

#[test]
fn matches_the_atan2_reference() {
    let (pos, neg) = patches(4, 4, 23);
    for p in pos.iter().chain(&neg) {
        let d = hog(p);
        let r = reference(p);
        for i in 0..HOG_LEN {
            assert_abs_diff_eq!(d[i], r[i], epsilon = 2e-3);
        }
    }
}

proptest::proptest! {
    #[test]
    fn random_patches_mirror_and_stay_in_range(values in proptest::collection::vec(0.0f32..1.0, 1024)) {
        let p = Patch::from_grey(values).unwrap();
        let d = hog(&p);
        let m = hog(&p.mirrored());
        for i in 0..HOG_LEN {
            proptest::prop_assert!((0.0..=1.0).contains(&d[i]));
            proptest::prop_assert!((m[mirrored_index(i)] - d[i]).abs() < 1e-4);
        }
    }
}
