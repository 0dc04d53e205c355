//! Training the ball classifier, shared by `ball-lab train` (patch folders, labelled
//! photos) and the tools' `train_sim` (candidates mined from simulated matches, beside
//! labelled photos): patches from folders and labelled photos, the fit, its report and the
//! model file.

use crate::cli::labelled::{LabelledArgs, LabelledFolder};
use crate::training::hog_svm::{TrainConfig, train};
use anyhow::{Context, Result};
use std::path::Path;
use vision::stages::patch::{Patch, PatchConfig, extract};

/// Every image of a folder as a patch: the whole image is the candidate window.
pub fn folder_patches(dir: &Path) -> Result<Vec<Patch>> {
    let paths = robot_agent::image_files(dir)?;
    let cfg = PatchConfig::default();
    let mut out = Vec::new();
    for p in &paths {
        let image = match robot_agent::load_rgb(p) {
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

/// Positive and negative patches of the labelled photos of `--images` and `--labels`,
/// `random_negatives` random windows per photo.
pub fn labelled_folder_patches(
    args: &LabelledArgs,
    random_negatives: usize,
    seed: u64,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<Patch>, Vec<Patch>)> {
    let folder = LabelledFolder::open(args)?;
    crate::cli::labelled_patches::labelled_patches(&folder, random_negatives, seed, progress)
}

/// Trains the classifier on the patches (split and folds from `seed`), prints its report
/// and writes the model to `out`.
pub fn fit_and_write(
    positives: &[Patch],
    negatives: &[Patch],
    seed: u64,
    out: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<()> {
    progress(&format!(
        "{} ball patches, {} others",
        positives.len(),
        negatives.len()
    ));
    let cfg = TrainConfig {
        seed,
        ..TrainConfig::default()
    };
    let (model, report) = train(positives, negatives, &cfg, progress)?;
    println!("{report}");
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(out, model.to_json()?).with_context(|| format!("writing {}", out.display()))?;
    println!(
        "wrote {} ({} support vectors)",
        out.display(),
        model.support_vector_count()
    );
    Ok(())
}
