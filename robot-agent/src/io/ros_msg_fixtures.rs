//! A small encoder of the ROS messages `ros_msg` decodes, written apart from the decoder
//! (from the ROS 1 and CDR rules, not from its code) so that round trips test both. Used
//! by the library's tests, the runtime's recording tests and (with the `test-support`
//! feature) the system tests' and the tools'; it depends on nothing in the crate.

#![allow(dead_code)]

/// Bytes of one message being written.
#[derive(Debug)]
pub struct Enc {
    buf: Vec<u8>,
    cdr: bool,
}

impl Enc {
    pub fn new(cdr: bool) -> Self {
        Enc {
            // Plain CDR, little-endian, no options.
            buf: if cdr { vec![0, 1, 0, 0] } else { Vec::new() },
            cdr,
        }
    }

    fn align(&mut self, n: usize) {
        if self.cdr {
            while !(self.buf.len() - 4).is_multiple_of(n) {
                self.buf.push(0);
            }
        }
    }

    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    pub fn string(&mut self, s: &str) -> &mut Self {
        if self.cdr {
            self.u32(s.len() as u32 + 1);
            self.buf.extend_from_slice(s.as_bytes());
            self.buf.push(0);
        } else {
            self.u32(s.len() as u32);
            self.buf.extend_from_slice(s.as_bytes());
        }
        self
    }

    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.u32(b.len() as u32);
        self.buf.extend_from_slice(b);
        self
    }

    pub fn f64_seq(&mut self, v: &[f64]) -> &mut Self {
        self.u32(v.len() as u32);
        for &x in v {
            self.f64(x);
        }
        self
    }

    pub fn string_seq(&mut self, v: &[&str]) -> &mut Self {
        self.u32(v.len() as u32);
        for s in v {
            self.string(s);
        }
        self
    }

    /// `std_msgs/Header` (ROS 1 with a sequence number 7; ROS 2 without).
    pub fn header(&mut self, secs: u32, nsecs: u32, frame_id: &str) -> &mut Self {
        if !self.cdr {
            self.u32(7);
        }
        self.u32(secs).u32(nsecs).string(frame_id)
    }

    pub fn done(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.buf)
    }
}

pub fn compressed_image(
    cdr: bool,
    (secs, nsecs): (u32, u32),
    frame_id: &str,
    format: &str,
    data: &[u8],
) -> Vec<u8> {
    Enc::new(cdr)
        .header(secs, nsecs, frame_id)
        .string(format)
        .bytes(data)
        .done()
}

pub fn joint_state(
    cdr: bool,
    (secs, nsecs): (u32, u32),
    names: &[&str],
    positions: &[f64],
) -> Vec<u8> {
    let zeros = vec![0.0; positions.len()];
    Enc::new(cdr)
        .header(secs, nsecs, "")
        .string_seq(names)
        .f64_seq(positions)
        .f64_seq(&zeros)
        .f64_seq(&[])
        .done()
}

pub fn pose2d(cdr: bool, x_m: f64, y_m: f64, theta_rad: f64) -> Vec<u8> {
    Enc::new(cdr).f64(x_m).f64(y_m).f64(theta_rad).done()
}

/// Odometry at (x, y) heading `yaw_rad`, with `variance` on the pose covariance's
/// diagonal.
pub fn odometry(
    cdr: bool,
    (secs, nsecs): (u32, u32),
    (x_m, y_m, yaw_rad): (f64, f64, f64),
    variance: f64,
) -> Vec<u8> {
    let mut e = Enc::new(cdr);
    e.header(secs, nsecs, "odom").string("base_link");
    e.f64(x_m).f64(y_m).f64(0.0);
    let half = yaw_rad / 2.0;
    e.f64(0.0).f64(0.0).f64(half.sin()).f64(half.cos());
    for i in 0..36 {
        e.f64(if i % 7 == 0 { variance } else { 0.0 });
    }
    for _ in 0..6 + 36 {
        e.f64(0.0);
    }
    e.done()
}

/// One message of a test bag: topic, ROS type (`sensor_msgs/CompressedImage`), log time
/// (ns) and the encoded message.
pub type Msg = (&'static str, &'static str, u64, Vec<u8>);

/// Writes `messages` to an MCAP file with ROS 1 (`ros1msg`, `ros1`) or ROS 2 (`ros2msg`,
/// `cdr`) channels, one per topic.
pub fn write_bag(path: &std::path::Path, cdr: bool, messages: &[Msg]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).expect("test bag written"));
    let mut w = mcap::WriteOptions::new()
        .profile(if cdr { "ros2" } else { "ros1" })
        .create(file)
        .expect("test bag written");
    let (schema_encoding, message_encoding) = if cdr {
        ("ros2msg", "cdr")
    } else {
        ("ros1msg", "ros1")
    };
    let mut channels = std::collections::BTreeMap::new();
    for (seq, (topic, schema, log_time, data)) in messages.iter().enumerate() {
        let id = *channels.entry(*topic).or_insert_with(|| {
            let name = if cdr {
                schema.replacen('/', "/msg/", 1)
            } else {
                schema.to_string()
            };
            let s = w
                .add_schema(&name, schema_encoding, b"# definition not needed")
                .expect("test bag written");
            w.add_channel(s, topic, message_encoding, &Default::default())
                .expect("test bag written")
        });
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: seq as u32,
            log_time: *log_time,
            publish_time: *log_time,
        };
        w.write_to_known_channel(&header, data)
            .expect("test bag written");
    }
    w.finish().expect("test bag written");
}
