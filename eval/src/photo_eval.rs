//! The detector on photos it was never tuned or trained on: randomised held-out photos
//! ([`sim::photo_synth`]'s `heldout` profile) on three kinds of background, and real
//! photographs (with balls, and without), scored per image against their labels by
//! [`robot_agent::labels::eval`] with no camera model, as `robot-agent evaluate` does.
//!
//! Every row says where its photos come from: `simulated` rows are painted by this
//! project; `real` rows are photographs nobody here made.

use crate::plot::{Chart, Marker, PALETTE, Series, Style, write_png};
use anyhow::{Context, Result};
use robot_agent::RgbImage;
use robot_agent::labels::BallBox;
use robot_agent::labels::eval::{LabelEval, LabelReport, SIZE_BANDS_PX, TimingMs, band_name};
use robot_agent::{CandidateClassifier, Detector, DetectorConfig, NoClock};
use serde::Serialize;
use sim::Frame;
use sim::{Background, PhotoProfile, synth_photo};
use std::path::{Path, PathBuf};
use std::time::Instant;
use tools::photo_set::{encode, rendered_views};
use tools::progress::Progress;

/// Where the generated section of the accuracy report starts and ends.
pub const SECTION_BEGIN: &str = "<!-- evaluate-photos:begin -->";
pub const SECTION_END: &str = "<!-- evaluate-photos:end -->";

/// One scored set of photos.
#[derive(Debug, Clone, Serialize)]
pub struct PhotoSetResult {
    pub name: String,
    /// `simulated` or `real`.
    pub source: &'static str,
    pub report: LabelReport,
}

/// What to score.
#[derive(Debug, Clone)]
pub struct PhotoEvalConfig {
    /// Randomised photos per kind of background.
    pub count: u64,
    pub seed: u64,
    /// Real photos to paint the held-out balls on, and to score as photos without a ball.
    pub backgrounds: PathBuf,
    /// Real photos with labelled balls (Pascal VOC labels in `labels/`).
    pub real_balls: PathBuf,
}

fn frame_of(image: RgbImage) -> Frame {
    Frame {
        width: image.width(),
        height: image.height(),
        rgb: image.data().to_vec(),
    }
}

/// Scores one photo into `eval`.
fn score(
    eval: &mut LabelEval,
    ms: &mut Vec<f64>,
    name: &str,
    image: &RgbImage,
    balls: &[BallBox],
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
) -> Result<()> {
    let started = Instant::now();
    let candidates = detector.detect(image, None, classifier, &mut NoClock)?;
    let took_ms = started.elapsed().as_secs_f64() * 1e3;
    ms.push(took_ms);
    let scored: Vec<_> = candidates
        .iter()
        .map(|c| (c.circle, c.probability))
        .collect();
    eval.add(name, balls, &scored, took_ms);
    Ok(())
}

fn finish(eval: &LabelEval, ms: &[f64]) -> LabelReport {
    let timing = sim::quantile(ms, 0.5)
        .zip(sim::quantile(ms, 0.9))
        .map(|(median, p90)| TimingMs { median, p90 });
    eval.report(timing)
}

/// Scores every set; `progress` counts the photos scored (its length grows as the sets
/// are found).
pub fn evaluate_photos(
    cfg: &PhotoEvalConfig,
    detector_cfg: &DetectorConfig,
    classifier: &dyn CandidateClassifier,
    min_probability: f64,
    progress: &Progress,
) -> Result<Vec<PhotoSetResult>> {
    let detector = Detector::new(*detector_cfg)?;
    let background_files = robot_agent::image_files(&cfg.backgrounds)?;
    let mut pictures = Vec::new();
    for p in &background_files {
        pictures.push(frame_of(robot_agent::load_rgb(p)?));
    }
    let renders = rendered_views(24, cfg.seed)?;
    let profile = PhotoProfile::heldout();
    let mut out = Vec::new();
    let kinds: [(&str, Option<&[Frame]>); 3] = [
        ("held-out carpets", None),
        ("held-out rendered pitch", Some(&renders)),
        ("held-out real backgrounds", Some(&pictures)),
    ];
    progress.add_work(kinds.len() as u64 * cfg.count);
    for (name, frames) in kinds {
        let (mut eval, mut ms) = (LabelEval::new(min_probability), Vec::new());
        for i in 0..cfg.count {
            let background = match frames {
                None => Background::Carpet,
                Some(f) => Background::Picture(&f[i as usize % f.len()]),
            };
            let photo = synth_photo(&profile, background, cfg.seed, i);
            // Through the file format, so JPEG artefacts are the real codec's.
            let (bytes, _) = encode(&photo)?;
            let image = robot_agent::decode_rgb(&bytes)?;
            let balls: Vec<BallBox> = photo
                .balls
                .iter()
                .map(|b| BallBox {
                    x_min_px: b.box_px[0],
                    y_min_px: b.box_px[1],
                    x_max_px: b.box_px[2],
                    y_max_px: b.box_px[3],
                })
                .collect();
            score(
                &mut eval,
                &mut ms,
                &format!("{i:05}"),
                &image,
                &balls,
                &detector,
                classifier,
            )?;
            progress.inc(name);
        }
        out.push(PhotoSetResult {
            name: name.to_string(),
            source: "simulated",
            report: finish(&eval, &ms),
        });
    }
    // Real photos with labelled balls.
    let (mut eval, mut ms) = (LabelEval::new(min_probability), Vec::new());
    let real_files = robot_agent::image_files(&cfg.real_balls.join("images"))?;
    progress.add_work((real_files.len() + background_files.len()) as u64);
    for p in real_files {
        let image = robot_agent::load_rgb(&p)?;
        let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
        let xml_path = cfg.real_balls.join("labels").join(format!("{stem}.xml"));
        let xml = std::fs::read_to_string(&xml_path)
            .with_context(|| format!("reading {}", xml_path.display()))?;
        let labels = robot_agent::labels::voc::parse_voc(
            &xml,
            &xml_path.display().to_string(),
            &robot_agent::labels::BallNames::default(),
        )?;
        let name = p.file_name().and_then(|s| s.to_str()).unwrap_or_default();
        score(
            &mut eval,
            &mut ms,
            name,
            &image,
            &labels.balls,
            &detector,
            classifier,
        )?;
        progress.inc("real photos with balls");
    }
    out.push(PhotoSetResult {
        name: "real photos with balls".into(),
        source: "real",
        report: finish(&eval, &ms),
    });
    // The real backgrounds on their own: photos without a ball.
    let (mut eval, mut ms) = (LabelEval::new(min_probability), Vec::new());
    for (p, frame) in background_files.iter().zip(&pictures) {
        let image = RgbImage::new(frame.width, frame.height, frame.rgb.clone())?;
        let name = p.file_name().and_then(|s| s.to_str()).unwrap_or_default();
        score(&mut eval, &mut ms, name, &image, &[], &detector, classifier)?;
        progress.inc("real photos without a ball");
    }
    out.push(PhotoSetResult {
        name: "real photos without a ball".into(),
        source: "real",
        report: finish(&eval, &ms),
    });
    Ok(out)
}

fn pct(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{:.1}", 100.0 * v))
}

/// The results as markdown: one table of the sets, one of recall by ball width.
pub fn markdown(results: &[PhotoSetResult]) -> String {
    let mut s = String::from(
        "| photos | source | images | with a ball | recall % | precision % | false per image | \
         best candidate % | any candidate % | ms median (p90) |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in results {
        let p = &r.report;
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.name,
            r.source,
            p.images,
            p.images_with_ball,
            pct(p.recall_published),
            pct(p.precision),
            p.false_positives_per_image
                .map_or("–".into(), |v| format!("{v:.3}")),
            pct(p.recall_best),
            pct(p.recall_any),
            p.timing_ms
                .map_or("–".into(), |t| format!("{:.2} ({:.2})", t.median, t.p90)),
        ));
    }
    s.push_str("\n| photos | ");
    s.push_str(
        &(0..SIZE_BANDS_PX.len())
            .map(band_name)
            .collect::<Vec<_>>()
            .join(" | "),
    );
    s.push_str(" |\n|---|");
    s.push_str(&"---|".repeat(SIZE_BANDS_PX.len()));
    s.push('\n');
    for r in results.iter().filter(|r| r.report.balls > 0) {
        s.push_str(&format!("| {} |", r.name));
        for b in &r.report.bands {
            s.push_str(&format!(
                " {} ({} balls) |",
                pct(b.recall_published),
                b.balls
            ));
        }
        s.push('\n');
    }
    s
}

/// Recall by ball width, one line per set with balls.
pub fn recall_chart(results: &[PhotoSetResult]) -> Chart {
    let mut chart = Chart::new(
        "Published recall by ball width (no camera model)",
        "ball box width (px, band middle)",
        "recall",
    );
    let mids: Vec<f64> = SIZE_BANDS_PX
        .iter()
        .map(|&(lo, hi)| {
            if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                lo + 10.0
            }
        })
        .collect();
    for (k, r) in results.iter().filter(|r| r.report.balls > 0).enumerate() {
        let pts: Vec<(f64, f64)> = r
            .report
            .bands
            .iter()
            .zip(&mids)
            .filter_map(|(b, &m)| Some((m, b.recall_published?)))
            .collect();
        chart.series.push(Series::new(
            &r.name,
            PALETTE[k % PALETTE.len()],
            Style::LineAndMarkers(Marker::Circle),
            pts,
        ));
    }
    chart
}

/// Writes the chart into `dir` as `name`; returns the file written.
pub fn write_plot(dir: &Path, name: &str, results: &[PhotoSetResult]) -> Result<String> {
    std::fs::create_dir_all(dir)?;
    let path = dir.join(name);
    write_png(&recall_chart(results), &path)?;
    Ok(path.display().to_string())
}
