//! Labelling photos with the teacher, for `train` on photos nobody labelled and for
//! `detect --teacher --write-labels`: every photo's balls, doubts and named negatives
//! (`labels::teacher`), written as label files a labelling tool opens, with the photos the
//! teacher doubted listed apart (`doubtful.txt`: left out of training, worth a person's
//! look first), every photo's labels as JSON lines (`teacher-labels.jsonl`, which a later
//! run reuses instead of asking the teacher again) and a contact sheet of a sample
//! (`contact-sheet.png`) to glance at.

use crate::cli::progress::bar;
use crate::labels::BallBox;
use crate::labels::prelabel::LabelFormat;
use crate::labels::teacher::{
    Agreement, PhotoLabels, Settled, Taught, TeacherLabelling, label_photo, settle,
};
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use teacher::{Passes, Teacher};
use vision::image::RgbImage;

/// `--teacher-passes`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PassesArg {
    /// The whole photo, tiles at its own resolution and tiles enlarged twice: small balls
    /// too.
    Labelling,
    /// The whole photo once: large balls only.
    Quick,
}

/// The teacher's flags.
#[derive(Debug, Clone, clap::Args)]
pub struct TeacherArgs {
    /// A teacher weights file of `teacher convert` in place of the shipped one.
    #[arg(long, value_name = "FILE")]
    pub teacher_weights: Option<PathBuf>,
    /// A sports ball the teacher scores at least this is labelled a ball.
    #[arg(long, default_value_t = TeacherLabelling::default().accept)]
    pub teacher_accept: f64,
    /// A sports ball the teacher scores at least this, and below `--teacher-accept`,
    /// makes its photo doubtful (left out of training, listed for a person).
    #[arg(long, default_value_t = TeacherLabelling::default().doubt)]
    pub teacher_doubt: f64,
    /// Where the teacher looks in a photo.
    #[arg(long, value_enum, default_value_t = PassesArg::Labelling)]
    pub teacher_passes: PassesArg,
    /// Photos may hold several balls: a doubt beside a sure ball makes the photo doubtful
    /// too (by default, one ball a photo, such a doubt is taken for something else).
    #[arg(long)]
    pub teacher_several_balls: bool,
}

impl TeacherArgs {
    pub fn labelling(&self) -> Result<TeacherLabelling> {
        let passes = match self.teacher_passes {
            PassesArg::Quick => Passes::quick(),
            PassesArg::Labelling => Passes::labelling(),
        };
        let (accept, doubt) = (self.teacher_accept, self.teacher_doubt);
        if !(0.0..=1.0).contains(&accept) || !(0.0..=accept).contains(&doubt) {
            bail!(
                "--teacher-accept {accept} and --teacher-doubt {doubt}: scores are 0 to 1, \
                 and the doubt is at most the accept"
            );
        }
        Ok(TeacherLabelling {
            passes,
            accept,
            doubt,
            one_ball: !self.teacher_several_balls,
            ..TeacherLabelling::default()
        })
    }

    /// The teacher: the shipped one, or the weights file named.
    pub fn teacher(&self) -> Result<Teacher> {
        match &self.teacher_weights {
            None => Teacher::shipped().context("the shipped teacher"),
            Some(path) => {
                let bytes = std::fs::read(path)
                    .with_context(|| format!("reading the teacher's weights {}", path.display()))?;
                Teacher::from_safetensors(&bytes).with_context(|| {
                    format!(
                        "{} is not a teacher weights file: make one with teacher/convert.sh",
                        path.display()
                    )
                })
            }
        }
    }
}

/// One photo's labels as a line of `teacher-labels.jsonl`: boxes `[x0, y0, x1, y1, score]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LabelRecord {
    pub photo: String,
    pub width_px: u32,
    pub height_px: u32,
    pub balls: Vec<[f64; 5]>,
    pub doubts: Vec<[f64; 5]>,
    /// Doubts beside a sure ball, taken for something else (one ball a photo).
    #[serde(default)]
    pub beside: Vec<[f64; 5]>,
    #[serde(default)]
    pub negatives: Vec<(String, [f64; 5])>,
    /// The teacher's settings, so a run with others asks again.
    pub settings: String,
}

fn boxed(t: &Taught) -> [f64; 5] {
    let b = &t.ball_box;
    let r = |v: f64| (v * 100.0).round() / 100.0;
    [
        r(b.x_min_px),
        r(b.y_min_px),
        r(b.x_max_px),
        r(b.y_max_px),
        (t.score * 1e4).round() / 1e4,
    ]
}

fn ball_box(v: &[f64; 5]) -> BallBox {
    BallBox {
        x_min_px: v[0],
        y_min_px: v[1],
        x_max_px: v[2],
        y_max_px: v[3],
    }
}

impl LabelRecord {
    fn new(photo: &str, image: &RgbImage, labels: &PhotoLabels, settings: &str) -> Self {
        LabelRecord {
            photo: photo.to_string(),
            width_px: image.width(),
            height_px: image.height(),
            balls: labels.balls.iter().map(boxed).collect(),
            doubts: labels.doubts.iter().map(boxed).collect(),
            beside: labels.beside.iter().map(boxed).collect(),
            negatives: labels
                .negatives
                .iter()
                .map(|(n, t)| ((*n).to_string(), boxed(t)))
                .collect(),
            settings: settings.to_string(),
        }
    }

    pub fn ball_boxes(&self) -> Vec<BallBox> {
        self.balls.iter().map(ball_box).collect()
    }

    /// What the teacher took for something else: the doubts beside a sure ball and its
    /// named negatives.
    pub fn not_balls(&self) -> Vec<BallBox> {
        self.beside
            .iter()
            .chain(self.negatives.iter().map(|(_, v)| v))
            .map(ball_box)
            .collect()
    }

    /// The record's boxes as labels (named negatives left out).
    fn labels(&self) -> PhotoLabels {
        let taught = |v: &[f64; 5]| Taught {
            ball_box: ball_box(v),
            score: v[4],
        };
        PhotoLabels {
            balls: self.balls.iter().map(taught).collect(),
            doubts: self.doubts.iter().map(taught).collect(),
            beside: self.beside.iter().map(taught).collect(),
            negatives: Vec::new(),
        }
    }

    /// The balls and doubts of `labels` in place of the record's.
    fn set_labels(&mut self, labels: &PhotoLabels) {
        self.balls = labels.balls.iter().map(boxed).collect();
        self.doubts = labels.doubts.iter().map(boxed).collect();
        self.beside = labels.beside.iter().map(boxed).collect();
    }

    pub fn certain(&self) -> bool {
        self.doubts.is_empty()
    }

    /// The sports balls split again by their scores, as [`label_photo`] splits them.
    fn resplit(&mut self, how: &TeacherLabelling) {
        let mut all: Vec<[f64; 5]> = std::mem::take(&mut self.balls);
        all.append(&mut self.doubts);
        all.append(&mut self.beside);
        all.sort_by(|a, b| b[4].total_cmp(&a[4]));
        for v in all {
            if v[4] >= how.accept {
                self.balls.push(v);
            } else if v[4] >= how.doubt {
                self.doubts.push(v);
            }
        }
        if how.one_ball && !self.balls.is_empty() {
            self.beside = std::mem::take(&mut self.doubts);
        }
    }
}

fn settings_key(how: &TeacherLabelling) -> String {
    format!(
        "passes {:?}, accept {}, doubt {}, negative {}, one ball {}",
        how.passes, how.accept, how.doubt, how.negative, how.one_ball
    )
}

/// What labelling a folder made.
#[derive(Debug, Default)]
pub struct FolderLabels {
    pub records: Vec<LabelRecord>,
    /// Photos that could not be read.
    pub failed: usize,
    /// Photos whose labels came from an earlier run's `teacher-labels.jsonl`.
    pub reused: usize,
}

impl FolderLabels {
    /// The relative names of the doubtful photos.
    pub fn doubtful(&self) -> BTreeSet<String> {
        self.records
            .iter()
            .filter(|r| !r.certain())
            .map(|r| r.photo.clone())
            .collect()
    }

    /// Photos with a ball, balls, doubtful photos, named negatives.
    pub fn counts(&self) -> (usize, usize, usize, usize) {
        let with_ball = self.records.iter().filter(|r| !r.balls.is_empty()).count();
        let balls = self.records.iter().map(|r| r.balls.len()).sum();
        let doubtful = self.records.iter().filter(|r| !r.certain()).count();
        let negatives = self.records.iter().map(|r| r.negatives.len()).sum();
        (with_ball, balls, doubtful, negatives)
    }
}

/// How long between progress lines on stderr (for logs, where no bar is drawn).
const PROGRESS_EVERY: Duration = Duration::from_secs(10);

/// How a folder's labels are written.
#[derive(Debug, Clone, Copy)]
pub struct LabelOutput {
    pub format: LabelFormat,
    /// Keep a label file already there (a person may have corrected it) instead of
    /// writing the teacher's over it.
    pub keep_existing: bool,
    /// The photos are a recording's frames (a folder per camera, named by capture time in
    /// nanoseconds): neighbours up to this many frames away lend each other labels
    /// ([`lend_labels`](crate::labels::teacher::lend_labels)).
    pub lend: Option<usize>,
}

/// Labels every photo of `files` (below `images`) with the teacher into `out`: label files,
/// `doubtful.txt`, `teacher-labels.jsonl` and `contact-sheet.png`.
pub fn label_folder(
    images: &Path,
    files: &[PathBuf],
    out: &Path,
    output: LabelOutput,
    teacher: &Teacher,
    how: &TeacherLabelling,
) -> Result<FolderLabels> {
    if files.is_empty() {
        bail!(
            "{} and its subfolders hold no PNG or JPEG files",
            images.display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let settings = settings_key(how);
    let jsonl = out.join("teacher-labels.jsonl");
    let mut known: BTreeMap<String, LabelRecord> = BTreeMap::new();
    if let Ok(text) = std::fs::read_to_string(&jsonl) {
        for line in text.lines().filter(|l| !l.trim().is_empty()) {
            // A line of another version or a truncated last line is asked again.
            if let Ok(r) = serde_json::from_str::<LabelRecord>(line)
                && r.settings == settings
            {
                known.insert(r.photo.clone(), r);
            }
        }
    }
    let bar = bar(files.len(), "teacher labelling");
    let mut result = FolderLabels::default();
    let started = Instant::now();
    let mut last_line = Instant::now();
    let mut fresh = 0usize;
    for (k, path) in files.iter().enumerate() {
        let name = crate::cli::files::relative_name(path, images);
        if let Some(mut r) = known.remove(&name) {
            // As the teacher gave them, whatever a student or a recording's frames made
            // of them in the run that wrote them.
            r.resplit(how);
            result.records.push(r);
            result.reused += 1;
        } else {
            match robot_agent::load_rgb(path) {
                Ok(image) => {
                    let labels = label_photo(teacher, &image, how)
                        .with_context(|| format!("the teacher on {}", path.display()))?;
                    result
                        .records
                        .push(LabelRecord::new(&name, &image, &labels, &settings));
                    fresh += 1;
                }
                Err(e) => {
                    result.failed += 1;
                    bar.suspend(|| eprintln!("{}: left out: {e}", path.display()));
                }
            }
        }
        bar.inc(1);
        if bar.is_hidden() && last_line.elapsed() >= PROGRESS_EVERY {
            let per = started.elapsed().as_secs_f64() / fresh.max(1) as f64;
            eprintln!(
                "teacher labelling: {} of {} photos ({:.1} s a photo, about {:.0} min left)",
                k + 1,
                files.len(),
                per,
                per * (files.len() - k - 1) as f64 / 60.0
            );
            last_line = Instant::now();
        }
    }
    bar.finish_and_clear();
    if let Some(max_gap) = output.lend {
        let (promoted, demoted) = lend_between_frames(&mut result.records, max_gap);
        eprintln!(
            "frames lent each other labels: {promoted} doubts on the ball's path became \
             balls, {demoted} balls off it became doubts"
        );
    }
    write_outputs(out, output, &result)?;
    contact_sheet(images, &result.records, &out.join("contact-sheet.png"))?;
    Ok(result)
}

/// The student's word on every photo's labels ([`settle`]): `judge` is its probability
/// that a circle in a photo holds a ball. The photos are read again from `images`; a
/// photo that cannot be read keeps its labels. Returns what changed.
pub fn settle_folder(
    images: &Path,
    labels: &mut FolderLabels,
    how: &Agreement,
    judge: impl Fn(&RgbImage, &vision::Circle) -> Option<f64>,
) -> Settled {
    let mut total = Settled::default();
    let bar = bar(
        labels.records.len(),
        "the student judges the teacher's labels",
    );
    for r in &mut labels.records {
        bar.inc(1);
        if r.balls.is_empty() && r.doubts.is_empty() {
            continue;
        }
        let Ok(image) = robot_agent::load_rgb(&images.join(&r.photo)) else {
            continue;
        };
        let mut photo = r.labels();
        total += settle(&mut photo, how, |b| {
            judge(&image, &crate::cli::net_train::box_circle(b))
        });
        r.set_labels(&photo);
    }
    bar.finish_and_clear();
    total
}

/// [`lend_labels`](crate::labels::teacher::lend_labels) over each camera's frames in time
/// order (a frame's time from its file name, nanoseconds).
fn lend_between_frames(records: &mut [LabelRecord], max_gap: usize) -> (usize, usize) {
    let mut cameras: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (k, r) in records.iter().enumerate() {
        let folder = Path::new(&r.photo)
            .parent()
            .map(|p| p.to_string_lossy().into_owned())
            .unwrap_or_default();
        cameras.entry(folder).or_default().push(k);
    }
    let (mut promoted, mut demoted) = (0, 0);
    for indices in cameras.values() {
        let mut frames: Vec<(f64, PhotoLabels)> = indices
            .iter()
            .map(|&k| (frame_time_s(&records[k].photo), records[k].labels()))
            .collect();
        let mut order: Vec<usize> = (0..frames.len()).collect();
        order.sort_by(|a, b| frames[*a].0.total_cmp(&frames[*b].0));
        let mut sorted: Vec<(f64, PhotoLabels)> = order
            .iter()
            .map(|&i| std::mem::take(&mut frames[i]))
            .collect();
        let (p, d) = crate::labels::teacher::lend_labels(&mut sorted, max_gap);
        promoted += p;
        demoted += d;
        for (&i, (_, labels)) in order.iter().zip(sorted) {
            records[indices[i]].set_labels(&labels);
        }
    }
    (promoted, demoted)
}

/// A frame's capture time from its file name (`{nanoseconds}.png`), seconds.
fn frame_time_s(photo: &str) -> f64 {
    Path::new(photo)
        .file_stem()
        .and_then(|s| s.to_str())
        .and_then(|s| s.parse::<u64>().ok())
        .map_or(0.0, |ns| ns as f64 * 1e-9)
}

/// Every `every`-th frame of each camera of a recording (MCAP: the agent's own recordings
/// or a MiRo's ROS bag), written as PNG photos `{left,right}/{capture ns}.png` under `dir`
/// for the teacher to label. Returns how many.
pub fn recording_frames(recording: &Path, dir: &Path, every: usize) -> Result<usize> {
    use robot_agent::FrameSource;
    let mut source =
        robot_agent::McapSource::open(recording.to_path_buf(), &robot_agent::RosTopics::default())
            .with_context(|| format!("reading the recording {}", recording.display()))?;
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut written = 0;
    while let Some(frame) = source.next_frame()? {
        let camera = format!("{:?}", frame.camera).to_lowercase();
        let n = seen.entry(camera.clone()).or_default();
        *n += 1;
        if !(*n - 1).is_multiple_of(every.max(1)) {
            continue;
        }
        let folder = dir.join(&camera);
        std::fs::create_dir_all(&folder)
            .with_context(|| format!("creating {}", folder.display()))?;
        let path = folder.join(format!("{:020}.png", frame.stamp.0));
        if !path.exists() {
            let png = robot_agent::encode_png(&frame.image)?;
            std::fs::write(&path, png).with_context(|| format!("writing {}", path.display()))?;
        }
        written += 1;
    }
    if written == 0 {
        bail!(
            "{} holds no camera frames the agent reads (a ROS recording's camera topics, or \
             the agent's own recordings)",
            recording.display()
        );
    }
    Ok(written)
}

/// The label files, the doubtful list, the records and the contact sheet.
pub fn write_outputs(out: &Path, output: LabelOutput, labels: &FolderLabels) -> Result<()> {
    let format = output.format;
    let mut jsonl = String::new();
    for r in &labels.records {
        jsonl += &serde_json::to_string(r)?;
        jsonl.push('\n');
        let rel = Path::new(&r.photo).with_extension(format.extension());
        let path = out.join(&rel);
        if output.keep_existing && path.exists() {
            continue;
        }
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("creating {}", parent.display()))?;
        }
        let file_name = Path::new(&r.photo)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        std::fs::write(
            &path,
            format.file(&file_name, r.width_px, r.height_px, &r.ball_boxes()),
        )
        .with_context(|| format!("writing {}", path.display()))?;
    }
    crate::cli::files::write_file(&out.join("teacher-labels.jsonl"), jsonl.as_bytes())?;
    let doubtful: String = labels.doubtful().into_iter().map(|n| n + "\n").collect();
    crate::cli::files::write_file(&out.join("doubtful.txt"), doubtful.as_bytes())?;
    if format == LabelFormat::Yolo {
        let classes = out.join("classes.txt");
        if !classes.exists() {
            std::fs::write(&classes, "ball\n")
                .with_context(|| format!("writing {}", classes.display()))?;
        }
    }
    Ok(())
}

/// Photos on the contact sheet, and its columns and thumbnail side.
const SHEET_PHOTOS: usize = 24;
const SHEET_COLUMNS: usize = 6;
const THUMB_PX: u32 = 200;

/// A sample of the labelled photos, small, with the teacher's boxes drawn (green: a ball,
/// orange: a doubt, blue: a named negative): the doubtful photos first (up to a third),
/// then photos with balls and without, spread over the folder.
pub fn contact_sheet(images: &Path, records: &[LabelRecord], path: &Path) -> Result<()> {
    let doubtful: Vec<&LabelRecord> = records.iter().filter(|r| !r.certain()).collect();
    let sure: Vec<&LabelRecord> = records.iter().filter(|r| r.certain()).collect();
    let mut chosen: Vec<&LabelRecord> = spread(&doubtful, SHEET_PHOTOS / 3);
    chosen.extend(spread(&sure, SHEET_PHOTOS - chosen.len()));
    if chosen.is_empty() {
        return Ok(());
    }
    let rows = chosen.len().div_ceil(SHEET_COLUMNS);
    let cols = chosen.len().min(SHEET_COLUMNS);
    let mut sheet = RgbImage::filled(cols as u32 * THUMB_PX, rows as u32 * THUMB_PX, [32, 32, 32])?;
    for (k, r) in chosen.iter().enumerate() {
        let Ok(image) = robot_agent::load_rgb(&images.join(&r.photo)) else {
            continue;
        };
        let scale = f64::from(THUMB_PX) / f64::from(image.width().max(image.height()));
        let (ox, oy) = (
            (k % SHEET_COLUMNS) as u32 * THUMB_PX,
            (k / SHEET_COLUMNS) as u32 * THUMB_PX,
        );
        for y in 0..THUMB_PX {
            for x in 0..THUMB_PX {
                let (sx, sy) = ((f64::from(x) + 0.5) / scale, (f64::from(y) + 0.5) / scale);
                if let Some(px) = image.pixel(sx as u32, sy as u32) {
                    sheet.set_pixel(ox + x, oy + y, px);
                }
            }
        }
        let mut draw = |v: &[f64; 5], rgb: [u8; 3]| {
            let b = ball_box(v);
            let to = |p: f64| (p + 0.5) * scale;
            rectangle(
                &mut sheet,
                [ox, oy],
                [
                    to(b.x_min_px),
                    to(b.y_min_px),
                    to(b.x_max_px),
                    to(b.y_max_px),
                ],
                rgb,
            );
        };
        for (_, v) in &r.negatives {
            draw(v, [60, 140, 255]);
        }
        for v in r.doubts.iter().chain(&r.beside) {
            draw(v, [255, 150, 0]);
        }
        for v in &r.balls {
            draw(v, [0, 230, 60]);
        }
    }
    let png = robot_agent::encode_png(&sheet)?;
    crate::cli::files::write_file(path, &png)
}

/// Up to `n` of `items`, evenly spread.
fn spread<'a>(items: &[&'a LabelRecord], n: usize) -> Vec<&'a LabelRecord> {
    if items.len() <= n {
        return items.to_vec();
    }
    (0..n).map(|k| items[k * items.len() / n]).collect()
}

/// A box's outline (at least 3 px wide, so a small ball's shows) on a thumbnail at `origin`.
fn rectangle(image: &mut RgbImage, origin: [u32; 2], b: [f64; 4], rgb: [u8; 3]) {
    let c = [(b[0] + b[2]) / 2.0, (b[1] + b[3]) / 2.0];
    let half = [
        ((b[2] - b[0]) / 2.0).max(1.5),
        ((b[3] - b[1]) / 2.0).max(1.5),
    ];
    let (x0, x1) = (
        (c[0] - half[0]).floor() as i64,
        (c[0] + half[0]).ceil() as i64,
    );
    let (y0, y1) = (
        (c[1] - half[1]).floor() as i64,
        (c[1] + half[1]).ceil() as i64,
    );
    let limit = i64::from(THUMB_PX) - 1;
    for y in y0.max(0)..=y1.min(limit) {
        for x in x0.max(0)..=x1.min(limit) {
            if x == x0 || x == x1 || y == y0 || y == y1 {
                image.set_pixel(origin[0] + x as u32, origin[1] + y as u32, rgb);
            }
        }
    }
}

/// Says what the teacher made.
pub fn report(labels: &FolderLabels, out: &Path) {
    let (with_ball, balls, doubtful, negatives) = labels.counts();
    eprintln!(
        "the teacher labelled {} photos ({} from an earlier run): {balls} balls in {with_ball} \
         photos, {doubtful} photos doubtful (left out of training; listed in {}), {negatives} \
         named negatives, {} photos unreadable; labels in {}",
        labels.records.len(),
        labels.reused,
        out.join("doubtful.txt").display(),
        labels.failed,
        out.display()
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reused_record_is_split_again_as_the_teacher_gave_it() {
        let how = TeacherLabelling::default();
        let b = |x: f64, score: f64| [x, 0.0, x + 10.0, 10.0, score];
        // A student made a ball of the doubt at 0.3 and a doubt of the sure ball at 0.8.
        let mut r = LabelRecord {
            photo: "a.png".into(),
            width_px: 100,
            height_px: 100,
            balls: vec![b(0.0, 0.3)],
            doubts: vec![b(50.0, 0.8)],
            beside: vec![b(80.0, 0.02)],
            negatives: Vec::new(),
            settings: settings_key(&how),
        };
        r.resplit(&how);
        assert_eq!(r.balls, vec![b(50.0, 0.8)]);
        // One ball a photo: the doubt beside the sure ball is something else; what is
        // below the doubt threshold is dropped.
        assert_eq!(r.beside, vec![b(0.0, 0.3)]);
        assert!(r.certain());
    }
}
