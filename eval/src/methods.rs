//! The methods compared by the evaluation, all fed the same simulated deliveries in
//! arrival order and asked for their estimate at the same evaluation ticks.

use crate::baseline::SeedBaseline;
use fusion_server::FusionConfig;
use proto::Stamp;
use sim::{Delivery, SimRun};
use sim::{HORIZONS_S, TickRecord};
pub use tools::scoring::{drive, drive_ticks, fusion_config, model_record, run_fusion};

/// A method the evaluation compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Method {
    Fusion,
    SeedBaseline,
    Oracle,
    BestSingleRobot,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Fusion => "fusion",
            Method::SeedBaseline => "seed-baseline",
            Method::Oracle => "oracle",
            Method::BestSingleRobot => "best-single-robot",
        }
    }
}

/// The oracle: the same core, told the simulated floor's true rolling deceleration and the
/// walls' mean restitution instead of learning them.
pub fn oracle_config(run: &SimRun) -> FusionConfig {
    let mut cfg = FusionConfig {
        pitch: run.pitch.clone(),
        ..FusionConfig::default()
    };
    let t = &mut cfg.tracker;
    t.motion.decel_mps2 = run.params.rolling_decel_mps2;
    t.motion.restitution = run.params.restitution_mean;
    t.surface.decel_sigma_mps2 = 1e-6;
    t.surface.restitution_sigma = 1e-6;
    t.learn_decel = false;
    t.learn_restitution = false;
    cfg
}

/// Runs the seed's method over the deliveries that `keep` accepts.
pub fn run_baseline(run: &SimRun, keep: impl Fn(&Delivery) -> bool) -> Vec<TickRecord> {
    let mut baseline = SeedBaseline::default();
    drive(
        run,
        keep,
        &mut baseline,
        |b, d| b.ingest(d.arrival, &d.obs),
        |b, t_s| baseline_record(b, run.stamp_of(t_s), t_s),
    )
}

/// The seed's estimate at `at` (`t_s` on the run's clock), its predictions straight lines.
pub fn baseline_record(b: &mut SeedBaseline, at: Stamp, t_s: f64) -> Option<TickRecord> {
    let (p, v) = b.query(at)?;
    Some(TickRecord {
        t_s,
        position: p,
        velocity: v,
        predicted: HORIZONS_S
            .iter()
            .map(|h| [p[0] + h * v[0], p[1] + h * v[1]])
            .collect(),
        stop: None,
        first_bounce_t_s: None,
    })
}
