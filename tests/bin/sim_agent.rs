//! The agent on simulated cameras, built by this package, whose tests run it as a process: cargo gives a
//! package's tests the paths of its own binaries only. The program is `tools::cmd::sim_agent::main`.

fn main() -> anyhow::Result<()> {
    tools::cmd::sim_agent::main()
}
