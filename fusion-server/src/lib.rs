//! Team ball fusion.
//!
//! [`core`] is the pure fusion core: observations and time in, one ball estimate and its
//! predicted path out. It never reads a clock and never does I/O, so the live server,
//! offline replay and the evaluation all drive the very same code.
//!
//! Around it, [`engine`] (also pure) decodes, validates and counts what arrives, and the
//! I/O shell serves it: [`serve`] (Zenoh and HTTP, through [`intake`], [`live`] and
//! [`http`], whose [`http::guard`] bounds connections),
//! [`net`] (Zenoh session settings), [`metrics`] and [`query`]; [`record`] writes match
//! logs (MCAP files Foxglove opens) and [`mcap_read`] reads them back for replay,
//! including logs cut short by a crash; [`replay`] re-fuses them offline and
//! [`replay_live`] plays them as if live, under the control of the coach's page.

pub mod args;
pub mod config;
pub mod core;
pub mod engine;
pub mod http;
pub mod intake;
pub mod live;
pub mod matchlog;
pub mod mcap_read;
pub mod metrics;
pub mod net;
pub mod query;
pub mod record;
pub mod replay;
pub mod replay_live;
pub mod serve;
