//! The `robot-agent` command line ([`main`]): `run` finds the ball in camera frames and
//! publishes it over Zenoh; `service` is `run` set up from one settings file, as the robot's
//! system service starts it. What a laptop runs for the detector (training, labelling,
//! calibration, photo evaluation) is the `lab` crate's `ball-lab`.

mod run_cmd;
pub mod service_cmd;

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

/// The logging of the agent's programs and the tools around it: tracing to standard error,
/// `RUST_LOG` to choose, Zenoh's own chatter held to errors. Call once, first thing.
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=error"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        // Colour codes only for a terminal: a log written to a file or the journal stays plain.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
}

/// The `robot-agent` command line: parses the arguments, sets up logging
/// ([`init_logging`]) and runs the subcommand.
pub fn main() -> Result<()> {
    let cli = Cli::parse();
    init_logging();
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
    }
}
