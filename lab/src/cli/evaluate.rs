//! The detector on labelled photos, scored against their ball boxes
//! ([`crate::labels::eval`]): shared by `ball-lab evaluate` and the held-out score of
//! `ball-lab train`. Every photo is searched on its own (no lighting adaptation carries
//! from one photo to the next) and without world validation, which needs a robot's pose.

use crate::cli::labelled::{Item, LabelledFolder};
use crate::labels::eval::{LabelEval, LabelReport, TimingMs};
use anyhow::Result;
use std::collections::BTreeMap;
use std::time::Instant;
use vision::photo::detect_photo;
use vision::{CandidateClassifier, Detector, NoClock};

/// How photos are scored and reported.
#[derive(Debug, Clone, Copy)]
pub struct EvaluateOptions<'a> {
    pub min_probability: f64,
    /// The progress bar's name.
    pub what: &'a str,
    /// A line per photo on stderr.
    pub verbose: bool,
}

/// The scores of a set of photos: all of them, and per folder (event).
#[derive(Debug)]
pub struct Evaluated {
    pub report: LabelReport,
    pub folders: Vec<(String, LabelReport)>,
    pub unreadable: usize,
    pub warnings: usize,
    pub unlabelled: usize,
}

fn timing(ms: &[f64]) -> Option<TimingMs> {
    proto::stats::quantile(ms, 0.5)
        .zip(proto::stats::quantile(ms, 0.9))
        .map(|(median, p90)| TimingMs { median, p90 })
}

/// A newly trained model's held-out score (at probability 0.5, quietly), or `None` when
/// nothing is held out.
pub fn held_out_score(
    val: (&LabelledFolder, &[&Item]),
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
) -> Result<Option<LabelReport>> {
    if val.1.is_empty() {
        return Ok(None);
    }
    let opts = EvaluateOptions {
        min_probability: 0.5,
        what: "held-out score",
        verbose: false,
    };
    Ok(Some(
        evaluate_items(val.0, val.1, detector, classifier, &opts)?.report,
    ))
}

/// Runs the detector on every photo of `items` and scores it.
pub fn evaluate_items(
    folder: &LabelledFolder,
    items: &[&Item],
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
    opts: &EvaluateOptions<'_>,
) -> Result<Evaluated> {
    let mut eval = LabelEval::new(opts.min_probability);
    let mut per_folder: BTreeMap<String, (LabelEval, Vec<f64>)> = BTreeMap::new();
    let (mut unreadable, mut warnings, mut unlabelled) = (0usize, 0usize, 0usize);
    let mut ms = Vec::new();
    let n = items.len();
    let bar = crate::cli::progress::bar(n, opts.what);
    for (k, item) in items.iter().enumerate() {
        let name = item.name();
        bar.inc(1);
        let outcome = (|| -> Result<_> {
            let image = robot_agent::load_rgb(&item.image)?;
            let labels = folder.labels(item, &image)?;
            let model = folder.camera.model_for(&image)?;
            Ok((image, labels, model))
        })();
        let (image, labels, model) = match outcome {
            Ok(o) => o,
            Err(e) => {
                bar.suspend(|| eprintln!("[{}/{n}] {name}: left out: {e:#}", k + 1));
                unreadable += 1;
                continue;
            }
        };
        unlabelled += usize::from(item.label.is_none());
        for w in &labels.warnings {
            bar.suspend(|| eprintln!("[{}/{n}] {name}: line {}: {}", k + 1, w.line, w.what));
        }
        warnings += labels.warnings.len();
        let started = Instant::now();
        let candidates = detect_photo(
            detector,
            classifier,
            opts.min_probability,
            &image,
            model.as_ref(),
            &mut NoClock,
        )?;
        let took_ms = started.elapsed().as_secs_f64() * 1e3;
        ms.push(took_ms);
        // Every candidate proposed, with the checker's probability when it gave one.
        let candidates: Vec<_> = candidates
            .iter()
            .map(|c| (c.circle, c.probability))
            .collect();
        let image_name = if item.folder.is_empty() {
            name.clone()
        } else {
            format!("{}/{name}", item.folder)
        };
        eval.add_stages(&image_name, &labels.balls, &candidates, took_ms);
        let (f, f_ms) = per_folder
            .entry(item.folder.clone())
            .or_insert_with(|| (LabelEval::new(opts.min_probability), Vec::new()));
        f.add_stages(&image_name, &labels.balls, &candidates, took_ms);
        f_ms.push(took_ms);
        if opts.verbose
            && let Some(row) = eval.last()
        {
            let line = format!(
                "[{}/{n}] {image_name}: {} ({} with a candidate), {} \
                 ({} on a ball, {} accepted), published {}",
                k + 1,
                crate::cli::progress::count(row.balls.len(), "ball"),
                row.balls_proposed.iter().filter(|&&p| p).count(),
                crate::cli::progress::count(row.candidates, "candidate"),
                row.candidates_on_ball,
                row.candidates_accepted,
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
            bar.suspend(|| eprintln!("{line}"));
        }
    }
    bar.finish_and_clear();
    Ok(Evaluated {
        report: eval.report(timing(&ms)),
        folders: per_folder
            .into_iter()
            .map(|(name, (e, ms))| (name, e.report(timing(&ms))))
            .collect(),
        unreadable,
        warnings,
        unlabelled,
    })
}
