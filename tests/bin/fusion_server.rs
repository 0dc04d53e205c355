//! The fusion server, built by this package, whose tests run it as a process: cargo gives a
//! package's tests the paths of its own binaries only. The program is `fusion_server::main`.

fn main() -> anyhow::Result<()> {
    fusion_server::main()
}
