//! Benchmarks, the load test and the fuzzer.
//!
//! - [`server_bench`]: the server benchmark's results and table (`bench_server`).
//! - [`load`] and [`load_report`]: a `fusion-server` process fed by many simulated robots at
//!   once, and what is read back from it (`load_test`).
//! - [`edges`]: the server process at its edges: made-up robot ids, idle sockets under a
//!   low open-files limit, concurrent requests, live-stream viewers (`bench_edges`).
//! - [`fuzz`]: a deterministic fuzzer over every decoder and validator (`fuzz`).
//! - [`views_bench`]: what the robots' camera views cost the server, how soon they reach a
//!   page and how much they add to a match log, with real agents (`bench_views`).
//!
//! Binaries: `bench_server`, `bench_edges`, `bench_agent`, `load_test`, `replay_speed`, `trace`, `fuzz`, `bench_views`.

pub mod edges;
pub mod fuzz;
pub mod load;
pub mod load_report;
pub mod server_bench;
pub mod views_bench;
