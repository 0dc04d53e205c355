//! `ball-lab calibrate-colour`: the colour detector's window fitted to the balls of
//! labelled photos ([`crate::colour_fit`]), written as the settings
//! file's `[detector.thresholds]` and `[detector.limits]` tables.

use crate::cli::labelled::{LabelledArgs, LabelledFolder};
use crate::colour_fit::{ColourSamples, fit};
use anyhow::{Context, Result};
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct CalibrateColourArgs {
    /// Labelled photos of the ball (`--images DIR [--labels DIR]`).
    #[command(flatten)]
    pub labelled: LabelledArgs,
    /// Where to write the settings (TOML); printed when not given.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: CalibrateColourArgs) -> Result<()> {
    let folder = LabelledFolder::open(&args.labelled)?;
    let mut samples = ColourSamples::default();
    let (mut balls, mut left_out) = (0usize, 0usize);
    let bar = crate::cli::progress::bar(folder.items.len(), "reading photos");
    for item in &folder.items {
        bar.inc(1);
        let loaded = robot_agent::load_rgb(&item.image)
            .map_err(anyhow::Error::from)
            .and_then(|image| Ok((folder.labels(item, &image)?, image)));
        let (labels, image) = match loaded {
            Ok(l) => l,
            Err(e) => {
                bar.suspend(|| eprintln!("{}: left out: {e:#}", item.image.display()));
                left_out += 1;
                continue;
            }
        };
        for b in &labels.balls {
            let r = 0.5 * b.width_px().min(b.height_px());
            if r >= 2.0 {
                samples.add_ball(&image, b.centre_px(), r);
                balls += 1;
            }
        }
    }
    bar.finish_and_clear();
    let f = fit(&samples).context("fitting the colour window")?;
    eprintln!(
        "{balls} balls from {} photos ({left_out} left out): the window holds {:.1} % of \
         the ball pixels and {:.2} % of the pixels around the balls",
        folder.items.len() - left_out,
        100.0 * f.ball_inside,
        100.0 * f.background_inside
    );
    let text = f.to_toml();
    match &args.out {
        Some(path) => {
            if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
            println!(
                "wrote {} (use it with --config {} --detector dissertation)",
                path.display(),
                path.display()
            );
        }
        None => print!("{text}"),
    }
    Ok(())
}
