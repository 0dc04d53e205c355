//! `ball-lab evaluate`: the agent's detector on a folder of labelled photos, scored
//! against the labelled ball boxes ([`crate::labels::eval`]).
//!
//! Every photo is searched on its own ([`crate::cli::evaluate`]); with photos in
//! subfolders (events), every folder also gets its own row.

use crate::cli::evaluate::{EvaluateOptions, evaluate_items};
use crate::cli::labelled::{LabelledArgs, LabelledFolder};
use anyhow::Result;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct EvaluateArgs {
    #[command(flatten)]
    pub detector: robot_agent::DetectorArgs,
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
    /// Also draw the precision-recall curve as a PNG.
    #[arg(long)]
    pub pr_plot: Option<PathBuf>,
    /// A line per photo on stderr.
    #[arg(long)]
    pub verbose: bool,
}

use crate::cli::files::write_file;

pub fn run(args: EvaluateArgs) -> Result<()> {
    let config = robot_agent::load_config(args.config.as_deref())?;
    let chosen = args.detector.choose(&config.detector)?;
    eprintln!("{}", chosen.describe());
    let (detector, classifier) = (chosen.detector, chosen.classifier);
    let folder = LabelledFolder::open(&args.folder)?;
    let items: Vec<_> = folder.items.iter().collect();
    let out = evaluate_items(
        &folder,
        &items,
        &detector,
        classifier.as_ref(),
        &EvaluateOptions {
            min_probability: config.validation.min_probability,
            what: "evaluating",
            verbose: args.verbose,
        },
    )?;
    let report = &out.report;
    println!("{report}");
    if out.folders.len() > 1 {
        println!();
        println!(
            "{:<28} {:>6} {:>8} {:>9} {:>11} {:>8} {:>8} {:>11} {:>11} {:>10} {:>10}",
            "folder",
            "photos",
            "recall",
            "precision",
            "ball recall",
            "FP/photo",
            "ms",
            "cand recall",
            "cand/photo",
            "checker P",
            "checker R"
        );
        for (name, r) in &out.folders {
            let pct =
                |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{:.1} %", 100.0 * v));
            println!(
                "{:<28} {:>6} {:>8} {:>9} {:>11} {:>8} {:>8} {:>11} {:>11} {:>10} {:>10}",
                if name.is_empty() { "." } else { name },
                r.images,
                pct(r.recall_published),
                pct(r.precision),
                pct(r.ball_recall),
                r.false_positives_per_image
                    .map_or("–".to_string(), |v| format!("{v:.3}")),
                r.timing_ms
                    .map_or("–".to_string(), |t| format!("{:.2}", t.median)),
                pct(r.candidate_recall),
                r.candidates_per_frame
                    .map_or("–".to_string(), |c| format!("{:.2}", c.mean)),
                pct(r.checker.precision),
                pct(r.checker.recall)
            );
        }
    }
    if out.unlabelled + out.unreadable + out.warnings > 0 {
        println!(
            "{} images without a label file (taken as no ball), {} left out \
             (unreadable image or labels), {} label warnings",
            out.unlabelled, out.unreadable, out.warnings
        );
    }
    if let Some(path) = &args.json {
        // The report as before, with the per-folder reports beside it.
        let mut json = serde_json::to_value(report)?;
        if let Some(map) = json.as_object_mut() {
            map.insert(
                "folders".into(),
                out.folders
                    .iter()
                    .map(|(n, r)| {
                        Ok(serde_json::json!({"folder": n, "report": serde_json::to_value(r)?}))
                    })
                    .collect::<Result<Vec<_>, serde_json::Error>>()?
                    .into(),
            );
        }
        write_file(path, serde_json::to_string_pretty(&json)?.as_bytes())?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.pr_plot {
        super::pr_chart::write_png(
            path,
            "Precision and recall",
            super::pr_chart::Curve {
                name: "detector",
                points: &report.pr_curve,
                threshold: config.validation.min_probability,
            },
        )?;
        println!(
            "wrote {} (precision against recall as the threshold falls)",
            path.display()
        );
    }
    if let Some(path) = &args.plot {
        let groups: Vec<Vec<Option<f64>>> = report
            .bands
            .iter()
            .map(|b| vec![b.recall_published, b.recall_best])
            .collect();
        let chart = super::bar_chart::grouped_bars(&groups)?;
        write_file(path, &robot_agent::encode_png(&chart)?)?;
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
