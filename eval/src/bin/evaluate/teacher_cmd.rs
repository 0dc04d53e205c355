//! `--labelled DIR --teacher`: the labelling teacher (NanoDet-g, COCO's sports ball) on a
//! folder of labelled photos, box by box (`eval::teacher_eval`): per event, per set of
//! passes (the whole photo once; with native and enlarged tiles), its recall by ball width
//! at the threshold that keeps 95 % and 98 % of its boxes right, and its time per photo.
//! Its generated section is marked `<!-- evaluate-teacher:begin -->` / `…:end -->`.

use crate::labelled_cmd::event;
use anyhow::{Context, Result};
use eval::plot::{Chart, PALETTE, Series, Style};
use eval::report;
use eval::teacher_eval::{AtThreshold, LabellerReport, PhotoBoxes, score};
use lab::cli::labelled::{Item, LabelledArgs, LabelledFolder};
use lab::labels::BallBox;
use lab::labels::eval::band_name;
use lab::labels::teacher::{TeacherLabelling, taught};
use std::path::{Path, PathBuf};
use std::time::Instant;
use teacher::{Passes, Teacher};

pub const SECTION_BEGIN: &str = "<!-- evaluate-teacher:begin -->";
pub const SECTION_END: &str = "<!-- evaluate-teacher:end -->";

#[derive(Debug, Clone, clap::Args)]
pub struct TeacherEvalArgs {
    /// With `--labelled`: score the labelling teacher instead of the robot's detectors.
    #[arg(long, requires = "labelled")]
    pub teacher: bool,
    /// With `--teacher`: every Nth photo only (a quick look; 1 is all).
    #[arg(long, default_value_t = 1, requires = "teacher")]
    pub every: usize,
    /// With `--teacher`: the reports (each event's and pass set's scores at every
    /// threshold) as JSON.
    #[arg(long, requires = "teacher")]
    pub teacher_json: Option<PathBuf>,
}

/// A robot detector scored beside the teacher.
struct Robot {
    name: String,
    detector: vision::Detector,
    classifier: std::sync::Arc<dyn vision::CandidateClassifier + Send + Sync>,
}

/// The robot's detectors of `--beside`, scored box by box beside the teacher (every
/// candidate with its probability).
fn robots(beside: &[String]) -> Result<Vec<Robot>> {
    crate::labelled_cmd::beside_models(beside)?
        .into_iter()
        .map(|s| {
            let (detector, classifier) = s.load()?;
            Ok(Robot {
                name: s.name,
                detector,
                classifier,
            })
        })
        .collect()
}

/// A robot detector's candidates in a photo as ball boxes with their probabilities (the
/// repeats of a ball and those refused outright left out), and its time, milliseconds.
fn robot_boxes(robot: &Robot, image: &vision::RgbImage) -> Result<(Vec<(BallBox, f64)>, f64)> {
    let started = Instant::now();
    let found = vision::photo::detect_photo(
        &robot.detector,
        robot.classifier.as_ref(),
        robot_agent::ValidationConfig::default().min_probability,
        image,
        None,
        &mut vision::NoClock,
    )?
    .into_iter()
    .filter(|c| c.rejection != Some(vision::photo::PhotoRejection::Repeat))
    .filter_map(|c| {
        let p = c.probability?;
        let [x, y] = c.circle.center_px;
        let r = c.circle.radius_px;
        Some((
            BallBox {
                x_min_px: x - r,
                y_min_px: y - r,
                x_max_px: x + r,
                y_max_px: y + r,
            },
            p,
        ))
    })
    .collect();
    Ok((found, started.elapsed().as_secs_f64() * 1000.0))
}

fn pct(v: f64) -> String {
    format!("{:.1}", 100.0 * v)
}

/// The teacher's ball boxes in a photo, as label boxes, and the time the teacher took,
/// milliseconds.
fn ball_boxes(
    teacher: &Teacher,
    image: &vision::RgbImage,
    passes: &Passes,
) -> Result<(Vec<(BallBox, f64)>, f64)> {
    let started = Instant::now();
    let found = teacher
        .detect(image.data(), image.width(), image.height(), passes, 0.05)?
        .iter()
        .filter(|d| d.class == teacher::SPORTS_BALL)
        .map(|d| {
            let t = taught(d);
            (t.ball_box, t.score)
        })
        .collect();
    Ok((found, started.elapsed().as_secs_f64() * 1000.0))
}

/// One photo scored: its event, labelled balls, and per pass set the teacher's ball boxes
/// and time.
struct Scored {
    event: String,
    balls: Vec<BallBox>,
    found: Vec<Vec<(BallBox, f64)>>,
    ms: Vec<f64>,
}

/// The pass sets compared, with their names in the table.
fn pass_sets() -> [(Passes, &'static str); 2] {
    [
        (Passes::quick(), "whole photo"),
        (Passes::labelling(), "whole + tiles + 2× tiles"),
    ]
}

fn row(name: &str, passes: &str, r: &LabellerReport, ms: f64) -> String {
    let bands_of = |a: &AtThreshold| -> String {
        let bands: Vec<String> = (0..4)
            .map(|b| {
                if r.band_balls[b] == 0 {
                    "–".to_string()
                } else {
                    pct(a.band_recall[b])
                }
            })
            .collect();
        bands.join(" / ")
    };
    // The labelling threshold `train` and `detect --teacher` use.
    let accept = TeacherLabelling::default().accept;
    let labelling = r.at_threshold(accept).map_or("– | – | –".to_string(), |a| {
        format!("{} | {} | {}", pct(a.recall), pct(a.precision), bands_of(a))
    });
    let at = |p: f64| match r.at_precision(p) {
        Some(a) => format!("{} @ {:.2} | {}", pct(a.recall), a.threshold, bands_of(a)),
        None => "– | –".to_string(),
    };
    format!(
        "| {name} | {passes} | {} | {} | {} | {labelling} | {} | {} | {:.0} |",
        r.photos,
        r.balls,
        pct(r.reach),
        at(0.95),
        at(0.98),
        ms
    )
}

pub fn run(
    dir: &Path,
    labels: Option<&Path>,
    beside: &[String],
    args: &TeacherEvalArgs,
    doc: Option<&Path>,
    plots: &Path,
) -> Result<()> {
    let folder = LabelledFolder::open(&LabelledArgs {
        images: Some(dir.to_path_buf()),
        labels: labels.map(Path::to_path_buf),
        ball_classes: Vec::new(),
        ball_names: Vec::new(),
        camera: None,
        calibration: None,
    })?;
    let teacher = Teacher::shipped().context("the shipped teacher")?;
    let items: Vec<&Item> = folder.items.iter().step_by(args.every.max(1)).collect();
    let mut events: Vec<String> = items.iter().map(|i| event(i)).collect();
    events.sort();
    events.dedup();
    let bands: Vec<String> = (0..4).map(band_name).collect();
    let mut lines = vec![
        format!(
            "| event | passes | photos | balls | reached % | recall % at the labelling threshold {accept} | precision % there | by width ({bands}) | recall % @ threshold, 95 % precision | by width | recall % @ threshold, 98 % precision | by width | ms a photo |",
            accept = TeacherLabelling::default().accept,
            bands = bands.join(" / ")
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|".to_string(),
    ];
    // Each photo read once and seen through every pass set, then by each robot detector.
    let sets = pass_sets();
    let robots = robots(beside)?;
    let names: Vec<String> = sets
        .iter()
        .map(|(_, n)| n.to_string())
        .chain(robots.iter().map(|r| format!("robot: {}", r.name)))
        .collect();
    let mut scored = Vec::new();
    for (k, item) in items.iter().enumerate() {
        let loaded = robot_agent::load_rgb(&item.image)
            .map_err(anyhow::Error::from)
            .and_then(|image| {
                let balls = folder.labels(item, &image)?.balls;
                let (mut found, mut ms) = (Vec::new(), Vec::new());
                for (passes, _) in &sets {
                    let (f, t) = ball_boxes(&teacher, &image, passes)?;
                    found.push(f);
                    ms.push(t);
                }
                for robot in &robots {
                    let (f, t) = robot_boxes(robot, &image)?;
                    found.push(f);
                    ms.push(t);
                }
                Ok(Scored {
                    event: event(item),
                    balls,
                    found,
                    ms,
                })
            });
        match loaded {
            Ok(s) => scored.push(s),
            Err(err) => eprintln!("{}: left out: {err:#}", item.image.display()),
        }
        if k % 20 == 19 {
            eprintln!("teacher: {} of {} photos", k + 1, items.len());
        }
    }
    let mut json = Vec::new();
    let mut overall: Vec<(&str, LabellerReport)> = Vec::new();
    for (p, name) in names.iter().enumerate() {
        let name = name.as_str();
        let report_of = |rows: Vec<&Scored>| {
            let photos: Vec<PhotoBoxes> = rows
                .iter()
                .map(|s| PhotoBoxes {
                    balls: s.balls.clone(),
                    found: s.found[p].clone(),
                })
                .collect();
            let ms: Vec<f64> = rows.iter().map(|s| s.ms[p]).collect();
            (score(&photos), proto::stats::median(&ms).unwrap_or(0.0))
        };
        for e in &events {
            let (r, median) = report_of(scored.iter().filter(|s| &s.event == e).collect());
            lines.push(row(e, name, &r, median));
            json.push(
                serde_json::json!({"event": e, "passes": name, "report": r, "ms_median": median}),
            );
        }
        let (r, median) = report_of(scored.iter().collect());
        lines.push(row("**all**", name, &r, median));
        json.push(
            serde_json::json!({"event": "all", "passes": name, "report": r, "ms_median": median}),
        );
        overall.push((name, r));
    }
    let table = lines.join("\n");
    println!("{table}");
    let plot = plots.join("teacher-pr.png");
    eval::plot::write_png(&pr_chart(&overall), &plot)?;
    eprintln!("wrote {}", plot.display());
    if let Some(path) = &args.teacher_json {
        std::fs::write(path, serde_json::to_vec_pretty(&json)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = doc {
        let mut every = if args.every > 1 {
            format!(" --every {}", args.every)
        } else {
            String::new()
        };
        for b in beside {
            every.push_str(&format!(" --beside {b}"));
        }
        let section = format!(
            "Produced by `cargo run --release -p eval --bin evaluate -- --labelled {} --teacher{every} --doc {} --plots {}` \
             (real photos; the shipped teacher, and the robot's detectors with every candidate it judged; a box is right when its centre lies in a labelled ball \
             no better box took; recall per labelled ball; \"reached\": a box of any score on the ball).\n\n{table}",
            dir.display(),
            path.display(),
            plots.display()
        );
        report::rewrite_section_between(path, SECTION_BEGIN, SECTION_END, &section)?;
        eprintln!("updated {}", path.display());
    }
    Ok(())
}

/// Box precision against ball recall as the threshold falls, per pass set, with the
/// 10–20 px balls' recall beside (the size most robot-football balls are seen at).
fn pr_chart(reports: &[(&str, LabellerReport)]) -> Chart {
    let mut chart = Chart::new(
        "Ball boxes on real onboard photos: the teacher and the robot's detectors",
        "recall (labelled balls found)",
        "precision (boxes on a ball)",
    );
    chart.x_range = Some((0.0, 1.0));
    chart.y_range = Some((0.0, 1.0));
    for (k, (name, r)) in reports.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let all: Vec<(f64, f64)> = r.curve.iter().map(|a| (a.recall, a.precision)).collect();
        let small: Vec<(f64, f64)> = r
            .curve
            .iter()
            .map(|a| (a.band_recall[1], a.precision))
            .collect();
        chart
            .series
            .push(Series::new(*name, color, Style::Line, all));
        chart.series.push(Series::new(
            format!("{name}: 10–20 px balls"),
            color,
            Style::Dashed,
            small,
        ));
    }
    chart
}
