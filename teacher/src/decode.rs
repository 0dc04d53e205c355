//! NanoDet-g's outputs as boxes: per level (strides 8, 16 and 32 over the 416 px input),
//! each cell's 80 class scores (already through a sigmoid) and, per side of the box, a
//! distribution over 11 distances (0 to 10 strides, generalised focal loss): the
//! expected distance, in strides, from the cell's centre to that side.

use crate::Detection;

/// Bins per side of the distance distribution (`reg_max + 1`).
pub const BINS: usize = 11;

/// One level of the output: its cells' scores and distance logits.
#[derive(Debug)]
pub struct Level<'a> {
    /// Cells per side; the level's stride is `input / side`.
    pub side: usize,
    /// `side²` rows of the class scores.
    pub scores: &'a [f32],
    /// `side²` rows of `4 * BINS` logits (left, top, right, bottom).
    pub distances: &'a [f32],
}

/// Every (cell, class) of every level scoring at least `min_score`, as a box in input
/// pixels.
pub fn boxes(
    levels: &[Level<'_>],
    classes: usize,
    input_px: f32,
    min_score: f32,
) -> Vec<Detection> {
    let mut out = Vec::new();
    for level in levels {
        let stride = input_px / level.side as f32;
        let cells = level.side * level.side;
        for cell in 0..cells {
            let Some(row) = level.scores.get(cell * classes..(cell + 1) * classes) else {
                break;
            };
            let Some(logits) = level.distances.get(cell * 4 * BINS..(cell + 1) * 4 * BINS) else {
                break;
            };
            let mut sides: Option<[f32; 4]> = None;
            for (class, &score) in row.iter().enumerate() {
                if score < min_score || !score.is_finite() {
                    continue;
                }
                let d = *sides.get_or_insert_with(|| {
                    let mut d = [0f32; 4];
                    for (k, side) in d.iter_mut().enumerate() {
                        *side = expected_bin(&logits[k * BINS..(k + 1) * BINS]) * stride;
                    }
                    d
                });
                let cx = ((cell % level.side) as f32 + 0.5) * stride;
                let cy = ((cell / level.side) as f32 + 0.5) * stride;
                out.push(Detection {
                    class,
                    score,
                    box_px: [cx - d[0], cy - d[1], cx + d[2], cy + d[3]],
                });
            }
        }
    }
    out
}

/// The expected bin of a softmax over `logits`.
fn expected_bin(logits: &[f32]) -> f32 {
    let max = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let mut sum = 0.0;
    let mut weighted = 0.0;
    for (i, l) in logits.iter().enumerate() {
        let e = (l - max).exp();
        sum += e;
        weighted += e * i as f32;
    }
    if sum > 0.0 { weighted / sum } else { 0.0 }
}

/// Intersection over union of two boxes `[x0, y0, x1, y1]`.
pub fn iou(a: &[f32; 4], b: &[f32; 4]) -> f32 {
    let w = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let h = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = w * h;
    let area = |r: &[f32; 4]| (r[2] - r[0]).max(0.0) * (r[3] - r[1]).max(0.0);
    let union = area(a) + area(b) - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

/// Greedy non-maximum suppression per class: the best box of each overlapping group
/// (IoU above `max_iou`) stays, best first.
pub fn suppress(mut dets: Vec<Detection>, max_iou: f32) -> Vec<Detection> {
    dets.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut kept: Vec<Detection> = Vec::new();
    for d in dets {
        if kept
            .iter()
            .all(|k| k.class != d.class || iou(&k.box_px, &d.box_px) <= max_iou)
        {
            kept.push(d);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_confident_cell_becomes_its_box() {
        // One 2x2 level over a 64 px input (stride 32), two classes.
        let mut scores = vec![0.0f32; 4 * 2];
        scores[3 * 2 + 1] = 0.9; // cell (1, 1), class 1
        let mut distances = vec![-20.0f32; 4 * 4 * BINS];
        let cell = 3 * 4 * BINS;
        distances[cell] = 10.0; // left: bin 0
        distances[cell + BINS + 1] = 10.0; // top: 1 stride
        distances[cell + 2 * BINS + 2] = 10.0; // right: 2 strides
        distances[cell + 3 * BINS] = 10.0; // bottom: 0
        let level = Level {
            side: 2,
            scores: &scores,
            distances: &distances,
        };
        let found = boxes(&[level], 2, 64.0, 0.5);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].class, 1);
        let b = found[0].box_px;
        let expect = [48.0, 16.0, 112.0, 48.0];
        for (got, want) in b.iter().zip(expect) {
            assert!((got - want).abs() < 1e-3, "{b:?}");
        }
    }

    #[test]
    fn overlapping_boxes_of_one_class_leave_the_best() {
        let d = |class, score, x0| Detection {
            class,
            score,
            box_px: [x0, 0.0, x0 + 10.0, 10.0],
        };
        let kept = suppress(
            vec![
                d(0, 0.5, 0.0),
                d(0, 0.9, 1.0),
                d(1, 0.4, 0.0),
                d(0, 0.3, 30.0),
            ],
            0.5,
        );
        let scores: Vec<f32> = kept.iter().map(|k| k.score).collect();
        assert_eq!(scores, vec![0.9, 0.4, 0.3]);
    }
}
