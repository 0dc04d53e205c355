//! The few ROS messages a MiRo's recording needs, decoded from their two wire encodings:
//! ROS 1 (MCAP message encoding `ros1`) and ROS 2's CDR (`cdr`).
//!
//! - `sensor_msgs/CompressedImage`: the camera frames (JPEG or PNG bytes).
//! - `sensor_msgs/JointState`: the head joints by name (`lift`, `yaw`, `pitch`).
//! - `geometry_msgs/Pose2D`: the body pose from odometry.
//! - `nav_msgs/Odometry`: the same as position, orientation and covariance.
//!
//! **ROS 1** is little-endian and packed: a `Header` is `u32 seq, u32 secs, u32 nsecs,
//! string frame_id`; a string and a variable array are a `u32` count and the elements.
//! **CDR** (XCDR1, as ROS 2 writes it) starts with a 4-byte encapsulation header
//! (`00 01` little-endian, `00 00` big-endian, then two option bytes); every primitive is
//! aligned to its size, counted from the end of that header; a string's `u32` length
//! counts its terminating NUL; a ROS 2 header has no `seq` and an `i32` second.
//!
//! Every count is checked against the bytes that remain before anything is allocated, so
//! a truncated or damaged message is an error, never a panic or a huge allocation. Bytes
//! left over after the last field mean the message is not what its schema says and are
//! an error too (CDR may end in alignment padding).

use proto::{HeadJoints, Pose2, Stamp};
use thiserror::Error;

/// Why a message could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum RosDecodeError {
    /// A field runs past the end of the message.
    #[error("{field} needs {needed} bytes but only {remaining} remain")]
    Truncated {
        /// The field being read.
        field: &'static str,
        /// Bytes it needs.
        needed: u64,
        /// Bytes left in the message.
        remaining: usize,
    },
    /// The CDR encapsulation header is not plain CDR.
    #[error("CDR encapsulation {0:02x?} is not plain CDR (00 00 or 00 01)")]
    Encapsulation([u8; 2]),
    /// A string is not UTF-8.
    #[error("{field} is not UTF-8")]
    NotUtf8 {
        /// The field being read.
        field: &'static str,
    },
    /// A CDR string does not end in NUL.
    #[error("{field} does not end in NUL as a CDR string must")]
    MissingNul {
        /// The field being read.
        field: &'static str,
    },
    /// A ROS 2 stamp before the epoch.
    #[error("header stamp has negative seconds ({0})")]
    NegativeStamp(i32),
    /// Bytes after the last field.
    #[error("{0} bytes after the message's last field")]
    TrailingBytes(usize),
}

/// The wire encoding of a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 1 serialisation (MCAP `ros1`).
    Ros1,
    /// ROS 2 CDR serialisation (MCAP `cdr`).
    Cdr,
}

impl Encoding {
    /// The encoding of an MCAP channel's `message_encoding`, if it is a ROS one.
    pub fn of_mcap(message_encoding: &str) -> Option<Encoding> {
        match message_encoding {
            "ros1" => Some(Encoding::Ros1),
            "cdr" => Some(Encoding::Cdr),
            _ => None,
        }
    }
}

/// The message types decoded here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MessageType {
    CompressedImage,
    JointState,
    Pose2D,
    Odometry,
}

impl MessageType {
    /// The type a schema names, ROS 1 style (`sensor_msgs/CompressedImage`) or ROS 2
    /// style (`sensor_msgs/msg/CompressedImage`).
    pub fn of_schema_name(name: &str) -> Option<MessageType> {
        let (package, rest) = name.split_once('/')?;
        let ty = rest.strip_prefix("msg/").unwrap_or(rest);
        match (package, ty) {
            ("sensor_msgs", "CompressedImage") => Some(MessageType::CompressedImage),
            ("sensor_msgs", "JointState") => Some(MessageType::JointState),
            ("geometry_msgs", "Pose2D") => Some(MessageType::Pose2D),
            ("nav_msgs", "Odometry") => Some(MessageType::Odometry),
            _ => None,
        }
    }
}

/// `std_msgs/Header` without ROS 1's sequence number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// The stamp, nanoseconds since the epoch (zero when the publisher left it unset).
    pub stamp: Stamp,
    pub frame_id: String,
}

/// `sensor_msgs/CompressedImage`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CompressedImage {
    pub header: Header,
    /// As published, e.g. `jpeg` or `rgb8; jpeg compressed bgr8`.
    pub format: String,
    /// The compressed image.
    pub data: Vec<u8>,
}

/// `sensor_msgs/JointState`: positions in radians (or metres for prismatic joints).
#[derive(Debug, Clone, PartialEq)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}

impl JointState {
    /// The position of the joint called `name`.
    pub fn position_of(&self, name: &str) -> Option<f64> {
        let i = self.name.iter().position(|n| n == name)?;
        self.position.get(i).copied().filter(|p| p.is_finite())
    }

    /// A MiRo's neck joints (`lift`, `yaw`, `pitch`; MiRo's own angles match
    /// `proto::miro`'s chain), if all three are present.
    pub fn miro_head(&self) -> Option<HeadJoints> {
        Some(HeadJoints {
            lift_rad: self.position_of("lift")?,
            yaw_rad: self.position_of("yaw")?,
            pitch_rad: self.position_of("pitch")?,
        })
    }
}

/// `geometry_msgs/Pose2D`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose2D {
    pub x_m: f64,
    pub y_m: f64,
    pub theta_rad: f64,
}

impl Pose2D {
    pub fn pose(&self) -> Pose2 {
        Pose2 {
            x_m: self.x_m,
            y_m: self.y_m,
            theta_rad: self.theta_rad,
        }
    }
}

/// What the agent uses of `nav_msgs/Odometry`: the planar pose and its covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    pub header: Header,
    pub child_frame_id: String,
    pub x_m: f64,
    pub y_m: f64,
    /// The heading from the orientation quaternion.
    pub yaw_rad: f64,
    /// Row-major 6×6 covariance of (x, y, z, roll, pitch, yaw).
    pub pose_covariance: [f64; 36],
}

impl Odometry {
    pub fn pose(&self) -> Pose2 {
        Pose2 {
            x_m: self.x_m,
            y_m: self.y_m,
            theta_rad: self.yaw_rad,
        }
    }

    /// The row-major 3×3 covariance of (x, y, yaw) taken from the 6×6 one.
    pub fn planar_covariance(&self) -> [f64; 9] {
        const AXES: [usize; 3] = [0, 1, 5];
        let mut out = [0.0; 9];
        for (r, &i) in AXES.iter().enumerate() {
            for (c, &j) in AXES.iter().enumerate() {
                out[3 * r + c] = self.pose_covariance[6 * i + j];
            }
        }
        out
    }
}

/// A cursor over one message's bytes with every read bounds-checked.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Where CDR alignment is counted from; `None` for ROS 1 (no alignment).
    cdr_origin: Option<usize>,
    big_endian: bool,
}

impl<'a> Reader<'a> {
    fn new(encoding: Encoding, bytes: &'a [u8]) -> Result<Self, RosDecodeError> {
        match encoding {
            Encoding::Ros1 => Ok(Reader {
                bytes,
                pos: 0,
                cdr_origin: None,
                big_endian: false,
            }),
            Encoding::Cdr => {
                let head = bytes.get(..4).ok_or(RosDecodeError::Truncated {
                    field: "CDR encapsulation header",
                    needed: 4,
                    remaining: bytes.len(),
                })?;
                let big_endian = match [head[0], head[1]] {
                    [0, 0] => true,
                    [0, 1] => false,
                    other => return Err(RosDecodeError::Encapsulation(other)),
                };
                Ok(Reader {
                    bytes,
                    pos: 4,
                    cdr_origin: Some(4),
                    big_endian,
                })
            }
        }
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn take(&mut self, n: u64, field: &'static str) -> Result<&'a [u8], RosDecodeError> {
        let remaining = self.remaining();
        let n_usize = usize::try_from(n).ok().filter(|&k| k <= remaining).ok_or(
            RosDecodeError::Truncated {
                field,
                needed: n,
                remaining,
            },
        )?;
        let out = &self.bytes[self.pos..self.pos + n_usize];
        self.pos += n_usize;
        Ok(out)
    }

    /// Skips CDR padding up to a multiple of `size` (nothing in ROS 1).
    fn align(&mut self, size: usize, field: &'static str) -> Result<(), RosDecodeError> {
        if let Some(origin) = self.cdr_origin {
            let pad = (size - (self.pos - origin) % size) % size;
            self.take(pad as u64, field)?;
        }
        Ok(())
    }

    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], RosDecodeError> {
        self.align(N, field)?;
        let mut out = [0; N];
        out.copy_from_slice(self.take(N as u64, field)?);
        if self.big_endian {
            out.reverse();
        }
        Ok(out)
    }

    fn u32(&mut self, field: &'static str) -> Result<u32, RosDecodeError> {
        self.array::<4>(field).map(u32::from_le_bytes)
    }

    fn i32(&mut self, field: &'static str) -> Result<i32, RosDecodeError> {
        self.array::<4>(field).map(i32::from_le_bytes)
    }

    fn f64(&mut self, field: &'static str) -> Result<f64, RosDecodeError> {
        self.array::<8>(field).map(f64::from_le_bytes)
    }

    fn string(&mut self, field: &'static str) -> Result<String, RosDecodeError> {
        let len = self.u32(field)?;
        let raw = self.take(u64::from(len), field)?;
        let text = match (self.cdr_origin, raw.split_last()) {
            (None, _) => raw,
            // Some writers send an empty CDR string as a bare zero length.
            (Some(_), None) => raw,
            (Some(_), Some((0, text))) => text,
            (Some(_), Some(_)) => return Err(RosDecodeError::MissingNul { field }),
        };
        String::from_utf8(text.to_vec()).map_err(|_| RosDecodeError::NotUtf8 { field })
    }

    fn bytes(&mut self, field: &'static str) -> Result<Vec<u8>, RosDecodeError> {
        let len = self.u32(field)?;
        Ok(self.take(u64::from(len), field)?.to_vec())
    }

    fn f64_seq(&mut self, field: &'static str) -> Result<Vec<f64>, RosDecodeError> {
        let count = self.u32(field)?;
        if count == 0 {
            return Ok(Vec::new());
        }
        self.align(8, field)?;
        let needed = u64::from(count) * 8;
        if needed > self.remaining() as u64 {
            return Err(RosDecodeError::Truncated {
                field,
                needed,
                remaining: self.remaining(),
            });
        }
        (0..count).map(|_| self.f64(field)).collect()
    }

    fn string_seq(&mut self, field: &'static str) -> Result<Vec<String>, RosDecodeError> {
        let count = self.u32(field)?;
        // Each string takes at least its 4-byte length: refuse counts the bytes cannot hold
        // before reserving anything.
        let needed = u64::from(count) * 4;
        if needed > self.remaining() as u64 {
            return Err(RosDecodeError::Truncated {
                field,
                needed,
                remaining: self.remaining(),
            });
        }
        (0..count).map(|_| self.string(field)).collect()
    }

    fn header(&mut self) -> Result<Header, RosDecodeError> {
        let stamp = match self.cdr_origin {
            None => {
                self.u32("header.seq")?;
                let secs = self.u32("header.stamp.secs")?;
                let nsecs = self.u32("header.stamp.nsecs")?;
                stamp_of(u64::from(secs), nsecs)
            }
            Some(_) => {
                let secs = self.i32("header.stamp.sec")?;
                let nsecs = self.u32("header.stamp.nanosec")?;
                let secs = u64::try_from(secs).map_err(|_| RosDecodeError::NegativeStamp(secs))?;
                stamp_of(secs, nsecs)
            }
        };
        Ok(Header {
            stamp,
            frame_id: self.string("header.frame_id")?,
        })
    }

    /// The message ends here: nothing but CDR's alignment padding may follow.
    fn finish(self) -> Result<(), RosDecodeError> {
        let left = self.remaining();
        let padding_allowed = if self.cdr_origin.is_some() { 7 } else { 0 };
        if left > padding_allowed {
            return Err(RosDecodeError::TrailingBytes(left));
        }
        Ok(())
    }
}

fn stamp_of(secs: u64, nsecs: u32) -> Stamp {
    Stamp(
        secs.saturating_mul(1_000_000_000)
            .saturating_add(u64::from(nsecs)),
    )
}

/// Decodes a `sensor_msgs/CompressedImage`.
pub fn decode_compressed_image(
    encoding: Encoding,
    bytes: &[u8],
) -> Result<CompressedImage, RosDecodeError> {
    let mut r = Reader::new(encoding, bytes)?;
    let header = r.header()?;
    let format = r.string("format")?;
    let data = r.bytes("data")?;
    r.finish()?;
    Ok(CompressedImage {
        header,
        format,
        data,
    })
}

/// Decodes a `sensor_msgs/JointState`.
pub fn decode_joint_state(encoding: Encoding, bytes: &[u8]) -> Result<JointState, RosDecodeError> {
    let mut r = Reader::new(encoding, bytes)?;
    let header = r.header()?;
    let name = r.string_seq("name")?;
    let position = r.f64_seq("position")?;
    let velocity = r.f64_seq("velocity")?;
    let effort = r.f64_seq("effort")?;
    r.finish()?;
    Ok(JointState {
        header,
        name,
        position,
        velocity,
        effort,
    })
}

/// Decodes a `geometry_msgs/Pose2D`.
pub fn decode_pose2d(encoding: Encoding, bytes: &[u8]) -> Result<Pose2D, RosDecodeError> {
    let mut r = Reader::new(encoding, bytes)?;
    let pose = Pose2D {
        x_m: r.f64("x")?,
        y_m: r.f64("y")?,
        theta_rad: r.f64("theta")?,
    };
    r.finish()?;
    Ok(pose)
}

/// Decodes a `nav_msgs/Odometry` (the twist is read, to check the message, and dropped).
pub fn decode_odometry(encoding: Encoding, bytes: &[u8]) -> Result<Odometry, RosDecodeError> {
    let mut r = Reader::new(encoding, bytes)?;
    let header = r.header()?;
    let child_frame_id = r.string("child_frame_id")?;
    let x_m = r.f64("pose.position.x")?;
    let y_m = r.f64("pose.position.y")?;
    r.f64("pose.position.z")?;
    let [qx, qy, qz, qw] = [
        r.f64("pose.orientation.x")?,
        r.f64("pose.orientation.y")?,
        r.f64("pose.orientation.z")?,
        r.f64("pose.orientation.w")?,
    ];
    let mut pose_covariance = [0.0; 36];
    for c in &mut pose_covariance {
        *c = r.f64("pose.covariance")?;
    }
    for _ in 0..6 + 36 {
        r.f64("twist")?;
    }
    r.finish()?;
    let yaw_rad = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
    Ok(Odometry {
        header,
        child_frame_id,
        x_m,
        y_m,
        yaw_rad,
        pose_covariance,
    })
}

#[cfg(test)]
#[path = "ros_msg_tests.rs"]
mod tests;
