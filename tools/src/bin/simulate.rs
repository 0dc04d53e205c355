//! `simulate`: a simulated match written as a match log with its ground truth
//! ([`tools::cmd::simulate`], where the system tests build it too).

fn main() -> anyhow::Result<()> {
    tools::cmd::simulate::main()
}
