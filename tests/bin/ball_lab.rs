//! The laptop's workbench (`ball-lab`), built by this package, whose tests run it as a
//! process: cargo gives a package's tests the paths of its own binaries only. The program is
//! `lab::cli::main_exit`.

fn main() -> std::process::ExitCode {
    lab::cli::main_exit()
}
