//! Team ball fusion, in three layers.
//!
//! **Pure** (no clock reads, no I/O): [`estimator`], the fusion core (observations and time
//! in, one ball estimate and its predicted path out); [`engine`], which decodes, validates,
//! admits and counts what arrives around it; and [`query`], the answers to robots'
//! questions. The live server, offline replay and the evaluation all drive this same code.
//!
//! **Match logs** ([`matchlog`]): writing, reading, re-fusing and replaying MCAP files.
//!
//! **Security** ([`security`]): the certificates and access-control list of a secured
//! Zenoh network.
//!
//! **The shell** ([`shell`]): Zenoh, HTTP, the live stream, metrics and settings.
//!
//! **The command line** ([`cli`]): `serve`, `replay` and `keys`, as the binary runs them.

pub mod cli;
pub mod engine;
pub mod estimator;
pub mod matchlog;
pub mod query;
pub mod security;
pub mod shell;
