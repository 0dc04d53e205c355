//! Simulated match logs, built by this package, whose tests run it as a process: cargo gives a
//! package's tests the paths of its own binaries only. The program is `tools::cmd::simulate::main`.

fn main() -> anyhow::Result<()> {
    tools::cmd::simulate::main()
}
