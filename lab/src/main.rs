//! `ball-lab`: what a laptop runs for a MiRo team's ball detector. `calibrate` fits a camera
//! model to chessboard images; `calibrate-colour` fits the colour detector's window to
//! labelled photos; `train` fits the ball network (or the two-stage detector, or the
//! HOG + SVM filter); `detect` finds the ball in a folder of photos; `evaluate` scores the
//! detector on labelled photos. The command line lives in the library ([`lab::cli`]).

fn main() -> std::process::ExitCode {
    lab::cli::main_exit()
}
