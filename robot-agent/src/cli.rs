//! The `robot-agent` command line ([`main`]: `run`, `calibrate`, `calibrate-colour`, `train`,
//! `detect`, `evaluate`), and the flag groups and command steps it shares with the
//! simulator-driven tools (`sim_calibrate`, `train_sim`), so both write the same files from
//! the same inputs.
//!
//! - [`calibrate`]: the board and lens flags, the fit from chessboard images, its report.
//! - [`train`]: patches from folders and labelled photos, the classifier's fit and file.
//! - [`labelled`]: a folder of photos with labelled ball boxes and the camera to read
//!   them with.
//! - [`labelled_patches`]: training patches cut from labelled photos.
//! - [`net_train`]: the ball network from labelled photos, events held out whole.
//! - [`evaluate`]: the detector scored on labelled photos, overall and per folder.
//! - [`progress`]: the progress bar of the long photo commands.

pub mod calibrate;
#[cfg(feature = "train")]
pub mod detector_train;
pub mod evaluate;
pub mod labelled;
pub mod labelled_patches;
#[cfg(feature = "train")]
pub mod net_train;
pub mod progress;
#[cfg(feature = "train")]
pub mod teach;
pub mod train;

mod bar_chart;
mod calibrate_cmd;
mod calibrate_colour_cmd;
mod camera_args;
pub(crate) mod detect_cmd;
mod evaluate_cmd;
mod files;
mod pr_chart;
mod run_cmd;
pub mod service_cmd;
#[cfg(feature = "train")]
mod train_cmd;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(name = "robot-agent", version, about = "A MiRo's ball perception")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Finds the ball in camera frames and publishes it over Zenoh.
    Run(Box<run_cmd::RunCmdArgs>),
    /// Runs as the robot's system service does: `run` with every setting from one file.
    Service(service_cmd::ServiceArgs),
    /// Fits a camera model to chessboard images.
    Calibrate(calibrate_cmd::CalibrateArgs),
    /// Fits the colour detector's window to the balls of labelled photos.
    CalibrateColour(calibrate_colour_cmd::CalibrateColourArgs),
    /// Trains the colour-patch ball network (default), the two-stage detector or the
    /// HOG + SVM filter.
    #[cfg(feature = "train")]
    Train(Box<train_cmd::TrainArgs>),
    /// Finds the ball in a folder of photos (no index, no pose): every candidate, as JSON lines.
    Detect(detect_cmd::DetectArgs),
    /// Scores the detector on photos with labelled ball boxes (Pascal VOC or YOLO).
    Evaluate(Box<evaluate_cmd::EvaluateArgs>),
}

/// [`main`] as a process's exit status: 1 on an error, [`service_cmd::SETTINGS_EXIT_CODE`]
/// when the service's settings are wrong (the package's unit does not restart on it).
pub fn main_exit() -> std::process::ExitCode {
    match main() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e:?}");
            if e.downcast_ref::<service_cmd::SettingsError>().is_some() {
                std::process::ExitCode::from(service_cmd::SETTINGS_EXIT_CODE)
            } else {
                std::process::ExitCode::FAILURE
            }
        }
    }
}

/// The `robot-agent` command line: parses the arguments, sets up logging (`RUST_LOG`,
/// Zenoh's own chatter held to errors) and runs the subcommand.
pub fn main() -> Result<()> {
    let cli = Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=error"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    match cli.command {
        Command::Run(args) => {
            let rt = tokio::runtime::Builder::new_multi_thread()
                .enable_all()
                .build()?;
            rt.block_on(run_cmd::run(*args))
        }
        Command::Service(args) => {
            let rt = tokio::runtime::Builder::new_multi_thread()
                .enable_all()
                .build()?;
            rt.block_on(service_cmd::run(args))
        }
        Command::Calibrate(args) => calibrate_cmd::run(args),
        Command::CalibrateColour(args) => calibrate_colour_cmd::run(args),
        #[cfg(feature = "train")]
        Command::Train(args) => train_cmd::run(*args),
        Command::Detect(args) => detect_cmd::run(args),
        Command::Evaluate(args) => evaluate_cmd::run(*args),
    }
}
