//! `sim_robots`: simulated MiRos publishing a simulated match's observations in real time
//! ([`tools::cmd::sim_robots`], where the system tests build it too).

fn main() -> anyhow::Result<()> {
    tools::cmd::sim_robots::main()
}
