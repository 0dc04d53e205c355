//! `robot-agent evaluate`: the agent's detector on a folder of labelled photos, scored
//! against the labelled ball boxes ([`robot_agent::labels::eval`]).
//!
//! Every photo is searched on its own, with the configured colour window (no lighting
//! adaptation carries from one photo to the next) and without world validation, which
//! needs a robot's pose.

use anyhow::{Context, Result};
use robot_agent::cli::labelled::{LabelledArgs, LabelledFolder};
use robot_agent::detection::detect::{Detector, NoClock};
use robot_agent::labels::eval::{LabelEval, TimingMs};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Debug, clap::Args)]
pub struct EvaluateArgs {
    #[command(flatten)]
    pub model: robot_agent::runtime::models::ClassifierArgs,
    #[command(flatten)]
    pub folder: LabelledArgs,
    /// Pipeline settings (TOML: `[detector]`, `[validation]` for `min_probability`).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Also write the report, with every image's outcome, as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Also draw recall by ball size as a PNG bar chart.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

fn write_file(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
}

pub fn run(args: EvaluateArgs) -> Result<()> {
    let config = robot_agent::runtime::models::load_config(args.config.as_deref())?;
    let folder = LabelledFolder::open(&args.folder)?;
    let detector = Detector::new(config.detector).context("the detector's settings")?;
    let classifier = robot_agent::runtime::models::classifier(
        &config.detector,
        args.model.classifier.as_deref(),
    )?;
    let mut eval = LabelEval::new(config.validation.min_probability);
    let (mut unreadable, mut warnings, mut unlabelled) = (0usize, 0usize, 0usize);
    let mut ms = Vec::new();
    let n = folder.items.len();
    for (k, item) in folder.items.iter().enumerate() {
        let name = item.name();
        let outcome = (|| -> Result<_> {
            let image = robot_agent::io::image_io::load_rgb(&item.image)?;
            let labels = folder.labels(item, &image)?;
            let model = folder.camera.model_for(&image)?;
            Ok((image, labels, model))
        })();
        let (image, labels, model) = match outcome {
            Ok(o) => o,
            Err(e) => {
                eprintln!("[{}/{n}] {name}: left out: {e:#}", k + 1);
                unreadable += 1;
                continue;
            }
        };
        unlabelled += usize::from(item.label.is_none());
        for w in &labels.warnings {
            eprintln!("[{}/{n}] {name}: line {}: {}", k + 1, w.line, w.what);
        }
        warnings += labels.warnings.len();
        let started = Instant::now();
        let candidates =
            detector.detect(&image, model.as_ref(), classifier.as_ref(), &mut NoClock)?;
        let took_ms = started.elapsed().as_secs_f64() * 1e3;
        ms.push(took_ms);
        let scored: Vec<_> = candidates
            .iter()
            .map(|c| (c.circle, c.probability))
            .collect();
        eval.add(&name, &labels.balls, &scored, took_ms);
        if let Some(row) = eval.last() {
            eprintln!(
                "[{}/{n}] {name}: {} balls, {} candidates, published {}",
                k + 1,
                row.balls.len(),
                row.candidates,
                match (row.published, row.published_on_ball) {
                    (None, _) => "nothing".to_string(),
                    (Some(p), on) => format!(
                        "({:.0}, {:.0}) r {:.1} p {:.2}{}",
                        p[0],
                        p[1],
                        p[2],
                        p[3],
                        if on { " on a ball" } else { " off the balls" }
                    ),
                }
            );
        }
    }
    let timing = proto::stats::quantile(&ms, 0.5)
        .zip(proto::stats::quantile(&ms, 0.9))
        .map(|(median, p90)| TimingMs { median, p90 });
    let report = eval.report(timing);
    println!("{report}");
    if unlabelled + unreadable + warnings > 0 {
        println!(
            "{unlabelled} images without a label file (taken as no ball), {unreadable} left out \
             (unreadable image or labels), {warnings} label warnings"
        );
    }
    if let Some(path) = &args.json {
        write_file(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.plot {
        let groups: Vec<Vec<Option<f64>>> = report
            .bands
            .iter()
            .map(|b| vec![b.recall_published, b.recall_best])
            .collect();
        let chart = crate::bar_chart::grouped_bars(&groups)?;
        write_file(path, &robot_agent::io::image_io::encode_png(&chart)?)?;
        println!(
            "wrote {} (recall by ball width {}; blue: published, orange: best candidate)",
            path.display(),
            report
                .bands
                .iter()
                .map(|b| b.band.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}
