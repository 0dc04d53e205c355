//! The detector on photos it was never tuned or trained on: randomised held-out photos
//! ([`sim::photo_synth`]'s `heldout` profile) on three kinds of background, and real
//! photographs (with balls, and without), scored per image against their labels by
//! [`lab::labels::eval`] with no camera model, as `ball-lab evaluate` does.
//!
//! Every row says where its photos come from: `simulated` rows are painted by this
//! project; `real` rows are photographs nobody here made.

use crate::plot::{Chart, Marker, PALETTE, Series, Style, write_png};
use anyhow::{Context, Result};
use lab::labels::BallBox;
use lab::labels::eval::{LabelEval, LabelReport, SIZE_BANDS_PX, TimingMs, band_name};
use serde::Serialize;
use sim::Frame;
use sim::{Background, PhotoProfile, synth_photo};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tools::photo_set::{encode, rendered_views};
use tools::progress::Progress;
use vision::CandidateClassifier;
use vision::Detector;
use vision::NoClock;
use vision::RgbImage;
use vision::photo::detect_photo;

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
    /// What the randomised photos are drawn from (the `heldout` profile, or some of its
    /// ball designs).
    pub profile: PhotoProfile,
}

fn frame_of(image: RgbImage) -> Frame {
    Frame {
        width: image.width(),
        height: image.height(),
        rgb: image.data().to_vec(),
    }
}

/// A photo's candidates (circle and probability) and the detector's time on it.
type Detected = (Vec<(vision::Circle, Option<f64>)>, f64);

/// Runs the detector on one photo.
fn detect(
    image: &RgbImage,
    min_probability: f64,
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
) -> Result<Detected> {
    let started = Instant::now();
    let candidates = detect_photo(
        detector,
        classifier,
        min_probability,
        image,
        None,
        &mut NoClock,
    )?;
    let took_ms = started.elapsed().as_secs_f64() * 1e3;
    Ok((
        candidates
            .iter()
            .map(|c| (c.circle, c.probability))
            .collect(),
        took_ms,
    ))
}

/// Scores one photo into `eval`, every candidate proposed with it.
fn score(
    eval: &mut LabelEval,
    ms: &mut Vec<f64>,
    name: &str,
    image: &RgbImage,
    balls: &[BallBox],
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
) -> Result<()> {
    let (candidates, took_ms) = detect(image, eval.min_probability(), detector, classifier)?;
    ms.push(took_ms);
    eval.add_stages(name, balls, &candidates, took_ms);
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
    detector: &Detector,
    classifier: &dyn CandidateClassifier,
    min_probability: f64,
    progress: &Progress,
) -> Result<Vec<PhotoSetResult>> {
    let background_files = robot_agent::image_files(&cfg.backgrounds)?;
    let mut pictures = Vec::new();
    for p in &background_files {
        pictures.push(frame_of(robot_agent::load_rgb(p)?));
    }
    let renders = rendered_views(24, cfg.seed)?;
    let profile = &cfg.profile;
    let mut out = Vec::new();
    let kinds: [(&str, Option<&[Frame]>); 3] = [
        ("held-out carpets", None),
        ("held-out rendered pitch", Some(&renders)),
        ("held-out real backgrounds", Some(&pictures)),
    ];
    // The photos with a ball again, by the ball's design, over every background.
    let mut designs: BTreeMap<&'static str, (LabelEval, Vec<f64>)> = BTreeMap::new();
    progress.add_work(kinds.len() as u64 * cfg.count);
    for (name, frames) in kinds {
        let (mut eval, mut ms) = (LabelEval::new(min_probability), Vec::new());
        for i in 0..cfg.count {
            let background = match frames {
                None => Background::Carpet,
                Some(f) => Background::Picture(&f[i as usize % f.len()]),
            };
            let photo = synth_photo(profile, background, cfg.seed, i);
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
            let (candidates, took_ms) = detect(&image, min_probability, detector, classifier)?;
            let photo_name = format!("{name} {i:05}");
            ms.push(took_ms);
            eval.add_stages(&photo_name, &balls, &candidates, took_ms);
            if let Some(b) = photo.balls.first() {
                let (e, m) = designs
                    .entry(b.design.name())
                    .or_insert_with(|| (LabelEval::new(min_probability), Vec::new()));
                m.push(took_ms);
                e.add_stages(&photo_name, &balls, &candidates, took_ms);
            }
            progress.inc(name);
        }
        out.push(PhotoSetResult {
            name: name.to_string(),
            source: "simulated",
            report: finish(&eval, &ms),
        });
    }
    for (design, (eval, ms)) in &designs {
        out.push(PhotoSetResult {
            name: format!("held-out, {design} balls"),
            source: "simulated",
            report: finish(eval, ms),
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
        let labels = lab::labels::voc::parse_voc(
            &xml,
            &xml_path.display().to_string(),
            &lab::labels::BallNames::default(),
        )?;
        let name = p.file_name().and_then(|s| s.to_str()).unwrap_or_default();
        score(
            &mut eval,
            &mut ms,
            name,
            &image,
            &labels.balls,
            detector,
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
        score(&mut eval, &mut ms, name, &image, &[], detector, classifier)?;
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

/// The names of the per-stage columns ([`stage_cells`]).
fn stage_columns() -> Vec<String> {
    let mut columns = vec!["candidate recall %".to_string()];
    columns.extend((0..SIZE_BANDS_PX.len()).map(|i| format!("candidates {}", band_name(i))));
    columns.extend([
        "candidates per photo mean (p90)".to_string(),
        "checker precision %".to_string(),
        "checker recall %".to_string(),
    ]);
    columns
}

/// A report's per-stage cells, in the order of [`stage_columns`]: the share of labelled
/// balls some candidate is on, overall and per width band (with the band's balls), the
/// candidates per photo, and the checker's precision and recall per candidate at the
/// report's `min_probability` (with their counts).
fn stage_cells(r: &LabelReport) -> Vec<String> {
    let mut cells = vec![pct(r.candidate_recall)];
    cells.extend(
        r.bands
            .iter()
            .map(|b| format!("{} ({})", pct(b.recall_candidate), b.balls)),
    );
    let c = &r.checker;
    cells.extend([
        r.candidates_per_frame
            .map_or("–".into(), |f| format!("{:.1} ({:.1})", f.mean, f.p90)),
        format!(
            "{} ({}/{})",
            pct(c.precision),
            c.accepted_on_ball,
            c.accepted
        ),
        format!("{} ({}/{})", pct(c.recall), c.accepted_on_ball, c.on_ball),
    ]);
    cells
}

/// What a per-stage table ([`stage_table_head`]) holds, for the line above it.
pub fn stage_table_note(min_probability: f64) -> String {
    format!(
        "Per stage: the candidates (the share of labelled balls some candidate's centre is \
         in, whatever the checker made of it, overall and per width band with the band's \
         balls; candidates per photo), and the checker per candidate at `min_probability` \
         {min_probability} (precision: accepted candidates on a ball over those accepted; \
         recall: accepted candidates on a ball over those on a ball; a candidate refused \
         outright counts as below)."
    )
}

/// The header and rule lines of a per-stage markdown table: the `leading` columns, then
/// the stages' (the share of labelled balls some candidate is on, overall and per width
/// band; candidates per photo, mean and p90; the checker's precision and recall per
/// candidate), each line ended.
pub fn stage_table_head(leading: &[&str]) -> String {
    let columns: Vec<String> = leading
        .iter()
        .map(|c| c.to_string())
        .chain(stage_columns())
        .collect();
    format!(
        "| {} |\n|{}\n",
        columns.join(" | "),
        "---|".repeat(columns.len())
    )
}

/// One row of a per-stage table ([`stage_table_head`]): the `leading` cells, then the
/// report's stages (band cells with the band's balls, checker cells with their counts),
/// without a line end.
pub fn stage_table_row(leading: &[&str], r: &LabelReport) -> String {
    let cells: Vec<String> = leading
        .iter()
        .map(|c| c.to_string())
        .chain(stage_cells(r))
        .collect();
    format!("| {} |", cells.join(" | "))
}

/// The results as markdown: one table of the sets, one of recall by ball width, one of
/// the stages.
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
    s.push('\n');
    if let Some(r) = results.first() {
        s.push_str(&stage_table_note(r.report.min_probability));
        s.push_str("\n\n");
    }
    s.push_str(&stage_table_head(&["photos"]));
    for r in results {
        s.push_str(&stage_table_row(&[&r.name], &r.report));
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

#[cfg(test)]
mod tests {
    use super::*;
    use lab::labels::eval::is_hit;
    use vision::Circle;

    fn ball(x: f64, y: f64, w: f64) -> BallBox {
        BallBox {
            x_min_px: x - w / 2.0,
            y_min_px: y - w / 2.0,
            x_max_px: x + w / 2.0,
            y_max_px: y + w / 2.0,
        }
    }

    /// A set of two photos: a 15 px ball with two candidates on it (one refused, one below
    /// the threshold) and one off it (accepted and published), and a photo without a ball
    /// or a candidate.
    fn result() -> PhotoSetResult {
        let mut eval = LabelEval::new(0.5);
        let balls = [ball(50.0, 50.0, 15.0)];
        let circle = |x: f64, y: f64, r: f64| Circle {
            center_px: [x, y],
            radius_px: r,
            score: 1.0,
        };
        let (on, off) = (circle(51.0, 49.0, 7.0), circle(200.0, 20.0, 6.0));
        assert!(is_hit(&on, &balls[0]) && !is_hit(&off, &balls[0]));
        eval.add_stages(
            "a",
            &balls,
            &[(on, None), (on, Some(0.3)), (off, Some(0.9))],
            1.0,
        );
        eval.add_stages("b", &[], &[], 1.0);
        PhotoSetResult {
            name: "two photos".into(),
            source: "simulated",
            report: eval.report(None),
        }
    }

    #[test]
    fn the_photo_tables_gain_a_stage_table() {
        let text = markdown(&[result()]);
        assert!(
            text.contains(
                "| photos | candidate recall % | candidates < 10 px | candidates 10–20 px | \
                 candidates 20–40 px | candidates >= 40 px | candidates per photo mean (p90) | \
                 checker precision % | checker recall % |\n|---|---|---|---|---|---|---|---|---|\n"
            ),
            "{text}"
        );
        assert!(
            text.contains(
                "| two photos | 100.0 | – (0) | 100.0 (1) | – (0) | – (0) | 1.5 (2.7) | \
                 0.0 (0/1) | 0.0 (0/2) |"
            ),
            "{text}"
        );
        assert!(text.contains("at `min_probability` 0.5 ("), "{text}");
        // The existing tables stay.
        assert!(text.contains("| photos | source | images |"), "{text}");
        assert!(
            text.contains(
                "| two photos | – (0 balls) | 0.0 (1 balls) | – (0 balls) | – (0 balls) |"
            ),
            "{text}"
        );
    }

    #[test]
    fn a_labelled_photo_stage_row_has_the_header_columns() {
        let mut eval = LabelEval::new(0.5);
        let circle = |x: f64, y: f64| Circle {
            center_px: [x, y],
            radius_px: 10.0,
            score: 1.0,
        };
        // A 30 px ball: candidates on it accepted and below, two off it accepted.
        eval.add_stages(
            "a",
            &[ball(55.0, 55.0, 30.0)],
            &[
                (circle(55.0, 55.0), Some(0.9)),
                (circle(50.0, 60.0), Some(0.2)),
                (circle(150.0, 60.0), Some(0.6)),
                (circle(160.0, 20.0), Some(0.7)),
            ],
            1.0,
        );
        let report = eval.report(None);
        let leading = ["event", "split", "detector"];
        let head = stage_table_head(&leading);
        let row = stage_table_row(&["2019", "held out", "net"], &report);
        assert!(
            head.starts_with("| event | split | detector | candidate recall % |"),
            "{head}"
        );
        assert_eq!(
            row,
            "| 2019 | held out | net | 100.0 | – (0) | – (0) | 100.0 (1) | – (0) | \
             4.0 (4.0) | 33.3 (1/3) | 50.0 (1/2) |"
        );
        let bars = |line: &str| line.matches('|').count();
        let mut lines = head.lines();
        assert_eq!(lines.next().map(bars), Some(bars(&row)));
        assert_eq!(lines.next().map(bars), Some(bars(&row)));
        assert_eq!(stage_cells(&report).len(), stage_columns().len());
    }
}
