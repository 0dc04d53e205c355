//! The methods compared by the evaluation, all fed the same simulated deliveries in
//! arrival order and asked for their estimate at the same evaluation ticks.

use crate::baseline::SeedBaseline;
use fusion_server::core::motion::{Bounds, MotionModel, fly};
use fusion_server::core::predict::stop;
use fusion_server::core::{Fusion, FusionConfig};
use sim::score::{BOUNCE_LOOKAHEAD_S, HORIZONS_S, TickRecord, tick_times_s};
use sim::{Delivery, SimRun};

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
    t.decel_sigma_mps2 = 1e-6;
    t.restitution_sigma = 1e-6;
    t.learn_decel = false;
    t.learn_restitution = false;
    cfg
}

pub fn fusion_config(run: &SimRun) -> FusionConfig {
    FusionConfig {
        pitch: run.pitch.clone(),
        ..FusionConfig::default()
    }
}

/// Runs the fusion core (with `cfg`) over the deliveries that `keep` accepts.
pub fn run_fusion(
    run: &SimRun,
    cfg: FusionConfig,
    keep: impl Fn(&Delivery) -> bool,
) -> Vec<TickRecord> {
    let bounds = Bounds::from_pitch(&cfg.pitch);
    let base_model = cfg.tracker.motion;
    let mut fusion = Fusion::new(cfg);
    drive(
        run,
        keep,
        &mut fusion,
        |f, d| {
            f.ingest(&d.obs, d.arrival);
        },
        |f, t_s| {
            let filter = f.filter_at(run.stamp_of(t_s))?;
            let model = filter.model(&base_model);
            Some(model_record(
                t_s,
                filter.position(),
                filter.velocity(),
                &model,
                &bounds,
            ))
        },
    )
}

/// Runs the seed's method over the deliveries that `keep` accepts.
pub fn run_baseline(run: &SimRun, keep: impl Fn(&Delivery) -> bool) -> Vec<TickRecord> {
    let mut baseline = SeedBaseline::default();
    drive(
        run,
        keep,
        &mut baseline,
        |b, d| b.ingest(d.arrival, &d.obs),
        |b, t_s| {
            let (p, v) = b.query(run.stamp_of(t_s))?;
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
        },
    )
}

fn model_record(
    t_s: f64,
    p: [f64; 2],
    v: [f64; 2],
    model: &MotionModel,
    bounds: &Bounds,
) -> TickRecord {
    let predicted = HORIZONS_S
        .iter()
        .map(|h| fly(p, v, *h, model, bounds).position)
        .collect();
    let stop = stop(p, v, model, bounds).map(|s| (t_s + s.t_s, s.position_m));
    let first_bounce_t_s = fly(p, v, BOUNCE_LOOKAHEAD_S, model, bounds)
        .hits()
        .next()
        .map(|h| t_s + h.t_s);
    TickRecord {
        t_s,
        position: p,
        velocity: v,
        predicted,
        stop,
        first_bounce_t_s,
    }
}

/// Feeds deliveries in arrival order and queries at every tick.
fn drive<S>(
    run: &SimRun,
    keep: impl Fn(&Delivery) -> bool,
    state: &mut S,
    ingest: impl Fn(&mut S, &Delivery),
    query: impl Fn(&mut S, f64) -> Option<TickRecord>,
) -> Vec<TickRecord> {
    let mut out = Vec::new();
    let mut next = 0;
    for t_s in tick_times_s(run.duration_s) {
        let at = run.stamp_of(t_s);
        while let Some(d) = run.deliveries.get(next).filter(|d| d.arrival <= at) {
            if keep(d) {
                ingest(state, d);
            }
            next += 1;
        }
        if let Some(r) = query(state, t_s) {
            out.push(r);
        }
    }
    out
}
