//! The `ball-lab` command line ([`main`]: `calibrate`, `calibrate-colour`, `train`,
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
pub mod detector_train;
pub mod evaluate;
pub mod labelled;
pub mod labelled_patches;
pub mod net_train;
pub mod progress;
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
mod train_cmd;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "ball-lab",
    version,
    about = "A MiRo team's workbench for its ball detector: training, labelling, calibration, evaluation on photos"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fits a camera model to chessboard images.
    Calibrate(calibrate_cmd::CalibrateArgs),
    /// Fits the colour detector's window to the balls of labelled photos.
    CalibrateColour(calibrate_colour_cmd::CalibrateColourArgs),
    /// Trains the colour-patch ball network (default), the two-stage detector or the
    /// HOG + SVM filter.
    Train(Box<train_cmd::TrainArgs>),
    /// Finds the ball in a folder of photos (no index, no pose): every candidate, as JSON lines.
    Detect(detect_cmd::DetectArgs),
    /// Scores the detector on photos with labelled ball boxes (Pascal VOC or YOLO).
    Evaluate(Box<evaluate_cmd::EvaluateArgs>),
}

/// [`main`] as a process's exit status: 1 on an error.
pub fn main_exit() -> std::process::ExitCode {
    match main() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e:?}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// The `ball-lab` command line: parses the arguments, sets up logging
/// (`robot_agent::cli::init_logging`) and runs the subcommand.
pub fn main() -> Result<()> {
    let cli = Cli::parse();
    robot_agent::cli::init_logging();
    match cli.command {
        Command::Calibrate(args) => calibrate_cmd::run(args),
        Command::CalibrateColour(args) => calibrate_colour_cmd::run(args),
        Command::Train(args) => train_cmd::run(*args),
        Command::Detect(args) => detect_cmd::run(args),
        Command::Evaluate(args) => evaluate_cmd::run(*args),
    }
}
