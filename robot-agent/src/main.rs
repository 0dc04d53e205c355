//! `robot-agent`: a MiRo's ball perception. `run` finds the ball in camera frames and
//! publishes observations and status over Zenoh (`service`: the same, set up from one
//! settings file); `calibrate` fits a camera model to
//! chessboard images; `calibrate-colour` fits the colour detector's window to labelled
//! photos; `train` fits the ball network (or the HOG + SVM filter); `detect` finds the ball
//! in a folder of photos; `evaluate` scores the detector on labelled photos. The command
//! line lives in the library ([`robot_agent::cli`]).

fn main() -> std::process::ExitCode {
    robot_agent::cli::main_exit()
}
