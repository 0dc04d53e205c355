//! `robot-agent train`: the HOG + SVM ball classifier from folders of ball and non-ball
//! patches, or from photos with labelled ball boxes.

use anyhow::Result;
use robot_agent::cli::labelled::LabelledArgs;
use robot_agent::cli::train::{fit_and_write, folder_patches, labelled_folder_patches};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// Folder of ball patches (PNG or JPEG, any size; each image is one candidate window).
    #[arg(
        long,
        requires = "negatives",
        required_unless_present = "images",
        conflicts_with = "images"
    )]
    pub positives: Option<PathBuf>,
    /// Folder of non-ball patches.
    #[arg(long, requires = "positives")]
    pub negatives: Option<PathBuf>,
    /// Labelled photos instead (`--images DIR --labels DIR`, as `evaluate` takes them):
    /// each ball box is a positive, candidates and random windows away from the balls are
    /// negatives.
    #[command(flatten)]
    pub labelled: LabelledArgs,
    /// Random negative windows per labelled photo.
    #[arg(long, default_value_t = 8)]
    pub random_negatives: usize,
    /// Seed of the random negative windows, the split and the folds.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where to write the model (JSON).
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: TrainArgs) -> Result<()> {
    let started = Instant::now();
    let mut progress = |line: &str| eprintln!("[{:6.1} s] {line}", started.elapsed().as_secs_f64());
    let (mut positives, mut negatives) = (Vec::new(), Vec::new());
    if let (Some(p), Some(n)) = (&args.positives, &args.negatives) {
        positives.extend(folder_patches(p)?);
        negatives.extend(folder_patches(n)?);
    }
    if args.labelled.given() {
        let (p, n) = labelled_folder_patches(
            &args.labelled,
            args.random_negatives,
            args.seed,
            &mut progress,
        )?;
        positives.extend(p);
        negatives.extend(n);
    }
    if !(args.positives.is_some() || args.labelled.given()) {
        anyhow::bail!("give --positives and --negatives, or --images and --labels");
    }
    fit_and_write(&positives, &negatives, args.seed, &args.out, &mut progress)
}
