//! `ball-lab detect`: the detector on a folder of photos (PNG or JPEG, subfolders
//! included, no index, no pose), one JSON line per photo with every candidate it considered,
//! and optionally the photos with the candidates drawn and its balls as label files for a
//! person to correct (`--write-labels yolo|voc DIR`, with `review.csv` listing the least
//! certain photos first).
//!
//! A photo that cannot be read or decoded is reported on its own line (`file`, `error`) and
//! counted; the run goes on and fails at the end if any photo did.

use super::camera_args::{CameraArgs, PhotoCamera};
use super::files::relative_name;
use crate::labels::prelabel::{self, LabelFormat};
use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use serde::Serialize;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use vision::photo::{PhotoCandidate, detect_photo, overlay};
use vision::{CandidateClassifier, Detector, NoClock};

#[derive(Debug, clap::Args)]
pub struct DetectArgs {
    #[command(flatten)]
    pub detector: robot_agent::DetectorArgs,
    /// Folder of photos (PNG or JPEG, subfolders included; other files are left alone).
    #[arg(long)]
    pub images: PathBuf,
    /// Write the published balls as label files to correct in a labelling tool: `yolo DIR`
    /// (`NAME.txt` and `classes.txt`) or `voc DIR` (`NAME.xml`), in the photos' subfolders;
    /// `DIR/review.csv` lists the photos least certain first. A label file that already
    /// exists is kept, not overwritten.
    #[arg(long, num_args = 2, value_names = ["FORMAT", "DIR"])]
    pub write_labels: Vec<String>,
    /// Write the JSON lines here instead of to stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write each photo with its candidates drawn (PNG) to this folder.
    #[arg(long)]
    pub overlays: Option<PathBuf>,
    /// Pipeline settings (TOML: `[detector]`, and `[validation]`'s `min_probability`).
    #[arg(long)]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Label the photos with the teacher (a COCO detector that knows balls; slow, for a
    /// laptop or server) instead of running the robot's detector: with `--write-labels`,
    /// its balls as label files, the photos it doubted in `doubtful.txt` and a contact
    /// sheet.
    #[arg(long, requires = "write_labels")]
    pub teacher: bool,
    #[command(flatten)]
    pub teacher_args: crate::cli::teach::TeacherArgs,
}

/// One photo's line.
#[derive(Debug, Serialize)]
struct PhotoLine {
    file: String,
    width_px: u32,
    height_px: u32,
    /// Detection and classification, without decoding the file.
    time_ms: f64,
    candidates: Vec<CandidateLine>,
}

#[derive(Debug, Serialize)]
struct CandidateLine {
    u_px: f64,
    v_px: f64,
    radius_px: f64,
    probability: Option<f64>,
    published: bool,
    rejection: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    angular_radius_rad: Option<f64>,
}

/// A photo that could not be processed.
#[derive(Debug, Serialize)]
struct FailedLine<'a> {
    file: &'a str,
    error: String,
}

fn round(value: f64, decimals: i32) -> f64 {
    let scale = 10f64.powi(decimals);
    (value * scale).round() / scale
}

impl From<&PhotoCandidate> for CandidateLine {
    fn from(c: &PhotoCandidate) -> Self {
        CandidateLine {
            u_px: round(c.circle.center_px[0], 2),
            v_px: round(c.circle.center_px[1], 2),
            radius_px: round(c.circle.radius_px, 2),
            probability: c.probability.map(|p| round(p, 4)),
            published: c.published(),
            rejection: c.rejection.map(|r| r.reason()),
            angular_radius_rad: c.angular_radius_rad.map(|a| round(a, 5)),
        }
    }
}

/// How long between progress lines on stderr.
const PROGRESS_EVERY: Duration = Duration::from_secs(2);

/// What the detector runs with.
struct Detection {
    detector: Detector,
    classifier: std::sync::Arc<dyn CandidateClassifier + Send + Sync>,
    min_probability: f64,
}

pub fn run(args: DetectArgs) -> Result<()> {
    if args.teacher {
        return run_teacher(&args);
    }
    let config = robot_agent::load_config(args.config.as_deref())?;
    let chosen = args.detector.choose(&config.detector)?;
    eprintln!("{}", chosen.describe());
    let detection = Detection {
        detector: chosen.detector,
        classifier: chosen.classifier,
        min_probability: config.validation.min_probability,
    };
    let mut labels = match args.write_labels.as_slice() {
        [] => None,
        [format, dir] => Some(LabelWriter::new(format, dir, detection.min_probability)?),
        _ => bail!("--write-labels takes a format (yolo or voc) and a folder"),
    };
    let mut camera = PhotoCamera::new(&args.camera)?;
    let files = robot_agent::image_files_recursive(&args.images)?;
    if files.is_empty() {
        bail!(
            "{} and its subfolders hold no PNG or JPEG files",
            args.images.display()
        );
    }
    if let Some(dir) = &args.overlays {
        prepare_overlays(dir, &args.images)?;
    }
    let mut out = lines_out(args.out.as_deref())?;
    let (mut failed, mut with_ball) = (0usize, 0usize);
    let mut last_progress = Instant::now();
    for (k, path) in files.iter().enumerate() {
        let name = relative_name(path, &args.images);
        match detect_one(
            path,
            &name,
            &detection,
            &mut camera,
            args.overlays.as_deref(),
        ) {
            Ok(line) => {
                with_ball += usize::from(line.candidates.iter().any(|c| c.published));
                if let Some(w) = labels.as_mut() {
                    w.add(&name, &line)?;
                }
                writeln!(out, "{}", serde_json::to_string(&line)?)?;
            }
            Err(Failure::Photo(err)) => {
                failed += 1;
                // The error names the photo.
                eprintln!("{err:#}");
                let line = FailedLine {
                    file: &name,
                    error: format!("{err:#}"),
                };
                writeln!(out, "{}", serde_json::to_string(&line)?)?;
            }
            Err(Failure::Fatal(err)) => return Err(err.context(name)),
        }
        if last_progress.elapsed() >= PROGRESS_EVERY {
            eprintln!("{} of {} photos, {failed} failed", k + 1, files.len());
            last_progress = Instant::now();
        }
    }
    out.flush()?;
    eprintln!(
        "{} photos: a ball published in {with_ball}, {failed} could not be processed",
        files.len()
    );
    if let Some(w) = labels {
        w.finish()?;
    }
    if failed > 0 {
        bail!("{failed} of {} photos could not be processed", files.len());
    }
    Ok(())
}

/// `detect --teacher --write-labels FORMAT DIR`: the teacher's labels of every photo, a
/// JSON line each (to `--out` or stdout).
fn run_teacher(args: &DetectArgs) -> Result<()> {
    let [format, dir] = args.write_labels.as_slice() else {
        bail!("--teacher writes labels: give --write-labels yolo|voc DIR");
    };
    let format = LabelFormat::from_str(format, true)
        .map_err(|_| anyhow::anyhow!("--write-labels {format}: the format is yolo or voc"))?;
    let how = args.teacher_args.labelling()?;
    let teacher = args.teacher_args.teacher()?;
    let files = robot_agent::image_files_recursive(&args.images)?;
    let dir = PathBuf::from(dir);
    let output = crate::cli::teach::LabelOutput {
        format,
        keep_existing: true,
        lend: None,
    };
    let labels =
        crate::cli::teach::label_folder(&args.images, &files, &dir, output, &teacher, &how)?;
    let mut out = lines_out(args.out.as_deref())?;
    for r in &labels.records {
        writeln!(out, "{}", serde_json::to_string(r)?)?;
    }
    out.flush()?;
    crate::cli::teach::report(&labels, &dir);
    if labels.failed > 0 {
        bail!(
            "{} of {} photos could not be read",
            labels.failed,
            files.len()
        );
    }
    Ok(())
}

/// Where the JSON lines go: the file named, or stdout.
fn lines_out(path: Option<&Path>) -> Result<Box<dyn Write>> {
    Ok(match path {
        Some(path) => Box::new(BufWriter::new(
            std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?,
        )),
        None => Box::new(BufWriter::new(std::io::stdout().lock())),
    })
}

/// `--write-labels`: the label files and the review list.
struct LabelWriter {
    format: LabelFormat,
    dir: PathBuf,
    threshold: f64,
    written: usize,
    kept: usize,
    /// Per photo: its name, uncertainty, published probability and label file.
    review: Vec<(String, f64, Option<f64>, String)>,
}

impl LabelWriter {
    fn new(format: &str, dir: &str, threshold: f64) -> Result<Self> {
        let format = LabelFormat::from_str(format, true)
            .map_err(|_| anyhow::anyhow!("--write-labels {format}: the format is yolo or voc"))?;
        let dir = PathBuf::from(dir);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(LabelWriter {
            format,
            dir,
            threshold,
            written: 0,
            kept: 0,
            review: Vec::new(),
        })
    }

    /// Writes a photo's label file unless one exists, and notes how sure the detector was.
    fn add(&mut self, name: &str, line: &PhotoLine) -> Result<()> {
        let (w, h) = (line.width_px, line.height_px);
        let balls: Vec<_> = line
            .candidates
            .iter()
            .filter(|c| c.published)
            .filter_map(|c| {
                let circle = vision::Circle {
                    center_px: [c.u_px, c.v_px],
                    radius_px: c.radius_px,
                    score: 1.0,
                };
                prelabel::circle_box(&circle, w, h)
            })
            .collect();
        let rel = Path::new(name).with_extension(self.format.extension());
        let path = self.dir.join(&rel);
        if path.exists() {
            self.kept += 1;
        } else {
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)
                    .with_context(|| format!("creating {}", parent.display()))?;
            }
            let file_name = Path::new(name)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            std::fs::write(&path, self.format.file(&file_name, w, h, &balls))
                .with_context(|| format!("writing {}", path.display()))?;
            self.written += 1;
        }
        let probabilities: Vec<f64> = line
            .candidates
            .iter()
            .filter_map(|c| c.probability)
            .collect();
        let published = line
            .candidates
            .iter()
            .find(|c| c.published)
            .and_then(|c| c.probability);
        self.review.push((
            name.to_string(),
            prelabel::uncertainty(&probabilities, self.threshold),
            published,
            rel.to_string_lossy().replace('\\', "/"),
        ));
        Ok(())
    }

    /// Writes `review.csv` (least certain first) and, for YOLO, `classes.txt` when absent.
    fn finish(mut self) -> Result<()> {
        self.review
            .sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        let mut csv = String::from("photo,uncertainty,ball_probability,label_file\n");
        for (name, u, p, file) in &self.review {
            let p = p.map(|p| format!("{p:.4}")).unwrap_or_default();
            csv += &format!("{},{u:.4},{p},{}\n", csv_field(name), csv_field(file));
        }
        let review = self.dir.join("review.csv");
        std::fs::write(&review, csv).with_context(|| format!("writing {}", review.display()))?;
        if self.format == LabelFormat::Yolo {
            let classes = self.dir.join("classes.txt");
            if !classes.exists() {
                std::fs::write(&classes, "ball\n")
                    .with_context(|| format!("writing {}", classes.display()))?;
            }
        }
        eprintln!(
            "wrote {} to {} ({} kept); {} lists the least certain photos first",
            crate::cli::progress::count(self.written, "label file"),
            self.dir.display(),
            crate::cli::progress::count(self.kept, "existing one"),
            review.display()
        );
        Ok(())
    }
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Why a photo gave no line of candidates.
enum Failure {
    /// The photo itself: reported and counted, the run goes on.
    Photo(anyhow::Error),
    /// The run's set-up does not fit the photos (a calibration of another size).
    Fatal(anyhow::Error),
}

/// One photo: decoded, detected, drawn.
fn detect_one(
    path: &Path,
    name: &str,
    detection: &Detection,
    camera: &mut PhotoCamera,
    overlays: Option<&Path>,
) -> Result<PhotoLine, Failure> {
    let image = robot_agent::load_rgb(path).map_err(|e| Failure::Photo(e.into()))?;
    let (width_px, height_px) = (image.width(), image.height());
    let model = camera
        .for_photo(width_px, height_px)
        .map_err(Failure::Fatal)?;
    let started = Instant::now();
    let candidates = detect_photo(
        &detection.detector,
        detection.classifier.as_ref(),
        detection.min_probability,
        &image,
        model.as_ref(),
        &mut NoClock,
    )
    .map_err(|e| Failure::Photo(anyhow::Error::from(e).context(format!("detecting in {name}"))))?;
    let time_ms = started.elapsed().as_secs_f64() * 1e3;
    if let Some(dir) = overlays {
        write_overlay(dir, name, &image, &candidates).map_err(Failure::Fatal)?;
    }
    Ok(PhotoLine {
        file: name.to_string(),
        width_px,
        height_px,
        time_ms: round(time_ms, 3),
        candidates: candidates.iter().map(CandidateLine::from).collect(),
    })
}

/// Creates the overlay folder; it must not be the photos' own folder, whose next run
/// would take the overlays for photos.
fn prepare_overlays(dir: &Path, images: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let same = |a: &Path, b: &Path| -> Result<bool> {
        let canon = |p: &Path| -> Result<PathBuf> {
            p.canonicalize()
                .with_context(|| format!("reading {}", p.display()))
        };
        Ok(canon(a)? == canon(b)?)
    };
    if same(dir, images)? {
        bail!(
            "--overlays {} is the photos' folder: choose another",
            dir.display()
        );
    }
    Ok(())
}

/// `NAME.png` for a PNG photo, `NAME.EXT.png` for a JPEG (so `a.png` and `a.jpg` do not
/// overwrite each other's).
fn overlay_name(photo: &str) -> String {
    if photo.to_ascii_lowercase().ends_with(".png") {
        photo.to_string()
    } else {
        format!("{photo}.png")
    }
}

fn write_overlay(
    dir: &Path,
    name: &str,
    image: &vision::image::RgbImage,
    candidates: &[PhotoCandidate],
) -> Result<()> {
    let path = dir.join(overlay_name(name));
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    let png = robot_agent::encode_png(&overlay(image, candidates))
        .with_context(|| format!("encoding {}", path.display()))?;
    std::fs::write(&path, png).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlays_of_a_png_and_a_jpeg_of_one_name_do_not_collide() {
        assert_eq!(overlay_name("a.png"), "a.png");
        assert_eq!(overlay_name("B.PNG"), "B.PNG");
        assert_eq!(overlay_name("a.jpg"), "a.jpg.png");
    }

    #[test]
    fn review_names_are_quoted_where_csv_needs_it() {
        assert_eq!(csv_field("a,b.jpg"), "\"a,b.jpg\"");
        assert_eq!(csv_field("plain.jpg"), "plain.jpg");
    }
}
