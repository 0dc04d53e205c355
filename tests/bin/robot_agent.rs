//! The robot agent, built by this package, whose tests run it as a process: cargo gives a
//! package's tests the paths of its own binaries only. The program is `robot_agent::cli::main_exit`.

fn main() -> std::process::ExitCode {
    robot_agent::cli::main_exit()
}
