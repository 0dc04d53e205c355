//! `sim_agent`: the robot agent on the simulator's rendered cameras
//! ([`tools::cmd::sim_agent`], where the system tests build it too).

fn main() -> anyhow::Result<()> {
    tools::cmd::sim_agent::main()
}
