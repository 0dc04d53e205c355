//! The programs around the products, and what they share.
//!
//! - **The simulated world on the network**: [`sim_robots`] (simulated MiRos publishing a
//!   match's observations in real time), [`sim_source`] and [`agent_recall`] (the real agent
//!   on the simulator's rendered cameras), [`sim_args`] (the flags they share).
//! - **Simulated match logs**: [`sim_log`] (a match written with its ground truth, and
//!   scored back with [`scoring`]).
//! - **Makers of shipped artifacts**: [`sim_patches`] (the classifier's training patches),
//!   [`photo_set`] (randomised labelled photos), [`tracks`], [`track_fixtures`] and
//!   [`track_cases`] (ball tracks in CSV, and the regression tracks).
//! - **Command-line plumbing**: [`cmd`] (the programs the system tests also run),
//!   [`progress`] (logging is `robot_agent::cli::init_logging`).
//!
//! Binaries: `demo`, `sim_robots`, `sim_agent`, `simulate`, `score_log`, `sim_track`,
//! `synth_photos`, `sim_calibrate`, `train_sim`.

pub mod agent_recall;
pub mod cmd;
pub mod photo_set;
pub mod progress;
pub mod scoring;
pub mod sim_args;
pub mod sim_log;
pub mod sim_patches;
pub mod sim_robots;
pub mod sim_source;
pub mod track_cases;
pub mod track_fixtures;
pub mod tracks;
