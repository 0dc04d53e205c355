//! What a frame is, wherever it comes from: the image, its camera and capture time, and
//! the robot's state at the capture ([`StoredFrame`], [`RobotState`]); and an image message
//! of a recording, decoded only when its frame is processed ([`McapImage`]).

use crate::pipeline::FrameInput;
use anyhow::{Result, bail};
use proto::{Camera, HeadJoints, Pose2, Stamp};
use serde::{Deserialize, Serialize};
use vision::image::RgbImage;

/// The robot's state at a capture: what projection needs besides the image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotState {
    #[serde(default)]
    pub state_stamp: Option<Stamp>,
    pub pose: Pose2,
    /// Row-major 3×3 covariance of (x, y, θ).
    pub pose_covariance: [f64; 9],
    pub head: HeadJoints,
}

/// A frame read from disk.
#[derive(Debug, Clone)]
pub struct StoredFrame {
    pub stamp: Stamp,
    pub camera: Camera,
    pub image: RgbImage,
    pub state: RobotState,
}

impl StoredFrame {
    /// The frame as the pipeline takes it.
    pub fn input(&self) -> FrameInput<'_> {
        FrameInput {
            stamp: self.stamp,
            camera: self.camera,
            image: &self.image,
            pose: self.state.pose,
            pose_covariance: self.state.pose_covariance,
            head: self.state.head,
        }
    }
}

/// An image message, decoded when its frame is processed.
#[derive(Debug, Clone)]
pub enum McapImage {
    Compressed(Vec<u8>),
    Raw {
        width: u32,
        height: u32,
        encoding: String,
        step: u32,
        data: Vec<u8>,
    },
}

impl McapImage {
    pub fn decode(&self) -> Result<RgbImage> {
        match self {
            McapImage::Compressed(bytes) => {
                crate::io::image_io::decode_rgb(bytes).map_err(Into::into)
            }
            McapImage::Raw {
                width,
                height,
                encoding,
                step,
                data,
            } => raw_to_rgb(*width, *height, encoding, *step, data),
        }
    }
}

fn raw_to_rgb(width: u32, height: u32, encoding: &str, step: u32, data: &[u8]) -> Result<RgbImage> {
    let channels = match encoding {
        "rgb8" | "bgr8" => 3,
        "mono8" => 1,
        other => bail!("raw image encoding {other:?} is not rgb8, bgr8 or mono8"),
    };
    let (w, h, step) = (width as usize, height as usize, step as usize);
    if step < w * channels || data.len() < step * h.saturating_sub(1) + w * channels {
        bail!(
            "raw image of {width}×{height} ({encoding}, step {step}) holds only {} bytes",
            data.len()
        );
    }
    let mut rgb = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        let row = &data[y * step..y * step + w * channels];
        match encoding {
            "rgb8" => rgb.extend_from_slice(row),
            "bgr8" => row
                .chunks_exact(3)
                .for_each(|p| rgb.extend_from_slice(&[p[2], p[1], p[0]])),
            _ => row.iter().for_each(|&v| rgb.extend_from_slice(&[v, v, v])),
        }
    }
    Ok(RgbImage::new(width, height, rgb)?)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn raw_images_convert_and_short_buffers_are_refused() {
        let rgb = raw_to_rgb(2, 1, "bgr8", 6, &[1, 2, 3, 4, 5, 6]).unwrap();
        assert_eq!(rgb.data(), &[3, 2, 1, 6, 5, 4]);
        let mono = raw_to_rgb(2, 1, "mono8", 2, &[7, 9]).unwrap();
        assert_eq!(mono.data(), &[7, 7, 7, 9, 9, 9]);
        assert!(raw_to_rgb(2, 2, "rgb8", 6, &[0; 8]).is_err());
        assert!(raw_to_rgb(2, 1, "yuv422", 4, &[0; 4]).is_err());
    }
}
