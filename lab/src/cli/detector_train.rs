//! Training the two-stage detector from labelled photos: the candidate network on whole
//! photos, then the grey checker on patches cut around the labelled balls, around the new
//! candidate network's peaks and the appearance proposals (its hard negatives), and at
//! random; both with progress bars; then the whole detector scored on the held-out photos.

use crate::cli::evaluate::held_out_score;
use crate::cli::labelled::{Item, LabelledFolder};
use crate::cli::progress::bar;
use crate::labels::BallBox;
use crate::labels::eval::LabelReport;
use crate::training::ballnet_data::{Sample, SampleConfig, SampleCounts, photo_samples};
use crate::training::detector_train::{
    FramePhoto, Progress, StageTrainConfig, TrainedStage, candidate_net_of, train_candidates,
    train_checker, weights_file,
};
use anyhow::{Context, Result};
use indicatif::ProgressBar;
use proto::rng::Rng;
use std::collections::BTreeMap;
use vision::image::RgbImage;
use vision::stages::candidates::{HeatNet, PeakConfig};
use vision::stages::checker::{self, Checker};
use vision::{Detector, DetectorConfig, Proposer};

/// The labelled photos of `items`, decoded, with their ball boxes, and how many boxes of
/// other classes their labels held; a photo that cannot be read is reported and left out.
pub fn load_photos(
    folder: &LabelledFolder,
    items: &[&Item],
    what: &str,
) -> (Vec<(RgbImage, Vec<BallBox>)>, usize) {
    let bar = bar(items.len(), what);
    let (mut out, mut others) = (Vec::new(), 0);
    for item in items {
        let loaded = robot_agent::load_rgb(&item.image)
            .map_err(anyhow::Error::from)
            .and_then(|image| Ok((folder.labels(item, &image)?, image)));
        match loaded {
            Ok((labels, image)) => {
                others += labels.others;
                out.push((image, labels.balls));
            }
            Err(e) => bar.suspend(|| eprintln!("{}: left out: {e:#}", item.image.display())),
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    (out, others)
}

/// Draws the stage's batches on the bar and prints a line per epoch with the time spent
/// and, from the pace so far, the time left in the stage (for logs, where no bar is drawn).
fn report_progress<'a>(bar: &'a ProgressBar, what: &str) -> impl FnMut(Progress) + 'a {
    let what = what.to_string();
    let started = std::time::Instant::now();
    let (mut done, mut total) = (0usize, 0usize);
    move |p| match p {
        Progress::Batch { done: d, total: t } => {
            (done, total) = (d, t);
            bar.set_length(t as u64);
            bar.set_position(d as u64);
        }
        Progress::Epoch(r) => bar.suspend(|| {
            let spent_s = started.elapsed().as_secs_f64();
            let left_s = if done > 0 {
                spent_s * total.saturating_sub(done) as f64 / done as f64
            } else {
                0.0
            };
            let held_out = if r.val_loss.is_nan() {
                "– (nothing held out)".to_string()
            } else {
                format!("{:.4}", r.val_loss)
            };
            eprintln!(
                "{what} epoch {:>3}: training loss {:.4}, held-out loss {held_out} \
                 [{} spent, about {} left]",
                r.epoch,
                r.train_loss,
                minutes(spent_s),
                minutes(left_s)
            )
        }),
    }
}

/// A duration as `3m05s`.
fn minutes(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    format!("{}m{:02}s", s / 60, s % 60)
}

/// The checker's samples of some photos: every ball (and moved copies), the candidate
/// network's peaks and the appearance proposals, random windows.
fn checker_samples(
    photos: &[(RgbImage, Vec<BallBox>)],
    net: &HeatNet,
    cfg: &SampleConfig,
    seed: u64,
    what: &str,
) -> (Vec<Sample>, SampleCounts) {
    let bar = bar(photos.len(), what);
    let peaks = PeakConfig {
        max_candidates: 24,
        min_probability: 0.001,
        ..PeakConfig::default()
    };
    let mut samples = Vec::new();
    let mut counts = SampleCounts::default();
    for (k, (image, balls)) in photos.iter().enumerate() {
        let mut rng = Rng::stream(seed, "checker-samples", k as u64);
        let extra = net.candidates(image, &peaks);
        let (s, c) = photo_samples(image, balls, &extra, cfg, &mut rng);
        samples.extend(s);
        counts += c;
        bar.inc(1);
    }
    bar.finish_and_clear();
    eprintln!(
        "{what}: {} photos, {} balls of which {} had a candidate, {} ball and {} other samples",
        photos.len(),
        counts.balls,
        counts.proposed,
        counts.positives,
        counts.negatives
    );
    (samples, counts)
}

/// Which stages to train, and from what.
#[derive(Debug)]
pub struct DetectorTraining<'a> {
    pub candidates: StageTrainConfig,
    pub checker: StageTrainConfig,
    /// Fine-tune from these stages (a detector file's) instead of starting afresh.
    pub start: Option<&'a (TrainedStage, TrainedStage)>,
    /// Random windows per photo for the checker.
    pub random_negatives: usize,
    /// Moved and scaled copies of each ball for the checker.
    pub copies: usize,
    /// Rounds of hard-negative mining after the checker's training: the whole detector
    /// runs over the training photos, what the checker accepts away from every ball joins
    /// its samples ([`HARD_NEGATIVE_COPIES`] times), and the checker trains on for
    /// [`HARD_NEGATIVE_EPOCHS`] epochs.
    pub hard_negative_rounds: usize,
    pub metadata: BTreeMap<String, String>,
}

/// Copies of each mined false positive among the checker's samples.
pub const HARD_NEGATIVE_COPIES: usize = 4;

/// Epochs of the checker per hard-negative round.
pub const HARD_NEGATIVE_EPOCHS: usize = 3;

/// The checker's false positives on some photos: every candidate of the whole detector that
/// it accepts and that keeps clear of every labelled ball, as samples that are not a ball.
fn mined_negatives(
    photos: &[(RgbImage, Vec<BallBox>)],
    detector: &Detector,
    checker: &Checker,
) -> Result<Vec<Sample>> {
    let bar = bar(photos.len(), "mining false positives");
    let mut out = Vec::new();
    for (image, balls) in photos {
        let candidates =
            vision::photo::detect_photo(detector, checker, 0.5, image, None, &mut vision::NoClock)?;
        for c in candidates {
            let accepted = c.probability.is_some_and(|p| p >= 0.5);
            if accepted
                && balls
                    .iter()
                    .all(|b| crate::training::ballnet_data::clear_of(&c.circle, b))
                && let Some(patch) = checker::patch_for(image, &c.circle)
            {
                out.push(Sample {
                    patch,
                    ball: false,
                    target: [0.0; 3],
                });
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(out)
}

/// What a training run made.
#[derive(Debug)]
pub struct TrainedDetector {
    pub file: Vec<u8>,
    pub net: HeatNet,
    pub checker: Checker,
    pub candidate_epochs: (usize, usize),
    pub checker_epochs: (usize, usize),
    /// Training balls the candidate stage reached, of all training balls.
    pub training_balls_reached: (usize, usize),
    pub held_out: Option<LabelReport>,
}

/// Trains both stages on the photos of `train`, scoring the detector on `val`.
pub fn train_detector(
    folder: &LabelledFolder,
    train: &[&Item],
    val: (&LabelledFolder, &[&Item]),
    how: DetectorTraining<'_>,
) -> Result<TrainedDetector> {
    let (train_photos, others) = load_photos(folder, train, "loading training photos");
    anyhow::ensure!(!train_photos.is_empty(), "no training photo could be read");
    let balls: usize = train_photos.iter().map(|(_, b)| b.len()).sum();
    anyhow::ensure!(
        balls > 0,
        "the {} training photos' labels hold no ball, and {others} boxes of other classes: \
         name the ball's class with --ball-class (a class id) or --ball-name",
        train_photos.len()
    );
    let (val_photos, _) = load_photos(val.0, val.1, "loading held-out photos");
    let frames = |p: &[(RgbImage, Vec<BallBox>)]| -> Vec<FramePhoto> {
        p.iter().map(|(i, b)| FramePhoto::new(i, b)).collect()
    };
    let (train_frames, val_frames) = (frames(&train_photos), frames(&val_photos));
    let heat_bar = bar(0, "candidate network");
    let heat = train_candidates(
        &train_frames,
        &val_frames,
        &how.candidates,
        how.start.map(|s| &s.0),
        &mut report_progress(&heat_bar, "candidates"),
    )?;
    heat_bar.finish_and_clear();
    drop((train_frames, val_frames));
    let net = candidate_net_of(&heat)?;
    let cfg = SampleConfig {
        window_over_radius: checker::WINDOW_OVER_RADIUS,
        // The candidate network's circles are a few pixels off a small ball: the checker
        // learns balls that far off centre, and to correct them.
        on_ball_offset: 0.8,
        on_ball_ratio: 2.5,
        copy_offset: 0.6,
        copy_log_scale: 0.6,
        copies_per_ball: how.copies,
        random_per_photo: how.random_negatives,
        appearance: vision::settings::AppearanceConfig {
            max_candidates: 8,
            ..Default::default()
        },
    };
    let seed = how.checker.seed;
    let (train_samples, counts) = checker_samples(
        &train_photos,
        &net,
        &cfg,
        seed,
        "checker samples (training)",
    );
    let (val_samples, _) = checker_samples(
        &val_photos,
        &net,
        &cfg,
        seed + 1,
        "checker samples (held out)",
    );
    let check_bar = bar(0, "grey checker");
    let check = train_checker(
        &train_samples,
        &val_samples,
        &how.checker,
        how.start.map(|s| &s.1),
        &mut report_progress(&check_bar, "checker"),
    )?;
    check_bar.finish_and_clear();
    let mut check = check;
    let mut train_samples = train_samples;
    for round in 1..=how.hard_negative_rounds {
        let (_, _, current) = weights_file(&heat, &check, &how.metadata)?;
        let detector = net_detector(&DetectorConfig::default(), Some(net.clone()))?;
        let mined = mined_negatives(&train_photos, &detector, &current)?;
        eprintln!(
            "hard-negative round {round}: the checker accepted {} candidates away from every \
             ball in the training photos",
            mined.len()
        );
        for _ in 0..HARD_NEGATIVE_COPIES {
            train_samples.extend(mined.iter().cloned());
        }
        let cfg = StageTrainConfig {
            epochs: HARD_NEGATIVE_EPOCHS,
            ..how.checker
        };
        let round_bar = bar(0, "grey checker");
        check = train_checker(
            &train_samples,
            &val_samples,
            &cfg,
            Some(&check),
            &mut report_progress(&round_bar, &format!("checker round {round}")),
        )?;
        round_bar.finish_and_clear();
    }
    let (file, net, checker) = weights_file(&heat, &check, &how.metadata)?;
    let held_out = held_out_score(
        val,
        &net_detector(&DetectorConfig::default(), Some(net.clone()))?,
        &checker,
    )?;
    Ok(TrainedDetector {
        file,
        net,
        checker,
        candidate_epochs: (heat.best_epoch, heat.epochs.len()),
        checker_epochs: (check.best_epoch, check.epochs.len()),
        training_balls_reached: (counts.proposed, counts.balls),
        held_out,
    })
}

/// The two-stage detector's settings over `base`: the candidate network's peaks and the
/// strongest appearance proposals, judged by the grey checker.
/// The shipped candidate network unless `net` is given.
pub fn net_detector(base: &DetectorConfig, net: Option<HeatNet>) -> Result<Detector> {
    let config = DetectorConfig {
        proposer: Proposer::Net,
        classifier: vision::ClassifierKind::Checker,
        ..*base
    };
    match net {
        Some(n) => Detector::with_net(config, n),
        None => Detector::new(config),
    }
    .context("the detector's settings")
}
