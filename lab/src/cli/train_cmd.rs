//! `ball-lab train`: the two-stage detector (default, fine-tuned from the shipped one)
//! or the colour-patch ball network from photos with labelled ball boxes, or the HOG + SVM
//! classifier from the same photos or from folders of ball and non-ball patches.

use crate::cli::detector_train::{DetectorTraining, train_detector};
use crate::cli::files::{relative_name, write_file};
use crate::cli::labelled::{Item, LabelledArgs, LabelledFolder};
use crate::cli::net_train::{held_out, train_on_photos};
use crate::cli::train::{fit_and_write, folder_patches, labelled_folder_patches};
use crate::training::ballnet_data::SampleConfig;
use crate::training::ballnet_train::NetTrainConfig;
use crate::training::detector_train::StageTrainConfig;
use anyhow::{Context, Result, bail};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Which classifier to train.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelKind {
    /// The two-stage detector: the candidate network and the grey checker, one
    /// `.safetensors` file that `run`, `detect` and `evaluate` take with `--detector
    /// two-stage --model`.
    Detector,
    /// The colour-patch ball network that judges the robot's detector's candidates (the
    /// default): any ball colour, refines the ball's circle (`.safetensors`, taken with
    /// `--model`).
    Cnn,
    /// The HOG + SVM filter of the colour detector (`.json`).
    HogSvm,
}

#[derive(Debug, Clone, clap::Args)]
pub struct TrainArgs {
    /// The model to train. Default: the robot's detector's ball network from photos, the
    /// HOG + SVM filter from patch folders.
    #[arg(long, value_enum)]
    pub model: Option<ModelKind>,
    /// Folder of ball patches (PNG or JPEG, any size; each image is one candidate window;
    /// HOG + SVM only).
    #[arg(
        long,
        requires = "negatives",
        required_unless_present_any = ["images", "source"],
        conflicts_with = "images"
    )]
    pub positives: Option<PathBuf>,
    /// Folder of non-ball patches.
    #[arg(long, requires = "positives")]
    pub negatives: Option<PathBuf>,
    /// Labelled photos (`--images DIR [--labels DIR]`, as `evaluate` takes them).
    #[command(flatten)]
    pub labelled: LabelledArgs,
    /// Hold out a subfolder of `--images` (an event: repeatable) for the held-out score;
    /// `none` holds nothing out. Default: the event folder nearest a fifth of the photos
    /// (with three events or more), else every fifth photo.
    #[arg(long = "hold-out", value_name = "FOLDER")]
    pub hold_out: Vec<String>,
    /// A separate folder of labelled photos (labels beside them) for the held-out score.
    #[arg(long, value_name = "DIR")]
    pub val: Option<PathBuf>,
    /// Training epochs (ball network).
    #[arg(long, default_value_t = NetTrainConfig::default().epochs)]
    pub epochs: usize,
    /// Samples per batch (ball network).
    #[arg(long, default_value_t = NetTrainConfig::default().batch)]
    pub batch: usize,
    /// Peak learning rate (ball network; cosine schedule).
    #[arg(long, default_value_t = NetTrainConfig::default().learning_rate)]
    pub learning_rate: f64,
    /// Train without augmentation (ball network).
    #[arg(long)]
    pub no_augment: bool,
    /// The largest hue turn of the colour augmentation, degrees (180: any ball colour).
    #[arg(long, default_value_t = NetTrainConfig::default().max_hue_turn_rad.to_degrees())]
    pub hue_turn_deg: f64,
    /// Moved and scaled copies of every labelled ball (ball network).
    #[arg(long, default_value_t = SampleConfig::default().copies_per_ball)]
    pub copies: usize,
    /// Appearance proposals per photo that become samples (ball network; more gives more
    /// hard negatives). Default: as many as the detector makes.
    #[arg(long)]
    pub proposals: Option<usize>,
    /// Random negative windows per labelled photo.
    #[arg(long, default_value_t = 8)]
    pub random_negatives: usize,
    /// Seed of the samples, the augmentation, the initial weights and (HOG + SVM) the split
    /// and folds.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Epochs of the candidate network (detector). Default: 12 when fine-tuning, 30 from
    /// random weights.
    #[arg(long)]
    pub candidate_epochs: Option<usize>,
    /// Epochs of the grey checker (detector). Default: 8 when fine-tuning, 15 from random
    /// weights.
    #[arg(long)]
    pub checker_epochs: Option<usize>,
    /// Rounds of hard-negative mining (detector): after the checker's training, the whole
    /// detector runs over the training photos, what the checker accepts away from every
    /// ball is added to its samples, and it trains on for a few epochs.
    #[arg(long, default_value_t = 0)]
    pub hard_negative_rounds: usize,
    /// The detector file whose two stages are fine-tuned (detector): `shipped` (the
    /// default) for the shipped detector, `none` to start from random weights.
    #[arg(long, value_name = "MODEL", default_value = "shipped")]
    pub from: PathBuf,
    /// Where to write the model (`.safetensors` for the networks, JSON for HOG + SVM).
    #[arg(long)]
    pub out: PathBuf,
    /// The held-out precision-recall curve as a PNG (ball network).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// The held-out report as JSON (ball network).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Label the photos with the teacher (a COCO detector that knows balls) and train on
    /// its labels, even where label files exist. Without label files, this is what
    /// happens anyway.
    #[arg(long)]
    pub teacher: bool,
    /// Where the teacher's labels go (YOLO files, `doubtful.txt`, `teacher-labels.jsonl`,
    /// `contact-sheet.png`). Default: beside `--out`, named after it with `.labels`.
    #[arg(long, value_name = "DIR")]
    pub teacher_labels: Option<PathBuf>,
    #[command(flatten)]
    pub teacher_args: crate::cli::teach::TeacherArgs,
    /// Train on a recording's frames instead of photos: `mcap:FILE` (the agent's own
    /// recordings, or a MiRo's ROS bag in MCAP). The teacher labels them, neighbouring
    /// frames lending each other labels; the frames are written as photos beside the labels.
    #[arg(long, value_name = "mcap:FILE", conflicts_with = "images")]
    pub source: Option<String>,
    /// More labelled photos the ball network trains on as they are, beside `--images`
    /// (randomised photos of other ball designs, another team's labelled set): never held
    /// out, never labelled by the teacher. A folder with `images/` and `labels/` inside
    /// is read as YOLO's layout (repeatable).
    #[arg(long, value_name = "DIR")]
    pub also: Vec<PathBuf>,
    /// Rounds in which the network trained on the teacher's labels (the student) settles
    /// the teacher's doubts before the last training: a doubt the student is sure of
    /// becomes the photo's ball, a sure ball it calls background a doubt.
    #[arg(long, default_value_t = 3)]
    pub student_rounds: usize,
    /// With `--source`: every Nth frame of each camera (neighbouring frames are near
    /// copies of each other).
    #[arg(long, default_value_t = 1, requires = "source")]
    pub frame_step: usize,
}

/// How many frames away a frame's neighbours lend it labels.
const LEND_MAX_GAP: usize = 3;

/// Epochs of each stage when fine-tuning a detector.
const FINE_TUNE_CANDIDATE_EPOCHS: usize = 12;
const FINE_TUNE_CHECKER_EPOCHS: usize = 8;

pub fn run(args: TrainArgs) -> Result<()> {
    let kind = args.model.unwrap_or(if args.positives.is_some() {
        ModelKind::HogSvm
    } else {
        ModelKind::Cnn
    });
    match kind {
        ModelKind::HogSvm => run_svm(args),
        ModelKind::Cnn => run_net(args),
        ModelKind::Detector => run_detector(args),
    }
}

/// The folder of labelled photos, and the separate held-out folder when `--val` names one.
struct Split {
    folder: LabelledFolder,
    val_folder: Option<LabelledFolder>,
    /// The teacher's labels of `folder`, when the teacher made them.
    taught: Option<TeacherTaught>,
    /// `--also`'s folders, trained on as they are.
    also: Vec<LabelledFolder>,
    /// The part held out when none is named, chosen once (the student's rounds change
    /// the photos, not the choice).
    auto_hold_out: std::cell::OnceCell<AutoHoldOut>,
}

/// The teacher's labels of the training photos, and the photos as opened.
struct TeacherTaught {
    labels: crate::cli::teach::FolderLabels,
    /// `--images` (a recording's frames for `--source`).
    labelled: LabelledArgs,
    /// The photos with the label files beside them, when `--teacher` labelled photos that
    /// had some: the teacher's labels are held against them.
    theirs: Option<LabelledFolder>,
}

impl TeacherTaught {
    /// The teacher's labels of the photos kept for training against the label files beside
    /// them (when there are some), printed: how far to trust them.
    fn report_against(&self) -> Result<()> {
        let Some(theirs) = &self.theirs else {
            return Ok(());
        };
        let images = teacher_images(&self.labelled)?;
        let items: BTreeMap<PathBuf, &Item> = theirs
            .items
            .iter()
            .filter(|i| i.label.is_some())
            .map(|i| (i.image.clone(), i))
            .collect();
        let mut total = crate::labels::teacher::Against::default();
        let mut photos = 0;
        for r in self.labels.records.iter().filter(|r| r.certain()) {
            let Some(item) = items.get(&images.join(&r.photo)) else {
                continue;
            };
            let Ok(l) = theirs.labels_sized(item, r.width_px, r.height_px) else {
                continue;
            };
            total += crate::labels::teacher::against(&r.ball_boxes(), &l.balls);
            photos += 1;
        }
        if photos > 0 {
            let pct = |a: usize, b: usize| 100.0 * a as f64 / b.max(1) as f64;
            eprintln!(
                "against the label files beside the photos, in the {photos} photos kept for \
                 training: {} of the teacher's {} balls are on theirs ({:.1} %); {} of their {} \
                 balls are taught as balls ({:.1} %), the rest as background",
                total.right,
                total.taught,
                pct(total.right, total.taught),
                total.right,
                total.theirs,
                pct(total.right, total.theirs)
            );
        }
        Ok(())
    }
}

impl Split {
    fn open(args: &TrainArgs) -> Result<Self> {
        if args.positives.is_some() {
            bail!("the networks train on labelled photos: give --images DIR (or --model hog-svm)");
        }
        // Checked before the teacher's long labelling.
        let also = also_folders(args)?;
        if let Some(source) = &args.source {
            let recording = source
                .strip_prefix("mcap:")
                .with_context(|| format!("--source {source}: a recording is mcap:FILE"))?;
            let frames = labels_dir(args).join("frames");
            let n = crate::cli::teach::recording_frames(
                Path::new(recording),
                &frames,
                args.frame_step,
            )?;
            eprintln!(
                "{n} frames of {recording} written to {} for the teacher",
                frames.display()
            );
            let args = TrainArgs {
                labelled: LabelledArgs {
                    images: Some(frames),
                    ..args.labelled.clone()
                },
                ..args.clone()
            };
            let folder = LabelledFolder::open_unlabelled(&args.labelled)?;
            let (folder, labels) = teacher_labelled(&args, &folder, Some(LEND_MAX_GAP))?;
            return Ok(Split {
                folder,
                val_folder: None,
                taught: Some(TeacherTaught {
                    labels,
                    labelled: args.labelled.clone(),
                    theirs: None,
                }),
                also,
                auto_hold_out: Default::default(),
            });
        }
        let mut folder = LabelledFolder::open_unlabelled(&args.labelled)?;
        let mut taught = None;
        if args.teacher || folder.unlabelled() {
            let (f, labels) = teacher_labelled(args, &folder, None)?;
            let theirs = (!folder.unlabelled()).then_some(folder);
            folder = f;
            let t = TeacherTaught {
                labels,
                labelled: args.labelled.clone(),
                theirs,
            };
            t.report_against()?;
            taught = Some(t);
        }
        let val_folder = match &args.val {
            Some(dir) => Some(LabelledFolder::open(&LabelledArgs {
                images: Some(dir.clone()),
                labels: None,
                ..args.labelled.clone()
            })?),
            None => None,
        };
        Ok(Split {
            folder,
            val_folder,
            taught,
            also,
            auto_hold_out: Default::default(),
        })
    }

    /// How many rounds the student settles the teacher's labels before the last
    /// training (none without the teacher's labels).
    fn student_rounds(&self, args: &TrainArgs) -> usize {
        if self.taught.is_some() {
            args.student_rounds
        } else {
            0
        }
    }

    /// One round of agreement: the student (`judge`, trained on the teacher's labels)
    /// settles the teacher's doubts and unseats the sure balls it calls background; the
    /// labels are written again and the folder opened with them.
    fn settle(
        &mut self,
        args: &TrainArgs,
        judge: impl Fn(&vision::image::RgbImage, &vision::Circle) -> Option<f64>,
    ) -> Result<()> {
        let Some(taught) = self.taught.as_mut() else {
            return Ok(());
        };
        let TeacherTaught {
            labels, labelled, ..
        } = taught;
        let images = teacher_images(labelled)?;
        let how = crate::labels::teacher::Agreement {
            one_ball: !args.teacher_args.teacher_several_balls,
            ..Default::default()
        };
        let before = labels.counts();
        let settled = crate::cli::teach::settle_folder(&images, labels, &how, judge);
        let after = labels.counts();
        eprintln!(
            "the student settled the teacher's labels: doubts made balls: {}, sure balls made \
             doubts: {}; now {} balls in {} photos, {} photos doubtful (were {} balls, {} \
             doubtful)",
            settled.promoted, settled.demoted, after.1, after.0, after.2, before.1, before.2
        );
        let out = labels_dir(args);
        crate::cli::teach::write_outputs(&out, teacher_output(args), labels)?;
        crate::cli::teach::contact_sheet(&images, &labels.records, &out.join("contact-sheet.png"))?;
        self.folder = taught_folder(labelled, &out, labels)?;
        taught.report_against()
    }

    /// Training items, and the held-out folder with its items: the `--hold-out` folders'
    /// photos, or the `--val` folder's, or when neither is named a part chosen here (and
    /// said); `--hold-out none` holds nothing out.
    fn items<'a>(&'a self, hold_out: &[String]) -> Result<Parts<'a>> {
        if let Some(v) = &self.val_folder {
            return Ok(Parts {
                train: self.folder.items.iter().collect(),
                val_folder: v,
                val: v.items.iter().collect(),
                held_out: "the --val folder".to_string(),
            });
        }
        let nothing = hold_out.len() == 1 && hold_out[0] == "none";
        let mut described = hold_out.join(", ");
        let (val_items, train_items): (Vec<&Item>, Vec<&Item>) = if nothing {
            described.clear();
            (Vec::new(), self.folder.items.iter().collect())
        } else if hold_out.is_empty() {
            let choice = self.auto_hold_out.get_or_init(|| {
                let choice = automatic_hold_out(&self.folder.items);
                eprintln!(
                    "nothing named to hold out: holding out {}; name event folders with \
                     --hold-out (or a folder with --val) to choose, --hold-out none to train \
                     on every photo",
                    choice.describe(&self.folder.items)
                );
                choice
            });
            described = choice.describe(&self.folder.items);
            let (mut val, mut train) = (Vec::new(), Vec::new());
            for (k, i) in self.folder.items.iter().enumerate() {
                if choice.holds(k, i) {
                    val.push(i);
                } else {
                    train.push(i);
                }
            }
            (val, train)
        } else {
            let split: (Vec<&Item>, Vec<&Item>) = self
                .folder
                .items
                .iter()
                .partition(|i| held_out(i, hold_out));
            for f in hold_out {
                if !split.0.iter().any(|i| held_out(i, std::slice::from_ref(f))) {
                    bail!("--hold-out {f}: no photos in that folder of the --images folder");
                }
            }
            split
        };
        if train_items.is_empty() {
            bail!("every photo is held out: nothing is left to train on");
        }
        Ok(Parts {
            train: train_items,
            val_folder: &self.folder,
            val: val_items,
            held_out: described,
        })
    }
}

/// `--also`'s labelled folders: labels beside the photos, or a folder of `images/` and
/// `labels/` (YOLO's layout, and `synth_photos`'s).
fn also_folders(args: &TrainArgs) -> Result<Vec<LabelledFolder>> {
    if !args.also.is_empty() && args.model != Some(ModelKind::Cnn) {
        bail!("--also trains the ball network: give --model cnn");
    }
    args.also
        .iter()
        .map(|dir| {
            let (images, labels) = if dir.join("images").is_dir() && dir.join("labels").is_dir() {
                (dir.join("images"), Some(dir.join("labels")))
            } else {
                (dir.clone(), None)
            };
            LabelledFolder::open(&LabelledArgs {
                images: Some(images),
                labels,
                ball_classes: Vec::new(),
                ..args.labelled.clone()
            })
            .with_context(|| format!("--also {}", dir.display()))
        })
        .collect()
}

/// Where the teacher's labels go: `--teacher-labels`, or beside `--out` with `.labels`.
fn labels_dir(args: &TrainArgs) -> PathBuf {
    args.teacher_labels.clone().unwrap_or_else(|| {
        let mut dir = args.out.as_os_str().to_owned();
        dir.push(".labels");
        PathBuf::from(dir)
    })
}

/// The photos the teacher labels (`--images`, or a recording's frames).
fn teacher_images(labelled: &LabelledArgs) -> Result<PathBuf> {
    labelled
        .images
        .clone()
        .context("the teacher labels a folder of photos: give --images DIR")
}

/// How the teacher's labels are written: YOLO files, a recording's frames lending each
/// other labels.
fn teacher_output(args: &TrainArgs) -> crate::cli::teach::LabelOutput {
    crate::cli::teach::LabelOutput {
        format: crate::labels::prelabel::LabelFormat::Yolo,
        keep_existing: false,
        lend: args.source.is_some().then_some(LEND_MAX_GAP),
    }
}

/// The folder labelled by the teacher: its labels written beside `--out` (or to
/// `--teacher-labels`), the folder opened again with them, its doubtful photos left out.
fn teacher_labelled(
    args: &TrainArgs,
    folder: &LabelledFolder,
    lend: Option<usize>,
) -> Result<(LabelledFolder, crate::cli::teach::FolderLabels)> {
    let images = teacher_images(&args.labelled)?;
    let out = labels_dir(args);
    if !args.teacher {
        eprintln!(
            "{} holds no label files: the teacher labels its photos (into {})",
            images.display(),
            out.display()
        );
    }
    let how = args.teacher_args.labelling()?;
    let teacher = args.teacher_args.teacher()?;
    let files: Vec<PathBuf> = folder.items.iter().map(|i| i.image.clone()).collect();
    let output = crate::cli::teach::LabelOutput {
        lend,
        ..teacher_output(args)
    };
    let labels = crate::cli::teach::label_folder(&images, &files, &out, output, &teacher, &how)?;
    crate::cli::teach::report(&labels, &out);
    let (_, balls, _, _) = labels.counts();
    if balls == 0 {
        bail!(
            "the teacher found no ball it is sure of in the {} photos of {}: label a few \
             by hand (YOLO or VOC files beside the photos), or lower --teacher-accept \
             (now {}) and look at {}",
            labels.records.len(),
            images.display(),
            how.accept,
            out.join("contact-sheet.png").display()
        );
    }
    let taught = taught_folder(&args.labelled, &out, &labels)?;
    Ok((taught, labels))
}

/// The photos opened with the teacher's labels, the doubtful ones left out.
fn taught_folder(
    labelled: &LabelledArgs,
    out: &Path,
    labels: &crate::cli::teach::FolderLabels,
) -> Result<LabelledFolder> {
    let images = teacher_images(labelled)?;
    let doubtful = labels.doubtful();
    let mut taught = LabelledFolder::open(&LabelledArgs {
        labels: Some(out.to_path_buf()),
        ball_classes: vec![0],
        ..labelled.clone()
    })?;
    taught.items.retain(|i| {
        let name = relative_name(&i.image, &images);
        !doubtful.contains(&name)
    });
    taught.not_balls = labels
        .records
        .iter()
        .map(|r| (images.join(&r.photo), r.not_balls()))
        .filter(|(_, boxes)| !boxes.is_empty())
        .collect();
    Ok(taught)
}

/// The photos to train on and those held out for the score.
struct Parts<'a> {
    train: Vec<&'a Item>,
    val_folder: &'a LabelledFolder,
    val: Vec<&'a Item>,
    /// What was held out, for the file's recipe (empty: nothing).
    held_out: String,
}

/// The held-out part chosen when none is named.
#[derive(Debug, Clone, PartialEq, Eq)]
enum AutoHoldOut {
    /// A whole event: the top-level folder nearest a fifth of the photos (three events or
    /// more).
    Event(String),
    /// Every fifth photo in path order (fewer events: the held-out photos then share
    /// events with the training ones, so their score is optimistic).
    EveryFifth,
}

/// The photos' top-level folder (empty at the top).
fn event_of(item: &Item) -> &str {
    item.folder.split('/').next().unwrap_or("")
}

fn automatic_hold_out(items: &[Item]) -> AutoHoldOut {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for i in items {
        *counts.entry(event_of(i)).or_default() += 1;
    }
    let events: Vec<(&str, usize)> = counts.into_iter().filter(|(e, _)| !e.is_empty()).collect();
    if events.len() < 3 {
        return AutoHoldOut::EveryFifth;
    }
    let fifth = items.len() as f64 / 5.0;
    events
        .iter()
        .min_by(|a, b| {
            (a.1 as f64 - fifth)
                .abs()
                .total_cmp(&(b.1 as f64 - fifth).abs())
                .then_with(|| b.0.cmp(a.0))
        })
        .map_or(AutoHoldOut::EveryFifth, |(e, _)| {
            AutoHoldOut::Event((*e).to_string())
        })
}

impl AutoHoldOut {
    fn holds(&self, index: usize, item: &Item) -> bool {
        match self {
            AutoHoldOut::Event(e) => event_of(item) == e,
            AutoHoldOut::EveryFifth => index % 5 == 4,
        }
    }

    fn describe(&self, items: &[Item]) -> String {
        let n = items
            .iter()
            .enumerate()
            .filter(|(k, i)| self.holds(*k, i))
            .count();
        match self {
            AutoHoldOut::Event(e) => format!("the event folder {e} ({n} photos)"),
            AutoHoldOut::EveryFifth => format!(
                "every fifth photo ({n} photos; they share events with the \
                 training photos, so their score is optimistic)"
            ),
        }
    }
}

/// The file's recipe: the data, the command, the seed.
fn recipe(args: &TrainArgs, train_photos: usize, held_out: &str) -> BTreeMap<String, String> {
    let images = args
        .labelled
        .images
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    let mut metadata = BTreeMap::new();
    metadata.insert(
        "data".to_string(),
        format!(
            "{images}: {train_photos} photos for training{}",
            if held_out.is_empty() {
                String::new()
            } else {
                format!(", held out: {held_out}")
            }
        ),
    );
    metadata.insert(
        "command".to_string(),
        std::iter::once("robot-agent".to_string())
            .chain(std::env::args().skip(1))
            .collect::<Vec<_>>()
            .join(" "),
    );
    metadata.insert("seed".to_string(), args.seed.to_string());
    metadata
}

/// The held-out score as a model file records it.
fn held_out_line(report: &crate::labels::eval::LabelReport) -> String {
    format!(
        "{} photos: recall {:.3}, precision {:.3}, ball recall {:.3} at p >= 0.5",
        report.images,
        report.recall_published.unwrap_or(0.0),
        report.precision.unwrap_or(0.0),
        report.ball_recall.unwrap_or(0.0)
    )
}

/// The held-out precision-recall plot and JSON report, when asked for.
fn write_held_out(
    args: &TrainArgs,
    report: &crate::labels::eval::LabelReport,
    name: &str,
) -> Result<()> {
    if let Some(path) = &args.plot {
        super::pr_chart::write_png(
            path,
            "Held-out precision and recall",
            super::pr_chart::Curve {
                name,
                points: &report.pr_curve,
                threshold: 0.5,
            },
        )?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.json {
        write_file(path, serde_json::to_string_pretty(report)?.as_bytes())?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// The two-stage detector trained once on the split's training photos.
fn train_two_stage(
    args: &TrainArgs,
    split: &Split,
) -> Result<crate::cli::detector_train::TrainedDetector> {
    let parts = split.items(&args.hold_out)?;
    let (train_items, val_folder, val_items) = (&parts.train, parts.val_folder, &parts.val);
    if val_items.is_empty() {
        eprintln!(
            "nothing held out (--hold-out none): the last epochs are kept and no \
             held-out score is recorded"
        );
    }
    let p = &args.from;
    let start = if p.as_os_str() == "none" {
        None
    } else {
        let bytes = if p.as_os_str() == "shipped" {
            robot_agent::builtin::DETECTOR.to_vec()
        } else {
            std::fs::read(p).with_context(|| format!("reading {}", p.display()))?
        };
        Some(
            crate::training::detector_train::stages_of(&bytes)
                .with_context(|| format!("{} is not a detector file", p.display()))?,
        )
    };
    // Fine-tuning starts near a solution and needs fewer epochs.
    let (candidate_epochs, checker_epochs) = match start {
        Some(_) => (
            args.candidate_epochs.unwrap_or(FINE_TUNE_CANDIDATE_EPOCHS),
            args.checker_epochs.unwrap_or(FINE_TUNE_CHECKER_EPOCHS),
        ),
        None => (
            args.candidate_epochs
                .unwrap_or(StageTrainConfig::candidates().epochs),
            args.checker_epochs
                .unwrap_or(StageTrainConfig::checker().epochs),
        ),
    };
    let stage = |base: StageTrainConfig, epochs: usize| StageTrainConfig {
        epochs,
        seed: args.seed,
        ..base
    };
    train_detector(
        &split.folder,
        train_items,
        (val_folder, val_items),
        DetectorTraining {
            candidates: stage(StageTrainConfig::candidates(), candidate_epochs),
            checker: stage(StageTrainConfig::checker(), checker_epochs),
            start: start.as_ref(),
            random_negatives: args.random_negatives,
            copies: args.copies,
            hard_negative_rounds: args.hard_negative_rounds,
            metadata: recipe(args, train_items.len(), &parts.held_out),
        },
    )
}

fn run_detector(args: TrainArgs) -> Result<()> {
    let mut split = Split::open(&args)?;
    let started = Instant::now();
    let out = with_student_rounds(&args, &mut split, train_two_stage, |out| {
        (out.file.clone(), Box::new(out.checker.clone()))
    })?;
    let mut file = out.file.clone();
    let (reached, balls) = out.training_balls_reached;
    println!("the candidate stage reached {reached} of the {balls} training balls");
    if 2 * reached < balls {
        eprintln!(
            "warning: the candidate stage reaches fewer than half the training balls; the \
             detector cannot find a ball no candidate is on (more --candidate-epochs, or \
             labels that fit the balls' edges, may help)"
        );
    }
    if let Some(report) = &out.held_out {
        println!("held-out photos ({}):", report.images);
        println!("{report}");
        let mut meta = out.net.metadata().clone();
        meta.insert("held_out".to_string(), held_out_line(report));
        file = crate::training::detector_train::with_metadata(&file, &meta)?;
        write_held_out(&args, report, "two-stage detector")?;
    }
    write_file(&args.out, &file)?;
    println!(
        "wrote {} ({} bytes; candidate network epoch {} of {}, checker epoch {} of {}) in {:.0} s",
        args.out.display(),
        file.len(),
        out.candidate_epochs.0,
        out.candidate_epochs.1,
        out.checker_epochs.0,
        out.checker_epochs.1,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The student's weights file and its judge of a circle in a photo.
type Student = (Vec<u8>, Box<dyn vision::CandidateClassifier>);

/// `train` once, or with the teacher's labels, `--student-rounds` times before the last:
/// each round's model (`student` of its output) is written beside `--out`
/// (`NAME.round1.safetensors`, to compare with the last) and settles the teacher's labels.
fn with_student_rounds<T>(
    args: &TrainArgs,
    split: &mut Split,
    train: impl Fn(&TrainArgs, &Split) -> Result<T>,
    student: impl Fn(&T) -> Student,
) -> Result<T> {
    let rounds = split.student_rounds(args);
    for round in 1..=rounds {
        eprintln!("student round {round} of {rounds}: training on the teacher's labels");
        let (file, judge) = student(&train(args, split)?);
        let path = args.out.with_extension(format!("round{round}.safetensors"));
        write_file(&path, &file)?;
        eprintln!("wrote round {round}'s model to {}", path.display());
        split.settle(args, |image, circle| judge.probability(image, circle))?;
    }
    train(args, split)
}

/// The ball network trained once on the split's training photos.
fn train_net(args: &TrainArgs, split: &Split) -> Result<crate::cli::net_train::NetTraining> {
    let parts = split.items(&args.hold_out)?;
    let (train_items, val_folder, val_items) = (&parts.train, parts.val_folder, &parts.val);
    let cfg = NetTrainConfig {
        epochs: args.epochs,
        batch: args.batch,
        learning_rate: args.learning_rate,
        augment: !args.no_augment,
        max_hue_turn_rad: args.hue_turn_deg.to_radians(),
        seed: args.seed,
        ..NetTrainConfig::default()
    };
    let mut samples = SampleConfig {
        copies_per_ball: args.copies,
        random_per_photo: args.random_negatives,
        ..SampleConfig::default()
    };
    if let Some(n) = args.proposals {
        anyhow::ensure!(n > 0, "--proposals must be at least 1");
        samples.appearance.max_candidates = n;
    }
    let mut train: Vec<(&LabelledFolder, Vec<&Item>)> = vec![(&split.folder, train_items.clone())];
    for folder in &split.also {
        train.push((folder, folder.items.iter().collect()));
    }
    train_on_photos(
        &train,
        (val_folder, val_items),
        &cfg,
        &samples,
        recipe(args, train_items.len(), &parts.held_out),
    )
}

fn run_net(args: TrainArgs) -> Result<()> {
    let mut split = Split::open(&args)?;
    let started = Instant::now();
    let out = with_student_rounds(&args, &mut split, train_net, |out| {
        let net = vision::stages::classifier::NetClassifier::new(out.trained.net.clone());
        (out.trained.file.clone(), Box::new(net))
    })?;
    let mut file = out.trained.file.clone();
    if let Some(report) = &out.held_out {
        println!("held-out photos ({}):", report.images);
        println!("{report}");
        // Record the held-out score in the file itself.
        let mut meta = out.trained.net.metadata().clone();
        meta.insert("held_out".to_string(), held_out_line(report));
        file = crate::training::ballnet_train::with_metadata(&file, &meta)?;
        write_held_out(&args, report, "ball network")?;
    }
    write_file(&args.out, &file)?;
    println!(
        "wrote {} ({} bytes, epoch {} of {}) in {:.0} s",
        args.out.display(),
        file.len(),
        out.trained.best_epoch,
        out.trained.epochs.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn run_svm(args: TrainArgs) -> Result<()> {
    let started = Instant::now();
    let mut progress = |line: &str| eprintln!("[{:6.1} s] {line}", started.elapsed().as_secs_f64());
    let (mut positives, mut negatives) = (Vec::new(), Vec::new());
    if let (Some(p), Some(n)) = (&args.positives, &args.negatives) {
        positives.extend(folder_patches(p)?);
        negatives.extend(folder_patches(n)?);
    }
    if args.labelled.given() {
        let (p, n) = labelled_folder_patches(
            &args.labelled,
            args.random_negatives,
            args.seed,
            &mut progress,
        )?;
        positives.extend(p);
        negatives.extend(n);
    }
    if !(args.positives.is_some() || args.labelled.given()) {
        bail!("give --positives and --negatives, or --images and --labels");
    }
    fit_and_write(&positives, &negatives, args.seed, &args.out, &mut progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(folder: &str, name: &str) -> Item {
        Item {
            image: PathBuf::from(format!("{folder}/{name}")),
            label: None,
            folder: folder.to_string(),
        }
    }

    #[test]
    fn a_whole_event_near_a_fifth_is_held_out_when_none_is_named() {
        let mut items = Vec::new();
        for (event, n) in [("e1", 40), ("e2", 22), ("e3", 30), ("e4/r1", 8)] {
            for k in 0..n {
                items.push(item(event, &format!("{k}.jpg")));
            }
        }
        let choice = automatic_hold_out(&items);
        assert_eq!(choice, AutoHoldOut::Event("e2".to_string()));
        let held = items
            .iter()
            .enumerate()
            .filter(|(k, i)| choice.holds(*k, i))
            .count();
        assert_eq!(held, 22);
        assert!(choice.describe(&items).contains("e2 (22 photos)"));
    }

    #[test]
    fn one_folder_holds_out_every_fifth_photo() {
        let items: Vec<Item> = (0..23).map(|k| item("", &format!("{k}.jpg"))).collect();
        let choice = automatic_hold_out(&items);
        assert_eq!(choice, AutoHoldOut::EveryFifth);
        let held: Vec<usize> = (0..items.len())
            .filter(|&k| choice.holds(k, &items[k]))
            .collect();
        assert_eq!(held, [4, 9, 14, 19]);
    }
}
