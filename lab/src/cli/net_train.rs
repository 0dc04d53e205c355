//! Training the ball network from labelled photos: the photos split into training and
//! held-out sets by folder (whole events held out, never single photos), samples cut from
//! every photo with a progress bar, the fit, and the held-out score of the whole detector
//! (appearance proposals judged by the new network) on the held-out photos.

use crate::cli::evaluate::held_out_score;
use crate::cli::labelled::{Item, LabelledFolder};
use crate::cli::progress::bar;
use crate::labels::eval::LabelReport;
use crate::training::ballnet_data::{Sample, SampleConfig, SampleCounts, photo_samples};
use crate::training::ballnet_train::{NetTrainConfig, Progress, TrainedNet, train_net};
use anyhow::{Context, Result};
use proto::rng::Rng;
use std::collections::BTreeMap;
use vision::stages::classifier::NetClassifier;
use vision::{Detector, DetectorConfig};

/// Whether an item's folder is one of the held-out folders (a folder and everything
/// under it).
pub fn held_out(item: &Item, folders: &[String]) -> bool {
    folders.iter().any(|f| {
        let f = f.trim_end_matches('/');
        item.folder == f || item.folder.starts_with(&format!("{f}/"))
    })
}

/// The samples of the given photos, and how many balls the proposals covered; a photo
/// that cannot be read is reported and left out.
pub fn collect_samples(
    folder: &LabelledFolder,
    items: &[&Item],
    cfg: &SampleConfig,
    seed: u64,
    what: &str,
) -> Result<(Vec<Sample>, SampleCounts)> {
    let bar = bar(items.len(), what);
    // The candidate network's peaks, as the robot's detector proposes them and more (24,
    // three times the detector's 8): its hard negatives (ceiling lights, white robot
    // parts) are what the network must learn.
    let heat = robot_agent::builtin::candidate_net().context("the shipped candidate network")?;
    let peaks = vision::settings::PeakConfig {
        max_candidates: 24,
        ..DetectorConfig::default().candidates
    };
    let mut samples = Vec::new();
    let mut counts = SampleCounts::default();
    let mut left_out = 0;
    for (k, item) in items.iter().enumerate() {
        let loaded = robot_agent::load_rgb(&item.image)
            .map_err(anyhow::Error::from)
            .and_then(|image| Ok((folder.labels(item, &image)?, image)));
        match loaded {
            Ok((labels, image)) => {
                let mut rng = Rng::stream(seed, "ballnet-samples", k as u64);
                let mut extra = folder
                    .not_balls
                    .get(&item.image)
                    .map(|boxes| boxes.iter().map(box_circle).collect::<Vec<_>>())
                    .unwrap_or_default();
                extra.extend(heat.candidates(&image, &peaks));
                let (s, c) = photo_samples(&image, &labels.balls, &extra, cfg, &mut rng);
                samples.extend(s);
                counts += c;
            }
            Err(e) => {
                left_out += 1;
                bar.suspend(|| eprintln!("{}: left out: {e:#}", item.image.display()));
            }
        }
        bar.set_message(format!("{} samples", samples.len()));
        bar.inc(1);
    }
    bar.finish_and_clear();
    eprintln!(
        "{what}: {} photos ({left_out} left out), {} balls of which {} proposed, {} ball and \
         {} other samples",
        items.len() - left_out,
        counts.balls,
        counts.proposed,
        counts.positives,
        counts.negatives
    );
    Ok((samples, counts))
}

/// The circle inscribed in a box.
pub fn box_circle(b: &crate::labels::BallBox) -> vision::Circle {
    vision::Circle {
        center_px: b.centre_px(),
        radius_px: 0.25 * (b.width_px() + b.height_px()),
        score: 1.0,
    }
}

/// The detector the network is made for (`--detector net`: the candidate network's peaks
/// and the strongest appearance proposals), other settings as given.
pub fn net_detector(base: &DetectorConfig) -> Result<Detector> {
    Detector::new(robot_agent::DetectorKind::Net.apply(*base)).context("the detector's settings")
}

/// What a training run made: the network and, when photos were held out, the detector's
/// score on them.
#[derive(Debug)]
pub struct NetTraining {
    pub trained: TrainedNet,
    pub held_out: Option<LabelReport>,
}

/// Trains the network on the photos of `train` (each folder's items), scoring it on the
/// photos of `val`.
pub fn train_on_photos(
    train: &[(&LabelledFolder, Vec<&Item>)],
    val: (&LabelledFolder, &[&Item]),
    cfg: &NetTrainConfig,
    samples: &SampleConfig,
    metadata: BTreeMap<String, String>,
) -> Result<NetTraining> {
    let mut train_samples = Vec::new();
    for (k, (folder, items)) in train.iter().enumerate() {
        let what = if k == 0 {
            "training photos"
        } else {
            "more training photos"
        };
        let seed = cfg.seed + 1000 * k as u64;
        train_samples.extend(collect_samples(folder, items, samples, seed, what)?.0);
    }
    let (val_samples, _) = if val.1.is_empty() {
        (Vec::new(), SampleCounts::default())
    } else {
        collect_samples(val.0, val.1, samples, cfg.seed + 1, "held-out photos")?
    };
    let bar = bar(0, "training");
    let trained = train_net(
        &train_samples,
        &val_samples,
        cfg,
        &metadata,
        &mut |p| match p {
            Progress::Batch { done, total } => {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            }
            Progress::Epoch(r) => bar.suspend(|| {
                let held_out = if r.val_loss.is_finite() {
                    format!(
                        ", held-out loss {:.4}, held-out sample accuracy {:.2} %",
                        r.val_loss,
                        100.0 * r.val_accuracy
                    )
                } else {
                    String::new()
                };
                eprintln!(
                    "epoch {:>3}: training loss {:.4}{held_out}",
                    r.epoch, r.train_loss
                )
            }),
        },
    )?;
    bar.finish_and_clear();
    eprintln!(
        "kept epoch {} of {}",
        trained.best_epoch,
        trained.epochs.len()
    );
    let held_out = held_out_score(
        val,
        &net_detector(&DetectorConfig::default())?,
        &NetClassifier::new(trained.net.clone()),
    )?;
    Ok(NetTraining { trained, held_out })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_out_folder_holds_out_everything_under_it_and_nothing_else() {
        let item = |folder: &str| Item {
            image: format!("{folder}/a.jpg").into(),
            label: None,
            folder: folder.to_string(),
        };
        let out = ["2019".to_string(), "2024/r2/".to_string()];
        assert!(held_out(&item("2019"), &out));
        assert!(held_out(&item("2019/r4"), &out));
        assert!(held_out(&item("2024/r2"), &out));
        assert!(!held_out(&item("2024/r1"), &out));
        assert!(!held_out(&item("20190"), &out));
        assert!(!held_out(&item(""), &out));
    }
}
