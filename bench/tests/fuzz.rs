//! A sample of the fuzzer for CI: every target, a few thousand inputs each, no panic.

use bench::fuzz::{self, runner};
use tools::progress::Progress;

/// Inputs per target: a few seconds in all in a debug build.
const INPUTS: u64 = 2000;

#[test]
fn no_target_panics_on_a_sample_of_inputs() {
    let mut targets = fuzz::all_targets();
    assert!(targets.len() >= 19, "{} targets", targets.len());
    let progress = Progress::hidden(0);
    let mut findings = Vec::new();
    for target in &mut targets {
        assert!(!target.seeds.is_empty(), "{} has no seed", target.name);
        let (stats, found) = runner::run(target, 20261202, INPUTS, &progress);
        assert_eq!(stats.inputs, INPUTS);
        assert!(stats.rejected > 0, "{} rejected nothing", target.name);
        findings.extend(found);
    }
    let reports: Vec<String> = findings.iter().map(|f| f.report()).collect();
    assert!(reports.is_empty(), "{}", reports.join("\n"));
}

#[test]
fn every_target_accepts_its_seeds() {
    for mut target in fuzz::all_targets() {
        for seed in target.seeds.clone() {
            assert_eq!(
                (target.check)(&seed),
                fuzz::Verdict::Accepted,
                "{} refused its seed {:?}",
                target.name,
                String::from_utf8_lossy(&seed)
            );
        }
    }
}
