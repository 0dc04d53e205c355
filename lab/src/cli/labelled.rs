//! Labelled photo folders for `evaluate` and `train`: an image folder, a label folder of
//! Pascal VOC `.xml` or YOLO `.txt` files named after the images, and the camera the
//! images were taken with.
//!
//! The image folder is searched with its subfolders (a data set of several events, one
//! folder each); an image's label file is at the same relative place in the label folder,
//! or beside the image. An image without a label file is taken as holding no ball (YOLO's
//! convention for background images); a label file that cannot be read is reported and its
//! image left out. YOLO class ids that are balls come from `--ball-class`, or else from a
//! `classes.txt`, `obj.names` or `data.yaml` names list in the label folder or the folder
//! above it.

use crate::labels::yolo::{BallClassIds, parse_classes_txt, parse_data_yaml_names};
use crate::labels::{BallNames, ImageLabels};
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use vision::camera::CameraModel;
use vision::image::RgbImage;

#[derive(Debug, Clone, clap::Args)]
pub struct LabelledArgs {
    /// Folder of labelled photographs (PNG or JPEG), subfolders included.
    #[arg(long)]
    pub images: Option<PathBuf>,
    /// Folder of label files named after the images, in the same subfolders (or the
    /// images' own folder): Pascal VOC `.xml` or YOLO `.txt`. Default: beside the images.
    #[arg(long, requires = "images")]
    pub labels: Option<PathBuf>,
    /// A YOLO class id that is a ball (repeatable). Default: from a classes.txt, obj.names
    /// or data.yaml names list next to the labels.
    #[arg(long = "ball-class")]
    pub ball_classes: Vec<u32>,
    /// A class name that is a ball, any case (repeatable). Default: ball, sports ball,
    /// football, soccer ball.
    #[arg(long = "ball-name")]
    pub ball_names: Vec<String>,
    /// The camera of the photos: `pinhole:FX,FY,CX,CY` (pixels). Without it and without
    /// `--calibration` each photo is searched as it is, with no local views.
    #[arg(long, conflicts_with = "calibration")]
    pub camera: Option<String>,
    /// The camera's calibration from `ball-lab calibrate`.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
}

/// How the photos' camera is known.
#[derive(Debug, Clone, Copy)]
pub enum CameraChoice {
    /// Search each photo as it is.
    None,
    /// A distortion-free pinhole camera; the image size is each photo's.
    Pinhole {
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
    },
    Calibrated(CameraModel),
}

/// Parses `pinhole:FX,FY,CX,CY`.
pub fn parse_pinhole(text: &str) -> Result<CameraChoice> {
    let usage = || format!("camera {text:?} is not pinhole:FX,FY,CX,CY (pixels)");
    let rest = text.strip_prefix("pinhole:").with_context(usage)?;
    let v: Vec<f64> = rest
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(usage)?;
    match v[..] {
        [fx, fy, cx, cy] if fx > 0.0 && fy > 0.0 && cx.is_finite() && cy.is_finite() => {
            Ok(CameraChoice::Pinhole { fx, fy, cx, cy })
        }
        _ => bail!(usage()),
    }
}

impl CameraChoice {
    pub fn from_args(args: &LabelledArgs) -> Result<Self> {
        match (&args.camera, &args.calibration) {
            (Some(text), _) => parse_pinhole(text),
            (None, Some(path)) => {
                let [model, _] = robot_agent::load_models(Some(path), None)?;
                Ok(CameraChoice::Calibrated(model))
            }
            (None, None) => Ok(CameraChoice::None),
        }
    }

    /// The camera model for a photo of this size.
    pub fn model_for(&self, image: &RgbImage) -> Result<Option<CameraModel>> {
        let (w, h) = (image.width(), image.height());
        match *self {
            CameraChoice::None => Ok(None),
            CameraChoice::Pinhole { fx, fy, cx, cy } => {
                Ok(Some(CameraModel::pinhole(fx, fy, cx, cy, w, h)))
            }
            CameraChoice::Calibrated(m) => {
                let i = &m.intrinsics;
                if (i.width_px, i.height_px) != (w, h) {
                    bail!(
                        "the photo is {w}×{h} but the calibration is for {}×{}",
                        i.width_px,
                        i.height_px
                    );
                }
                Ok(Some(m))
            }
        }
    }
}

/// A photo and its label file, if it has one.
#[derive(Debug, Clone)]
pub struct Item {
    pub image: PathBuf,
    pub label: Option<PathBuf>,
    /// The image's folder relative to `--images` (empty at the top): its event, for
    /// per-folder scores.
    pub folder: String,
}

impl Item {
    pub fn name(&self) -> String {
        self.image
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    }
}

/// A labelled folder, ready to read.
#[derive(Debug)]
pub struct LabelledFolder {
    pub items: Vec<Item>,
    pub ball_names: BallNames,
    /// `None` when no YOLO ball class is known (an error only if a YOLO file is met).
    yolo: Option<BallClassIds>,
    pub camera: CameraChoice,
    /// Boxes known to hold no ball, by image path (what the teacher calls something
    /// else), taught as background beside the labels' balls.
    pub not_balls: std::collections::BTreeMap<PathBuf, Vec<crate::labels::BallBox>>,
}

/// The names list of a YOLO data set: `classes.txt` or `data.yaml` in `dir` or its parent.
fn names_list(dir: &Path) -> Result<Option<(PathBuf, Vec<String>)>> {
    for d in [Some(dir), dir.parent()].into_iter().flatten() {
        for list in ["classes.txt", "obj.names"] {
            let classes = d.join(list);
            if classes.is_file() {
                let text = std::fs::read_to_string(&classes)
                    .with_context(|| format!("reading {}", classes.display()))?;
                return Ok(Some((classes, parse_classes_txt(&text))));
            }
        }
        for yaml in ["data.yaml", "data.yml"] {
            let path = d.join(yaml);
            if path.is_file() {
                let text = std::fs::read_to_string(&path)
                    .with_context(|| format!("reading {}", path.display()))?;
                let names = parse_data_yaml_names(&text)
                    .with_context(|| format!("{} has no names: list", path.display()))?;
                return Ok(Some((path, names)));
            }
        }
    }
    Ok(None)
}

impl LabelledArgs {
    /// Whether a labelled folder was given.
    pub fn given(&self) -> bool {
        self.images.is_some()
    }
}

impl LabelledFolder {
    pub fn open(args: &LabelledArgs) -> Result<Self> {
        Self::open_with(args, true)
    }

    /// The folder even when none of its photos has a label file (for the teacher to label).
    pub fn open_unlabelled(args: &LabelledArgs) -> Result<Self> {
        Self::open_with(args, false)
    }

    /// Whether no photo has a label file.
    pub fn unlabelled(&self) -> bool {
        self.items.iter().all(|i| i.label.is_none())
    }

    fn open_with(args: &LabelledArgs, need_labels: bool) -> Result<Self> {
        let Some(images) = &args.images else {
            bail!("give the labelled photos as --images DIR [--labels DIR]");
        };
        let labels = args.labels.as_ref().unwrap_or(images);
        let ball_names = if args.ball_names.is_empty() {
            BallNames::default()
        } else {
            BallNames::new(&args.ball_names)
        };
        let yolo = if !args.ball_classes.is_empty() {
            Some(BallClassIds {
                ids: args.ball_classes.clone(),
                known_classes: None,
            })
        } else {
            match names_list(labels)? {
                Some((path, names)) => {
                    let ids = BallClassIds::from_names(&names, &ball_names);
                    eprintln!(
                        "{}: {} classes, ball classes {:?}",
                        path.display(),
                        names.len(),
                        ids.ids
                    );
                    Some(ids)
                }
                None => None,
            }
        };
        if !labels.is_dir() {
            bail!("{} is not a folder of labels", labels.display());
        }
        let mut items = Vec::new();
        let mut labelled = 0;
        for image in robot_agent::image_files_recursive(images)? {
            let relative = image.strip_prefix(images).unwrap_or(&image).to_path_buf();
            let folder = relative
                .parent()
                .map(|p| p.to_string_lossy().into_owned())
                .unwrap_or_default();
            let stem = image.file_stem().unwrap_or_default();
            let beside = image.parent().unwrap_or(images);
            let label = [labels.join(&folder), beside.to_path_buf()]
                .iter()
                .flat_map(|dir| {
                    ["xml", "txt"].iter().map(move |ext| {
                        let mut name = stem.to_os_string();
                        name.push(format!(".{ext}"));
                        dir.join(name)
                    })
                })
                .find(|p| p.is_file());
            labelled += usize::from(label.is_some());
            items.push(Item {
                image,
                label,
                folder,
            });
        }
        if items.is_empty() {
            bail!("no PNG or JPEG images in {}", images.display());
        }
        if labelled == 0 && need_labels {
            bail!(
                "none of the {} images in {} has a label file (NAME.xml or NAME.txt) in {}",
                items.len(),
                images.display(),
                labels.display()
            );
        }
        let yolo_file = items
            .iter()
            .filter_map(|i| i.label.as_ref())
            .find(|l| l.extension().is_some_and(|e| e == "txt"));
        if let (Some(file), None) = (yolo_file, &yolo) {
            bail!(
                "{} is a YOLO label file: give --ball-class ID, or put a classes.txt or \
                 data.yaml names list next to the labels",
                file.display()
            );
        }
        Ok(Self {
            items,
            ball_names,
            yolo,
            camera: CameraChoice::from_args(args)?,
            not_balls: Default::default(),
        })
    }

    /// The labels of an item whose image is `image`.
    pub fn labels(&self, item: &Item, image: &RgbImage) -> Result<ImageLabels> {
        self.labels_sized(item, image.width(), image.height())
    }

    /// The labels of an item whose image is `w` × `h` pixels.
    pub fn labels_sized(&self, item: &Item, w: u32, h: u32) -> Result<ImageLabels> {
        let Some(path) = &item.label else {
            return Ok(ImageLabels {
                width_px: w,
                height_px: h,
                ..ImageLabels::default()
            });
        };
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let file = path.display().to_string();
        if path.extension().is_some_and(|e| e == "xml") {
            let labels = crate::labels::voc::parse_voc(&text, &file, &self.ball_names)?;
            if (labels.width_px, labels.height_px) != (w, h) {
                bail!(
                    "{file}: labelled for a {}×{} image, but {} is {w}×{h}",
                    labels.width_px,
                    labels.height_px,
                    item.name()
                );
            }
            Ok(labels)
        } else {
            let ids = self.yolo.as_ref().with_context(|| {
                format!(
                    "{file} is a YOLO label file: give --ball-class ID, or put a classes.txt \
                     or data.yaml names list next to the labels"
                )
            })?;
            Ok(crate::labels::yolo::parse_yolo(&text, &file, w, h, ids)?)
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn pinhole_flags() {
        assert!(matches!(
            parse_pinhole("pinhole:500,501,320,240").unwrap(),
            CameraChoice::Pinhole { fx, cy, .. } if fx == 500.0 && cy == 240.0
        ));
        for bad in [
            "pinhole:500,501,320",
            "fisheye:1,2,3,4",
            "pinhole:-5,5,1,1",
            "pinhole:a,b,c,d",
        ] {
            assert!(parse_pinhole(bad).is_err(), "{bad}");
        }
    }
}
