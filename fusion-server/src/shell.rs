//! The I/O shell around the pure layers: the Zenoh session and its one publisher task
//! ([`serve`]), which publishes only while this server is the active one of its prefix
//! ([`standby`]), observations taken off the network threads ([`intake`]) into the shared
//! state ([`live`]), HTTP and the live stream ([`http`], whose [`http::guard`] bounds
//! connections), the Foxglove WebSocket ([`foxglove`]), a replay played as if live
//! ([`replay_live`]), [`metrics`], Zenoh settings ([`net`]) and the settings of a server
//! from its file and flags ([`config`], [`args`]).
//!
//! Arrows run one way: the shared state holds the hubs it feeds ([`foxglove_hub`], the
//! camera [`views`], the ball's [`history`], the counters of [`metrics`], the replay's
//! [`replay_control`]), none of which knows it; the parts that serve clients or feed it
//! ([`http`], [`foxglove`], [`intake`], [`replay_live`], [`serve`]) take it.

pub mod args;
pub mod config;
pub mod foxglove;
pub mod foxglove_hub;
pub mod history;
pub mod http;
pub mod intake;
pub mod live;
pub mod metrics;
pub mod net;
pub mod replay_control;
pub mod replay_live;
pub mod serve;
pub mod standby;
pub mod views;
