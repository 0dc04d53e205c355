//! The programs the system tests run as processes as well as the binaries of the same
//! names: each `main` parses its own arguments.

pub mod sim_agent;
pub mod sim_robots;
pub mod simulate;
