//! The server's settings: one type for the configuration file (TOML) and the command line
//! (`crate::shell::args::ServeArgs` writes its flags over the file's). Every field is optional;
//! flags override the file, and the file overrides the defaults. [`Settings::apply`] checks
//! them all in one place.

use crate::estimator::FusionConfig;
use crate::matchlog::record::RecorderConfig;
use crate::shell::net::NetConfig;
use crate::shell::serve::ServeConfig;
use proto::Pitch;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

mod pitch;
pub use pitch::{PitchFlags, check_pitch};

#[derive(Debug, Error)]
pub enum ConfigError {
    #[error("reading {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Parse {
        path: PathBuf,
        source: toml::de::Error,
    },
    #[error("{0}")]
    Invalid(String),
}

/// `[record]`: the match log.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecordFile {
    pub dir: Option<PathBuf>,
    /// Start a new file after this many megabytes...
    pub max_mb: Option<f64>,
    /// ... or after this many minutes of match time.
    pub max_minutes: Option<f64>,
    /// Finish a chunk at least this often (bounds what a crash can lose).
    pub flush_interval_s: Option<f64>,
    /// Keep the robots' camera views in the log (default true).
    pub views: Option<bool>,
}

impl RecordFile {
    /// The match log's settings, when a folder is given; checked.
    pub fn recorder(&self) -> Result<Option<RecorderConfig>, ConfigError> {
        let Some(dir) = &self.dir else {
            return Ok(None);
        };
        let mut r = RecorderConfig::new(dir);
        r.max_bytes = self.max_mb.map(|mb| (mb * 1e6) as u64);
        r.max_duration_s = self.max_minutes.map(|m| m * 60.0);
        if let Some(f) = self.flush_interval_s {
            r.flush_interval_s = f;
        }
        r.validate()
            .map_err(|e| ConfigError::Invalid(format!("record: {e}")))?;
        Ok(Some(r))
    }
}

/// `[fusion]`: tuning of the fusion core that an installation may need to change.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FusionFile {
    pub late_window_s: Option<f64>,
    pub horizon_s: Option<f64>,
    pub lost_after_s: Option<f64>,
    /// Starting rolling deceleration of the ball (the restitution starts at the pitch's
    /// `wall_restitution`).
    pub decel_mps2: Option<f64>,
    /// Uncertainty (one standard deviation) of the starting deceleration...
    pub decel_sigma_mps2: Option<f64>,
    /// ... and of the starting restitution.
    pub restitution_sigma: Option<f64>,
    /// Starting deceleration while the ball slides just after a kick...
    pub slide_decel_mps2: Option<f64>,
    /// ... until its speed has fallen to this share of the kick's (0 to 1).
    pub roll_ratio: Option<f64>,
    /// Starting tangential retention at the walls (0 to 1).
    pub tangential_retention: Option<f64>,
    /// Learn the deceleration from the ball's rolling; off keeps the starting value.
    pub learn_decel: Option<bool>,
    /// Learn the restitution from wall bounces; off keeps the starting value.
    pub learn_restitution: Option<bool>,
}

/// `[limits]`: the bounds that keep made-up or oversized input from hurting the server.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LimitsFile {
    /// Largest observation payload, bytes.
    pub max_observation_bytes: Option<usize>,
    /// Largest status payload, bytes.
    pub max_status_bytes: Option<usize>,
    /// Messages a robot may send per second on average.
    pub rate_limit_hz: Option<f64>,
    /// Messages a robot may send at once above the average.
    pub rate_burst: Option<f64>,
    /// Seconds a robot may stay quiet before the server forgets it.
    pub robot_expiry_s: Option<f64>,
    /// Accepted messages after which a robot keeps its place in a full table.
    pub established_messages: Option<u64>,
    /// HTTP connections open at once.
    pub http_max_connections: Option<usize>,
    /// Seconds from a request's first byte to the start of the answer.
    pub http_request_timeout_s: Option<f64>,
    /// Seconds without traffic before an HTTP connection is closed.
    pub http_idle_timeout_s: Option<f64>,
    /// Seconds a live-stream frame may take to send before the client is dropped.
    pub ws_send_timeout_s: Option<f64>,
    /// Largest camera view payload, bytes.
    pub max_view_bytes: Option<usize>,
    /// Camera views a robot may send per second (all its cameras), and at once above that.
    pub view_rate_hz: Option<f64>,
    pub view_burst: Option<f64>,
}

impl LimitsFile {
    pub fn apply(&self, cfg: &mut ServeConfig) -> Result<(), ConfigError> {
        let h = &mut cfg.http_limits;
        if let Some(n) = self.http_max_connections {
            if n == 0 {
                return Err(ConfigError::Invalid(
                    "limits.http_max_connections must be positive".into(),
                ));
            }
            h.max_connections = n;
        }
        if let Some(v) = self.http_request_timeout_s {
            h.request_timeout_s = positive("limits.http_request_timeout_s", v)?;
        }
        if let Some(v) = self.http_idle_timeout_s {
            h.idle_timeout_s = positive("limits.http_idle_timeout_s", v)?;
        }
        if let Some(v) = self.ws_send_timeout_s {
            h.ws_send_timeout_s = positive("limits.ws_send_timeout_s", v)?;
        }
        let engine = &mut cfg.engine;
        let bytes = |name: &str, v: usize| {
            if (256..=16 << 20).contains(&v) {
                Ok(v)
            } else {
                Err(ConfigError::Invalid(format!(
                    "limits.{name} must be in 256..=16777216 bytes, got {v}"
                )))
            }
        };
        if let Some(v) = self.max_observation_bytes {
            engine.max_observation_bytes = bytes("max_observation_bytes", v)?;
        }
        if let Some(v) = self.max_status_bytes {
            engine.max_status_bytes = bytes("max_status_bytes", v)?;
        }
        let a = &mut engine.admission;
        if let Some(v) = self.rate_limit_hz {
            a.rate_limit_hz = positive("limits.rate_limit_hz", v)?;
        }
        if let Some(v) = self.rate_burst {
            a.rate_burst = positive("limits.rate_burst", v)?.max(1.0);
        }
        if let Some(v) = self.robot_expiry_s {
            a.robot_expiry_s = positive("limits.robot_expiry_s", v)?;
        }
        if let Some(v) = self.established_messages {
            a.established_messages = v;
        }
        let views = &mut cfg.views;
        if let Some(v) = self.max_view_bytes {
            if !(1024..=proto::MAX_VIEW_PAYLOAD_BYTES).contains(&v) {
                return Err(ConfigError::Invalid(format!(
                    "limits.max_view_bytes must be in 1024..={}, got {v}",
                    proto::MAX_VIEW_PAYLOAD_BYTES
                )));
            }
            views.max_payload_bytes = v;
        }
        if let Some(v) = self.view_rate_hz {
            views.rate_hz = positive("limits.view_rate_hz", v)?;
        }
        if let Some(v) = self.view_burst {
            views.burst = positive("limits.view_burst", v)?.max(1.0);
        }
        Ok(())
    }
}

/// `[clock]`: how the robots' clock offsets are judged.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClockFile {
    /// Least capture-to-arrival time of an observation, seconds.
    pub latency_floor_s: Option<f64>,
    /// Offsets larger than this mark a robot's clock as suspect, seconds.
    pub offset_warn_s: Option<f64>,
    /// Whether robots' stamps are corrected by their estimated offsets.
    pub correct: Option<bool>,
    /// The largest correction either way, seconds.
    pub max_correction_s: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    pub server_id: Option<String>,
    /// Token the control endpoints require as `Authorization: Bearer TOKEN`; without one
    /// only this machine may use them.
    pub control_token: Option<String>,
    pub prefix: Option<String>,
    /// HTTP address, e.g. `127.0.0.1:8080`.
    pub http: Option<String>,
    /// Foxglove WebSocket address, e.g. `127.0.0.1:8765` (a port alone: on loopback).
    /// None: not served.
    pub foxglove: Option<String>,
    pub state_rate_hz: Option<f64>,
    pub publish_on_update: Option<bool>,
    pub stream_buffer: Option<usize>,
    /// Top speed assumed for intercepts when a query gives none.
    pub robot_speed_mps: Option<f64>,
    /// Accept only these robots.
    pub roster: Option<Vec<String>>,
    /// Other servers (standby) the access-control list trusts, when links are TLS.
    pub servers: Option<Vec<String>>,
    /// `zenohd` routers the access-control list trusts, when links are TLS.
    pub routers: Option<Vec<String>>,
    /// Serve an open network (no TLS) knowingly.
    pub open: Option<bool>,
    pub zenoh: Option<NetConfig>,
    pub pitch: Option<Pitch>,
    pub fusion: FusionFile,
    pub record: RecordFile,
    pub limits: LimitsFile,
    pub clock: ClockFile,
}

/// A Foxglove WebSocket address: `HOST:PORT`, or a port alone on loopback.
pub fn foxglove_addr(text: &str) -> Result<std::net::SocketAddr, ConfigError> {
    let bad = |e: String| {
        ConfigError::Invalid(format!("foxglove {text:?}: {e} (give PORT or HOST:PORT)"))
    };
    match text.parse::<u16>() {
        Ok(port) => Ok(std::net::SocketAddr::from(([127, 0, 0, 1], port))),
        Err(_) => text
            .parse::<std::net::SocketAddr>()
            .map_err(|e| bad(e.to_string())),
    }
}

impl Settings {
    pub fn parse(text: &str, path: &Path) -> Result<Self, ConfigError> {
        toml::from_str(text).map_err(|source| ConfigError::Parse {
            path: path.to_path_buf(),
            source,
        })
    }

    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Applies the file's settings over `cfg`.
    pub fn apply(&self, cfg: &mut ServeConfig) -> Result<(), ConfigError> {
        if let Some(id) = &self.server_id {
            if !proto::is_valid_id(id) {
                return Err(ConfigError::Invalid(format!(
                    "server_id {id:?} is not a valid id"
                )));
            }
            cfg.server_id = id.clone();
        }
        if let Some(h) = &self.http {
            h.parse::<std::net::SocketAddr>()
                .map_err(|e| ConfigError::Invalid(format!("http {h:?}: {e}")))?;
            cfg.http = h.clone();
        }
        if let Some(f) = &self.foxglove {
            cfg.foxglove = Some(foxglove_addr(f)?);
        }
        if let Some(t) = &self.control_token {
            if t.len() < 8 || !t.chars().all(|c| c.is_ascii_graphic()) {
                return Err(ConfigError::Invalid(
                    "the control token must be at least 8 visible ASCII characters".into(),
                ));
            }
            cfg.control_token = Some(t.clone());
        }
        if let Some(p) = &self.prefix {
            proto::KeySpace::new(p).map_err(|e| ConfigError::Invalid(e.to_string()))?;
            cfg.prefix = p.clone();
        }
        if let Some(r) = self.state_rate_hz {
            cfg.state_rate_hz = positive("state_rate_hz", r)?;
        }
        if let Some(b) = self.publish_on_update {
            cfg.publish_on_update = b;
        }
        if let Some(n) = self.stream_buffer {
            cfg.stream_buffer = n.max(1);
        }
        if let Some(s) = self.robot_speed_mps {
            cfg.engine.robot_speed_mps = positive("robot_speed_mps", s)?;
        }
        if let Some(r) = &self.roster {
            if let Some(bad) = r.iter().find(|id| !proto::is_valid_id(id)) {
                return Err(ConfigError::Invalid(format!(
                    "roster id {bad:?} is not a valid id"
                )));
            }
            cfg.engine.roster = Some(r.iter().cloned().collect());
        }
        for (name, list, dest) in [
            ("servers", &self.servers, &mut cfg.servers),
            ("routers", &self.routers, &mut cfg.routers),
        ] {
            if let Some(ids) = list {
                if let Some(bad) = ids.iter().find(|id| !proto::is_valid_id(id)) {
                    return Err(ConfigError::Invalid(format!(
                        "{name} id {bad:?} is not a valid id"
                    )));
                }
                dest.clone_from(ids);
            }
        }
        if let Some(b) = self.open {
            cfg.open = b;
        }
        if let Some(z) = &self.zenoh {
            z.check().map_err(|e| ConfigError::Invalid(e.to_string()))?;
            cfg.net = z.clone();
        }
        if let Some(p) = &self.pitch {
            check_pitch(p)?;
            cfg.engine.fusion.set_pitch(p.clone());
        }
        self.limits.apply(cfg)?;
        if let Some(v) = self.record.views {
            cfg.record_views = v;
        }
        if let Some(v) = self.clock.latency_floor_s {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ConfigError::Invalid(format!(
                    "clock.latency_floor_s must be zero or positive, got {v}"
                )));
            }
            cfg.engine.clock.latency_floor_s = v;
        }
        if let Some(v) = self.clock.offset_warn_s {
            cfg.engine.clock.warn_s = positive("clock.offset_warn_s", v)?;
        }
        if let Some(v) = self.clock.correct {
            cfg.engine.clock.correct = v;
        }
        if let Some(v) = self.clock.max_correction_s {
            cfg.engine.clock.max_correction_s = positive("clock.max_correction_s", v)?;
        }
        self.fusion.apply(&mut cfg.engine.fusion)
    }
}

/// `Ok(v)` when `v` is finite and positive.
fn positive(name: &str, v: f64) -> Result<f64, ConfigError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(ConfigError::Invalid(format!(
            "{name} must be positive, got {v}"
        )))
    }
}

/// `Ok(v)` when `v` lies strictly between 0 and 1.
fn fraction(name: &str, v: f64) -> Result<f64, ConfigError> {
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(ConfigError::Invalid(format!(
            "{name} must lie strictly between 0 and 1, got {v}"
        )))
    }
}

impl FusionFile {
    /// Applies the `[fusion]` table over `fusion`.
    pub fn apply(&self, fusion: &mut FusionConfig) -> Result<(), ConfigError> {
        if let Some(v) = self.late_window_s {
            fusion.late_window_s = positive("fusion.late_window_s", v)?;
        }
        if let Some(v) = self.horizon_s {
            fusion.horizon_s = positive("fusion.horizon_s", v)?;
        }
        if let Some(v) = self.lost_after_s {
            fusion.lost_after_s = positive("fusion.lost_after_s", v)?;
        }
        let tracker = &mut fusion.tracker;
        if let Some(v) = self.decel_mps2 {
            tracker.motion.decel_mps2 = positive("fusion.decel_mps2", v)?;
        }
        if let Some(v) = self.decel_sigma_mps2 {
            tracker.surface.decel_sigma_mps2 = positive("fusion.decel_sigma_mps2", v)?;
        }
        if let Some(v) = self.restitution_sigma {
            tracker.surface.restitution_sigma = positive("fusion.restitution_sigma", v)?;
        }
        if let Some(v) = self.slide_decel_mps2 {
            tracker.motion.slide_decel_mps2 = positive("fusion.slide_decel_mps2", v)?;
        }
        if let Some(v) = self.roll_ratio {
            tracker.motion.roll_ratio = fraction("fusion.roll_ratio", v)?;
        }
        if let Some(v) = self.tangential_retention {
            tracker.motion.tangential_retention = fraction("fusion.tangential_retention", v)?;
        }
        if let Some(b) = self.learn_decel {
            tracker.learn_decel = b;
        }
        if let Some(b) = self.learn_restitution {
            tracker.learn_restitution = b;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"
server_id = "pitch-a"
prefix = "lab/pitch_2"
http = "127.0.0.1:9000"
state_rate_hz = 50
roster = ["miro1", "miro2"]

[zenoh]
mode = "peer"
listen = ["tcp/127.0.0.1:7500"]
connect = ["tcp/127.0.0.1:7447"]

[fusion]
late_window_s = 0.3
decel_mps2 = 0.45
decel_sigma_mps2 = 0.05
restitution_sigma = 0.1
learn_decel = false
learn_restitution = true

[record]
dir = "logs"
max_mb = 200
views = false

[limits]
view_rate_hz = 4
view_burst = 6
"#;

    #[test]
    fn a_full_file_applies() -> Result<(), ConfigError> {
        let f = Settings::parse(EXAMPLE, Path::new("x.toml"))?;
        let mut cfg = ServeConfig::default();
        f.apply(&mut cfg)?;
        assert_eq!(cfg.server_id, "pitch-a");
        assert_eq!(cfg.http, "127.0.0.1:9000");
        assert_eq!(cfg.prefix, "lab/pitch_2");
        assert_eq!(cfg.state_rate_hz, 50.0);
        assert_eq!(cfg.net.connect, vec!["tcp/127.0.0.1:7447"]);
        assert!(!cfg.net.multicast_scouting);
        assert_eq!(cfg.engine.fusion.late_window_s, 0.3);
        let tracker = &cfg.engine.fusion.tracker;
        assert_eq!(tracker.motion.decel_mps2, 0.45);
        assert_eq!(tracker.surface.decel_sigma_mps2, 0.05);
        assert_eq!(tracker.surface.restitution_sigma, 0.1);
        assert!(!tracker.learn_decel);
        assert!(tracker.learn_restitution);
        assert_eq!(cfg.engine.roster.as_ref().map(|r| r.len()), Some(2));
        assert_eq!(f.record.max_mb, Some(200.0));
        assert!(!cfg.record_views, "[record] views = false");
        assert_eq!((cfg.views.rate_hz, cfg.views.burst), (4.0, 6.0));
        Ok(())
    }

    /// Every TOML example in the operations guide and the reference parses and applies.
    #[test]
    fn the_operations_guide_examples_apply() -> Result<(), ConfigError> {
        let docs = [
            (
                "docs/operations.md",
                include_str!("../../../docs/operations.md"),
            ),
            (
                "docs/reference.md",
                include_str!("../../../docs/reference.md"),
            ),
        ];
        let blocks: Vec<(&str, &str)> = docs
            .iter()
            .flat_map(|&(path, doc)| {
                doc.split("```toml\n")
                    .skip(1)
                    .filter_map(|b| b.split("```").next())
                    .map(move |b| (path, b))
            })
            .collect();
        assert!(blocks.len() >= 2, "the docs have their examples");
        for (path, b) in blocks {
            let f = Settings::parse(b, Path::new(path))?;
            f.apply(&mut ServeConfig::default())?;
        }
        Ok(())
    }

    /// The pitch's wall restitution is where the filter starts; the default pitch's is the
    /// motion model's default, so nothing changes without a `[pitch]`.
    #[test]
    fn the_pitch_restitution_is_the_filters_starting_value() -> Result<(), ConfigError> {
        use crate::estimator::{Fusion, FusionConfig};
        use proto::{Camera, Observation, Pose2, Stamp};
        assert_eq!(
            FusionConfig::default(),
            FusionConfig::for_pitch(Pitch::default())
        );
        let text = "[pitch]\nversion = 1\nlength_m = 5.0\nwidth_m = 3.0\n\
                    walls = [\"x_max\", \"x_min\"]\nwall_restitution = 0.8\nball_radius_m = 0.05\n";
        let mut cfg = ServeConfig::default();
        Settings::parse(text, Path::new("x.toml"))?.apply(&mut cfg)?;
        assert_eq!(cfg.engine.fusion.tracker.motion.restitution, 0.8);
        let t0 = Stamp(1_800_000_000_000_000_000);
        let mut fusion = Fusion::new(cfg.engine.fusion.clone());
        for seq in 0..10 {
            let stamp = t0.offset_secs(seq as f64 / 15.0);
            let obs = Observation {
                version: proto::VERSION,
                robot_id: "miro1".into(),
                seq,
                camera: Camera::Left,
                stamp,
                position_m: [0.5, 0.2],
                covariance_m2: [4e-4, 0.0, 0.0, 4e-4],
                confidence: 0.9,
                robot_pose: Pose2::default(),
                pixel: None,
            };
            fusion.ingest(&obs, stamp);
        }
        let state = fusion.ball_state(t0.offset_secs(1.0)).expect("a ball");
        assert_eq!(state.model.wall_restitution, 0.8);
        Ok(())
    }

    #[test]
    fn a_partial_pitch_table_keeps_the_other_defaults() -> Result<(), ConfigError> {
        let text = "[pitch]\nlength_m = 5.0\nwalls = [\"y_max\", \"y_min\"]\n";
        let mut cfg = ServeConfig::default();
        Settings::parse(text, Path::new("x.toml"))?.apply(&mut cfg)?;
        let want = Pitch {
            length_m: 5.0,
            walls: vec![proto::WallSide::YMax, proto::WallSide::YMin],
            ..Pitch::default()
        };
        assert_eq!(cfg.engine.fusion.pitch, want);
        Ok(())
    }

    #[test]
    fn mistakes_are_reported() {
        let p = Path::new("x.toml");
        assert!(matches!(
            Settings::parse("colour = 3", p),
            Err(ConfigError::Parse { .. })
        ));
        let mut cfg = ServeConfig::default();
        for bad in [
            "state_rate_hz = 0",
            "roster = [\"a b\"]",
            "prefix = \"/x\"",
            "[zenoh]\nlisten = [\"127.0.0.1\"]",
            "[pitch]\nwidth_m = 0",
            "[pitch]\nwall_restitution = 1.0",
            "[pitch]\nball_radius_m = 2.0",
            "[fusion]\ndecel_mps2 = 0",
            "[fusion]\ndecel_sigma_mps2 = -0.1",
            "[fusion]\nrestitution_sigma = nan",
            "[fusion]\nslide_decel_mps2 = 0",
            "[fusion]\nroll_ratio = 1.5",
            "[fusion]\ntangential_retention = nan",
            "[fusion]\nlate_window_s = inf",
            "[limits]\nmax_observation_bytes = 10",
            "[limits]\nrate_limit_hz = 0",
            "[limits]\nrobot_expiry_s = -1",
            "[limits]\nhttp_max_connections = 0",
            "[clock]\nlatency_floor_s = -1",
            "[clock]\noffset_warn_s = 0",
            "[clock]\nmax_correction_s = -1",
            "[limits]\nws_send_timeout_s = 0",
        ] {
            let f = Settings::parse(bad, p).expect(bad);
            assert!(
                matches!(f.apply(&mut cfg), Err(ConfigError::Invalid(_))),
                "{bad}"
            );
        }
    }
}
