//! Team ball fusion.
//!
//! [`core`] is the pure fusion core: observations and time in, one ball estimate and its
//! predicted path out. It never reads a clock and never does I/O, so the live server,
//! offline replay and the evaluation all drive the very same code.
//!
//! The I/O shell around it: [`record`] writes match logs (MCAP files Foxglove opens) and
//! [`mcap_read`] reads them back for replay, including logs cut short by a crash.

pub mod core;
pub mod mcap_read;
pub mod record;
