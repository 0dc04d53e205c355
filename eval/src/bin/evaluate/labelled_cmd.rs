//! `--labelled DIR`: the agent's detectors on a folder of labelled photos (any layout
//! `ball-lab evaluate` reads: Pascal VOC or YOLO labels, events in subfolders), a row per
//! event (top-level subfolder) and detector, events named by `--hold-out` marked as held out
//! from the ball network's training. Its generated section is marked
//! `<!-- evaluate-labelled:begin -->` / `…:end -->`.

use anyhow::{Context, Result};
use eval::photo_eval::{stage_table_head, stage_table_note, stage_table_row};
use eval::report;
use lab::cli::evaluate::{EvaluateOptions, evaluate_items};
use lab::cli::labelled::{Item, LabelledArgs, LabelledFolder};
use lab::labels::eval::LabelReport;
use robot_agent::DetectorKind;
use std::path::{Path, PathBuf};
use vision::Detector;
use vision::DetectorConfig;

pub const SECTION_BEGIN: &str = "<!-- evaluate-labelled:begin -->";
pub const SECTION_END: &str = "<!-- evaluate-labelled:end -->";

#[derive(Debug, Clone, clap::Args)]
pub struct LabelledEvalArgs {
    /// Score the detectors on this folder of labelled photos instead (labels beside the
    /// photos or in the same layout under `--labelled-labels`).
    #[arg(long, value_name = "DIR")]
    pub labelled: Option<PathBuf>,
    /// With `--labelled`: the label folder, when not beside the photos.
    #[arg(long, requires = "labelled")]
    pub labelled_labels: Option<PathBuf>,
    /// With `--labelled`: an event (top-level subfolder) held out of the network's
    /// training (repeatable); those rows are marked and summed apart.
    #[arg(long = "hold-out", requires = "labelled")]
    pub hold_out: Vec<String>,
    /// With `--labelled` or `--sorted`: a trained model scored beside the shipped detectors,
    /// as `NAME=FILE` (a model of the robot's detector, `net`: a ball network) or
    /// `NAME=DETECTOR:FILE` (one of another detector, as `mine=two-stage:d.safetensors`);
    /// repeatable. With
    /// `--teacher`, `shipped` scores the robot's detector beside the teacher.
    #[arg(long = "beside", value_name = "NAME=FILE")]
    pub beside: Vec<String>,
}

/// A detector to score: its row name, which detector, and the model file in place of its
/// shipped weights.
pub struct Scored {
    pub name: String,
    pub kind: DetectorKind,
    pub file: Option<PathBuf>,
}

impl Scored {
    /// Its detector and classifier, chosen as every command chooses them.
    pub fn load(
        &self,
    ) -> Result<(
        Detector,
        std::sync::Arc<dyn vision::CandidateClassifier + Send + Sync>,
    )> {
        let chosen = robot_agent::choose_detector(
            self.kind,
            &DetectorConfig::default(),
            self.file.as_deref(),
        )
        .with_context(|| format!("--beside {}", self.name))?;
        Ok((chosen.detector, chosen.classifier))
    }
}

/// `--beside`'s models: `shipped` (the robot's detector), `NAME=FILE` (a model file of the
/// robot's detector) or `NAME=DETECTOR:FILE` (a model file of another detector, as
/// `student=net:student.safetensors`).
pub fn beside_models(beside: &[String]) -> Result<Vec<Scored>> {
    beside
        .iter()
        .map(|m| match m.split_once('=') {
            Some((name, spec)) => {
                let (kind, file) = match spec.split_once(':') {
                    Some((kind, file)) => (
                        <DetectorKind as clap::ValueEnum>::from_str(kind, false).map_err(|_| {
                            anyhow::anyhow!(
                                "--beside {m}: {kind:?} is not a detector (two-stage, net or \
                                 dissertation)"
                            )
                        })?,
                        file,
                    ),
                    None => (DetectorKind::default(), spec),
                };
                Ok(Scored {
                    name: name.to_string(),
                    kind,
                    file: Some(PathBuf::from(file)),
                })
            }
            None if m == "shipped" => Ok(Scored {
                name: "shipped".to_string(),
                kind: DetectorKind::default(),
                file: None,
            }),
            None => anyhow::bail!("--beside {m}: give `shipped`, NAME=FILE or NAME=DETECTOR:FILE"),
        })
        .collect()
}

/// The shipped detectors, then `--beside NAME=FILE`'s.
pub fn detectors(beside: &[String]) -> Result<Vec<Scored>> {
    let shipped = [
        DetectorKind::Net,
        DetectorKind::TwoStage,
        DetectorKind::Dissertation,
    ]
    .into_iter()
    .map(|kind| Scored {
        name: kind.name().to_string(),
        kind,
        file: None,
    });
    let trained = beside_models(beside)?
        .into_iter()
        .filter(|s| s.file.is_some());
    Ok(shipped.chain(trained).collect())
}

/// A photo's event: its top-level subfolder.
pub fn event(item: &Item) -> String {
    item.folder.split('/').next().unwrap_or("").to_string()
}

fn pct(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{:.1}", 100.0 * v))
}

fn row(name: &str, split: &str, detector: &str, r: &LabelReport) -> String {
    let at = |p: f64| {
        r.recall_at_precision(p)
            .map_or("–".to_string(), |q| format!("{:.1}", 100.0 * q.recall))
    };
    let bands: Vec<String> = r
        .bands
        .iter()
        .map(|b| format!("{} ({})", pct(b.recall_published), b.balls))
        .collect();
    format!(
        "| {name} | {split} | {detector} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {} | {} |",
        r.images,
        r.images_with_ball,
        pct(r.recall_published),
        pct(r.precision),
        pct(r.ball_recall),
        at(0.97),
        at(0.9),
        r.false_positives_per_image.unwrap_or(0.0),
        bands.join(" | "),
        r.timing_ms
            .map_or("–".to_string(), |t| format!("{:.1}", t.median)),
    )
}

/// Scores both shipped detectors on the folder and prints (and, with `doc`, writes) the
/// tables: the scores as published, and per stage.
pub fn run(args: &LabelledEvalArgs, doc: Option<&Path>) -> Result<()> {
    let Some(dir) = &args.labelled else {
        anyhow::bail!("--labelled DIR is needed");
    };
    let folder = LabelledFolder::open(&LabelledArgs {
        images: Some(dir.clone()),
        labels: args.labelled_labels.clone(),
        ball_classes: Vec::new(),
        ball_names: Vec::new(),
        camera: None,
        calibration: None,
    })?;
    for h in &args.hold_out {
        anyhow::ensure!(
            folder.items.iter().any(|i| &event(i) == h),
            "--hold-out {h}: no photos in that subfolder of {}",
            dir.display()
        );
    }
    let mut events: Vec<String> = folder.items.iter().map(event).collect();
    events.sort();
    events.dedup();
    let mut lines = vec![
        "| event | split | detector | photos | with a ball | recall % | precision % | ball recall % | recall % at 97 % precision | recall % at 90 % precision | false per photo | < 10 px | 10–20 px | 20–40 px | >= 40 px | ms median |".to_string(),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|".to_string(),
    ];
    let mut stage_lines = Vec::new();
    let min_probability = robot_agent::ValidationConfig::default().min_probability;
    for scored in detectors(&args.beside)? {
        let name = scored.name.as_str();
        let (detector, classifier) = scored.load()?;
        let score = |items: &[&Item], what: &str| {
            evaluate_items(
                &folder,
                items,
                &detector,
                classifier.as_ref(),
                &EvaluateOptions {
                    min_probability,
                    what,
                    verbose: false,
                },
            )
        };
        for e in &events {
            let items: Vec<&Item> = folder.items.iter().filter(|i| &event(i) == e).collect();
            let split = if args.hold_out.contains(e) {
                "held out"
            } else if args.hold_out.is_empty() {
                "–"
            } else {
                "training"
            };
            let out = score(&items, e)?;
            lines.push(row(e, split, name, &out.report));
            stage_lines.push(stage_table_row(&[e, split, name], &out.report));
        }
        if !args.hold_out.is_empty() {
            let held: Vec<&Item> = folder
                .items
                .iter()
                .filter(|i| args.hold_out.contains(&event(i)))
                .collect();
            let out = score(&held, "held out")?;
            lines.push(row("**all held out**", "held out", name, &out.report));
            stage_lines.push(stage_table_row(
                &["**all held out**", "held out", name],
                &out.report,
            ));
        }
    }
    let table = format!(
        "{}\n\n{}\n\n{}{}",
        lines.join("\n"),
        stage_table_note(min_probability),
        stage_table_head(&["event", "split", "detector"]),
        stage_lines.join("\n")
    );
    println!("{table}");
    if let Some(path) = doc {
        let mut cmd = format!(
            "cargo run --release -p eval --bin evaluate -- --labelled {}",
            dir.display()
        );
        for h in &args.hold_out {
            cmd.push_str(&format!(" --hold-out {h}"));
        }
        for m in &args.beside {
            cmd.push_str(&format!(" --beside {m}"));
        }
        cmd.push_str(&format!(" --doc {}", path.display()));
        let section = format!(
            "Produced by `{cmd}` (real photos; the shipped detectors and any `--beside`, no camera model, \
             `min_probability` {min_probability}; recall and precision per photo, ball recall \
             and the width bands per labelled ball).\n\n{table}"
        );
        report::rewrite_section_between(path, SECTION_BEGIN, SECTION_END, &section)?;
        eprintln!("updated {}", path.display());
    }
    Ok(())
}
