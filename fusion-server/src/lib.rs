//! Team ball fusion.
//!
//! [`core`] is the pure fusion core: observations and time in, one ball estimate and its
//! predicted path out. It never reads a clock and never does I/O, so the live server,
//! offline replay and the evaluation all drive the very same code.

pub mod core;
