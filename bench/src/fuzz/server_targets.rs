//! fusion-server: the engine's intake (arbitrary payloads and keys, and a stream of
//! mutated valid observations into one engine), the query parser, the settings file and
//! the match-log reader.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use fusion_server::McapLog;
use fusion_server::ServeConfig;
use fusion_server::Settings;
use fusion_server::read_log_from;
use fusion_server::{BallQuery, QueryReply, check_query_size, parse_query};
use fusion_server::{Engine, EngineConfig};
use fusion_server::{LogCompression, RecorderConfig};
use proto::{Observation, Stamp};

use super::seeds::{self, BASE};
use super::{Target, Verdict};

pub fn targets() -> Vec<Target> {
    vec![
        intake_target("server_observation", false),
        intake_target("server_status", true),
        stream_target(),
        query_target(),
        settings_target(),
        matchlog_target(),
    ]
}

/// The key a payload arrives on: the input's first byte picks none, a robot's, or the
/// text up to the first newline.
fn split_key(bytes: &[u8]) -> (Option<String>, &[u8]) {
    let Some((&first, rest)) = bytes.split_first() else {
        return (None, bytes);
    };
    match first % 4 {
        0 => (None, rest),
        1 => (Some("miro1".to_owned()), rest),
        2 => match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (
                Some(String::from_utf8_lossy(&rest[..i]).into_owned()),
                &rest[i + 1..],
            ),
            None => (None, rest),
        },
        _ => (None, bytes),
    }
}

/// Observations (or statuses) with arbitrary payloads and keys into one engine, 10 ms
/// apart; what it publishes must stay finite.
fn intake_target(name: &'static str, status: bool) -> Target {
    let mut seeds: Vec<Vec<u8>> = if status {
        ["miro1", "miro2"]
            .iter()
            .map(|r| proto::encode(&seeds::status(r)))
            .collect()
    } else {
        (0..6)
            .map(|i| {
                let position_m = [0.1 * i as f64, -0.3];
                let dt_s = 1.0 + 0.01 * i as f64;
                proto::encode(&seeds::observation("miro4", 1000 + i, dt_s, position_m))
            })
            .collect()
    };
    // Sent on no key: the robot id is the payload's.
    for seed in &mut seeds {
        seed.insert(0, 0);
    }
    let mut engine = seeds::engine_with_estimate();
    let mut now = BASE.offset_secs(1.0);
    Target::new(name, seeds, move |bytes| {
        now = now.offset_secs(0.01);
        let (key, payload) = split_key(bytes);
        let ok = if status {
            engine.status(key.as_deref(), payload, now).is_ok()
        } else {
            engine.observation(key.as_deref(), payload, now).is_ok()
        };
        if let Some(state) = engine.ball_state(now) {
            seeds::assert_finite_state(&state);
        }
        Verdict::of(ok)
    })
}

/// Mutated valid observations into one engine, rebased onto its clock (capture stamps
/// keep the mutated offset from [`BASE`], less 0.4 s; sequence numbers keep increasing). After each,
/// the published state and a prediction must be finite.
fn stream_target() -> Target {
    let seeds = seeds::rolling_ball(12).iter().map(proto::encode).collect();
    let mut engine = Engine::new(EngineConfig::default());
    let mut calls: u64 = 0;
    Target::new("server_stream", seeds, move |bytes| {
        calls += 1;
        let now = BASE.offset_secs(calls as f64 * 0.01);
        let payload = match proto::decode::<Observation>(bytes) {
            Ok(mut obs) => {
                let offset_ns = i128::from(obs.stamp.0) - i128::from(BASE.0) - 400_000_000;
                let stamp = (i128::from(now.0) + offset_ns).clamp(0, i128::from(u64::MAX));
                obs.stamp = Stamp(u64::try_from(stamp).unwrap_or(u64::MAX));
                obs.seq = obs.seq.wrapping_add(calls);
                proto::encode(&obs)
            }
            Err(_) => bytes.to_vec(),
        };
        let robot = proto::decode::<Observation>(&payload).map(|o| o.robot_id);
        let ok = engine
            .observation(robot.as_deref().ok(), &payload, now)
            .is_ok();
        if let Some(state) = engine.ball_state(now) {
            seeds::assert_finite_state(&state);
        }
        if let Ok(QueryReply::Prediction(p)) =
            engine.query(&BallQuery::Predict { horizon_s: 2.0 }, now)
        {
            seeds::assert_finite_prediction(&p);
        }
        Verdict::of(ok)
    })
}

/// Query text split as the robots' and the HTTP queries are (`;` or `&` between pairs,
/// `=` within), parsed, and answered by an engine with an estimate.
fn query_target() -> Target {
    let seeds = ["t=1.5", "robot=miro1", "robot=miro2;speed=0.3", "t=0&t=10"];
    let engine = seeds::engine_with_estimate();
    let at = BASE.offset_secs(1.0);
    Target::new(
        "server_query",
        seeds.iter().map(|s| s.as_bytes().to_vec()).collect(),
        move |bytes| {
            let text = String::from_utf8_lossy(bytes);
            if check_query_size(&text).is_err() {
                return Verdict::Rejected;
            }
            let pairs = text
                .split([';', '&'])
                .filter(|p| !p.is_empty())
                .map(|p| p.split_once('=').unwrap_or((p, "")));
            let Ok(q) = parse_query(pairs) else {
                return Verdict::Rejected;
            };
            match engine.query(&q, at) {
                Ok(QueryReply::Prediction(p)) => seeds::assert_finite_prediction(&p),
                Ok(QueryReply::Intercept(i)) => {
                    assert!(i.t_s.is_finite() && i.point_m.iter().all(|v| v.is_finite()));
                }
                Err(_) => {}
            }
            Verdict::Accepted
        },
    )
}

/// The documented example configuration (the first TOML block of docs/reference.md),
/// mutated, parsed and applied.
fn settings_target() -> Target {
    let doc = include_str!("../../../docs/reference.md");
    let example = doc
        .split("```toml")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .unwrap_or("server_id = \"pitch-a\"\n");
    let seeds = vec![
        example.as_bytes().to_vec(),
        b"[fusion]\nhorizon_s = 3.0\n".to_vec(),
    ];
    Target::new("server_settings", seeds, |bytes| {
        let text = String::from_utf8_lossy(bytes);
        let Ok(settings) = Settings::parse(&text, Path::new("fuzz.toml")) else {
            return Verdict::Rejected;
        };
        let mut cfg = ServeConfig::default();
        Verdict::of(settings.apply(&mut cfg).is_ok())
    })
}

/// A small match log written by the recorder (observations, statuses and states; raw and
/// zstd chunks), its bytes mutated and read back from memory.
fn matchlog_target() -> Target {
    let seeds = [LogCompression::None, LogCompression::Zstd]
        .into_iter()
        .filter_map(|c| write_small_log(c).ok())
        .collect();
    Target::new("server_matchlog", seeds, |bytes| {
        let read = read_log_from(Cursor::new(bytes), Path::new("fuzz.mcap"));
        Verdict::of(read.is_ok_and(|r| r.complete))
    })
}

/// Writes a few messages with [`McapLog`] in a fresh temporary directory and returns the
/// file's bytes.
pub fn write_small_log(compression: LogCompression) -> anyhow::Result<Vec<u8>> {
    // A directory of this call's own: tests building the targets at once in one process
    // must not write the same file.
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir: PathBuf = std::env::temp_dir().join(format!(
        "fuzz-matchlog-{}-{call}-{:?}",
        std::process::id(),
        compression
    ));
    std::fs::create_dir_all(&dir)?;
    let cfg = RecorderConfig {
        chunk_size_bytes: 600,
        compression,
        ..RecorderConfig::new(&dir)
    };
    let log = McapLog::start(cfg, BASE)?;
    for obs in seeds::rolling_ball(4) {
        log.write(
            "rf/robots/miro1/obs",
            "Observation",
            obs.stamp,
            &proto::encode(&obs),
        );
    }
    log.write(
        "rf/robots/miro1/status",
        "RobotStatus",
        BASE,
        &proto::encode(&seeds::status("miro1")),
    );
    for (name, payload) in seeds::fusion_outputs() {
        log.write("rf/ball/state", name, BASE.offset_secs(0.5), &payload);
    }
    let summary = log.finish()?;
    let file = summary
        .and_then(|s| s.files.into_iter().next())
        .ok_or_else(|| anyhow::anyhow!("the recorder wrote no file"))?;
    let bytes = std::fs::read(&file)?;
    std::fs::remove_dir_all(&dir).ok();
    Ok(bytes)
}
