//! `--sorted DIR`: the agent's detectors on a folder of photos sorted, not boxed: photos in
//! `DIR/Positive/` hold a ball, photos in `DIR/Negative/` hold none (the names can be
//! changed). A photo is scored by whether the detector publishes a ball in it: in a
//! photo with a ball that is a sighting (the box is not checked: there is none), in a photo
//! without one it is a false sighting. A row per detector at the validation's
//! `min_probability`, the same shares as the threshold moves (plotted), and the time per
//! photo. Its generated section is marked `<!-- evaluate-sorted:begin -->` / `…:end -->`.

use crate::labelled_cmd::{Scored, detectors};
use anyhow::{Context, Result};
use eval::plot::{Chart, Marker, PALETTE, Series, Style};
use eval::report;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub const SECTION_BEGIN: &str = "<!-- evaluate-sorted:begin -->";
pub const SECTION_END: &str = "<!-- evaluate-sorted:end -->";

/// The thresholds the sweep reports.
const SWEEP: [f64; 5] = [0.3, 0.5, 0.7, 0.8, 0.9];

#[derive(Debug, Clone, clap::Args)]
pub struct SortedEvalArgs {
    /// Score the detectors on photos sorted into a folder with a ball and one without
    /// (no boxes needed): DIR/Positive and DIR/Negative unless named otherwise.
    #[arg(long, value_name = "DIR")]
    pub sorted: Option<PathBuf>,
    /// With `--sorted`: the subfolder of photos that hold a ball.
    #[arg(long, default_value = "Positive", requires = "sorted")]
    pub with_ball: String,
    /// With `--sorted`: the subfolder of photos that hold none.
    #[arg(long, default_value = "Negative", requires = "sorted")]
    pub without_ball: String,
    /// With `--sorted`: every Nth photo of each folder only (a quick look; 1 is all).
    #[arg(long, default_value_t = 1, requires = "sorted")]
    pub sorted_every: usize,
}

/// What one detector made of one photo.
#[derive(Debug, Clone, Copy)]
struct PhotoResult {
    /// The most probable candidate's probability (0 when there is none).
    best: f64,
    ms: f64,
}

/// One detector's results on both folders.
struct DetectorResult {
    name: String,
    with_ball: Vec<PhotoResult>,
    without_ball: Vec<PhotoResult>,
    unreadable: usize,
}

/// The share of photos whose best candidate reaches `threshold`.
fn share(photos: &[PhotoResult], threshold: f64) -> f64 {
    if photos.is_empty() {
        return f64::NAN;
    }
    photos.iter().filter(|p| p.best >= threshold).count() as f64 / photos.len() as f64
}

fn median_ms(r: &DetectorResult) -> f64 {
    let ms: Vec<f64> = r
        .with_ball
        .iter()
        .chain(&r.without_ball)
        .map(|p| p.ms)
        .collect();
    proto::stats::quantile(&ms, 0.5).unwrap_or(f64::NAN)
}

fn photos_of(dir: &Path, every: usize) -> Result<Vec<PathBuf>> {
    anyhow::ensure!(
        dir.is_dir(),
        "{} is not a folder: --sorted DIR needs the folders of photos with a ball and \
         without one inside it (see --with-ball and --without-ball)",
        dir.display()
    );
    let mut files = robot_agent::image_files_recursive(dir)?;
    files.sort();
    let files: Vec<PathBuf> = files.into_iter().step_by(every.max(1)).collect();
    anyhow::ensure!(!files.is_empty(), "{} holds no photos", dir.display());
    Ok(files)
}

/// Runs one detector over the photos; a photo that cannot be read is counted and left out.
fn run_detector(
    scored: &Scored,
    folders: [&[PathBuf]; 2],
    min_probability: f64,
) -> Result<DetectorResult> {
    let (detector, classifier) = scored.load()?;
    let mut out = DetectorResult {
        name: scored.name.clone(),
        with_ball: Vec::new(),
        without_ball: Vec::new(),
        unreadable: 0,
    };
    let total = folders[0].len() + folders[1].len();
    let bar = tools::progress::Progress::new(total as u64, format!("photos ({})", scored.name));
    for (k, files) in folders.iter().enumerate() {
        for file in files.iter() {
            bar.inc(
                file.file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            );
            let image = match robot_agent::load_rgb(file) {
                Ok(i) => i,
                Err(e) => {
                    bar.suspend(|| eprintln!("{}: left out: {e}", file.display()));
                    out.unreadable += 1;
                    continue;
                }
            };
            let started = Instant::now();
            let candidates = vision::photo::detect_photo(
                &detector,
                classifier.as_ref(),
                min_probability,
                &image,
                None,
                &mut vision::NoClock,
            )
            .with_context(|| format!("{}: {}", scored.name, file.display()))?;
            let ms = started.elapsed().as_secs_f64() * 1e3;
            let best = candidates
                .iter()
                .filter(|c| c.rejection != Some(vision::photo::PhotoRejection::Repeat))
                .filter_map(|c| c.probability)
                .fold(0.0, f64::max);
            let result = PhotoResult { best, ms };
            if k == 0 {
                out.with_ball.push(result);
            } else {
                out.without_ball.push(result);
            }
        }
    }
    bar.finish();
    Ok(out)
}

fn pct(v: f64) -> String {
    if v.is_finite() {
        format!("{:.1}", 100.0 * v)
    } else {
        "–".to_string()
    }
}

/// The share of photos with a ball published against the share of photos without one, as
/// the threshold falls from 1 to 0.
fn chart(results: &[DetectorResult], title: &str) -> Chart {
    let mut chart = Chart::new(
        title,
        "photos with no ball: a ball published (false)",
        "photos with a ball: a ball published",
    );
    chart.x_range = Some((0.0, 1.0));
    chart.y_range = Some((0.0, 1.0));
    for (k, r) in results.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let points: Vec<(f64, f64)> = (0..=100)
            .rev()
            .map(|i| {
                let t = f64::from(i) / 100.0;
                (share(&r.without_ball, t), share(&r.with_ball, t))
            })
            .collect();
        chart
            .series
            .push(Series::new(r.name.clone(), color, Style::Line, points));
        let at = |t: f64| (share(&r.without_ball, t), share(&r.with_ball, t));
        chart.series.push(Series::new(
            "",
            color,
            Style::Markers(Marker::Circle),
            vec![at(robot_agent::ValidationConfig::default().min_probability)],
        ));
    }
    chart
}

/// Scores the shipped detectors (and `--beside`'s) on the sorted folders; prints the table
/// and, with `doc`, writes it and its plot.
pub fn run(
    args: &SortedEvalArgs,
    beside: &[String],
    doc: Option<&Path>,
    plots: &Path,
) -> Result<()> {
    let Some(dir) = &args.sorted else {
        anyhow::bail!("--sorted DIR is needed");
    };
    let with = photos_of(&dir.join(&args.with_ball), args.sorted_every)?;
    let without = photos_of(&dir.join(&args.without_ball), args.sorted_every)?;
    let min_probability = robot_agent::ValidationConfig::default().min_probability;
    let mut results = Vec::new();
    for scored in detectors(beside)? {
        results.push(run_detector(&scored, [&with, &without], min_probability)?);
    }
    let mut lines = vec![
        format!(
            "| detector | photos with a ball: a ball published % | photos with no ball: a ball published (false) % | {} | ms median |",
            SWEEP
                .iter()
                .map(|t| format!("at {t}: with / without %"))
                .collect::<Vec<_>>()
                .join(" | ")
        ),
        format!("|---|---|---|{}---|", "---|".repeat(SWEEP.len())),
    ];
    for r in &results {
        let sweep: Vec<String> = SWEEP
            .iter()
            .map(|&t| {
                format!(
                    "{} / {}",
                    pct(share(&r.with_ball, t)),
                    pct(share(&r.without_ball, t))
                )
            })
            .collect();
        lines.push(format!(
            "| {}{} | {} | {} | {} | {:.1} |",
            r.name,
            if r.unreadable > 0 {
                format!(" ({} unreadable)", r.unreadable)
            } else {
                String::new()
            },
            pct(share(&r.with_ball, min_probability)),
            pct(share(&r.without_ball, min_probability)),
            sweep.join(" | "),
            median_ms(r)
        ));
    }
    let table = lines.join("\n");
    println!("{table}");
    let folder_name = dir
        .file_name()
        .map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into());
    let plot_name = format!("sorted-{folder_name}.png");
    let plot_path = plots.join(&plot_name);
    std::fs::create_dir_all(plots).with_context(|| format!("creating {}", plots.display()))?;
    eval::plot::write_png(
        &chart(
            &results,
            &format!("{folder_name}: photos with and without a ball, as the threshold falls"),
        ),
        &plot_path,
    )?;
    eprintln!("wrote {}", plot_path.display());
    if let Some(path) = doc {
        let mut cmd = format!(
            "cargo run --release -p eval --bin evaluate -- --sorted {}",
            dir.display()
        );
        if args.with_ball != "Positive" {
            cmd.push_str(&format!(" --with-ball {}", args.with_ball));
        }
        if args.without_ball != "Negative" {
            cmd.push_str(&format!(" --without-ball {}", args.without_ball));
        }
        if args.sorted_every > 1 {
            cmd.push_str(&format!(" --sorted-every {}", args.sorted_every));
        }
        for m in beside {
            cmd.push_str(&format!(" --beside {m}"));
        }
        cmd.push_str(&format!(
            " --doc {} --plots {}",
            path.display(),
            plots.display()
        ));
        let section = format!(
            "Produced by `{cmd}` (real photos, {} with a ball and {} without; no camera \
             model; a photo counts as a ball published when its most probable candidate \
             reaches the threshold, `min_probability` {min_probability} in the first two \
             columns, whether or not the candidate lies on the ball: the photos carry no \
             boxes).\n\n{table}\n\n![{folder_name}]({})",
            with.len(),
            without.len(),
            relative_plot(path, &plot_path)
        );
        report::rewrite_section_between(path, SECTION_BEGIN, SECTION_END, &section)?;
        eprintln!("updated {}", path.display());
    }
    Ok(())
}

/// The plot's path as the document links it (relative to the document's folder when it is
/// below it).
fn relative_plot(doc: &Path, plot: &Path) -> String {
    let base = doc.parent().unwrap_or(Path::new(""));
    plot.strip_prefix(base)
        .unwrap_or(plot)
        .display()
        .to_string()
}
