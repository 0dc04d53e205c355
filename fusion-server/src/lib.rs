//! Team ball fusion, in three layers.
//!
//! **Pure** (no clock reads, no I/O): the estimator, the fusion core (observations and
//! time in, one ball estimate and its predicted path out: [`Fusion`]); the [`Engine`],
//! which decodes, validates, admits and counts what arrives around it; and the answers to
//! robots' questions ([`BallQuery`]). The live server, offline replay and the evaluation
//! all drive this same code.
//!
//! **Match logs**: writing ([`McapLog`], [`RecorderSink`]), reading ([`read_logs`]),
//! re-fusing ([`replay`]) MCAP files.
//!
//! **Security**: the certificates ([`Authority`]) and access-control list
//! ([`install_acl`]) of a secured Zenoh network.
//!
//! **The shell**: Zenoh, HTTP, the live stream, metrics and settings, started by
//! [`serve`] from a [`ServeConfig`]; [`main`] is the `fusion-server` program itself.
//!
//! This root is the crate's front door: the modules behind it are private.
//!
//! ```
//! use fusion_server::{Bounds, Fusion, FusionConfig, MotionModel, fly};
//! use proto::{Pitch, Stamp};
//!
//! // The fusion core, driven with time passed in: one robot sees a still ball near the
//! // centre spot ten times a second, and the server's ball is there.
//! let mut fusion = Fusion::new(FusionConfig::default());
//! let at = |k: u64| Stamp(1_000_000_000 + k * 100_000_000);
//! for k in 0..10 {
//!     let obs = proto::test_support::observation("miro1", k, at(k), [0.2, -0.1]);
//!     fusion.ingest(&obs, at(k));
//! }
//! let ball = fusion.ball_state(at(9)).expect("a ball after ten sightings");
//! assert!((ball.position_m[0] - 0.2).abs() < 0.05);
//!
//! // The motion model on its own: a ball at 1 m/s, half a second later, has rolled
//! // a little less than half a metre.
//! let bounds = Bounds::from_pitch(&Pitch::default());
//! let flight = fly([0.0, 0.0], [1.0, 0.0], 0.5, &MotionModel::default(), &bounds);
//! assert!(flight.position[0] > 0.3 && flight.position[0] < 0.5);
//! ```

mod camera_views;
mod cli;
mod clock;
mod engine;
mod estimator;
mod matchlog;
mod query;
mod scene;
mod security;
mod shell;

pub use cli::main;
pub use clock::{Clock, SystemClock};
pub use engine::{AdmissionConfig, Engine, EngineConfig, MAX_ROBOTS};
pub use estimator::motion::fly;
pub use estimator::predict::stop;
pub use estimator::{
    Bounds, Fusion, FusionConfig, FusionCounters, MotionEvent, MotionEventKind, MotionModel,
};
pub use matchlog::read::{LogMessage, LogRead, ReadError, read_log, read_log_from, read_logs};
pub use matchlog::record::{LogCompression, RecorderConfig, Schema, remove_earlier};
pub use matchlog::replay::{ReplayOptions, ReplayReport, ReplaySink, replay};
pub use matchlog::{LogKind, MatchLog, McapLog, RecorderSink};
pub use query::{
    BallQuery, MAX_QUERY_BYTES, QueryError, QueryReply, check_size as check_query_size,
    parse as parse_query,
};
pub use security::acl::{Roster, install as install_acl};
pub use security::keys::{Authority, Issued, KeysError, Validity};
pub use security::node_dir::write as write_node_dir;
pub use security::{robot_common_name, server_common_name};
pub use shell::args::{
    ServeArgs, as_match_log, bind_foxglove, bind_http, finish_log, serve_config, shutdown_signal,
    start_log,
};
pub use shell::config::{ConfigError, PitchFlags, Settings};
pub use shell::http::guard::HttpLimits;
pub use shell::serve::{ServeConfig, Shared, serve, serve_all, shared};
