//! `synth_photos`: a folder of randomised labelled photos of a ball (YOLO labels), for
//! `robot-agent evaluate` and `robot-agent train`. The `train` profile is for training;
//! the `heldout` profile draws from ranges the classifier never saw (see
//! `sim::photo_synth`).

use clap::Parser;
use std::path::PathBuf;
use tools::photo_set::{PhotoSetSpec, write_photo_set};
use tools::progress::Progress;

#[derive(Debug, Parser)]
#[command(about = "Write randomised labelled ball photos (images/ and YOLO labels/)")]
struct Args {
    /// `train` or `heldout`.
    #[arg(long, default_value = "heldout")]
    profile: String,
    /// Number of photos.
    #[arg(long, default_value_t = 1000)]
    count: u64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Real photos to paint balls on (files, or folders of PNG and JPEG files).
    #[arg(long, value_delimiter = ',')]
    backgrounds: Vec<PathBuf>,
    /// Rendered views of the simulated pitch in the rotation of backgrounds.
    #[arg(long, default_value_t = 24)]
    rendered: usize,
    /// Kinds of background to go round: carpet, rendered, photos (default: every kind
    /// available).
    #[arg(long, value_delimiter = ',')]
    kinds: Vec<tools::photo_set::BackgroundKind>,
    /// The folder to write (`images/`, `labels/`, `manifest.json`).
    #[arg(long)]
    out: PathBuf,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn image_files(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            out.extend(robot_agent::image_files(p)?);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

fn run(args: Args) -> anyhow::Result<()> {
    let Some(profile) = sim::PhotoProfile::named(&args.profile) else {
        anyhow::bail!("unknown profile {:?}: use train or heldout", args.profile);
    };
    let spec = PhotoSetSpec {
        profile,
        count: args.count,
        seed: args.seed,
        backgrounds: image_files(&args.backgrounds)?,
        rendered: args.rendered,
        kinds: args.kinds,
    };
    let progress = Progress::new(args.count, "photos written");
    let with_ball = write_photo_set(&spec, &args.out, &progress)?;
    progress.finish();
    eprintln!(
        "wrote {} photos ({with_ball} with a ball) to {}",
        args.count,
        args.out.display()
    );
    Ok(())
}
