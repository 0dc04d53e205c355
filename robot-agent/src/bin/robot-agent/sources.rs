//! Where camera frames come from: the simulator's rendered cameras, an image folder, or an
//! MCAP recording.

use crate::frames_io::{
    FrameRecord, McapFrames, StoredFrame, load_image, read_index, read_mcap, state_at,
};
use anyhow::{Context, Result, bail};
use std::path::PathBuf;

/// A frame with, from the simulator, the ball's ground truth.
#[derive(Debug)]
pub struct Captured {
    pub frame: StoredFrame,
    pub truth: Option<sim::render_scene::BallTruth>,
}

/// Frames in capture order.
pub trait FrameSource: Send {
    /// The next frame, or `None` at the end.
    fn next_frame(&mut self) -> Result<Option<Captured>>;
    /// Frames are paced by their stamps unless the source is a file (processed as fast as
    /// possible unless asked otherwise).
    fn live(&self) -> bool;
}

/// How a `--source` argument names a source.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceSpec {
    Sim,
    Images(PathBuf),
    Mcap(PathBuf),
}

impl std::str::FromStr for SourceSpec {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Self> {
        match s.split_once(':') {
            None if s == "sim" => Ok(SourceSpec::Sim),
            Some(("images", dir)) if !dir.is_empty() => Ok(SourceSpec::Images(dir.into())),
            Some(("mcap", file)) if !file.is_empty() => Ok(SourceSpec::Mcap(file.into())),
            _ => bail!("source {s:?} is not sim, images:DIR or mcap:FILE"),
        }
    }
}

/// An image folder with its `frames.jsonl` index.
#[derive(Debug)]
pub struct ImagesSource {
    dir: PathBuf,
    records: std::vec::IntoIter<FrameRecord>,
}

impl ImagesSource {
    pub fn open(dir: PathBuf) -> Result<Self> {
        let records = read_index(&dir)?;
        tracing::info!("{}: {} frames", dir.display(), records.len());
        Ok(ImagesSource {
            dir,
            records: records.into_iter(),
        })
    }
}

impl FrameSource for ImagesSource {
    fn next_frame(&mut self) -> Result<Option<Captured>> {
        let Some(r) = self.records.next() else {
            return Ok(None);
        };
        let image = load_image(&self.dir, &r.file)?;
        Ok(Some(Captured {
            frame: StoredFrame {
                stamp: r.stamp,
                camera: r.camera,
                image,
                state: r.state,
            },
            truth: None,
        }))
    }

    fn live(&self) -> bool {
        false
    }
}

/// An MCAP recording of camera images and robot states.
#[derive(Debug)]
pub struct McapSource {
    frames: McapFrames,
    next: usize,
}

impl McapSource {
    pub fn open(path: PathBuf) -> Result<Self> {
        let frames = read_mcap(&path)?;
        for (why, n) in &frames.skipped {
            tracing::warn!("{}: skipped {n} message(s): {why}", path.display());
        }
        if frames.states.is_empty() && !frames.images.is_empty() {
            bail!(
                "{} has images but no /robot/state messages: frames cannot be projected without the robot's pose",
                path.display()
            );
        }
        tracing::info!(
            "{}: {} images, {} states",
            path.display(),
            frames.images.len(),
            frames.states.len()
        );
        Ok(McapSource { frames, next: 0 })
    }
}

impl FrameSource for McapSource {
    fn next_frame(&mut self) -> Result<Option<Captured>> {
        while let Some((stamp, camera, image)) = self.frames.images.get(self.next) {
            self.next += 1;
            let image = match image.decode() {
                Ok(i) => i,
                Err(e) => {
                    tracing::warn!("skipping an image at {}: {e:#}", stamp.0);
                    continue;
                }
            };
            let state = state_at(&self.frames.states, *stamp).context("no robot state")?;
            return Ok(Some(Captured {
                frame: StoredFrame {
                    stamp: *stamp,
                    camera: *camera,
                    image,
                    state,
                },
                truth: None,
            }));
        }
        Ok(None)
    }

    fn live(&self) -> bool {
        false
    }
}
