//! Training the two-stage detector's networks on a CPU with candle, and their weights file.
//!
//! - The candidate network ([`vision::stages::candidates`]) learns from whole labelled
//!   photos: each step takes random crops of photos shrunk at a random scale about the
//!   detector's own, flipped, their colours turned (any hue, swapped channels or grey),
//!   their brightness, contrast and noise changed. A cell holding a ball's centre is a
//!   ball; every other cell is not, its penalty for firing reduced near a ball (by
//!   (1 − Y)⁴, Y a Gaussian about the ball's centre, as in CenterNet). The loss is the
//!   focal loss of the logits (γ = 2) over the number of balls, plus the squared error of
//!   the centre and radius learned on the ball's cell and the eight around it (so that
//!   whichever of them peaks points at the ball).
//! - The grey checker ([`vision::stages::checker`]) learns from patches
//!   ([`crate::training::ballnet_data`]): candidates on and off the balls, moved and
//!   scaled copies of every ball, random windows, augmented every epoch; the logistic loss
//!   plus the squared error of the correction on balls.
//!
//! Both use AdamW with a cosine learning-rate schedule and keep the epoch with the lowest
//! held-out loss (the last one without held-out data). The file holds both networks
//! (tensors `heat.*` and `check.*`) with the format and the caller's metadata; it is read
//! back by the agent's own forward passes before it is returned, so a file that comes out
//! of here always loads.

use crate::labels::BallBox;
use crate::training::ballnet_data::{Sample, augment, ball_circle, colour_matrix};
use candle_core::{DType, Device, Tensor};
use candle_nn::{Conv2dConfig, Module, Optimizer, VarBuilder, VarMap};
use proto::rng::Rng;
use std::collections::{BTreeMap, HashMap};
use thiserror::Error;
use vision::image::RgbImage;
use vision::stages::candidates::{self, CELL_PX, FORMAT, HEAD_IN, HeatNet, InputGeometry, LAYERS};
use vision::stages::checker::{self, Checker};
use vision::stages::nn::WeightsError;
use vision::stages::patch::PATCH_SIDE_PX;

/// Why training failed.
#[derive(Debug, Error)]
pub enum DetectorTrainError {
    #[error("no training data: {0}")]
    NoData(String),
    #[error("training settings: {0}")]
    Settings(String),
    #[error("tensor computation: {0}")]
    Candle(#[from] candle_core::Error),
    #[error("the trained weights do not load: {0}")]
    Weights(#[from] WeightsError),
    #[error("writing the weights file: {0}")]
    Serialise(String),
}

/// One training run's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StageTrainConfig {
    pub epochs: usize,
    pub batch: usize,
    pub learning_rate: f64,
    pub weight_decay: f64,
    pub seed: u64,
}

impl StageTrainConfig {
    fn check(&self) -> Result<(), DetectorTrainError> {
        if self.epochs == 0
            || self.batch == 0
            || self.learning_rate.is_nan()
            || self.learning_rate <= 0.0
        {
            return Err(DetectorTrainError::Settings(format!(
                "epochs {}, batch {} and learning rate {} must all be positive",
                self.epochs, self.batch, self.learning_rate
            )));
        }
        Ok(())
    }

    /// The candidate network's defaults.
    pub fn candidates() -> Self {
        StageTrainConfig {
            epochs: 30,
            batch: 8,
            learning_rate: 4e-3,
            weight_decay: 1e-4,
            seed: 1,
        }
    }

    /// The checker's defaults.
    pub fn checker() -> Self {
        StageTrainConfig {
            epochs: 15,
            batch: 128,
            learning_rate: 3e-3,
            weight_decay: 1e-4,
            seed: 1,
        }
    }
}

/// What training reports as it goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress {
    Batch { done: usize, total: usize },
    Epoch(EpochReport),
}

/// One epoch's mean losses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpochReport {
    pub epoch: usize,
    pub train_loss: f64,
    pub val_loss: f64,
}

/// A stage's variables: name (without the stage's prefix), shape, values.
type Tensors = Vec<(String, Vec<usize>, Vec<f32>)>;

/// A trained stage: its variables (named without the stage's prefix) and reports.
#[derive(Debug)]
pub struct TrainedStage {
    tensors: Tensors,
    pub epochs: Vec<EpochReport>,
    pub best_epoch: usize,
}

/// A labelled photo for the candidate network, stored shrunk.
#[derive(Debug, Clone)]
pub struct FramePhoto {
    /// RGB values 0..255, `width`×`height`, rows with the channels innermost.
    rgb: Vec<f32>,
    width: usize,
    height: usize,
    /// Ball circles in the stored pixels: centre x, y and radius.
    balls: Vec<[f64; 3]>,
    /// Stored pixels over the detector's input pixels.
    over_detector: f64,
}

/// How much larger than the detector's input a photo is stored, so that training can
/// zoom in.
const STORE_OVER_DETECTOR: f64 = 1.5;

/// Side of the training crops, input pixels (multiples of the cell).
const CROP_W: usize = 192;
const CROP_H: usize = 144;

impl FramePhoto {
    /// A labelled photo for the candidate network.
    pub fn new(image: &RgbImage, balls: &[BallBox]) -> Self {
        let g0 = InputGeometry::for_frame(image.width(), image.height());
        let scale = (g0.scale * STORE_OVER_DETECTOR).min(1.0);
        let g = InputGeometry::with_scale(image.width(), image.height(), scale);
        let size = [f64::from(image.width()), f64::from(image.height())];
        FramePhoto {
            rgb: candidates::shrink(image, &g),
            width: g.width_px,
            height: g.height_px,
            balls: balls
                .iter()
                .map(|b| {
                    let (c, r) = ball_circle(b, size);
                    [c[0] * scale, c[1] * scale, r * scale]
                })
                .collect(),
            over_detector: scale / g0.scale,
        }
    }
}

/// One augmented crop: the network's input `[3][h][w]` (channel-major for candle) and the
/// targets per cell.
struct Crop {
    input: Vec<f32>,
    /// Per cell: 1 ball, 0 not, and the weight of the cell in the logit's loss.
    label: Vec<f32>,
    weight: Vec<f32>,
    /// Per cell: 1 where the ball's place is learned (its cell and the eight around it).
    reg: Vec<f32>,
    /// Per cell: offset x, y (cells), log radius (zero off balls).
    target: Vec<f32>,
}

/// Bilinear sample of the stored photo's RGB at (x, y), edge-clamped.
fn sample_rgb(p: &FramePhoto, x: f64, y: f64) -> [f32; 3] {
    let xf = x.clamp(0.0, (p.width - 1) as f64);
    let yf = y.clamp(0.0, (p.height - 1) as f64);
    let (x0, y0) = (xf.floor() as usize, yf.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(p.width - 1), (y0 + 1).min(p.height - 1));
    let (fx, fy) = ((xf - x0 as f64) as f32, (yf - y0 as f64) as f32);
    let at = |x: usize, y: usize, k: usize| p.rgb[(y * p.width + x) * 3 + k];
    let mut out = [0f32; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let top = at(x0, y0, k) + (at(x1, y0, k) - at(x0, y0, k)) * fx;
        let bot = at(x0, y1, k) + (at(x1, y1, k) - at(x0, y1, k)) * fx;
        *o = top + (bot - top) * fy;
    }
    out
}

/// A random augmented crop of a photo, or the photo's whole (centred) view when
/// `augment` is off.
fn crop(p: &FramePhoto, rng: &mut Rng, augment: bool) -> Crop {
    // Stored pixels per input pixel: about the detector's, zoomed 0.6–1.5×.
    let zoom = if augment {
        rng.range(0.6f64.ln(), 1.5f64.ln()).exp()
    } else {
        1.0
    };
    let step = p.over_detector / zoom;
    let (vw, vh) = (p.width as f64 / step, p.height as f64 / step);
    // A crop with a ball in it half the time, so balls are not rare.
    let centre = if augment && !p.balls.is_empty() && rng.chance(0.5) {
        let b = p.balls[rng.index(p.balls.len())];
        let j = 0.4 * CROP_W as f64;
        [
            b[0] / step + rng.range(-j, j),
            b[1] / step + rng.range(-j, j),
        ]
    } else if augment {
        [rng.range(0.0, vw), rng.range(0.0, vh)]
    } else {
        [0.5 * vw, 0.5 * vh]
    };
    let x0 = (centre[0] - 0.5 * CROP_W as f64).clamp(0.0, (vw - CROP_W as f64).max(0.0));
    let y0 = (centre[1] - 0.5 * CROP_H as f64).clamp(0.0, (vh - CROP_H as f64).max(0.0));
    let flip = augment && rng.chance(0.5);
    let m = if augment && rng.chance(0.5) {
        colour_matrix(rng, std::f64::consts::PI)
    } else {
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    };
    let (gain, contrast, noise) = if augment {
        (
            rng.range(0.55f64.ln(), 1.6f64.ln()).exp() as f32,
            rng.range(0.6, 1.3) as f32,
            rng.range(0.0, 8.0),
        )
    } else {
        (1.0, 1.0, 0.0)
    };
    let (w, h) = (CROP_W, CROP_H);
    // The crop's pixels that lie on the photo; the rest stay at the mean (zero input).
    let (uw, uh) = (
        ((vw - x0).floor() as usize).min(w),
        ((vh - y0).floor() as usize).min(h),
    );
    let mut rgb = vec![0f32; uw * uh * 3];
    for y in 0..uh {
        for x in 0..uw {
            let sx = if flip { uw - 1 - x } else { x };
            let v = sample_rgb(
                p,
                (x0 + sx as f64 + 0.5) * step - 0.5,
                (y0 + y as f64 + 0.5) * step - 0.5,
            );
            let mut c = [0f32; 3];
            for (k, ck) in c.iter_mut().enumerate() {
                let mixed: f64 = (0..3).map(|j| m[k][j] * f64::from(v[j] - 128.0)).sum();
                let n = if noise > 0.0 {
                    rng.normal() * noise
                } else {
                    0.0
                };
                *ck = ((mixed as f32 * contrast + 128.0) * gain + n as f32).clamp(0.0, 255.0);
            }
            rgb[(y * uw + x) * 3..][..3].copy_from_slice(&c);
        }
    }
    let g = InputGeometry {
        scale: 1.0,
        width_px: uw.max(1),
        height_px: uh.max(1),
        padded_width_px: w,
        padded_height_px: h,
    };
    let act = if uw * uh == 0 {
        vision::stages::nn::Act::zeros(1, h, w, 3)
    } else {
        candidates::normalise(&rgb, &g)
    };
    let mut input = vec![0f32; 3 * w * h];
    for (i, px) in act.data.chunks_exact(3).enumerate() {
        for k in 0..3 {
            input[k * w * h + i] = px[k];
        }
    }
    let (rows, cols) = (h / CELL_PX, w / CELL_PX);
    let mut label = vec![0f32; rows * cols];
    // Near a ball, a cell's penalty for firing is reduced (CenterNet's (1 - Y)^4 with a
    // Gaussian Y about the ball's centre).
    let mut near = vec![0f32; rows * cols];
    let mut reg = vec![0f32; rows * cols];
    let mut target = vec![0f32; 3 * rows * cols];
    let cell = CELL_PX as f64;
    let mut best_r = vec![0f64; rows * cols];
    for b in &p.balls {
        let mut cx = b[0] / step - x0;
        let cy = b[1] / step - y0;
        if flip {
            cx = uw as f64 - cx;
        }
        let r = b[2] / step;
        let sigma = (0.5 * r).max(0.5 * cell);
        for row in 0..rows {
            for col in 0..cols {
                let (ccx, ccy) = (
                    candidates::cell_centre_px(col),
                    candidates::cell_centre_px(row),
                );
                let d2 = (ccx - cx).powi(2) + (ccy - cy).powi(2);
                let y = (-d2 / (2.0 * sigma * sigma)).exp() as f32;
                let i = row * cols + col;
                near[i] = near[i].max(y);
            }
        }
        if cx < 0.0 || cy < 0.0 || cx >= uw as f64 || cy >= uh as f64 || r < 0.5 {
            continue;
        }
        let (col, row) = (
            candidates::nearest_cell(cx, cols),
            candidates::nearest_cell(cy, rows),
        );
        label[row * cols + col] = 1.0;
        // The ball's cell and its eight neighbours all learn where the ball is from them,
        // so whichever of them peaks points at the ball.
        for dr in -1i64..=1 {
            for dc in -1i64..=1 {
                let (rr, cc) = (row as i64 + dr, col as i64 + dc);
                if rr < 0 || cc < 0 || rr >= rows as i64 || cc >= cols as i64 {
                    continue;
                }
                let i = rr as usize * cols + cc as usize;
                if r > best_r[i] {
                    best_r[i] = r;
                    reg[i] = 1.0;
                    target[i] = ((cx - candidates::cell_centre_px(cc as usize)) / cell) as f32;
                    target[rows * cols + i] =
                        ((cy - candidates::cell_centre_px(rr as usize)) / cell) as f32;
                    target[2 * rows * cols + i] = (r / cell).ln() as f32;
                }
            }
        }
    }
    let weight: Vec<f32> = label
        .iter()
        .zip(&near)
        .map(|(&l, &y)| if l > 0.0 { 1.0 } else { (1.0 - y).powi(4) })
        .collect();
    Crop {
        input,
        label,
        weight,
        reg,
        target,
    }
}

/// The candidate network as candle layers (NCHW), named as the weights file names them.
struct HeatLayers {
    layers: Vec<candle_nn::Conv2d>,
    head: candle_nn::Conv2d,
}

impl HeatLayers {
    fn new(vb: &VarBuilder<'_>) -> candle_core::Result<Self> {
        let layers = LAYERS
            .iter()
            .map(|l| {
                let cfg = Conv2dConfig {
                    padding: l.dilation,
                    stride: l.stride,
                    dilation: l.dilation,
                    ..Conv2dConfig::default()
                };
                candle_nn::conv2d(l.cin, l.cout, 3, cfg, vb.pp(l.name))
            })
            .collect::<candle_core::Result<Vec<_>>>()?;
        let head = candle_nn::conv2d(
            HEAD_IN,
            candidates::OUTPUTS,
            1,
            Conv2dConfig::default(),
            vb.pp("head"),
        )?;
        Ok(HeatLayers { layers, head })
    }

    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let mut x = x.clone();
        for l in &self.layers {
            x = l.forward(&x)?.relu()?;
        }
        self.head.forward(&x)
    }
}

/// softplus(x) = ln(1 + eˣ), stable for any x.
fn softplus(x: &Tensor) -> candle_core::Result<Tensor> {
    x.relu()? + (x.abs()?.neg()?.exp()? + 1.0)?.log()?
}

/// The focal loss of logits against labels with per-element weights, summed.
fn focal_sum(logit: &Tensor, label: &Tensor, weight: &Tensor) -> candle_core::Result<Tensor> {
    let p = candle_nn::ops::sigmoid(logit)?;
    // -ln p = softplus(-x), -ln(1-p) = softplus(x).
    let pos = ((p.affine(-1.0, 1.0)?.sqr()? * softplus(&logit.neg()?)?)? * label)?;
    let neg = ((p.sqr()? * softplus(logit)?)? * label.affine(-1.0, 1.0)?)?;
    ((pos + neg)? * weight)?.sum_all()
}

fn heat_loss(layers: &HeatLayers, crops: &[Crop], device: &Device) -> candle_core::Result<Tensor> {
    let n = crops.len();
    let (rows, cols) = (CROP_H / CELL_PX, CROP_W / CELL_PX);
    let x = Tensor::from_vec(
        crops
            .iter()
            .flat_map(|c| c.input.iter().copied())
            .collect::<Vec<f32>>(),
        (n, 3, CROP_H, CROP_W),
        device,
    )?;
    let cells = (n, 1, rows, cols);
    let label = Tensor::from_vec(
        crops
            .iter()
            .flat_map(|c| c.label.iter().copied())
            .collect::<Vec<f32>>(),
        cells,
        device,
    )?;
    let weight = Tensor::from_vec(
        crops
            .iter()
            .flat_map(|c| c.weight.iter().copied())
            .collect::<Vec<f32>>(),
        cells,
        device,
    )?;
    let target = Tensor::from_vec(
        crops
            .iter()
            .flat_map(|c| c.target.iter().copied())
            .collect::<Vec<f32>>(),
        (n, 3, rows, cols),
        device,
    )?;
    let reg = Tensor::from_vec(
        crops
            .iter()
            .flat_map(|c| c.reg.iter().copied())
            .collect::<Vec<f32>>(),
        cells,
        device,
    )?;
    let out = layers.forward(&x)?;
    let logit = out.narrow(1, 0, 1)?;
    let balls: f32 = crops.iter().map(|c| c.label.iter().sum::<f32>()).sum();
    let norm = f64::from(balls.max(1.0));
    let focal = (focal_sum(&logit, &label, &weight)? / norm)?;
    let placed: f32 = crops.iter().map(|c| c.reg.iter().sum::<f32>()).sum();
    let d = (out.narrow(1, 1, 3)? - target)?.broadcast_mul(&reg)?;
    let place = (d.sqr()?.sum_all()? / f64::from(placed.max(1.0)))?;
    focal + place
}

/// The variables by name, in name order (a fixed order for the file and the seeded
/// initialisation); the colour-patch network's training uses it too.
pub(crate) fn sorted_vars(varmap: &VarMap) -> Result<Vec<(String, candle_core::Var)>, String> {
    let vars = varmap
        .data()
        .lock()
        .map_err(|_| "the variables' lock is poisoned".to_string())?;
    let mut out: Vec<(String, candle_core::Var)> =
        vars.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(out)
}

/// Safetensors bytes of named f32 tensors (name, shape, values) with `metadata` and the
/// `format` named in it; the colour-patch network's training writes its file with it too.
pub(crate) fn encode(
    tensors: &[(String, Vec<usize>, Vec<f32>)],
    metadata: &BTreeMap<String, String>,
    format: &str,
) -> Result<Vec<u8>, String> {
    let bytes: Vec<Vec<u8>> = tensors
        .iter()
        .map(|(_, _, v)| v.iter().flat_map(|x| x.to_le_bytes()).collect())
        .collect();
    let views = tensors
        .iter()
        .zip(&bytes)
        .map(|((n, s, _), b)| {
            safetensors::tensor::TensorView::new(safetensors::Dtype::F32, s.clone(), b)
                .map(|v| (n.clone(), v))
                .map_err(|e| e.to_string())
        })
        .collect::<Result<Vec<_>, _>>()?;
    safetensors::serialize(views, Some(file_metadata(metadata, format))).map_err(|e| e.to_string())
}

/// The same weights file with other metadata and the `format` named in it.
pub(crate) fn restamp(
    file: &[u8],
    metadata: &BTreeMap<String, String>,
    format: &str,
) -> Result<Vec<u8>, String> {
    let st = safetensors::SafeTensors::deserialize(file).map_err(|e| e.to_string())?;
    safetensors::serialize(st.tensors(), Some(file_metadata(metadata, format)))
        .map_err(|e| e.to_string())
}

fn file_metadata(metadata: &BTreeMap<String, String>, format: &str) -> HashMap<String, String> {
    let mut meta: HashMap<String, String> = metadata
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    meta.insert("format".into(), format.into());
    meta
}

/// The epochs' reports and the weights of the best one so far: the lowest held-out loss,
/// or the last epoch when nothing is held out.
struct Epochs {
    reports: Vec<EpochReport>,
    best: Option<(f64, usize, Tensors)>,
}

impl Epochs {
    fn new() -> Self {
        Epochs {
            reports: Vec::new(),
            best: None,
        }
    }

    /// Records an epoch (reported to `progress`), keeping the variables when it is the best.
    fn record(
        &mut self,
        report: EpochReport,
        held_out: bool,
        varmap: &VarMap,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), DetectorTrainError> {
        progress(Progress::Epoch(report));
        self.reports.push(report);
        let key = if held_out {
            report.val_loss
        } else {
            -(report.epoch as f64)
        };
        if self.best.as_ref().is_none_or(|(k, _, _)| key <= *k) {
            self.best = Some((key, report.epoch, snapshot(varmap)?));
        }
        Ok(())
    }

    fn finish(self) -> Result<TrainedStage, DetectorTrainError> {
        let (_, best_epoch, tensors) = self
            .best
            .ok_or_else(|| DetectorTrainError::Settings("no epoch ran".into()))?;
        Ok(TrainedStage {
            tensors,
            epochs: self.reports,
            best_epoch,
        })
    }
}

fn snapshot(varmap: &VarMap) -> Result<Tensors, DetectorTrainError> {
    sorted_vars(varmap)
        .map_err(DetectorTrainError::Serialise)?
        .into_iter()
        .map(|(name, var)| {
            let t = var.as_tensor();
            Ok((name, t.dims().to_vec(), t.flatten_all()?.to_vec1::<f32>()?))
        })
        .collect()
}

/// Seeded initial weights (He normal, zero biases) in place of candle's unseeded ones;
/// with `start`, the variables it names start from its values instead (fine-tuning).
fn initialise(
    varmap: &VarMap,
    seed: u64,
    start: Option<&TrainedStage>,
) -> Result<(), DetectorTrainError> {
    for (k, (name, var)) in sorted_vars(varmap)
        .map_err(DetectorTrainError::Serialise)?
        .into_iter()
        .enumerate()
    {
        let dims = var.as_tensor().dims().to_vec();
        let n: usize = dims.iter().product();
        let given = start.and_then(|s| {
            s.tensors
                .iter()
                .find(|(t, d, _)| *t == name && *d == dims)
                .map(|(_, _, v)| v.clone())
        });
        let values: Vec<f32> = if let Some(v) = given {
            v
        } else if name.ends_with(".bias") {
            vec![0.0; n]
        } else {
            let fan_in: usize = dims[1..].iter().product();
            let sd = (2.0 / fan_in as f64).sqrt();
            let mut rng = Rng::stream(seed, "detector-init", k as u64);
            (0..n).map(|_| (rng.normal() * sd) as f32).collect()
        };
        var.set(&Tensor::from_vec(values, dims, &Device::Cpu)?)?;
    }
    Ok(())
}

/// The head's logit bias at the start: a ball is rare among cells.
fn prior_bias(varmap: &VarMap) -> Result<(), DetectorTrainError> {
    for (name, var) in sorted_vars(varmap).map_err(DetectorTrainError::Serialise)? {
        if name == "head.bias" {
            let mut v = var.as_tensor().to_vec1::<f32>()?;
            v[0] = -4.6;
            var.set(&Tensor::from_vec(v, candidates::OUTPUTS, &Device::Cpu)?)?;
        }
    }
    Ok(())
}

fn cosine(cfg: &StageTrainConfig, step: usize, total: usize) -> f64 {
    cfg.learning_rate * 0.5 * (1.0 + (std::f64::consts::PI * step as f64 / total as f64).cos())
}

fn optimiser(varmap: &VarMap, cfg: &StageTrainConfig) -> candle_core::Result<candle_nn::AdamW> {
    candle_nn::AdamW::new(
        varmap.all_vars(),
        candle_nn::ParamsAdamW {
            lr: cfg.learning_rate,
            weight_decay: cfg.weight_decay,
            ..candle_nn::ParamsAdamW::default()
        },
    )
}

/// Trains the candidate network on `train` photos, keeping the epoch with the lowest loss
/// on `val` (fixed crops of the held-out photos); `start` fine-tunes a trained stage.
/// An epoch draws twice as many crops as there are training photos.
pub fn train_candidates(
    train: &[FramePhoto],
    val: &[FramePhoto],
    cfg: &StageTrainConfig,
    start: Option<&TrainedStage>,
    progress: &mut dyn FnMut(Progress),
) -> Result<TrainedStage, DetectorTrainError> {
    cfg.check()?;
    if train.iter().all(|p| p.balls.is_empty()) {
        return Err(DetectorTrainError::NoData(format!(
            "{} training photos and not one ball among them",
            train.len()
        )));
    }
    let device = Device::Cpu;
    let varmap = VarMap::new();
    let vb = VarBuilder::from_varmap(&varmap, DType::F32, &device);
    let layers = HeatLayers::new(&vb)?;
    initialise(&varmap, cfg.seed, start)?;
    if start.is_none() {
        prior_bias(&varmap)?;
    }
    let mut opt = optimiser(&varmap, cfg)?;
    let mut rng = Rng::stream(cfg.seed, "heat-train", 0);
    let per_epoch = 2 * train.len();
    let batches = per_epoch.div_ceil(cfg.batch);
    let total = batches * cfg.epochs;
    let mut val_rng = Rng::stream(cfg.seed, "heat-val", 0);
    let val_crops: Vec<Crop> = val
        .iter()
        .flat_map(|p| [crop(p, &mut val_rng, true), crop(p, &mut val_rng, false)])
        .collect();
    let mut epochs = Epochs::new();
    for epoch in 0..cfg.epochs {
        let mut sum = 0.0;
        for b in 0..batches {
            let step = epoch * batches + b;
            opt.set_learning_rate(cosine(cfg, step, total));
            let crops: Vec<Crop> = (0..cfg.batch)
                .map(|_| crop(&train[rng.index(train.len())], &mut rng, true))
                .collect();
            let l = heat_loss(&layers, &crops, &device)?;
            opt.backward_step(&l)?;
            sum += f64::from(l.to_scalar::<f32>()?);
            progress(Progress::Batch {
                done: step + 1,
                total,
            });
        }
        let mut val_loss = f64::NAN;
        if !val_crops.is_empty() {
            let mut s = 0.0;
            for chunk in val_crops.chunks(16) {
                s += f64::from(heat_loss(&layers, chunk, &device)?.to_scalar::<f32>()?)
                    * chunk.len() as f64;
            }
            val_loss = s / val_crops.len() as f64;
        }
        let report = EpochReport {
            epoch: epoch + 1,
            train_loss: sum / batches as f64,
            val_loss,
        };
        epochs.record(report, !val_crops.is_empty(), &varmap, progress)?;
    }
    epochs.finish()
}

/// The checker as candle layers.
struct CheckLayers {
    convs: Vec<candle_nn::Conv2d>,
    fc1: candle_nn::Linear,
    fc2: candle_nn::Linear,
}

impl CheckLayers {
    fn new(vb: &VarBuilder<'_>) -> candle_core::Result<Self> {
        let cfg = Conv2dConfig {
            padding: 1,
            ..Conv2dConfig::default()
        };
        let mut convs = Vec::new();
        for (k, &(cin, cout)) in checker::CONVOLUTIONS.iter().enumerate() {
            convs.push(candle_nn::conv2d(
                cin,
                cout,
                3,
                cfg,
                vb.pp(format!("conv{}", k + 1)),
            )?);
        }
        let last = checker::CONVOLUTIONS[checker::CONVOLUTIONS.len() - 1].1;
        let flat = last * checker::LAST_SIDE * checker::LAST_SIDE;
        Ok(CheckLayers {
            convs,
            fc1: candle_nn::linear(flat, checker::HIDDEN, vb.pp("fc1"))?,
            fc2: candle_nn::linear(checker::HIDDEN, checker::OUTPUTS, vb.pp("fc2"))?,
        })
    }

    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let mut x = x.clone();
        for (k, c) in self.convs.iter().enumerate() {
            x = c.forward(&x)?.relu()?;
            if k + 1 < self.convs.len() {
                x = x.max_pool2d(2)?;
            }
        }
        let x = x.flatten_from(1)?;
        self.fc2.forward(&self.fc1.forward(&x)?.relu()?)
    }
}

fn check_loss(
    layers: &CheckLayers,
    samples: &[&Sample],
    device: &Device,
) -> candle_core::Result<Tensor> {
    let n = samples.len();
    let side = PATCH_SIDE_PX;
    let mut xs = Vec::with_capacity(n * side * side);
    let (mut labels, mut targets) = (Vec::with_capacity(n), Vec::with_capacity(3 * n));
    for s in samples {
        xs.extend(checker::input(&s.patch));
        labels.push(if s.ball { 1f32 } else { 0.0 });
        targets.extend(s.target.iter().map(|t| t.clamp(-1.0, 1.0)));
    }
    let x = Tensor::from_vec(xs, (n, 1, side, side), device)?;
    let labels = Tensor::from_vec(labels, (n, 1), device)?;
    let targets = Tensor::from_vec(targets, (n, 3), device)?;
    let out = layers.forward(&x)?;
    let logit = out.narrow(1, 0, 1)?;
    let bce = (softplus(&logit)? - (&logit * &labels)?)?.mean_all()?;
    let d = (out.narrow(1, 1, 3)? - targets)?.broadcast_mul(&labels)?;
    let balls = f64::from(labels.sum_all()?.to_scalar::<f32>()?.max(1.0));
    bce + (d.sqr()?.sum_all()? / balls)?
}

/// Trains the checker on patch samples, keeping the epoch with the lowest held-out loss;
/// `start` fine-tunes a trained stage.
pub fn train_checker(
    train: &[Sample],
    val: &[Sample],
    cfg: &StageTrainConfig,
    start: Option<&TrainedStage>,
    progress: &mut dyn FnMut(Progress),
) -> Result<TrainedStage, DetectorTrainError> {
    cfg.check()?;
    let balls = train.iter().filter(|s| s.ball).count();
    if balls == 0 || balls == train.len() {
        return Err(DetectorTrainError::NoData(format!(
            "the checker needs balls and other things ({balls} balls, {} others)",
            train.len() - balls
        )));
    }
    let device = Device::Cpu;
    let varmap = VarMap::new();
    let vb = VarBuilder::from_varmap(&varmap, DType::F32, &device);
    let layers = CheckLayers::new(&vb)?;
    initialise(&varmap, cfg.seed, start)?;
    let mut opt = optimiser(&varmap, cfg)?;
    let mut rng = Rng::stream(cfg.seed, "check-train", 0);
    let batches = train.len().div_ceil(cfg.batch);
    let total = batches * cfg.epochs;
    let mut order: Vec<usize> = (0..train.len()).collect();
    let mut epochs = Epochs::new();
    for epoch in 0..cfg.epochs {
        rng.shuffle(&mut order);
        let mut sum = 0.0;
        for (b, chunk) in order.chunks(cfg.batch).enumerate() {
            let step = epoch * batches + b;
            opt.set_learning_rate(cosine(cfg, step, total));
            let augmented: Vec<Sample> = chunk
                .iter()
                .map(|&i| augment(&train[i], &mut rng, std::f64::consts::PI))
                .collect();
            let refs: Vec<&Sample> = augmented.iter().collect();
            let l = check_loss(&layers, &refs, &device)?;
            opt.backward_step(&l)?;
            sum += f64::from(l.to_scalar::<f32>()?) * chunk.len() as f64;
            progress(Progress::Batch {
                done: step + 1,
                total,
            });
        }
        let mut val_loss = f64::NAN;
        if !val.is_empty() {
            let mut s = 0.0;
            for chunk in val.chunks(512) {
                let refs: Vec<&Sample> = chunk.iter().collect();
                s += f64::from(check_loss(&layers, &refs, &device)?.to_scalar::<f32>()?)
                    * chunk.len() as f64;
            }
            val_loss = s / val.len() as f64;
        }
        let report = EpochReport {
            epoch: epoch + 1,
            train_loss: sum / train.len() as f64,
            val_loss,
        };
        epochs.record(report, !val.is_empty(), &varmap, progress)?;
    }
    epochs.finish()
}

/// Both stages of a detector's weights file, to fine-tune from.
pub fn stages_of(bytes: &[u8]) -> Result<(TrainedStage, TrainedStage), DetectorTrainError> {
    // Checks the file as the agent reads it.
    HeatNet::from_safetensors(bytes)?;
    Checker::from_safetensors(bytes)?;
    let st = safetensors::SafeTensors::deserialize(bytes)
        .map_err(|e| DetectorTrainError::Serialise(e.to_string()))?;
    let mut heat = Vec::new();
    let mut check = Vec::new();
    let mut names: Vec<String> = st.names().into_iter().map(str::to_string).collect();
    names.sort();
    for name in names {
        let t = st
            .tensor(&name)
            .map_err(|e| DetectorTrainError::Serialise(e.to_string()))?;
        let values: Vec<f32> = t
            .data()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let entry = |n: &str| (n.to_string(), t.shape().to_vec(), values.clone());
        if let Some(n) = name.strip_prefix("heat.") {
            heat.push(entry(n));
        } else if let Some(n) = name.strip_prefix("check.") {
            check.push(entry(n));
        }
    }
    let stage = |tensors| TrainedStage {
        tensors,
        epochs: Vec::new(),
        best_epoch: 0,
    };
    Ok((stage(heat), stage(check)))
}

/// The safetensors bytes of some stages, each under its prefix, with `metadata` and the
/// format.
fn serialise(
    stages: &[(&str, &TrainedStage)],
    metadata: &BTreeMap<String, String>,
) -> Result<Vec<u8>, DetectorTrainError> {
    let tensors: Tensors = stages
        .iter()
        .flat_map(|(prefix, stage)| {
            stage
                .tensors
                .iter()
                .map(move |(n, d, v)| (format!("{prefix}.{n}"), d.clone(), v.clone()))
        })
        .collect();
    encode(&tensors, metadata, FORMAT).map_err(DetectorTrainError::Serialise)
}

/// The agent's candidate network of a trained stage.
pub fn candidate_net_of(stage: &TrainedStage) -> Result<HeatNet, DetectorTrainError> {
    Ok(HeatNet::from_safetensors(&serialise(
        &[("heat", stage)],
        &BTreeMap::new(),
    )?)?)
}

/// The detector's weights file of both stages, with `metadata` (the format is added); read
/// back by the agent's forward passes before it is returned.
pub fn weights_file(
    candidates: &TrainedStage,
    checker: &TrainedStage,
    metadata: &BTreeMap<String, String>,
) -> Result<(Vec<u8>, HeatNet, Checker), DetectorTrainError> {
    let file = serialise(&[("heat", candidates), ("check", checker)], metadata)?;
    let heat = HeatNet::from_safetensors(&file)?;
    let check = Checker::from_safetensors(&file)?;
    Ok((file, heat, check))
}

/// The same weights file with other metadata (the format is kept).
pub fn with_metadata(
    file: &[u8],
    metadata: &BTreeMap<String, String>,
) -> Result<Vec<u8>, DetectorTrainError> {
    restamp(file, metadata, FORMAT).map_err(DetectorTrainError::Serialise)
}

/// The candle forward passes of a trained pair on given inputs, for the tests that hold
/// the agent's own forward passes to the training crate's.
#[cfg(test)]
pub(crate) fn candle_outputs(
    candidates: &TrainedStage,
    checker: &TrainedStage,
    heat_input_chw: (&[f32], usize, usize),
    patches: &[f32],
) -> Result<(Vec<f32>, Vec<f32>), DetectorTrainError> {
    let device = Device::Cpu;
    let load = |stage: &TrainedStage| -> Result<VarMap, DetectorTrainError> {
        let varmap = VarMap::new();
        {
            let mut data = varmap
                .data()
                .lock()
                .map_err(|_| DetectorTrainError::Serialise("poisoned".into()))?;
            for (name, dims, values) in &stage.tensors {
                let t = Tensor::from_vec(values.clone(), dims.clone(), &device)?;
                data.insert(name.clone(), candle_core::Var::from_tensor(&t)?);
            }
        }
        Ok(varmap)
    };
    let hv = load(candidates)?;
    let heat = HeatLayers::new(&VarBuilder::from_varmap(&hv, DType::F32, &device))?;
    let (x, h, w) = heat_input_chw;
    let x = Tensor::from_vec(x.to_vec(), (1, 3, h, w), &device)?;
    // [1, 4, rows, cols] to rows of cells with the outputs innermost.
    let heat_out = heat
        .forward(&x)?
        .squeeze(0)?
        .permute((1, 2, 0))?
        .flatten_all()?
        .to_vec1::<f32>()?;
    let cv = load(checker)?;
    let check = CheckLayers::new(&VarBuilder::from_varmap(&cv, DType::F32, &device))?;
    let side = PATCH_SIDE_PX;
    let n = patches.len() / (side * side);
    let p = Tensor::from_vec(patches.to_vec(), (n, 1, side, side), &device)?;
    let check_out = check.forward(&p)?.flatten_all()?.to_vec1::<f32>()?;
    Ok((heat_out, check_out))
}

#[cfg(test)]
#[path = "detector_train_tests.rs"]
mod tests;
