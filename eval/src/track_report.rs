//! The tracks evaluation's report: the runs pooled per method, as JSON, as markdown tables
//! and as a chart of error against horizon.

use crate::plot::{Chart, Marker, PALETTE, Series, Style};
use crate::track_eval::{
    AFTER_PUSH_S, BOUNCE_WINDOW_S, EVENT_MATCH_S, MOVING_MPS, PHASE_HORIZON_S, Phase,
    RELOCATION_FOUND_M, STOP_MIN_TO_GO_M, TICK_S, TrackMethod, TrackRun, TrackSamples,
};
use crate::track_obs::ObserverSetup;
use proto::Pitch;
use serde::Serialize;
use sim::{HORIZONS_S, Spread, horizon_key};
use std::collections::BTreeMap;
use tools::tracks::{TimeUnit, TrackFile};

/// Horizons the tables show (the JSON and the chart have all of [`HORIZONS_S`]).
pub const TABLE_HORIZONS_S: [f64; 3] = [0.5, 1.0, 2.0];
/// The short horizons the lag table shows.
pub const SHORT_HORIZONS_S: [f64; 2] = [0.1, 0.2];

pub const SECTION_BEGIN: &str = "<!-- evaluate-tracks:begin -->";
pub const SECTION_END: &str = "<!-- evaluate-tracks:end -->";

/// One file that was read.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct FileSummary {
    pub file: String,
    pub source: Option<String>,
    pub time_unit: TimeUnit,
    pub tracks: usize,
    pub rows: usize,
    pub skipped_rows: usize,
    pub skipped_lines: Vec<usize>,
}

impl FileSummary {
    pub fn of(f: &TrackFile) -> Self {
        FileSummary {
            file: f.file.clone(),
            source: f.source.clone(),
            time_unit: f.time_unit,
            tracks: f.tracks.len(),
            rows: f.rows,
            skipped_rows: f.skipped_rows,
            skipped_lines: f.skipped_lines.clone(),
        }
    }
}

/// One track, over its seeds.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TrackSummary {
    pub track: String,
    pub duration_s: f64,
    pub wall_bounces: usize,
    pub pushes: usize,
    pub samples_outside_pitch: usize,
    /// Observations per seed.
    pub observations: usize,
}

/// One method, pooled over every track and seed.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct MethodSummary {
    pub method: String,
    /// Share of ticks with an estimate.
    pub coverage: f64,
    pub now_error_m: Spread,
    /// Keyed by [`horizon_key`].
    pub horizon_error_m: BTreeMap<String, Spread>,
    /// Windows left out because the ball was pushed within them, per horizon.
    pub windows_across_push: BTreeMap<String, usize>,
    /// States with the track's next bounce within [`BOUNCE_WINDOW_S`]: |predicted − true|
    /// time of the first predicted bounce off that wall, and how many predicted none
    /// (methods that predict bounces).
    pub bounce_time_error_s: Option<Spread>,
    pub bounces_missed: Option<usize>,
    pub first_estimate_s: Spread,
    /// Share of states `stopped` while the track moved faster than [`MOVING_MPS`].
    pub stopped_while_moving: Option<f64>,
    pub moving_states: usize,
    /// Pushes of a ball at rest: from the track moving to the first state not `stopped`.
    pub kick_onset_lag_s: Spread,
    /// The motion parameters at the end of each track (fusion methods).
    pub final_decel_mps2: Option<Spread>,
    pub final_slide_decel_mps2: Option<Spread>,
    pub final_restitution: Option<Spread>,
    pub final_restitution_samples: Option<Spread>,
    pub observations_applied: u64,
    pub observations_outside_walls: u64,
    /// Relocated balls: from their first capture to the first state within
    /// [`RELOCATION_FOUND_M`] of them, and those never found.
    pub relocation_found_s: Spread,
    pub relocation_found_max_s: Option<f64>,
    pub relocations_not_found: usize,
    /// The track's wall bounces with no push near, and how the core took them (methods
    /// that tell bounces from kicks).
    pub bounces: Option<BounceRecognition>,
    /// Where the ball stops (methods that predict it): the error, the error over the
    /// distance still to go, the share within 10 % of it, and the states that predicted no
    /// stop.
    pub stop_error_m: Option<Spread>,
    pub stop_relative_error: Option<Spread>,
    pub stop_within_10_percent: Option<f64>,
    pub stop_not_predicted: usize,
    /// Errors per horizon ([`horizon_key`]) by phase, keyed by [`Phase::name`].
    pub phase_error_m: BTreeMap<String, BTreeMap<String, Spread>>,
    /// How the served covariance covers the true position (methods that serve one): per
    /// horizon ([`horizon_key`]), over all states (`"all"`) and per [`Phase::name`] ...
    pub coverage_95: BTreeMap<String, BTreeMap<String, Coverage>>,
    /// ... and the true stop.
    pub stop_coverage_95: Option<Coverage>,
}

/// The squared Mahalanobis distance within which a 2-D Gaussian holds 95 % of its mass.
pub const D2_95: f64 = 5.991;

/// How well served covariances cover the truth.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Coverage {
    pub n: usize,
    /// Share of states whose true position lies in the served 95 % region (d² ≤ [`D2_95`]).
    pub inside_95: Option<f64>,
    /// Median 2σ radius (twice the square root of the larger eigenvalue), metres.
    pub median_radius_m: Option<f64>,
}

impl Coverage {
    pub fn of(samples: &[(f64, f64)]) -> Self {
        let n = samples.len();
        let inside = samples.iter().filter(|(d2, _)| *d2 <= D2_95).count();
        let radii: Vec<f64> = samples.iter().map(|(_, r)| *r).collect();
        Coverage {
            n,
            inside_95: (n > 0).then(|| inside as f64 / n as f64),
            median_radius_m: Spread::of(&radii).median,
        }
    }
}

/// The track's clear wall bounces (no push within [`EVENT_MATCH_S`]) as the core took them.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct BounceRecognition {
    pub clear_bounces: usize,
    pub recognised: usize,
    pub taken_for_kicks: usize,
    /// Share of the clear bounces recognised.
    pub recognised_share: Option<f64>,
    /// All the bounces the core counted, and the kicks it inferred.
    pub bounces_seen: usize,
    pub kicks_inferred: usize,
    /// Kicks with neither a course change nor a bounce of the track near.
    pub kicks_unprompted: usize,
}

impl MethodSummary {
    pub fn of(method: TrackMethod, s: &TrackSamples) -> Self {
        let per_h = |v: &dyn Fn(usize) -> Spread| -> BTreeMap<String, Spread> {
            (0..HORIZONS_S.len())
                .map(|k| (horizon_key(HORIZONS_S[k]), v(k)))
                .collect()
        };
        let models = (!s.final_model.is_empty()).then_some(&s.final_model);
        let spread_of = |f: fn(&proto::ModelParams) -> f64| {
            models.map(|m| Spread::of(&m.iter().map(f).collect::<Vec<_>>()))
        };
        MethodSummary {
            method: method.name().to_string(),
            coverage: if s.ticks_possible == 0 {
                0.0
            } else {
                s.ticks as f64 / s.ticks_possible as f64
            },
            now_error_m: Spread::of(&s.now_err_m),
            horizon_error_m: per_h(&|k| Spread::of(&s.horizon_err_m[k])),
            windows_across_push: (0..HORIZONS_S.len())
                .map(|k| (horizon_key(HORIZONS_S[k]), s.pushed_windows[k]))
                .collect(),
            bounce_time_error_s: method
                .predicts_bounces()
                .then(|| Spread::of(&s.bounce_time_err_s)),
            bounces_missed: method.predicts_bounces().then_some(s.bounce_missed),
            first_estimate_s: Spread::of(&s.first_estimate_s),
            stopped_while_moving: (s.moving_states > 0)
                .then(|| s.stopped_while_moving as f64 / s.moving_states as f64),
            moving_states: s.moving_states,
            kick_onset_lag_s: Spread::of(&s.onset_lag_s),
            final_decel_mps2: spread_of(|m| m.rolling_decel_mps2),
            final_slide_decel_mps2: spread_of(|m| m.slide_decel_mps2),
            final_restitution: spread_of(|m| m.wall_restitution),
            final_restitution_samples: spread_of(|m| f64::from(m.restitution_samples)),
            observations_applied: s.observations_applied,
            observations_outside_walls: s.outside_walls,
            relocation_found_s: Spread::of(&s.relocation_found_s),
            relocation_found_max_s: s.relocation_found_s.iter().copied().reduce(f64::max),
            relocations_not_found: s.relocations_not_found,
            bounces: method.infers_events().then(|| BounceRecognition {
                clear_bounces: s.clear_bounces,
                recognised: s.bounces_recognised,
                taken_for_kicks: s.bounces_taken_for_kicks,
                recognised_share: (s.clear_bounces > 0)
                    .then(|| s.bounces_recognised as f64 / s.clear_bounces as f64),
                bounces_seen: s.bounces_seen,
                kicks_inferred: s.kicks_inferred,
                kicks_unprompted: s.kicks_unprompted,
            }),
            stop_error_m: method.predicts_stops().then(|| Spread::of(&s.stop_err_m)),
            stop_relative_error: method.predicts_stops().then(|| Spread::of(&s.stop_rel_err)),
            stop_within_10_percent: (method.predicts_stops() && !s.stop_rel_err.is_empty()).then(
                || {
                    s.stop_rel_err.iter().filter(|r| **r <= 0.1).count() as f64
                        / s.stop_rel_err.len() as f64
                },
            ),
            stop_not_predicted: s.stop_not_predicted,
            phase_error_m: (0..HORIZONS_S.len())
                .map(|k| {
                    let by = Phase::ALL
                        .iter()
                        .map(|p| {
                            (
                                p.name().to_string(),
                                Spread::of(&s.phase_err_m[*p as usize][k]),
                            )
                        })
                        .collect();
                    (horizon_key(HORIZONS_S[k]), by)
                })
                .collect(),
            coverage_95: (0..HORIZONS_S.len())
                .filter(|k| !s.horizon_d2[*k].is_empty())
                .map(|k| {
                    let mut by = BTreeMap::new();
                    by.insert("all".to_string(), Coverage::of(&s.horizon_d2[k]));
                    for p in Phase::ALL {
                        by.insert(
                            p.name().to_string(),
                            Coverage::of(&s.phase_d2[p as usize][k]),
                        );
                    }
                    (horizon_key(HORIZONS_S[k]), by)
                })
                .collect(),
            stop_coverage_95: (!s.stop_d2.is_empty()).then(|| Coverage::of(&s.stop_d2)),
        }
    }
}

/// The setup the report was made with.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SetupSummary {
    pub pitch_m: [f64; 2],
    pub ball_radius_m: f64,
    pub observers: ObserverSetup,
    pub seeds: u64,
    pub tick_s: f64,
    pub bounce_window_s: f64,
    pub moving_mps: f64,
}

/// The whole report.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TracksReport {
    pub files: Vec<FileSummary>,
    pub setup: SetupSummary,
    pub tracks: Vec<TrackSummary>,
    pub methods: Vec<MethodSummary>,
}

/// Pools the runs (over `seeds` seeds, on `pitch`, seen by `observers`) per method and per
/// track.
pub fn report(
    files: Vec<FileSummary>,
    pitch: &Pitch,
    observers: &ObserverSetup,
    seeds: u64,
    runs: &[TrackRun],
) -> TracksReport {
    let mut tracks: Vec<TrackSummary> = Vec::new();
    for r in runs {
        if tracks.iter().any(|t| t.track == r.track) {
            continue;
        }
        tracks.push(TrackSummary {
            track: r.track.clone(),
            duration_s: r.duration_s,
            wall_bounces: r.bounces,
            pushes: r.pushes,
            samples_outside_pitch: r.samples_outside,
            observations: r.observations,
        });
    }
    let methods = TrackMethod::ALL
        .iter()
        .map(|m| {
            let mut pooled = TrackSamples::new();
            for (_, s) in runs.iter().flat_map(|r| &r.methods).filter(|(x, _)| x == m) {
                pooled.merge(s);
            }
            MethodSummary::of(*m, &pooled)
        })
        .collect();
    TracksReport {
        files,
        setup: SetupSummary {
            pitch_m: [pitch.length_m, pitch.width_m],
            ball_radius_m: pitch.ball_radius_m,
            observers: observers.clone(),
            seeds,
            tick_s: TICK_S,
            bounce_window_s: BOUNCE_WINDOW_S,
            moving_mps: MOVING_MPS,
        },
        tracks,
        methods,
    }
}

fn cm(s: &Spread) -> String {
    match (s.median, s.p90) {
        (Some(m), Some(p)) => format!("{:.1} / {:.1} ({})", m * 100.0, p * 100.0, s.n),
        _ => "–".into(),
    }
}

fn opt(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map_or("–".into(), f)
}

/// The two markdown tables: errors by horizon; bounces, onset and learning.
pub fn markdown(rep: &TracksReport) -> String {
    let mut s = String::from("| method | now, cm | ");
    for h in TABLE_HORIZONS_S {
        s.push_str(&format!("{} s ahead, cm |", horizon_key(h)));
        if h != TABLE_HORIZONS_S[TABLE_HORIZONS_S.len() - 1] {
            s.push(' ');
        }
    }
    s.push_str("\n|---|---|");
    s.push_str(&"---|".repeat(TABLE_HORIZONS_S.len()));
    s.push('\n');
    for m in &rep.methods {
        s.push_str(&format!("| {} | {} |", m.method, cm(&m.now_error_m)));
        for h in TABLE_HORIZONS_S {
            let cell = m
                .horizon_error_m
                .get(&horizon_key(h))
                .map_or("–".into(), cm);
            s.push_str(&format!(" {cell} |"));
        }
        s.push('\n');
    }
    s.push_str(
        "\nCells: median / 90th percentile (number of states scored).\n\n\
         | method | bounce time error, ms (n, no bounce predicted) | first estimate after, s | \
         stopped while moving | kick onset lag, ms (n) | deceleration at the end (slide), m/s² | \
         restitution at the end (bounces learnt from) |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for m in &rep.methods {
        let bounce = match (&m.bounce_time_error_s, m.bounces_missed) {
            (Some(b), Some(missed)) => match (b.median, b.p90) {
                (Some(md), Some(p)) => {
                    format!("{:.0} / {:.0} ({}, {missed})", md * 1e3, p * 1e3, b.n)
                }
                _ => format!("– (0, {missed})"),
            },
            _ => "not predicted".into(),
        };
        let stopped = m.stopped_while_moving.map_or("–".into(), |x| {
            format!("{:.1} % of {}", x * 100.0, m.moving_states)
        });
        let decel = match (&m.final_decel_mps2, &m.final_slide_decel_mps2) {
            (Some(d), Some(sl)) => format!(
                "{} (slide {})",
                opt(d.median, |v| format!("{v:.3}")),
                opt(sl.median, |v| format!("{v:.2}"))
            ),
            _ => "–".into(),
        };
        let rest = match (&m.final_restitution, &m.final_restitution_samples) {
            (Some(r), Some(n)) => format!(
                "{} ({})",
                opt(r.median, |v| format!("{v:.2}")),
                opt(n.median, |v| format!("{v:.0}"))
            ),
            _ => "–".into(),
        };
        let lag = &m.kick_onset_lag_s;
        let lag = match (lag.median, lag.p90) {
            (Some(md), Some(p)) => format!("{:.0} / {:.0} ({})", md * 1e3, p * 1e3, lag.n),
            _ => "–".into(),
        };
        s.push_str(&format!(
            "| {} | {bounce} | {} | {stopped} | {lag} | {decel} | {rest} |\n",
            m.method,
            opt(m.first_estimate_s.median, |v| format!("{v:.2}")),
        ));
    }
    s.push_str(&format!(
        "\n{PHASE_HORIZON_S:.0} s ahead by what the window holds (cm, median / p90 (states)): \
         the first {AFTER_PUSH_S:.1} s after a push (the kick's speed still being learned), a \
         wall bounce, neither.\n\n| method |"
    ));
    for p in Phase::ALL {
        s.push_str(&format!(" {} |", p.name()));
    }
    s.push_str("\n|---|---|---|---|\n");
    let phase_cell = |m: &MethodSummary, h: f64, p: Option<Phase>| {
        let spread = match p {
            Some(p) => m
                .phase_error_m
                .get(&horizon_key(h))
                .and_then(|by| by.get(p.name())),
            None => m.horizon_error_m.get(&horizon_key(h)),
        };
        spread.map_or("–".into(), cm)
    };
    for m in &rep.methods {
        s.push_str(&format!("| {} |", m.method));
        for p in Phase::ALL {
            s.push_str(&format!(" {} |", phase_cell(m, PHASE_HORIZON_S, Some(p))));
        }
        s.push('\n');
    }
    s.push_str(&format!(
        "\nThe first moments ahead, where a path that lags a bounce or a strike shows (cm, \
         median / p90 (states)); the windows as above.\n\n\
         | method | horizon | all | {} | {} | {} |\n|---|---|---|---|---|---|\n",
        Phase::AfterPush.name(),
        Phase::AcrossBounce.name(),
        Phase::Free.name()
    ));
    for m in &rep.methods {
        for h in SHORT_HORIZONS_S {
            s.push_str(&format!(
                "| {} | {} s | {} |",
                m.method,
                horizon_key(h),
                phase_cell(m, h, None)
            ));
            for p in Phase::ALL {
                s.push_str(&format!(" {} |", phase_cell(m, h, Some(p))));
            }
            s.push('\n');
        }
    }
    s.push_str(&format!(
        "\nWall bounces with nothing else changing the ball's course within {:.1} s, as the core \
         took them: went through as a bounce (foreseen, or found at the wall) or took for a \
         kick; all the bounces it counted and kicks it inferred, and of those kicks the ones \
         with neither a course change nor a bounce near.\n\n\
         | method | clear wall bounces | recognised as bounces | taken for kicks | bounces counted | kicks inferred (unprompted) |\n\
         |---|---|---|---|---|---|\n",
        EVENT_MATCH_S
    ));
    for m in &rep.methods {
        let Some(b) = &m.bounces else { continue };
        s.push_str(&format!(
            "| {} | {} | {} ({}) | {} | {} | {} ({}) |\n",
            m.method,
            b.clear_bounces,
            b.recognised,
            opt(b.recognised_share, |v| format!("{:.0} %", v * 100.0)),
            b.taken_for_kicks,
            b.bounces_seen,
            b.kicks_inferred,
            b.kicks_unprompted
        ));
    }
    if rep
        .methods
        .iter()
        .any(|m| m.stop_error_m.as_ref().is_some_and(|e| e.n > 0))
    {
        s.push_str(&format!(
            "\nWhere the ball stops, from the states of a moving ball at least {:.0} cm from its \
             next stop with nothing changing its course before it: the predicted stop's error, \
             that error over the distance still to go, and the share of states within 10 % of \
             it.\n\n\
             | method | stop error, cm | error / distance to go | within 10 % | no stop predicted |\n\
             |---|---|---|---|---|\n",
            STOP_MIN_TO_GO_M * 100.0
        ));
        for m in &rep.methods {
            let (Some(e), Some(r)) = (&m.stop_error_m, &m.stop_relative_error) else {
                continue;
            };
            let rel = match (r.median, r.p90) {
                (Some(md), Some(p)) => {
                    format!("{:.0} % / {:.0} % ({})", md * 100.0, p * 100.0, r.n)
                }
                _ => "–".into(),
            };
            s.push_str(&format!(
                "| {} | {} | {rel} | {} | {} |\n",
                m.method,
                cm(e),
                opt(m.stop_within_10_percent, |v| format!("{:.0} %", v * 100.0)),
                m.stop_not_predicted
            ));
        }
    }
    if rep.methods.iter().any(|m| !m.coverage_95.is_empty()) {
        s.push_str(&format!(
            "\nHow sure the served path says it is, against where the ball went: the share of \
             states whose true position lies in the served 95 % region (d² ≤ {D2_95:.2}; \
             honest is 88–98 %) and the median 2σ radius, by horizon and by what the window \
             holds; the stop row scores the predicted stop as the stop table does.\n\n\
             | method | horizon | all | {} | {} | {} |\n|---|---|---|---|---|---|\n",
            Phase::AfterPush.name(),
            Phase::AcrossBounce.name(),
            Phase::Free.name()
        ));
        let cell = |c: Option<&Coverage>| match c {
            Some(Coverage {
                n,
                inside_95: Some(i),
                median_radius_m: Some(r),
            }) => format!("{:.0} % · {:.0} cm ({n})", i * 100.0, r * 100.0),
            _ => "–".into(),
        };
        for m in &rep.methods {
            if m.coverage_95.is_empty() {
                continue;
            }
            for h in TABLE_HORIZONS_S {
                let Some(by) = m.coverage_95.get(&horizon_key(h)) else {
                    continue;
                };
                s.push_str(&format!(
                    "| {} | {} s | {} | {} | {} | {} |\n",
                    m.method,
                    horizon_key(h),
                    cell(by.get("all")),
                    cell(by.get(Phase::AfterPush.name())),
                    cell(by.get(Phase::AcrossBounce.name())),
                    cell(by.get(Phase::Free.name())),
                ));
            }
            if let Some(c) = &m.stop_coverage_95 {
                s.push_str(&format!(
                    "| {} | stop | {} | | | |\n",
                    m.method,
                    cell(Some(c))
                ));
            }
        }
    }
    let relocated = |m: &MethodSummary| m.relocation_found_s.n + m.relocations_not_found;
    if rep.methods.iter().any(|m| relocated(m) > 0) {
        s.push_str(&format!(
            "\nBalls placed elsewhere (a break in the track): seconds from the first capture of \
             the ball at its new place to the first state within {:.0} cm of it.\n\n\
             | method | relocations | found after, s: median / p90 / max | not found |\n\
             |---|---|---|---|\n",
            RELOCATION_FOUND_M * 100.0
        ));
        for m in &rep.methods {
            let f = &m.relocation_found_s;
            let cell = match (f.median, f.p90, m.relocation_found_max_s) {
                (Some(md), Some(p), Some(mx)) => format!("{md:.2} / {p:.2} / {mx:.2}"),
                _ => "–".into(),
            };
            s.push_str(&format!(
                "| {} | {} | {cell} | {} |\n",
                m.method,
                relocated(m),
                m.relocations_not_found
            ));
        }
    }
    if rep.tracks.len() > 1 || rep.setup.seeds > 1 {
        s.push_str(
            "\nFirst estimate, deceleration and restitution: medians over the tracks × seeds.\n",
        );
    }
    s
}

/// The files read and where they came from, and the tracks that were scored.
pub fn markdown_tracks(rep: &TracksReport) -> String {
    let mut s = String::from("| file | tracks | rows (skipped) |\n|---|---|---|\n");
    for f in &rep.files {
        s.push_str(&format!(
            "| `{}` | {} | {} ({}) |\n",
            f.file, f.tracks, f.rows, f.skipped_rows
        ));
    }
    s.push_str("\nWhere the data came from (the files' `# source:` lines):\n\n");
    for f in &rep.files {
        s.push_str(&format!(
            "- `{}`: {}\n",
            f.file,
            f.source.as_deref().unwrap_or("not stated in the file")
        ));
    }
    s.push_str(
        "\n| track | duration, s | wall bounces | pushes | observations |\n|---|---|---|---|---|\n",
    );
    for t in &rep.tracks {
        s.push_str(&format!(
            "| {} | {:.1} | {} | {} | {} |\n",
            t.track, t.duration_s, t.wall_bounces, t.pushes, t.observations
        ));
    }
    s
}

fn method_color(name: &str) -> [u8; 3] {
    let k = TrackMethod::ALL
        .iter()
        .position(|m| m.name() == name)
        .unwrap_or(0);
    [PALETTE[0], PALETTE[2], PALETTE[3], PALETTE[1]][k]
}

/// Median (solid) and 90th percentile (dashed) error against horizon, per method; the
/// current-position error at horizon 0.
pub fn horizon_chart(rep: &TracksReport) -> Chart {
    let mut chart = Chart::new(
        "Tracks from CSV: prediction error against horizon (median solid, p90 dashed)",
        "horizon (s)",
        "position error (m)",
    );
    for m in &rep.methods {
        let points = |q: fn(&Spread) -> Option<f64>| -> Vec<(f64, f64)> {
            std::iter::once((0.0, &m.now_error_m))
                .chain(
                    HORIZONS_S
                        .iter()
                        .filter_map(|h| Some((*h, m.horizon_error_m.get(&horizon_key(*h))?))),
                )
                .filter_map(|(h, s)| Some((h, q(s)?)))
                .collect()
        };
        let color = method_color(&m.method);
        let median = points(|s| s.median);
        if median.is_empty() {
            continue;
        }
        chart.series.push(Series::new(
            m.method.clone(),
            color,
            Style::LineAndMarkers(Marker::Circle),
            median,
        ));
        chart
            .series
            .push(Series::new("", color, Style::Dashed, points(|s| s.p90)));
    }
    chart.x_range = Some((0.0, 2.1));
    chart
}
