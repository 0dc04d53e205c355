//! `robot-agent run`: frames from an image folder, a recording or a running robot's ROS
//! topics through the perception pipeline, observations and status out over Zenoh
//! ([`crate::runtime`]).

use crate::runtime::source::SourceSpec;
use crate::runtime::{RunArgs, Source};
use anyhow::Result;

#[derive(Debug, clap::Args)]
pub struct RunCmdArgs {
    /// `images:DIR` (a folder with a frames.jsonl index), `mcap:FILE` (a recording of
    /// camera images and robot states, or a MiRo's ROS 2 bag or converted ROS 1 bag),
    /// `ros1` (a running MiRo's topics from its ROS 1 master: `--ros-master-uri`, else
    /// `ROS_MASTER_URI`), or `zenoh:ros2` / `zenoh:ros1` (a running MiRo's ROS topics as a
    /// Zenoh ROS bridge publishes them).
    #[arg(long)]
    pub source: SourceSpec,
    #[command(flatten)]
    pub run: RunArgs,
}

pub async fn run(args: RunCmdArgs) -> Result<()> {
    crate::runtime::run(args.run, Source::Spec(args.source), None).await?;
    Ok(())
}
