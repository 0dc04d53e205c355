//! The flags every simulator-driven program shares: which match, how long, how many robots
//! and when it starts. `demo`, `sim_robots`, `simulate` and `sim_agent` flatten them (with
//! the server's pitch flags, `PitchFlags`, beside them), so one match is named the same
//! way everywhere.

use clap::Args;
use proto::{Pitch, Stamp};

#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Simulated match")]
pub struct MatchArgs {
    /// Scenario to play (`match`, `team-rally`, `corner`, the seed's six, ...).
    #[arg(long, default_value = "match")]
    pub scenario: String,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Match length, seconds (default: the scenario's).
    #[arg(long, value_name = "S")]
    pub duration_s: Option<f64>,
    /// Robots on the pitch in a `match` (default five).
    #[arg(long, value_name = "N")]
    pub team_size: Option<usize>,
    /// Match start as nanoseconds since the UNIX epoch (default: now, or the simulator's own
    /// epoch for a log); processes that play one match together must share it.
    #[arg(long, value_name = "NS")]
    pub start_ns: Option<u64>,
}

impl MatchArgs {
    /// The start, or `default` when none was given.
    pub fn start_or(&self, default: Stamp) -> Stamp {
        self.start_ns.map(Stamp).unwrap_or(default)
    }

    /// The match at `start` on `pitch`: deterministic, so every process computes the
    /// same one.
    pub fn simulate(&self, pitch: &Pitch, start: Stamp) -> anyhow::Result<sim::SimRun> {
        crate::sim_robots::simulate_on(
            pitch,
            &self.scenario,
            self.seed,
            start,
            self.duration_s,
            self.team_size,
        )
    }
}
