//! Camera frames on disk: an image folder with a `frames.jsonl` index, and MCAP
//! recordings of camera images (compressed or raw) with the robot's pose.
//!
//! MCAP layout (JSON messages, JSON-schema channels), written by `--record-frames` and read
//! by `--source mcap:FILE`; a real robot's recorder only has to follow it:
//!
//! - `/camera/left/image`, `/camera/right/image`: `foxglove.CompressedImage`
//!   (`{timestamp: {sec, nsec}, frame_id, format: "png" | "jpeg", data: base64}`) or
//!   `foxglove.RawImage` (`{timestamp, frame_id, width, height, encoding: "rgb8" | "bgr8" |
//!   "mono8", step, data: base64}`). The camera is the topic's (or else the frame id's)
//!   `left` / `right`.
//! - `/robot/state`: `rf.RobotFrameState`, [`RobotState`](crate::runtime::frame::RobotState): the pose, its covariance and the
//!   head joints at a stamp. Each image takes the latest state at or before its capture
//!   (or the first one).
//!
//! A MiRo's ROS recordings (channels with the `ros1` or `cdr` message encoding) are read
//! too: see [`crate::ros_frames`].

use crate::io::ros_msg::Encoding;
use crate::runtime::frame::{McapImage, RobotState, StoredFrame};
use crate::runtime::ros_frames::{RosMessage, RosStates, RosTopics};
use anyhow::{Context, Result, bail};
use base64::Engine;
use base64::engine::general_purpose::STANDARD as BASE64;
use proto::{Camera, Stamp};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use vision::image::RgbImage;

/// One line of an image folder's `frames.jsonl`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameRecord {
    /// Image file (PNG or JPEG), relative to the folder.
    pub file: String,
    pub camera: Camera,
    /// Capture time, nanoseconds since the UNIX epoch.
    pub stamp: Stamp,
    #[serde(flatten)]
    pub state: RobotState,
}

/// Reads an image folder's index; images are loaded lazily by [`load_image`].
pub fn read_index(dir: &Path) -> Result<Vec<FrameRecord>> {
    let path = dir.join("frames.jsonl");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "reading {} (an image folder needs a frames.jsonl index: one JSON line per image \
             with file, camera, stamp, pose, pose_covariance and head)",
            path.display()
        )
    })?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let rec: FrameRecord = serde_json::from_str(line)
            .with_context(|| format!("{} line {}", path.display(), n + 1))?;
        out.push(rec);
    }
    out.sort_by_key(|r| r.stamp);
    Ok(out)
}

pub fn load_image(dir: &Path, file: &str) -> Result<RgbImage> {
    let path = dir.join(file);
    let bytes = std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
    crate::io::image_io::decode_rgb(&bytes).with_context(|| format!("decoding {}", path.display()))
}

/// Writes an image folder: PNG files and the `frames.jsonl` index.
#[derive(Debug)]
pub struct FolderWriter {
    dir: PathBuf,
    index: BufWriter<std::fs::File>,
    count: u64,
}

impl FolderWriter {
    pub fn create(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join("frames.jsonl");
        let index =
            std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        Ok(FolderWriter {
            dir: dir.to_path_buf(),
            index: BufWriter::new(index),
            count: 0,
        })
    }

    pub fn write(&mut self, frame: &StoredFrame) -> Result<()> {
        let side = camera_name(frame.camera);
        let file = format!("{:06}-{side}.png", self.count);
        let png = crate::io::image_io::encode_png(&frame.image)?;
        std::fs::write(self.dir.join(&file), png)?;
        let rec = FrameRecord {
            file,
            camera: frame.camera,
            stamp: frame.stamp,
            state: frame.state,
        };
        writeln!(self.index, "{}", serde_json::to_string(&rec)?)?;
        self.count += 1;
        Ok(())
    }

    pub fn finish(mut self) -> Result<()> {
        self.index.flush()?;
        Ok(())
    }
}

fn camera_name(camera: Camera) -> &'static str {
    match camera {
        Camera::Left => "left",
        Camera::Right => "right",
    }
}

const STATE_TOPIC: &str = "/robot/state";
const STATE_SCHEMA: &str = "rf.RobotFrameState";

fn image_topic(camera: Camera) -> String {
    format!("/camera/{}/image", camera_name(camera))
}

#[derive(Debug, Serialize, Deserialize)]
struct FoxgloveTime {
    sec: u64,
    nsec: u32,
}

impl FoxgloveTime {
    fn of(stamp: Stamp) -> Self {
        FoxgloveTime {
            sec: stamp.0 / 1_000_000_000,
            nsec: (stamp.0 % 1_000_000_000) as u32,
        }
    }

    fn stamp(&self) -> Stamp {
        Stamp(
            self.sec
                .saturating_mul(1_000_000_000)
                .saturating_add(u64::from(self.nsec)),
        )
    }
}

#[derive(Debug, Serialize, Deserialize)]
struct CompressedImage {
    timestamp: FoxgloveTime,
    frame_id: String,
    format: String,
    data: String,
}

#[derive(Debug, Deserialize)]
struct RawImage {
    timestamp: FoxgloveTime,
    frame_id: String,
    width: u32,
    height: u32,
    encoding: String,
    step: u32,
    data: String,
}

#[derive(Debug, Serialize, Deserialize)]
struct StateMessage {
    timestamp: FoxgloveTime,
    #[serde(flatten)]
    state: RobotState,
}

const COMPRESSED_SCHEMA: &str = r#"{"type":"object","title":"foxglove.CompressedImage","properties":{"timestamp":{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"frame_id":{"type":"string"},"format":{"type":"string"},"data":{"type":"string","contentEncoding":"base64"}}}"#;
const STATE_JSON_SCHEMA: &str = r#"{"type":"object","title":"rf.RobotFrameState","properties":{"timestamp":{"type":"object"},"pose":{"type":"object"},"pose_covariance":{"type":"array"},"head":{"type":"object"}}}"#;

/// Writes camera frames and robot states to an MCAP file in the layout above.
pub struct McapFrameWriter {
    writer: mcap::Writer<BufWriter<std::fs::File>>,
    image_channels: [u16; 2],
    state_channel: u16,
    sequence: u32,
}

impl std::fmt::Debug for McapFrameWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapFrameWriter")
            .field("sequence", &self.sequence)
            .finish_non_exhaustive()
    }
}

impl McapFrameWriter {
    pub fn create(path: &Path) -> Result<Self> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)?;
        }
        let file =
            std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("")
            .create(BufWriter::new(file))
            .context("starting the MCAP file")?;
        let image_schema = writer.add_schema(
            "foxglove.CompressedImage",
            "jsonschema",
            COMPRESSED_SCHEMA.as_bytes(),
        )?;
        let state_schema =
            writer.add_schema(STATE_SCHEMA, "jsonschema", STATE_JSON_SCHEMA.as_bytes())?;
        let meta = BTreeMap::new();
        let left = writer.add_channel(image_schema, &image_topic(Camera::Left), "json", &meta)?;
        let right = writer.add_channel(image_schema, &image_topic(Camera::Right), "json", &meta)?;
        let state_channel = writer.add_channel(state_schema, STATE_TOPIC, "json", &meta)?;
        Ok(McapFrameWriter {
            writer,
            image_channels: [left, right],
            state_channel,
            sequence: 0,
        })
    }

    fn put(&mut self, channel_id: u16, stamp: Stamp, payload: &[u8]) -> Result<()> {
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: stamp.0,
            publish_time: stamp.0,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.writer.write_to_known_channel(&header, payload)?;
        Ok(())
    }

    pub fn write(&mut self, frame: &StoredFrame) -> Result<()> {
        let state = StateMessage {
            timestamp: FoxgloveTime::of(frame.state.state_stamp.unwrap_or(frame.stamp)),
            state: frame.state,
        };
        self.put(
            self.state_channel,
            frame.stamp,
            &serde_json::to_vec(&state)?,
        )?;
        let image = CompressedImage {
            timestamp: FoxgloveTime::of(frame.stamp),
            frame_id: camera_name(frame.camera).into(),
            format: "png".into(),
            data: BASE64.encode(crate::io::image_io::encode_png(&frame.image)?),
        };
        let channel = self.image_channels[usize::from(frame.camera == Camera::Right)];
        self.put(channel, frame.stamp, &serde_json::to_vec(&image)?)
    }

    pub fn finish(mut self) -> Result<()> {
        self.writer.finish()?;
        Ok(())
    }
}

/// What an MCAP recording holds: images and states by capture time.
#[derive(Debug, Default)]
pub struct McapFrames {
    /// (stamp, camera, image bytes decoded lazily).
    pub images: Vec<(Stamp, Camera, McapImage)>,
    pub states: Vec<(Stamp, RobotState)>,
    /// The joints and poses of ROS channels.
    pub ros: RosStates,
    /// Whether the recording has ROS channels.
    pub has_ros: bool,
    /// Messages skipped, with the reason, for the log.
    pub skipped: BTreeMap<String, u64>,
}

fn camera_of(topic: &str, frame_id: &str) -> Option<Camera> {
    for text in [topic, frame_id] {
        let t = text.to_ascii_lowercase();
        if t.contains("left") {
            return Some(Camera::Left);
        }
        if t.contains("right") {
            return Some(Camera::Right);
        }
    }
    None
}

/// Reads a recording's images and states; messages it cannot use are counted, not fatal.
/// ROS channels are picked by `topics`.
pub fn read_mcap(path: &Path, topics: &RosTopics) -> Result<McapFrames> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let mut out = McapFrames::default();
    let stream = mcap::MessageStream::new(&bytes).context("not an MCAP file")?;
    for (n, message) in stream.enumerate() {
        let message = match message {
            Ok(m) => m,
            Err(e) if n == 0 => bail!("{} is not an MCAP file: {e}", path.display()),
            Err(e) => {
                *out.skipped
                    .entry(format!("unreadable record: {e}"))
                    .or_default() += 1;
                break;
            }
        };
        let topic = message.channel.topic.as_str();
        let schema = message
            .channel
            .schema
            .as_ref()
            .map(|s| s.name.as_str())
            .unwrap_or("");
        if let Some(encoding) = Encoding::of_mcap(&message.channel.message_encoding) {
            out.has_ros = true;
            let m = RosMessage {
                encoding,
                topic,
                schema_name: schema,
                log_time: Stamp(message.log_time),
                data: &message.data,
            };
            match crate::runtime::ros_frames::take(topics, &mut out.ros, &m) {
                Ok(Some(image)) => out.images.push(image),
                Ok(None) => {}
                Err(e) => *out.skipped.entry(format!("{topic}: {e:#}")).or_default() += 1,
            }
            continue;
        }
        let result: Result<()> = (|| {
            match schema {
                "foxglove.CompressedImage" => {
                    let m: CompressedImage = serde_json::from_slice(&message.data)?;
                    let camera =
                        camera_of(topic, &m.frame_id).context("image topic names no camera")?;
                    let data = BASE64.decode(m.data.as_bytes())?;
                    out.images
                        .push((m.timestamp.stamp(), camera, McapImage::Compressed(data)));
                }
                "foxglove.RawImage" => {
                    let m: RawImage = serde_json::from_slice(&message.data)?;
                    let camera =
                        camera_of(topic, &m.frame_id).context("image topic names no camera")?;
                    let data = BASE64.decode(m.data.as_bytes())?;
                    out.images.push((
                        m.timestamp.stamp(),
                        camera,
                        McapImage::Raw {
                            width: m.width,
                            height: m.height,
                            encoding: m.encoding,
                            step: m.step,
                            data,
                        },
                    ));
                }
                STATE_SCHEMA => {
                    let m: StateMessage = serde_json::from_slice(&message.data)?;
                    out.states.push((m.timestamp.stamp(), m.state));
                }
                other => bail!("schema {other:?} is not used"),
            }
            Ok(())
        })();
        if let Err(e) = result {
            *out.skipped.entry(format!("{topic}: {e}")).or_default() += 1;
        }
    }
    out.images
        .sort_by_key(|(s, c, _)| (*s, *c == Camera::Right));
    out.states.sort_by_key(|(s, _)| *s);
    Ok(out)
}

/// The latest state at or before `stamp`, else the first one.
pub fn state_at(states: &[(Stamp, RobotState)], stamp: Stamp) -> Option<RobotState> {
    let i = states.partition_point(|(s, _)| *s <= stamp);
    states.get(i.saturating_sub(1)).map(|(_, s)| *s)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    /// The index line shown in the agent's guide parses.
    #[test]
    fn the_guide_s_index_line_parses() {
        let guide = include_str!("../../../docs/robot-agent.md");
        let line = guide
            .split("```json\n")
            .nth(1)
            .and_then(|b| b.lines().next())
            .unwrap();
        let rec: FrameRecord = serde_json::from_str(line).unwrap();
        assert_eq!(rec.camera, Camera::Left);
        assert!(rec.state.pose_covariance[0] > 0.0);
    }
}
