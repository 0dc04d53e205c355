//! Helpers shared by the recorder tests: schemas, records and configurations.

use std::path::Path;
use std::sync::Arc;

use proto::test_support::{isotropic, observation};
use proto::{Camera, Observation, Pose2, Stamp};

use super::{LogCompression, Record, RecorderConfig, Schema, proto_schemas};
use crate::matchlog::read::LogMessage;

/// 2026-11-23T23:59:59Z.
pub(crate) const T0_NS: u64 = 1_795_478_399_000_000_000;

/// The schema of a wire message, by name, as proto generates it.
pub(crate) fn proto_schema(name: &str) -> Arc<Schema> {
    match proto_schemas().into_iter().find(|s| s.name == name) {
        Some(schema) => schema,
        None => panic!("proto has no schema {name}"),
    }
}

/// A real observation by `robot`, encoded as on the wire.
pub(crate) fn observation_json(robot: &str, seq: u64, stamp: Stamp) -> Vec<u8> {
    proto::encode(&Observation {
        covariance_m2: isotropic(0.1),
        ..observation(robot, seq, stamp, [0.01 * seq as f64, -0.5])
    })
}

/// An observation of `robot` captured `lag_s` before `at`, as logged at `at`.
pub(crate) fn logged_observation(
    robot: &str,
    seq: u64,
    at: Stamp,
    lag_s: f64,
    position_m: [f64; 2],
) -> LogMessage {
    let obs = Observation {
        version: proto::VERSION,
        robot_id: robot.into(),
        seq,
        camera: Camera::Left,
        stamp: at.offset_secs(-lag_s),
        position_m,
        covariance_m2: [1e-4, 0.0, 0.0, 1e-4],
        confidence: 0.9,
        robot_pose: Pose2::default(),
        pixel: None,
    };
    LogMessage {
        topic: format!("rf/robots/{robot}/obs"),
        schema_name: "Observation".into(),
        log_time: at,
        publish_time: at,
        data: proto::encode(&obs),
    }
}

/// A record on `topic` logged `offset_ns` after [`T0_NS`] and published 1 ms earlier.
pub(crate) fn record(
    topic: &str,
    schema: &Arc<Schema>,
    offset_ns: u64,
    payload: Vec<u8>,
) -> Record {
    Record {
        topic: topic.to_owned(),
        schema: Arc::clone(schema),
        log_time: Stamp(T0_NS + offset_ns),
        publish_time: Stamp(T0_NS + offset_ns - 1_000_000),
        payload,
    }
}

/// `n` records over three topics and two schemas (observations of two robots and
/// robot statuses), one every 10 ms.
pub(crate) fn mixed_records(n: u64) -> Vec<Record> {
    let obs = proto_schema("Observation");
    let status = proto_schema("RobotStatus");
    (0..n)
        .map(|i| {
            let offset_ns = 1_000_000 + i * 10_000_000;
            match i % 3 {
                0 => {
                    let json = observation_json("r1", i, Stamp(T0_NS + offset_ns));
                    record("ball/robots/r1/obs", &obs, offset_ns, json)
                }
                1 => {
                    let json = observation_json("r2", i, Stamp(T0_NS + offset_ns));
                    record("ball/robots/r2/obs", &obs, offset_ns, json)
                }
                _ => {
                    let json = format!("{{\"robot_id\":\"r1\",\"n\":{i}}}").into_bytes();
                    record("ball/robots/r1/status", &status, offset_ns, json)
                }
            }
        })
        .collect()
}

/// What reading `record` back must give.
pub(crate) fn expected(record: &Record) -> LogMessage {
    LogMessage {
        topic: record.topic.clone(),
        schema_name: record.schema.name.clone(),
        log_time: record.log_time,
        publish_time: record.publish_time,
        data: record.payload.clone(),
    }
}

/// Defaults in `dir` with the given compression, prefix `match`.
pub(crate) fn config(dir: &Path, compression: LogCompression) -> RecorderConfig {
    RecorderConfig {
        compression,
        ..RecorderConfig::new(dir)
    }
}
