//! Scoring the fusion core against a simulated run's ground truth, the evaluation's way:
//! deliveries fed in arrival order, the estimate and its predictions taken at every tick.
//! Shared by the evaluation and by `replay` of match logs that carry ground truth.

use fusion_server::stop;
use fusion_server::{Bounds, MotionModel, fly};
use fusion_server::{Fusion, FusionConfig};
use proto::Stamp;
use sim::{BOUNCE_LOOKAHEAD_S, HORIZONS_S, TickRecord, tick_times_s};
use sim::{Delivery, SimRun};

/// The fusion's configuration for a run: defaults on the run's pitch.
pub fn fusion_config(run: &SimRun) -> FusionConfig {
    FusionConfig::for_pitch(run.pitch.clone())
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

/// The record of an estimate (position, velocity) under `model`: predictions at every
/// horizon, stop point and first bounce.
pub fn model_record(
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
pub fn drive<S>(
    run: &SimRun,
    keep: impl Fn(&Delivery) -> bool,
    state: &mut S,
    ingest: impl Fn(&mut S, &Delivery),
    query: impl Fn(&mut S, f64) -> Option<TickRecord>,
) -> Vec<TickRecord> {
    drive_ticks(
        &run.deliveries,
        run.start,
        tick_times_s(run.duration_s),
        keep,
        state,
        ingest,
        query,
    )
}

/// [`drive`] over any arrival-ordered deliveries and ticks (seconds after `start`): before
/// each tick, every delivery that has arrived by then is ingested (if `keep` accepts it);
/// then the state is queried.
pub fn drive_ticks<S, R>(
    deliveries: &[Delivery],
    start: Stamp,
    ticks_s: impl IntoIterator<Item = f64>,
    keep: impl Fn(&Delivery) -> bool,
    state: &mut S,
    ingest: impl Fn(&mut S, &Delivery),
    query: impl Fn(&mut S, f64) -> Option<R>,
) -> Vec<R> {
    let mut out = Vec::new();
    let mut next = 0;
    for t_s in ticks_s {
        let at = start.offset_secs(t_s);
        while let Some(d) = deliveries.get(next).filter(|d| d.arrival <= at) {
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
