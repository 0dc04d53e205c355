//! The evaluation: every scenario over many seeds, every method on the same deliveries.

use crate::methods::{Method, fusion_config, oracle_config, run_baseline, run_fusion};
use crate::report::{Report, Row, check_targets};
use sim::{Delivery, ObsKind, SimConfig, SimRun};
use sim::{Samples, TickRecord, rms, score, tick_count};
use std::collections::BTreeMap;
use std::sync::Mutex;

/// One scenario and seed, scored for every method.
#[derive(Debug, Clone)]
pub struct RunResult {
    pub scenario: String,
    pub seed: u64,
    pub methods: Vec<(Method, Samples)>,
}

pub fn is_team(scenario: &str) -> bool {
    sim::TEAM_SCENARIOS.contains(&scenario)
}

/// Scores every method on one simulated run.
pub fn evaluate_run(run: &SimRun) -> RunResult {
    let n_ticks = tick_count(run.duration_s);
    let has_phantom = run.phantom.is_some();
    let no_phantom = |d: &Delivery| d.kind != ObsKind::Phantom;
    // Each method is also run without the phantom reports, to measure the phantom's pull.
    let scored = |with: Vec<TickRecord>, without: Option<Vec<TickRecord>>| {
        score(run, &with, n_ticks, without.as_deref())
    };
    let fusion = scored(
        run_fusion(run, fusion_config(run), |_| true),
        has_phantom.then(|| run_fusion(run, fusion_config(run), no_phantom)),
    );
    let oracle = scored(
        run_fusion(run, oracle_config(run), |_| true),
        has_phantom.then(|| run_fusion(run, oracle_config(run), no_phantom)),
    );
    let baseline = scored(
        run_baseline(run, |_| true),
        has_phantom.then(|| run_baseline(run, no_phantom)),
    );
    let mut methods = vec![(Method::Fusion, fusion), (Method::Oracle, oracle)];
    if is_team(&run.scenario)
        && let Some(best) = best_single_robot(run, n_ticks, methods[0].1.ticks, has_phantom)
    {
        methods.push((Method::BestSingleRobot, best));
    }
    methods.push((Method::SeedBaseline, baseline));
    RunResult {
        scenario: run.scenario.clone(),
        seed: run.seed,
        methods,
    }
}

/// The core fed one robot's observations, for the robot that does best on its own: the
/// lowest position RMSE among robots that keep an estimate most of the time.
fn best_single_robot(
    run: &SimRun,
    n_ticks: usize,
    fused_ticks: usize,
    has_phantom: bool,
) -> Option<Samples> {
    let singles: Vec<Samples> = run
        .observer_ids()
        .into_iter()
        .map(|id| {
            let mine = |d: &Delivery| d.obs.robot_id == id;
            score(
                run,
                &run_fusion(run, fusion_config(run), mine),
                n_ticks,
                has_phantom
                    .then(|| {
                        run_fusion(run, fusion_config(run), |d| {
                            mine(d) && d.kind != ObsKind::Phantom
                        })
                    })
                    .as_deref(),
            )
        })
        .collect();
    let key = |s: &Samples| rms(&s.position_err_m).unwrap_or(f64::INFINITY);
    let covering = singles
        .iter()
        .filter(|s| s.ticks as f64 >= 0.8 * fused_ticks as f64);
    let best = covering.min_by(|a, b| key(a).total_cmp(&key(b)))?;
    Some(best.clone())
}

/// Runs `scenarios` × `seeds` on `jobs` threads, reporting progress on stderr.
pub fn evaluate(
    scenarios: &[&str],
    seeds: u64,
    cfg: &SimConfig,
    jobs: usize,
) -> anyhow::Result<Vec<RunResult>> {
    let mut results = for_each_run(scenarios, seeds, jobs, |name, seed| {
        Ok(evaluate_run(&sim::run_scenario(name, seed, cfg)?))
    })?;
    results.sort_by(|a, b| (a.scenario.as_str(), a.seed).cmp(&(b.scenario.as_str(), b.seed)));
    Ok(results)
}

/// Calls `job` for every scenario × seed on `jobs` threads, with a progress bar on
/// stderr; the results come in completion order. The first error fails the whole.
pub fn for_each_run<T: Send>(
    scenarios: &[&str],
    seeds: u64,
    jobs: usize,
    job: impl Fn(&str, u64) -> anyhow::Result<T> + Sync,
) -> anyhow::Result<Vec<T>> {
    let work: Vec<(&str, u64)> = scenarios
        .iter()
        .flat_map(|s| (0..seeds).map(move |k| (*s, k)))
        .collect();
    for_each(
        &work,
        jobs,
        |(name, seed)| format!("{name} seed {seed}"),
        |(name, seed)| job(name, *seed),
    )
}

/// Calls `job` for every item on `jobs` threads, with a progress bar on stderr naming
/// each finished item by `label` and a summary line at the end; the results come in
/// completion order. The first error fails the whole.
pub fn for_each<I: Sync, T: Send>(
    items: &[I],
    jobs: usize,
    label: impl Fn(&I) -> String + Sync,
    job: impl Fn(&I) -> anyhow::Result<T> + Sync,
) -> anyhow::Result<Vec<T>> {
    let total = items.len();
    let queue = Mutex::new(items.iter());
    let results = Mutex::new(Vec::with_capacity(total));
    let errors = Mutex::new(Vec::new());
    let progress = tools::progress::Progress::new(total as u64, "runs");
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            scope.spawn(|| {
                loop {
                    let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                    let Some(item) = next else { break };
                    match job(item) {
                        Ok(r) => {
                            if let Ok(mut res) = results.lock() {
                                res.push(r);
                                progress.inc(label(item));
                            }
                        }
                        Err(e) => {
                            if let Ok(mut errs) = errors.lock() {
                                errs.push(format!("{}: {e:#}", label(item)));
                            }
                        }
                    }
                }
            });
        }
    });
    progress.finish();
    let errors = errors.into_inner().unwrap_or_default();
    if let Some(e) = errors.first() {
        anyhow::bail!("run failed: {e}");
    }
    Ok(results.into_inner().unwrap_or_default())
}

/// Pools the samples of every seed per (scenario, method).
pub fn pool(results: &[RunResult]) -> BTreeMap<(String, Method), (usize, Samples)> {
    let mut pooled: BTreeMap<(String, Method), (usize, Samples)> = BTreeMap::new();
    for r in results {
        for (m, s) in &r.methods {
            let e = pooled
                .entry((r.scenario.clone(), *m))
                .or_insert_with(|| (0, Samples::new()));
            e.0 += 1;
            e.1.merge(s.clone());
        }
    }
    pooled
}

/// The report rows in scenario order, methods in a fixed order, and the targets.
pub fn report(scenarios: &[&str], seeds: u64, results: &[RunResult]) -> Report {
    let pooled = pool(results);
    let order = [
        Method::Fusion,
        Method::Oracle,
        Method::BestSingleRobot,
        Method::SeedBaseline,
    ];
    let mut rows = Vec::new();
    for s in scenarios {
        for m in order {
            if let Some((n, samples)) = pooled.get(&(s.to_string(), m)) {
                rows.push(Row::new(s, m.name(), *n, samples));
            }
        }
    }
    let slow = |s: &str| sim::SLOW_ROBOT_SCENARIOS.contains(&s);
    let pick = |keep: &dyn Fn(&str) -> bool| -> Vec<&str> {
        scenarios.iter().copied().filter(|s| keep(s)).collect()
    };
    let targets = check_targets(
        &rows,
        &pick(&|s| !is_team(s) && !slow(s)),
        &pick(&|s| is_team(s)),
        &pick(&|s| slow(s)),
    );
    Report {
        seeds: seeds as usize,
        scenarios: rows,
        targets,
    }
}
