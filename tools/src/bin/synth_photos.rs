//! `synth_photos`: a folder of randomised labelled photos of a ball (YOLO labels), for
//! `ball-lab evaluate` and `ball-lab train`. The `train` profile is for training;
//! the `heldout` profile draws from ranges the classifier never saw (see
//! `sim::photo_synth`). `--designs` restricts the ball designs, so a whole kind of ball can
//! be held out: train on `--designs plain,patches,white-black-panels,modern,yellow`, test on
//! `--designs classic`.

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
    /// Real photos to paint balls on (files, or folders of PNG and JPEG files, subfolders
    /// included).
    #[arg(long, value_delimiter = ',')]
    backgrounds: Vec<PathBuf>,
    /// Background photos with YOLO labels beside them (a labelled data set's photos): paint
    /// over their balls of this class before painting one in, so no real ball is left
    /// unlabelled in a training photo.
    #[arg(long, value_name = "CLASS")]
    erase_class: Option<u32>,
    /// Rendered views of the simulated pitch in the rotation of backgrounds.
    #[arg(long, default_value_t = 24)]
    rendered: usize,
    /// Kinds of background to go round: carpet, rendered, photos (default: every kind
    /// available).
    #[arg(long, value_delimiter = ',')]
    kinds: Vec<tools::photo_set::BackgroundKind>,
    /// Ball designs to draw, at the profile's weights: plain, patches, classic,
    /// white-black-panels, modern, yellow (default: every design).
    #[arg(long, value_delimiter = ',')]
    designs: Vec<String>,
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
            out.extend(robot_agent::image_files_recursive(p)?);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// The designs called `names` (none: an empty list, every design).
fn designs(names: &[String]) -> anyhow::Result<Vec<sim::BallDesign>> {
    names
        .iter()
        .map(|n| {
            sim::BallDesign::named(n).ok_or_else(|| {
                let valid: Vec<&str> = sim::BallDesign::ALL.iter().map(|d| d.name()).collect();
                anyhow::anyhow!(
                    "unknown ball design {n:?}: use one or more of {}",
                    valid.join(", ")
                )
            })
        })
        .collect()
}

fn run(args: Args) -> anyhow::Result<()> {
    let Some(profile) = sim::PhotoProfile::named(&args.profile) else {
        anyhow::bail!("unknown profile {:?}: use train or heldout", args.profile);
    };
    let spec = PhotoSetSpec {
        profile: profile.with_designs(&designs(&args.designs)?),
        count: args.count,
        seed: args.seed,
        backgrounds: image_files(&args.backgrounds)?,
        erase_class: args.erase_class,
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
