//! The grey checker: a small convolutional network that looks at a candidate's 32×32
//! greyscale patch and says whether it is a ball, and where the ball's centre and edge are.
//!
//! The patch is the window [`WINDOW_OVER_RADIUS`] × the candidate's radius wide (about
//! 1.75 ball diameters), in luma, scaled so that its 98th percentile is white: the
//! checker knows a ball by its shape and shading, whatever its colour and the light.
//! Layers: four 3×3 convolutions (1→8→16→16→32, ReLU), each of the first three followed by
//! 2×2 max pooling (32→16→8→4), a hidden layer of [`HIDDEN`] and four outputs: the ball's
//! logit, its centre's offset from the candidate's in candidate radii, and the log of its
//! radius over the candidate's. About 0.6 M multiply-adds a patch; the patches of a frame
//! run as one batch ([`Checker::judge_all`]).

use crate::check::CandidateClassifier;
use crate::check::ballnet::Verdict;
use crate::check::patch::{PATCH_SIDE_PX, PatchConfig, RgbPatch, extract_rgb};
use crate::circle::Circle;
use crate::image::RgbImage;
use crate::nn::{Act, Conv, WeightsError, WeightsFile, max_pool2};
use std::collections::BTreeMap;

/// The patch window's side over the candidate's radius.
pub const WINDOW_OVER_RADIUS: f64 = 3.5;

/// Input and output channels of the four convolutions (tensors `check.conv{k}.*`).
pub const CONVOLUTIONS: [(usize, usize); 4] = [(1, 8), (8, 16), (16, 16), (16, 32)];

/// Side of the last convolution's output (after three poolings).
pub const LAST_SIDE: usize = PATCH_SIDE_PX >> 3;

/// Units of the hidden dense layer.
pub const HIDDEN: usize = 32;

/// Outputs: logit, centre offset x and y (candidate radii), log radius ratio.
pub const OUTPUTS: usize = 4;

/// The share of a patch's pixels at or below the value that becomes white.
pub const WHITE_QUANTILE: f64 = 0.98;

/// The colour patch the checker's grey input is made from.
pub fn patch_for(image: &RgbImage, circle: &Circle) -> Option<RgbPatch> {
    let cfg = PatchConfig {
        window_over_radius: WINDOW_OVER_RADIUS,
    };
    extract_rgb(image, circle.center_px, circle.radius_px, &cfg).ok()
}

/// The checker's input for a patch: luma over the patch's 98th percentile (clamped to
/// 1.5), less one half; rows of pixels. Training uses the same function.
pub fn input(patch: &RgbPatch) -> Vec<f32> {
    let luma: Vec<f32> = patch
        .data()
        .chunks_exact(3)
        .map(|p| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]))
        .collect();
    let mut order = luma.clone();
    let k = ((order.len() - 1) as f64 * WHITE_QUANTILE).round() as usize;
    let white = order.select_nth_unstable_by(k, f32::total_cmp).1.max(8.0);
    luma.iter().map(|&v| (v / white).min(1.5) - 0.5).collect()
}

/// The checker, ready to run.
#[derive(Debug, Clone, PartialEq)]
pub struct Checker {
    convs: Vec<Conv>,
    hidden: Conv,
    output: Conv,
    metadata: BTreeMap<String, String>,
}

impl Checker {
    /// The checker of a detector's weights file.
    pub fn from_safetensors(bytes: &[u8]) -> Result<Self, WeightsError> {
        let file = WeightsFile::read(bytes, crate::candidates::FORMAT)?;
        let mut convs = Vec::new();
        for (k, &(cin, cout)) in CONVOLUTIONS.iter().enumerate() {
            convs.push(file.conv(&format!("check.conv{}", k + 1), cin, cout, 3, 1, 1)?);
        }
        let last = CONVOLUTIONS[CONVOLUTIONS.len() - 1].1;
        Ok(Checker {
            convs,
            hidden: file.dense("check.fc1", last, LAST_SIDE * LAST_SIDE, HIDDEN)?,
            output: file.dense("check.fc2", HIDDEN, 1, OUTPUTS)?,
            metadata: file.metadata().clone(),
        })
    }

    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// Multiply-adds per patch.
    pub fn multiply_adds(&self) -> usize {
        let mut side = PATCH_SIDE_PX;
        let mut total = 0;
        for (k, c) in self.convs.iter().enumerate() {
            total += c.multiply_adds(side, side);
            if k + 1 < self.convs.len() {
                side /= 2;
            }
        }
        total + self.hidden.cin * self.hidden.cout + self.output.cin * self.output.cout
    }

    /// The verdicts on a batch of inputs from [`input`], concatenated.
    pub fn forward(&self, inputs: &[f32]) -> Vec<Verdict> {
        let side = PATCH_SIDE_PX;
        let n = inputs.len() / (side * side);
        if n == 0 {
            return Vec::new();
        }
        let mut a = Act {
            n,
            h: side,
            w: side,
            c: 1,
            data: inputs[..n * side * side].to_vec(),
        };
        let mut scratch = Vec::new();
        for (k, conv) in self.convs.iter().enumerate() {
            a = conv.forward(&a, true, &mut scratch);
            if k + 1 < self.convs.len() {
                a = max_pool2(&a);
            }
        }
        crate::check::ballnet::verdicts(&self.output.dense(&self.hidden.dense(&a, true), false))
    }

    /// The verdict on each circle of an image, `None` where no patch can be cut.
    pub fn judge_circles(&self, image: &RgbImage, circles: &[Circle]) -> Vec<Option<Verdict>> {
        let patches: Vec<Option<RgbPatch>> = circles.iter().map(|c| patch_for(image, c)).collect();
        let inputs: Vec<f32> = patches.iter().flatten().flat_map(input).collect();
        let mut verdicts = self.forward(&inputs).into_iter();
        patches
            .iter()
            .map(|p| p.as_ref().and_then(|_| verdicts.next()))
            .collect()
    }
}

impl CandidateClassifier for Checker {
    fn probability(&self, image: &RgbImage, circle: &Circle) -> Option<f64> {
        self.judge(image, circle).map(|(p, _)| p)
    }

    fn judge(&self, image: &RgbImage, circle: &Circle) -> Option<(f64, Circle)> {
        self.judge_all(image, std::slice::from_ref(circle))
            .pop()
            .flatten()
    }

    fn judge_all(&self, image: &RgbImage, circles: &[Circle]) -> Vec<Option<(f64, Circle)>> {
        self.judge_circles(image, circles)
            .into_iter()
            .zip(circles)
            .map(|(v, c)| v.map(|v| (v.probability(), v.refine(c))))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn the_input_is_brightness_normalised() {
        let dark = RgbPatch::from_fn_rgb(|x, _| if x < 16 { [10, 10, 10] } else { [40, 40, 40] });
        let bright = RgbPatch::from_fn_rgb(|x, _| {
            if x < 16 {
                [50, 50, 50]
            } else {
                [200, 200, 200]
            }
        });
        let (a, b) = (input(&dark), input(&bright));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 0.02, "{x} vs {y}");
        }
        assert!((a[31] - 0.5).abs() < 0.01, "the bright side is white");
    }
}
