//! A folder of randomised labelled photos ([`sim::photo_synth`]) as a user's own data set
//! would be laid out: `images/NNNNN.jpg` and YOLO labels `labels/NNNNN.txt` with a
//! `labels/classes.txt` naming class 0 `ball`, plus a `manifest.json` saying how it was
//! made (with the ball designs drawn from and each photo's balls' designs). `ball-lab evaluate` and `ball-lab train` read it like any other.
//!
//! Backgrounds go round in turn: a procedural carpet, a rendered view of the simulated
//! pitch (ball removed; fisheye frames of a simulated match) and, when given, a real photo.

use crate::progress::Progress;
use anyhow::{Context, Result, bail};
use lab::labels::BallBox;
use lab::labels::yolo::yolo_line;
use serde::Serialize;
use sim::Frame;
use sim::LensModel;
use sim::{Background, PhotoProfile, SynthPhoto, synth_photo};
use sim::{CameraRig, render_robot_cameras};
use sim::{CameraWorld, CameraWorldConfig};
use std::path::{Path, PathBuf};

/// What to make.
#[derive(Debug, Clone)]
pub struct PhotoSetSpec {
    pub profile: PhotoProfile,
    pub count: u64,
    pub seed: u64,
    /// Real photos to draw balls on (any size), in the rotation beside carpets and renders.
    pub backgrounds: Vec<PathBuf>,
    /// A YOLO label file beside a background photo marks balls of this class, which are
    /// painted over ([`sim::erase_box`]) before a ball is painted in (`None`: labels are
    /// not looked for).
    pub erase_class: Option<u32>,
    /// Rendered pitch views in the rotation.
    pub rendered: usize,
    /// Which kinds of background go round (empty: every kind there is).
    pub kinds: Vec<BackgroundKind>,
}

/// A kind of background.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BackgroundKind {
    /// A procedural carpet.
    Carpet,
    /// A rendered view of the simulated pitch.
    Rendered,
    /// One of the given photos.
    Photos,
}

#[derive(Debug, Serialize)]
struct Manifest<'a> {
    made_by: &'static str,
    profile: &'a str,
    seed: u64,
    count: u64,
    photos_with_a_ball: usize,
    backgrounds: Vec<String>,
    rendered_views: usize,
    kinds: Vec<BackgroundKind>,
    /// The ball designs drawn from, with their weights.
    designs: Vec<ManifestDesign>,
    /// Each photo's balls' designs (none for a photo without a ball).
    photos: Vec<ManifestPhoto>,
    note: &'static str,
}

#[derive(Debug, Serialize)]
struct ManifestDesign {
    design: &'static str,
    weight: f64,
}

#[derive(Debug, Serialize)]
struct ManifestPhoto {
    image: String,
    ball_designs: Vec<&'static str>,
}

/// Rendered views of the simulated pitch with no ball: `n` frames from a simulated match.
pub fn rendered_views(n: usize, seed: u64) -> Result<Vec<Frame>> {
    if n == 0 {
        return Ok(Vec::new());
    }
    let cfg = sim::SimConfig {
        duration_s: Some(20.0),
        ..sim::SimConfig::default()
    };
    let run = sim::run_scenario("match", seed, &cfg)?;
    let rig = CameraRig::new(LensModel::miro());
    let world = CameraWorld::new(&run, &rig, CameraWorldConfig::default(), seed);
    let ids: Vec<String> = run.robots.iter().map(|r| r.id.clone()).collect();
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let id = &ids[k % ids.len()];
        let t = 1.0 + 18.0 * k as f64 / n as f64;
        let mut scene = world.scene_at(id, t);
        scene.ball_m = None;
        let pose = run.robot(id).map(|r| r.pose_at(t)).unwrap_or_default();
        let [(left, _), (right, _)] =
            render_robot_cameras(&rig, &scene, pose, world.head_at(id, t), k as u64);
        out.push(if k % 2 == 0 { left } else { right });
    }
    Ok(out)
}

fn frame_of(image: vision::RgbImage) -> Frame {
    Frame {
        width: image.width(),
        height: image.height(),
        rgb: image.data().to_vec(),
    }
}

/// The boxes of class `class` in the YOLO label file beside a background photo (none
/// when there is no such file).
fn background_balls(
    photo: &Path,
    class: u32,
    width_px: u32,
    height_px: u32,
) -> Result<Vec<BallBox>> {
    let label = photo.with_extension("txt");
    if !label.is_file() {
        return Ok(Vec::new());
    }
    let text =
        std::fs::read_to_string(&label).with_context(|| format!("reading {}", label.display()))?;
    let ids = lab::labels::yolo::BallClassIds {
        ids: vec![class],
        known_classes: None,
    };
    let labels = lab::labels::yolo::parse_yolo(
        &text,
        &label.display().to_string(),
        width_px,
        height_px,
        &ids,
    )?;
    Ok(labels.balls)
}

/// Encodes a photo as JPEG at its quality, or PNG without one; returns the file's extension.
pub fn encode(photo: &SynthPhoto) -> Result<(Vec<u8>, &'static str)> {
    let f = &photo.frame;
    match photo.jpeg_quality {
        Some(q) => {
            let mut bytes = Vec::new();
            let w = u16::try_from(f.width).context("photo too wide for JPEG")?;
            let h = u16::try_from(f.height).context("photo too tall for JPEG")?;
            jpeg_encoder::Encoder::new(&mut bytes, q)
                .encode(&f.rgb, w, h, jpeg_encoder::ColorType::Rgb)
                .context("encoding JPEG")?;
            Ok((bytes, "jpg"))
        }
        None => {
            let image = vision::RgbImage::new(f.width, f.height, f.rgb.clone())?;
            Ok((robot_agent::encode_png(&image)?, "png"))
        }
    }
}

/// Writes the set into `out` (which must not hold an earlier set's files), reporting
/// progress (`progress` counts the photos written); returns the number of photos with a ball.
pub fn write_photo_set(spec: &PhotoSetSpec, out: &Path, progress: &Progress) -> Result<usize> {
    let (images, labels) = (out.join("images"), out.join("labels"));
    for dir in [&images, &labels] {
        if dir.exists() && std::fs::read_dir(dir)?.next().is_some() {
            bail!("{} is not empty: give a new folder", dir.display());
        }
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut pictures = Vec::new();
    let mut erased = 0;
    for p in &spec.backgrounds {
        let image = robot_agent::load_rgb(p)
            .with_context(|| format!("reading background {}", p.display()))?;
        let mut frame = frame_of(image);
        if let Some(class) = spec.erase_class {
            for b in background_balls(p, class, frame.width, frame.height)? {
                sim::erase_box(&mut frame, [b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px]);
                erased += 1;
            }
        }
        pictures.push(frame);
    }
    if spec.erase_class.is_some() {
        progress.message(format!(
            "{erased} labelled balls painted over in the backgrounds"
        ));
    }
    progress.message(format!("rendering {} pitch views", spec.rendered));
    let renders = rendered_views(spec.rendered, spec.seed)?;
    std::fs::write(labels.join("classes.txt"), "ball\n")?;
    let available = |k: &BackgroundKind| match k {
        BackgroundKind::Carpet => true,
        BackgroundKind::Rendered => !renders.is_empty(),
        BackgroundKind::Photos => !pictures.is_empty(),
    };
    let kinds: Vec<BackgroundKind> = if spec.kinds.is_empty() {
        [
            BackgroundKind::Carpet,
            BackgroundKind::Rendered,
            BackgroundKind::Photos,
        ]
        .into_iter()
        .filter(available)
        .collect()
    } else {
        if let Some(k) = spec.kinds.iter().find(|k| !available(k)) {
            bail!("no {k:?} backgrounds: give --backgrounds or --rendered");
        }
        spec.kinds.clone()
    };
    let mut with_ball = 0;
    let mut photos = Vec::new();
    for i in 0..spec.count {
        let k = (i as usize) / kinds.len();
        let background = match kinds[(i as usize) % kinds.len()] {
            BackgroundKind::Carpet => Background::Carpet,
            BackgroundKind::Rendered => Background::Picture(&renders[k % renders.len()]),
            BackgroundKind::Photos => Background::Picture(&pictures[k % pictures.len()]),
        };
        let photo = synth_photo(&spec.profile, background, spec.seed, i);
        let (bytes, ext) = encode(&photo)?;
        let name = format!("{i:05}");
        let image = format!("{name}.{ext}");
        std::fs::write(images.join(&image), bytes)?;
        photos.push(ManifestPhoto {
            image: format!("images/{image}"),
            ball_designs: photo.balls.iter().map(|b| b.design.name()).collect(),
        });
        let mut text = String::new();
        for b in &photo.balls {
            let [x0, y0, x1, y1] = b.box_px;
            let ball = BallBox {
                x_min_px: x0,
                y_min_px: y0,
                x_max_px: x1,
                y_max_px: y1,
            };
            text.push_str(&yolo_line(0, &ball, photo.frame.width, photo.frame.height));
            text.push('\n');
        }
        std::fs::write(labels.join(format!("{name}.txt")), text)?;
        with_ball += usize::from(!photo.balls.is_empty());
        progress.inc(name);
    }
    let manifest = Manifest {
        made_by: "synth_photos",
        profile: spec.profile.name,
        seed: spec.seed,
        count: spec.count,
        photos_with_a_ball: with_ball,
        backgrounds: spec
            .backgrounds
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
        rendered_views: spec.rendered,
        kinds: kinds.clone(),
        designs: spec
            .profile
            .designs
            .iter()
            .filter(|&&(_, w)| w > 0.0)
            .map(|&(d, weight)| ManifestDesign {
                design: d.name(),
                weight,
            })
            .collect(),
        photos,
        note: "simulated: balls painted by sim::photo_synth; backgrounds are carpets, renders \
               and the listed photos",
    };
    std::fs::write(
        out.join("manifest.json"),
        serde_json::to_string_pretty(&manifest)?,
    )?;
    Ok(with_ball)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use sim::BallDesign;

    #[test]
    fn the_manifest_names_each_photos_ball_design() {
        let dir = tempfile::tempdir().unwrap();
        let designs = [BallDesign::Classic, BallDesign::Yellow];
        let spec = PhotoSetSpec {
            profile: PhotoProfile {
                sizes_px: &[(64, 48)],
                ..PhotoProfile::train().with_designs(&designs)
            },
            count: 12,
            seed: 4,
            backgrounds: Vec::new(),
            erase_class: None,
            rendered: 0,
            kinds: vec![BackgroundKind::Carpet],
        };
        let with_ball = write_photo_set(&spec, dir.path(), &Progress::hidden(12)).unwrap();
        let text = std::fs::read_to_string(dir.path().join("manifest.json")).unwrap();
        let manifest: serde_json::Value = serde_json::from_str(&text).unwrap();
        let drawn: Vec<&str> = manifest["designs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| d["design"].as_str().unwrap())
            .collect();
        assert_eq!(drawn, ["classic", "yellow"]);
        let photos = manifest["photos"].as_array().unwrap();
        assert_eq!(photos.len(), 12);
        let mut balls = 0;
        for (i, p) in photos.iter().enumerate() {
            let image = p["image"].as_str().unwrap();
            assert!(dir.path().join(image).is_file(), "{image}");
            assert!(image.starts_with(&format!("images/{i:05}.")), "{image}");
            let labels = std::fs::read_to_string(dir.path().join(format!("labels/{i:05}.txt")));
            let designs = p["ball_designs"].as_array().unwrap();
            assert_eq!(designs.len(), labels.unwrap().lines().count());
            for d in designs {
                assert!(drawn.contains(&d.as_str().unwrap()), "{d}");
            }
            balls += usize::from(!designs.is_empty());
        }
        assert_eq!(balls, with_ball);
    }

    #[test]
    fn a_background_photos_labelled_ball_is_painted_over() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (96u32, 72u32);
        // A green floor with a red ball, labelled (class 0) beside the photo.
        let mut image = vision::RgbImage::filled(w, h, [40, 140, 50]).unwrap();
        for y in 0..h {
            for x in 0..w {
                if (f64::from(x) - 48.0).hypot(f64::from(y) - 36.0) < 10.0 {
                    image.set_pixel(x, y, [230, 20, 20]);
                }
            }
        }
        let background = dir.path().join("field.png");
        std::fs::write(&background, robot_agent::encode_png(&image).unwrap()).unwrap();
        std::fs::write(
            dir.path().join("field.txt"),
            "0 0.5 0.5 0.2083333 0.2777778\n",
        )
        .unwrap();
        let red = |out: &Path| -> usize {
            let mut n = 0;
            for f in std::fs::read_dir(out.join("images")).unwrap() {
                let photo = robot_agent::load_rgb(&f.unwrap().path()).unwrap();
                n += photo
                    .data()
                    .chunks_exact(3)
                    .filter(|p| u16::from(p[0]) > u16::from(p[1]) + 80)
                    .count();
            }
            n
        };
        for (erase, out) in [(None, "kept"), (Some(0), "erased")] {
            let spec = PhotoSetSpec {
                profile: PhotoProfile {
                    sizes_px: &[(96, 72)],
                    ball_chance: 0.0,
                    distractors: [0, 0],
                    ..PhotoProfile::train()
                },
                count: 4,
                seed: 2,
                backgrounds: vec![background.clone()],
                erase_class: erase,
                rendered: 0,
                kinds: vec![BackgroundKind::Photos],
            };
            let out = dir.path().join(out);
            write_photo_set(&spec, &out, &Progress::hidden(4)).unwrap();
            let n = red(&out);
            match erase {
                None => assert!(n > 20, "the real ball is in the photos ({n} red pixels)"),
                Some(_) => assert_eq!(n, 0, "the real ball is painted over"),
            }
        }
    }
}
