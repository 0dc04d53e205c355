//! The ball network: a small convolutional network that looks at one candidate's colour
//! patch and says whether it is a ball, and where the ball's centre and edge are.
//!
//! The design follows the patch networks of the RoboCup standard platform league: a
//! 32×32 colour patch of the window around a proposal (`WINDOW_OVER_RADIUS` × its radius
//! wide), three 3×3 convolutions of stride 2 (3→8→16→16 channels, ReLU) down to 4×4, a
//! hidden layer of 32 and four outputs: the ball's logit, its centre's offset from the
//! proposal's in units of the proposal's radius, and the log of its radius over the
//! proposal's. About 0.17 M multiply-adds a patch.
//!
//! The forward pass is the detector's own ([`crate::nn`]): a frame's proposals are judged
//! as one batch, each layer one matrix product over every patch. The training crate's
//! forward pass is checked against this one in the training module's tests.
//!
//! Weights are a safetensors file in the training crate's layout (convolutions
//! `[out, in, ky, kx]`, dense layers `[out, in]`, the first dense layer's inputs in
//! channel-major order) with metadata naming the format; a file for another architecture,
//! or a truncated one, is refused with what was wrong.

use crate::check::patch::{PATCH_SIDE_PX, PatchConfig, RgbPatch, extract_rgb};
use crate::circle::Circle;
use crate::image::RgbImage;
use crate::nn::{Act, Conv, WeightsError, WeightsFile};
use std::collections::BTreeMap;

/// The format named in a weights file's metadata.
pub const FORMAT: &str = "ballnet-v1";

/// The patch window's side over the proposal's radius.
pub const WINDOW_OVER_RADIUS: f64 = 3.0;

/// Input channels and output channels of the three convolutions.
pub const CONVOLUTIONS: [(usize, usize); 3] = [(3, 8), (8, 16), (16, 16)];

/// Units of the hidden dense layer.
pub const HIDDEN: usize = 32;

/// Outputs: logit, centre offset x and y (proposal radii), log radius ratio.
pub const OUTPUTS: usize = 4;

/// Side of the last convolution's output.
pub const LAST_SIDE: usize = PATCH_SIDE_PX >> CONVOLUTIONS.len();

/// Inputs of the hidden layer.
pub const FLAT: usize = LAST_SIDE * LAST_SIDE * CONVOLUTIONS[2].1;

/// Why a weights file cannot be used (the detector's networks share the reasons).
pub type BallNetError = WeightsError;

/// What the network says of one patch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// The ball's logit; its probability is the logistic of it.
    pub logit: f32,
    /// The ball's centre minus the proposal's, proposal radii, x right and y down.
    pub offset: [f32; 2],
    /// ln(ball radius / proposal radius).
    pub log_scale: f32,
}

impl Verdict {
    pub fn probability(&self) -> f64 {
        1.0 / (1.0 + (-f64::from(self.logit)).exp())
    }

    /// The ball's circle, given the proposal it was asked about.
    pub fn refine(&self, proposal: &Circle) -> Circle {
        let r = proposal.radius_px;
        // The net's corrections are bounded so a wild output cannot move a ball far away.
        let dx = f64::from(self.offset[0]).clamp(-1.0, 1.0);
        let dy = f64::from(self.offset[1]).clamp(-1.0, 1.0);
        let ds = f64::from(self.log_scale).clamp(-1.0, 1.0);
        Circle {
            center_px: [
                proposal.center_px[0] + dx * r,
                proposal.center_px[1] + dy * r,
            ],
            radius_px: r * ds.exp(),
            score: proposal.score,
        }
    }
}

/// A batch's verdicts from the output layer's four values per image (the ball network's
/// and the grey checker's heads say the same things).
pub fn verdicts(out: &Act) -> Vec<Verdict> {
    out.data
        .chunks_exact(OUTPUTS)
        .map(|v| Verdict {
            logit: v[0],
            offset: [v[1], v[2]],
            log_scale: v[3],
        })
        .collect()
}

/// The network, ready to run.
#[derive(Debug, Clone, PartialEq)]
pub struct BallNet {
    convs: Vec<Conv>,
    hidden: Conv,
    output: Conv,
    /// The file's metadata (training data, held-out score, ...).
    metadata: BTreeMap<String, String>,
}

/// The network's input for a patch: the patch's values in [0, 1], less their mean, over
/// their spread (plus a floor, so that a flat patch is not blown up into noise), rows of
/// pixels with the three channels innermost. Training uses the same function.
pub fn input(patch: &RgbPatch) -> Vec<f32> {
    let data = patch.data();
    let n = data.len() as f32;
    let mean = data.iter().map(|&v| f32::from(v)).sum::<f32>() / n / 255.0;
    let var = data
        .iter()
        .map(|&v| {
            let d = f32::from(v) / 255.0 - mean;
            d * d
        })
        .sum::<f32>()
        / n;
    let scale = 1.0 / (var.sqrt() + 0.02);
    data.iter()
        .map(|&v| (f32::from(v) / 255.0 - mean) * scale)
        .collect()
}

/// The patch the network sees for a proposal.
pub fn patch_for(image: &RgbImage, circle: &Circle) -> Option<RgbPatch> {
    let cfg = PatchConfig {
        window_over_radius: WINDOW_OVER_RADIUS,
    };
    extract_rgb(image, circle.center_px, circle.radius_px, &cfg).ok()
}

impl BallNet {
    /// The network of a weights file's bytes.
    pub fn from_safetensors(bytes: &[u8]) -> Result<Self, BallNetError> {
        let file = WeightsFile::read(bytes, FORMAT)?;
        let convs = CONVOLUTIONS
            .iter()
            .enumerate()
            .map(|(k, &(cin, cout))| file.conv(&format!("conv{}", k + 1), cin, cout, 3, 2, 1))
            .collect::<Result<Vec<_>, _>>()?;
        // The training crate flattens the last convolution channel-major; the forward pass
        // here reads it cell-major with the channels innermost.
        let hidden = file.dense("fc1", CONVOLUTIONS[2].1, LAST_SIDE * LAST_SIDE, HIDDEN)?;
        let output = file.dense("fc2", HIDDEN, 1, OUTPUTS)?;
        Ok(BallNet {
            convs,
            hidden,
            output,
            metadata: file.metadata().clone(),
        })
    }

    /// The file's metadata: format, training data, held-out score.
    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// The network's outputs for an input from [`input`].
    pub fn forward(&self, input: &[f32]) -> Verdict {
        let mut batch = Act::zeros(1, PATCH_SIDE_PX, PATCH_SIDE_PX, 3);
        let n = batch.data.len();
        batch.data.copy_from_slice(&input[..n]);
        self.forward_batch(&batch)[0]
    }

    /// The network's outputs for a batch of inputs from [`input`], one image each: every
    /// layer one matrix product for the whole batch.
    pub fn forward_batch(&self, batch: &Act) -> Vec<Verdict> {
        debug_assert_eq!(
            (batch.h, batch.w, batch.c),
            (PATCH_SIDE_PX, PATCH_SIDE_PX, 3)
        );
        let mut scratch = Vec::new();
        let mut a = self.convs[0].forward(batch, true, &mut scratch);
        for conv in &self.convs[1..] {
            a = conv.forward(&a, true, &mut scratch);
        }
        verdicts(&self.output.dense(&self.hidden.dense(&a, true), false))
    }

    /// The verdict on a proposal in an image, or `None` when no patch can be cut.
    pub fn judge(&self, image: &RgbImage, circle: &Circle) -> Option<Verdict> {
        self.judge_all(image, std::slice::from_ref(circle))
            .pop()
            .flatten()
    }

    /// [`BallNet::judge`] of every proposal of one image, in order, run as one batch.
    pub fn judge_all(&self, image: &RgbImage, circles: &[Circle]) -> Vec<Option<Verdict>> {
        let side = PATCH_SIDE_PX * PATCH_SIDE_PX * 3;
        let patches: Vec<Option<RgbPatch>> = circles.iter().map(|c| patch_for(image, c)).collect();
        let cut = patches.iter().flatten().count();
        if cut == 0 {
            return vec![None; circles.len()];
        }
        let mut batch = Act::zeros(cut, PATCH_SIDE_PX, PATCH_SIDE_PX, 3);
        for (dst, patch) in batch
            .data
            .chunks_exact_mut(side)
            .zip(patches.iter().flatten())
        {
            dst.copy_from_slice(&input(patch));
        }
        let mut verdicts = self.forward_batch(&batch).into_iter();
        patches
            .iter()
            .map(|p| p.as_ref().and_then(|_| verdicts.next()))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use std::collections::HashMap;

    /// A weights file with the given shapes, every value from `value(tensor, index)`.
    fn file(shapes: &[(&str, Vec<usize>)], format: &str) -> Vec<u8> {
        let bufs: Vec<(String, Vec<usize>, Vec<u8>)> = shapes
            .iter()
            .enumerate()
            .map(|(t, (name, shape))| {
                let n: usize = shape.iter().product();
                let bytes = (0..n)
                    .flat_map(|i| (((i * 7 + t * 3) % 11) as f32 * 0.01 - 0.05).to_le_bytes())
                    .collect();
                (name.to_string(), shape.clone(), bytes)
            })
            .collect();
        let views: Vec<(String, safetensors::tensor::TensorView<'_>)> = bufs
            .iter()
            .map(|(n, s, b)| {
                (
                    n.clone(),
                    safetensors::tensor::TensorView::new(safetensors::Dtype::F32, s.clone(), b)
                        .unwrap(),
                )
            })
            .collect();
        let meta: HashMap<String, String> = [("format".to_string(), format.to_string())].into();
        safetensors::serialize(views, Some(meta)).unwrap()
    }

    fn shapes() -> Vec<(&'static str, Vec<usize>)> {
        let [(i1, o1), (i2, o2), (i3, o3)] = CONVOLUTIONS;
        vec![
            ("conv1.weight", vec![o1, i1, 3, 3]),
            ("conv1.bias", vec![o1]),
            ("conv2.weight", vec![o2, i2, 3, 3]),
            ("conv2.bias", vec![o2]),
            ("conv3.weight", vec![o3, i3, 3, 3]),
            ("conv3.bias", vec![o3]),
            ("fc1.weight", vec![HIDDEN, FLAT]),
            ("fc1.bias", vec![HIDDEN]),
            ("fc2.weight", vec![OUTPUTS, HIDDEN]),
            ("fc2.bias", vec![OUTPUTS]),
        ]
    }

    #[test]
    fn a_well_formed_file_loads_and_runs() {
        let net = BallNet::from_safetensors(&file(&shapes(), FORMAT)).unwrap();
        let patch = RgbPatch::from_fn_rgb(|x, y| [(x * 8) as u8, (y * 8) as u8, 90]);
        let v = net.forward(&input(&patch));
        assert!(v.logit.is_finite() && v.log_scale.is_finite());
        assert!((0.0..=1.0).contains(&v.probability()));
    }

    #[test]
    fn bad_files_say_what_is_wrong() {
        assert!(matches!(
            BallNet::from_safetensors(b"not a model"),
            Err(BallNetError::Format(_))
        ));
        let good = file(&shapes(), FORMAT);
        assert!(matches!(
            BallNet::from_safetensors(&good[..good.len() - 10]),
            Err(BallNetError::Format(_))
        ));
        assert!(matches!(
            BallNet::from_safetensors(&file(&shapes(), "yolo")),
            Err(BallNetError::WrongFormat { .. })
        ));
        let mut other = shapes();
        other[0].1 = vec![8, 1, 3, 3];
        let e = BallNet::from_safetensors(&file(&other, FORMAT)).unwrap_err();
        assert!(e.to_string().contains("conv1.weight"), "{e}");
        let mut missing = shapes();
        missing.pop();
        assert_eq!(
            BallNet::from_safetensors(&file(&missing, FORMAT)),
            Err(BallNetError::Missing("fc2.bias".into()))
        );
    }

    #[test]
    fn refinement_is_bounded() {
        let v = Verdict {
            logit: 0.0,
            offset: [5.0, -0.5],
            log_scale: 0.2,
        };
        let c = v.refine(&Circle {
            center_px: [100.0, 50.0],
            radius_px: 10.0,
            score: 1.0,
        });
        assert_eq!(c.center_px, [110.0, 45.0]);
        assert!((c.radius_px - 10.0 * 0.2f64.exp()).abs() < 1e-5);
        assert_eq!(v.probability(), 0.5);
    }
}
