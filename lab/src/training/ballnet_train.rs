//! Training the ball network on a CPU with candle, and writing its weights file.
//!
//! The network is [`vision::stages::ballnet`]'s: three 3×3 stride-2 convolutions with
//! ReLU, a hidden layer of [`HIDDEN`] and four outputs (the ball's logit, its centre offset
//! over the radius, the log of its radius ratio). The loss is the logistic loss of the
//! logit plus the squared error of the correction on balls only. AdamW with a cosine
//! learning-rate schedule; every epoch sees every training sample once, augmented anew
//! ([`crate::training::ballnet_data::augment`]); the epoch with the lowest held-out loss
//! is the one written. The file is safetensors with the format and the caller's metadata
//! (data, command, held-out score) beside the weights, read back by
//! [`BallNet::from_safetensors`] before it is returned, so a file that comes out of here
//! always loads.

use crate::training::ballnet_data::{Sample, augment};
use candle_core::{DType, Device, Tensor};
use candle_nn::{Conv2d, Conv2dConfig, Linear, Module, Optimizer, VarBuilder, VarMap};
use proto::rng::Rng;
use std::collections::BTreeMap;
use thiserror::Error;
use vision::stages::ballnet::FLAT;
use vision::stages::ballnet::{
    BallNet, BallNetError, CONVOLUTIONS, FORMAT, HIDDEN, OUTPUTS, input,
};
use vision::stages::patch::PATCH_SIDE_PX;

/// The training's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NetTrainConfig {
    pub epochs: usize,
    pub batch: usize,
    pub learning_rate: f64,
    pub weight_decay: f64,
    /// The weight of the correction's loss beside the logistic loss.
    pub correction_weight: f64,
    /// Augment the training samples (every epoch anew).
    pub augment: bool,
    /// The largest turn of a sample's hue in augmentation, radians (π or more: any
    /// colour, channels swapped too).
    pub max_hue_turn_rad: f64,
    pub seed: u64,
}

impl Default for NetTrainConfig {
    fn default() -> Self {
        NetTrainConfig {
            epochs: 30,
            batch: 128,
            learning_rate: 3e-3,
            weight_decay: 1e-4,
            correction_weight: 1.0,
            augment: true,
            max_hue_turn_rad: 0.7,
            seed: 1,
        }
    }
}

/// Why training failed.
#[derive(Debug, Error)]
pub enum NetTrainError {
    #[error(
        "no training samples with both balls and other things ({balls} balls, {others} others)"
    )]
    OneClass { balls: usize, others: usize },
    #[error("training settings: {0}")]
    Settings(String),
    #[error("tensor computation: {0}")]
    Candle(#[from] candle_core::Error),
    #[error("the trained weights do not load: {0}")]
    Weights(#[from] BallNetError),
    #[error("writing the weights file: {0}")]
    Serialise(String),
}

/// One epoch's losses and the held-out accuracy at probability 0.5.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpochReport {
    pub epoch: usize,
    pub train_loss: f64,
    pub val_loss: f64,
    pub val_accuracy: f64,
}

/// The trained network, its weights file and the epochs' reports.
#[derive(Debug)]
pub struct TrainedNet {
    pub net: BallNet,
    pub file: Vec<u8>,
    pub epochs: Vec<EpochReport>,
    /// The epoch whose weights were kept (lowest held-out loss).
    pub best_epoch: usize,
}

/// The network as candle layers, named as the weights file names them.
struct Layers {
    convs: Vec<Conv2d>,
    fc1: Linear,
    fc2: Linear,
}

impl Layers {
    fn new(vb: &VarBuilder<'_>) -> candle_core::Result<Self> {
        let cfg = Conv2dConfig {
            padding: 1,
            stride: 2,
            ..Conv2dConfig::default()
        };
        let mut convs = Vec::new();
        for (k, &(cin, cout)) in CONVOLUTIONS.iter().enumerate() {
            convs.push(candle_nn::conv2d(
                cin,
                cout,
                3,
                cfg,
                vb.pp(format!("conv{}", k + 1)),
            )?);
        }
        Ok(Layers {
            convs,
            fc1: candle_nn::linear(FLAT, HIDDEN, vb.pp("fc1"))?,
            fc2: candle_nn::linear(HIDDEN, OUTPUTS, vb.pp("fc2"))?,
        })
    }

    /// Outputs `[batch, 4]` for inputs `[batch, 3, side, side]`.
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let mut x = x.clone();
        for c in &self.convs {
            x = c.forward(&x)?.relu()?;
        }
        let x = x.flatten_from(1)?;
        self.fc2.forward(&self.fc1.forward(&x)?.relu()?)
    }
}

/// A batch's inputs `[n, 3, side, side]`, labels `[n]`, targets `[n, 3]` and ball mask
/// `[n, 1]`.
fn batch(samples: &[&Sample], device: &Device) -> candle_core::Result<[Tensor; 4]> {
    let n = samples.len();
    let side = PATCH_SIDE_PX;
    let mut xs = Vec::with_capacity(n * side * side * 3);
    let (mut labels, mut targets, mut mask) = (Vec::new(), Vec::new(), Vec::new());
    for s in samples {
        xs.extend(input(&s.patch));
        let b = if s.ball { 1.0f32 } else { 0.0 };
        labels.push(b);
        mask.push(b);
        targets.extend(s.target.iter().map(|t| t.clamp(-1.0, 1.0)));
    }
    let x = Tensor::from_vec(xs, (n, side, side, 3), device)?
        .permute((0, 3, 1, 2))?
        .contiguous()?;
    Ok([
        x,
        Tensor::from_vec(labels, n, device)?,
        Tensor::from_vec(targets, (n, 3), device)?,
        Tensor::from_vec(mask, (n, 1), device)?,
    ])
}

/// The mean loss of a batch, and how many of its samples the logit classes right.
fn loss(
    layers: &Layers,
    [x, labels, targets, mask]: &[Tensor; 4],
    correction_weight: f64,
) -> candle_core::Result<(Tensor, usize)> {
    let out = layers.forward(x)?;
    let logit = out.narrow(1, 0, 1)?.squeeze(1)?;
    // Logistic loss, stable for any logit: max(x, 0) - x t + ln(1 + e^-|x|).
    let bce = ((logit.relu()? - (&logit * labels)?)?
        + (logit.abs()?.neg()?.exp()? + 1.0)?.log()?)?
    .mean_all()?;
    let d = ((out.narrow(1, 1, 3)? - targets)?.broadcast_mul(mask))?;
    let balls = mask.sum_all()?.to_scalar::<f32>()?.max(1.0);
    let correction = (d.sqr()?.sum_all()? / f64::from(balls))?;
    let total = (bce + (correction * correction_weight)?)?;
    let predicted = logit.ge(0.0)?.to_dtype(DType::F32)?;
    let right = predicted
        .eq(labels)?
        .to_dtype(DType::F32)?
        .sum_all()?
        .to_scalar::<f32>()? as usize;
    Ok((total, right))
}

/// The variables by name, in name order.
fn sorted_vars(varmap: &VarMap) -> Result<Vec<(String, candle_core::Var)>, NetTrainError> {
    crate::training::detector_train::sorted_vars(varmap).map_err(NetTrainError::Serialise)
}

/// The weights file of the current variables.
fn weights_file(
    varmap: &VarMap,
    metadata: &BTreeMap<String, String>,
) -> Result<Vec<u8>, NetTrainError> {
    let mut tensors = Vec::new();
    for (name, var) in sorted_vars(varmap)? {
        let t = var.as_tensor();
        tensors.push((name, t.dims().to_vec(), t.flatten_all()?.to_vec1::<f32>()?));
    }
    crate::training::detector_train::encode(&tensors, metadata, FORMAT)
        .map_err(NetTrainError::Serialise)
}

/// The same weights file with other metadata (the format is kept).
pub fn with_metadata(
    file: &[u8],
    metadata: &BTreeMap<String, String>,
) -> Result<Vec<u8>, NetTrainError> {
    crate::training::detector_train::restamp(file, metadata, FORMAT)
        .map_err(NetTrainError::Serialise)
}

/// Trains the network on `train`, keeping the epoch that does best on `val` (which may be
/// empty: then the last epoch is kept). `metadata` goes into the file; `progress` hears of
/// every batch (done, total) and every epoch.
pub fn train_net(
    train: &[Sample],
    val: &[Sample],
    cfg: &NetTrainConfig,
    metadata: &BTreeMap<String, String>,
    progress: &mut dyn FnMut(Progress),
) -> Result<TrainedNet, NetTrainError> {
    let balls = train.iter().filter(|s| s.ball).count();
    if balls == 0 || balls == train.len() {
        return Err(NetTrainError::OneClass {
            balls,
            others: train.len() - balls,
        });
    }
    if cfg.epochs == 0 || cfg.batch == 0 || cfg.learning_rate.is_nan() || cfg.learning_rate <= 0.0 {
        return Err(NetTrainError::Settings(format!(
            "epochs {}, batch {} and learning rate {} must all be positive",
            cfg.epochs, cfg.batch, cfg.learning_rate
        )));
    }
    let device = Device::Cpu;
    let varmap = VarMap::new();
    let vb = VarBuilder::from_varmap(&varmap, DType::F32, &device);
    let layers = Layers::new(&vb)?;
    // candle's initialisation draws from an unseeded generator; ours is seeded.
    reinitialise(&varmap, cfg.seed)?;
    let mut opt = candle_nn::AdamW::new(
        varmap.all_vars(),
        candle_nn::ParamsAdamW {
            lr: cfg.learning_rate,
            weight_decay: cfg.weight_decay,
            ..candle_nn::ParamsAdamW::default()
        },
    )?;
    let mut rng = Rng::stream(cfg.seed, "ballnet-train", 0);
    let batches_per_epoch = train.len().div_ceil(cfg.batch);
    let total_batches = batches_per_epoch * cfg.epochs;
    let mut order: Vec<usize> = (0..train.len()).collect();
    let mut epochs = Vec::new();
    let mut best: Option<(f64, usize, Vec<u8>)> = None;
    for epoch in 0..cfg.epochs {
        rng.shuffle(&mut order);
        let mut sum = 0.0;
        for (b, chunk) in order.chunks(cfg.batch).enumerate() {
            let step = epoch * batches_per_epoch + b;
            let lr = cfg.learning_rate
                * 0.5
                * (1.0 + (std::f64::consts::PI * step as f64 / total_batches as f64).cos());
            opt.set_learning_rate(lr);
            let augmented: Vec<Sample> = chunk
                .iter()
                .map(|&i| {
                    if cfg.augment {
                        augment(&train[i], &mut rng, cfg.max_hue_turn_rad)
                    } else {
                        train[i].clone()
                    }
                })
                .collect();
            let refs: Vec<&Sample> = augmented.iter().collect();
            let (l, _) = loss(&layers, &batch(&refs, &device)?, cfg.correction_weight)?;
            opt.backward_step(&l)?;
            sum += f64::from(l.to_scalar::<f32>()?) * chunk.len() as f64;
            progress(Progress::Batch {
                done: step + 1,
                total: total_batches,
            });
        }
        let train_loss = sum / train.len() as f64;
        let (val_loss, val_accuracy) = evaluate(&layers, val, cfg, &device)?;
        let report = EpochReport {
            epoch: epoch + 1,
            train_loss,
            val_loss,
            val_accuracy,
        };
        progress(Progress::Epoch(report));
        epochs.push(report);
        let key = if val.is_empty() {
            -(epoch as f64)
        } else {
            val_loss
        };
        if best.as_ref().is_none_or(|(k, _, _)| key <= *k) {
            best = Some((key, epoch + 1, weights_file(&varmap, metadata)?));
        }
    }
    let (_, best_epoch, file) =
        best.ok_or_else(|| NetTrainError::Settings("no epoch ran".into()))?;
    let net = BallNet::from_safetensors(&file)?;
    Ok(TrainedNet {
        net,
        file,
        epochs,
        best_epoch,
    })
}

/// What the training reports as it goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress {
    Batch { done: usize, total: usize },
    Epoch(EpochReport),
}

/// Mean loss and accuracy over samples, unaugmented.
fn evaluate(
    layers: &Layers,
    samples: &[Sample],
    cfg: &NetTrainConfig,
    device: &Device,
) -> Result<(f64, f64), NetTrainError> {
    if samples.is_empty() {
        return Ok((f64::NAN, f64::NAN));
    }
    let (mut sum, mut right) = (0.0, 0usize);
    for chunk in samples.chunks(512) {
        let refs: Vec<&Sample> = chunk.iter().collect();
        let (l, r) = loss(layers, &batch(&refs, device)?, cfg.correction_weight)?;
        sum += f64::from(l.to_scalar::<f32>()?) * chunk.len() as f64;
        right += r;
    }
    let n = samples.len() as f64;
    Ok((sum / n, right as f64 / n))
}

/// Replaces candle's initial weights with ones drawn from our own seeded generator (He
/// normal for weights, zero biases), so the same seed gives the same network everywhere.
fn reinitialise(varmap: &VarMap, seed: u64) -> Result<(), NetTrainError> {
    for (k, (name, var)) in sorted_vars(varmap)?.into_iter().enumerate() {
        let dims = var.as_tensor().dims().to_vec();
        let n: usize = dims.iter().product();
        let values: Vec<f32> = if name.ends_with(".bias") {
            vec![0.0; n]
        } else {
            let fan_in: usize = dims[1..].iter().product();
            let sd = (2.0 / fan_in as f64).sqrt();
            let mut rng = Rng::stream(seed, "ballnet-init", k as u64);
            (0..n).map(|_| (rng.normal() * sd) as f32).collect()
        };
        var.set(&Tensor::from_vec(values, dims, &Device::Cpu)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use vision::stages::patch::RgbPatch;

    /// A disc of a colour on a floor of another, or stripes: a task a small net learns in
    /// a few epochs.
    fn toy(rng: &mut Rng, ball: bool) -> Sample {
        let c = 16.0 + rng.range(-3.0, 3.0);
        let floor = [30 + rng.index(40) as u8, 100 + rng.index(60) as u8, 40];
        let patch = RgbPatch::from_fn_rgb(|x, y| {
            let (fx, fy) = (x as f64 - c, y as f64 - 16.0);
            let on = if ball {
                fx.hypot(fy) < 6.0
            } else {
                (x / 4) % 2 == 0
            };
            if on { [230, 120, 30] } else { floor }
        });
        Sample {
            patch,
            ball,
            target: if ball {
                [((16.0 - c) / 5.0) as f32, 0.0, 0.0]
            } else {
                [0.0; 3]
            },
        }
    }

    #[test]
    fn the_trained_file_runs_the_same_in_both_forward_passes() {
        let mut rng = Rng::new(5);
        let samples: Vec<Sample> = (0..64).map(|k| toy(&mut rng, k % 2 == 0)).collect();
        let cfg = NetTrainConfig {
            epochs: 1,
            batch: 32,
            ..NetTrainConfig::default()
        };
        let meta: BTreeMap<String, String> = [("data".to_string(), "toy".to_string())].into();
        let trained = train_net(&samples, &[], &cfg, &meta, &mut |_| {}).unwrap();
        assert_eq!(trained.net.metadata()["data"], "toy");
        // candle's forward pass on the file's weights against the hand-written one.
        let device = Device::Cpu;
        let mut varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &device);
        let layers = Layers::new(&vb).unwrap();
        let dir = std::env::temp_dir().join(format!("ballnet-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("net.safetensors");
        std::fs::write(&path, &trained.file).unwrap();
        varmap.load(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        for s in samples.iter().take(4) {
            let ours = trained.net.forward(&input(&s.patch));
            let out = layers
                .forward(&batch(&[s], &device).unwrap()[0])
                .unwrap()
                .flatten_all()
                .unwrap()
                .to_vec1::<f32>()
                .unwrap();
            let mine = [ours.logit, ours.offset[0], ours.offset[1], ours.log_scale];
            for (a, b) in mine.iter().zip(&out) {
                assert!((a - b).abs() < 1e-4, "{mine:?} vs {out:?}");
            }
        }
    }

    #[test]
    fn a_toy_task_is_learned() {
        let mut rng = Rng::new(9);
        let train: Vec<Sample> = (0..512).map(|k| toy(&mut rng, k % 2 == 0)).collect();
        let val: Vec<Sample> = (0..128).map(|k| toy(&mut rng, k % 2 == 1)).collect();
        let cfg = NetTrainConfig {
            epochs: 4,
            batch: 64,
            ..NetTrainConfig::default()
        };
        let mut batches = 0;
        let trained = train_net(&train, &val, &cfg, &BTreeMap::new(), &mut |p| {
            if let Progress::Batch { .. } = p {
                batches += 1;
            }
        })
        .unwrap();
        assert_eq!(batches, 4 * 8);
        let best = trained.epochs[trained.best_epoch - 1];
        assert!(best.val_accuracy > 0.95, "{:?}", trained.epochs);
        let first = trained.epochs[0].train_loss;
        let last = trained.epochs[3].train_loss;
        assert!(last < first, "{:?}", trained.epochs);
    }

    #[test]
    fn one_class_is_refused() {
        let mut rng = Rng::new(1);
        let balls: Vec<Sample> = (0..8).map(|_| toy(&mut rng, true)).collect();
        let err = train_net(
            &balls,
            &[],
            &NetTrainConfig::default(),
            &BTreeMap::new(),
            &mut |_| {},
        );
        assert!(matches!(
            err,
            Err(NetTrainError::OneClass {
                balls: 8,
                others: 0
            })
        ));
    }
}
