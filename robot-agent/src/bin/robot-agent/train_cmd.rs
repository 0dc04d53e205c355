//! `robot-agent train`: the HOG + SVM ball classifier from labelled patches.

use anyhow::{Context, Result, bail};
use robot_agent::patch::{Patch, PatchConfig, extract};
use robot_agent::train::{TrainConfig, train};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// Folder of ball patches (PNG or JPEG, any size; each image is one candidate window).
    #[arg(
        long,
        requires = "negatives",
        required_unless_present_any = ["from_sim", "images"],
        conflicts_with = "images"
    )]
    pub positives: Option<PathBuf>,
    /// Folder of non-ball patches.
    #[arg(long, requires = "positives")]
    pub negatives: Option<PathBuf>,
    /// Mine labelled candidates from simulated matches (alone, or beside labelled photos).
    #[arg(long, conflicts_with_all = ["positives", "negatives"])]
    pub from_sim: bool,
    /// Labelled photos instead (`--images DIR --labels DIR`, as `evaluate` takes them):
    /// each ball box is a positive, candidates and random windows away from the balls are
    /// negatives.
    #[command(flatten)]
    pub labelled: crate::labelled::LabelledArgs,
    /// Random negative windows per labelled photo.
    #[arg(long, default_value_t = 8)]
    pub random_negatives: usize,
    /// Simulated matches mined with `--from-sim`.
    #[arg(long, default_value_t = 6)]
    pub matches: u64,
    /// Seconds of each mined match.
    #[arg(long, default_value_t = 30.0)]
    pub seconds: f64,
    /// Seed of the mined matches, the split and the folds.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where to write the model (JSON).
    #[arg(long)]
    pub out: PathBuf,
}

/// Every image of a folder as a patch: the whole image is the candidate window.
fn folder_patches(dir: &Path) -> Result<Vec<Patch>> {
    let paths = crate::frames_io::image_files(dir)?;
    let cfg = PatchConfig::default();
    let mut out = Vec::new();
    for p in &paths {
        let image = match robot_agent::image_io::load_rgb(p) {
            Ok(i) => i,
            Err(e) => {
                eprintln!("skipping {}: {e}", p.display());
                continue;
            }
        };
        let (w, h) = (f64::from(image.width()), f64::from(image.height()));
        let centre = [(w - 1.0) / 2.0, (h - 1.0) / 2.0];
        let radius = w.min(h) / cfg.window_over_radius;
        match extract(&image, centre, radius, &cfg) {
            Ok(patch) => out.push(patch),
            Err(e) => eprintln!("skipping {}: {e}", p.display()),
        }
    }
    Ok(out)
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
        let folder = crate::labelled::LabelledFolder::open(&args.labelled)?;
        let (p, n) = crate::labelled_patches::labelled_patches(
            &folder,
            args.random_negatives,
            args.seed,
            &mut progress,
        )?;
        positives.extend(p);
        negatives.extend(n);
    }
    if args.from_sim {
        let [model, _] = crate::run::load_models(None, None)?;
        let (p, n) =
            crate::sim_patches::mine(&model, args.matches, args.seconds, args.seed, &mut progress)?;
        positives.extend(p);
        negatives.extend(n);
    }
    if !(args.positives.is_some() || args.labelled.given() || args.from_sim) {
        bail!("give --positives and --negatives, --images and --labels, or --from-sim");
    }
    progress(&format!(
        "{} ball patches, {} others",
        positives.len(),
        negatives.len()
    ));
    let cfg = TrainConfig {
        seed: args.seed,
        ..TrainConfig::default()
    };
    let (model, report) = train(&positives, &negatives, &cfg, &mut progress)?;
    println!("{report}");
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(&args.out, model.to_json()?)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "wrote {} ({} support vectors)",
        args.out.display(),
        model.support_vector_count()
    );
    Ok(())
}
