//! `train_sim`: the ball classifier trained on candidates mined from simulated matches
//! (each labelled by the renderer's truth), alone or beside labelled photos, written as
//! `ball-lab train` writes one. The shipped classifier is
//! `train_sim --matches 6 --images out/photos/train/images --labels out/photos/train/labels
//! --random-negatives 2 --out robot-agent/data/ball-classifier.json`.
//!
//! Flags: `--matches N` (default 6), `--seconds S` (default 30), `--seed N` (default 1: the
//! mined matches, the split and the folds), `--out FILE`, and the labelled photos'
//! flags of `ball-lab train`: `--images DIR --labels DIR` (with `--ball-class`,
//! `--ball-name`, `--camera` or `--calibration` as `ball-lab evaluate` takes them) and
//! `--random-negatives N` (default 8).

use anyhow::Result;
use clap::Parser;
use lab::cli::labelled::LabelledArgs;
use lab::cli::train::{fit_and_write, labelled_folder_patches};
use robot_agent::load_models;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Debug, Parser)]
#[command(
    name = "train_sim",
    about = "Trains the ball classifier on candidates mined from simulated matches"
)]
struct Args {
    /// Labelled photos beside the mined candidates (`--images DIR --labels DIR`, as
    /// `ball-lab evaluate` takes them): each ball box is a positive, candidates and
    /// random windows away from the balls are negatives.
    #[command(flatten)]
    labelled: LabelledArgs,
    /// Random negative windows per labelled photo.
    #[arg(long, default_value_t = 8)]
    random_negatives: usize,
    /// Simulated matches mined.
    #[arg(long, default_value_t = 6)]
    matches: u64,
    /// Seconds of each mined match.
    #[arg(long, default_value_t = 30.0)]
    seconds: f64,
    /// Seed of the mined matches, the split and the folds.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where to write the model (JSON).
    #[arg(long)]
    out: PathBuf,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let started = Instant::now();
    let mut progress = |line: &str| eprintln!("[{:6.1} s] {line}", started.elapsed().as_secs_f64());
    let (mut positives, mut negatives) = (Vec::new(), Vec::new());
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
    let [model, _] = load_models(None, None)?;
    let (p, n) =
        tools::sim_patches::mine(&model, args.matches, args.seconds, args.seed, &mut progress)?;
    positives.extend(p);
    negatives.extend(n);
    fit_and_write(&positives, &negatives, args.seed, &args.out, &mut progress)
}
