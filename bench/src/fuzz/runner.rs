//! Runs a target's inputs under `catch_unwind`, counting verdicts and recording panics.

use std::fmt::Write as _;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use sim::Rng;

use super::{Target, Verdict, mutate};
use tools::progress::Progress;

/// Counts of one target's run.
#[derive(Debug, Clone, PartialEq)]
pub struct Stats {
    pub target: &'static str,
    pub inputs: u64,
    pub accepted: u64,
    pub rejected: u64,
    pub panics: u64,
    pub elapsed: Duration,
}

impl Stats {
    pub fn inputs_per_s(&self) -> f64 {
        self.inputs as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// One input that made a target panic.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    pub target: &'static str,
    pub seed: u64,
    /// Index of the input in the target's stream (0-based).
    pub iteration: u64,
    /// The panic message and its location.
    pub message: String,
    pub input: Vec<u8>,
}

impl Finding {
    /// The finding and its input, escaped, for a terminal.
    pub fn report(&self) -> String {
        let mut out = format!(
            "PANIC in {} (seed {}, input {}): {}\n  input ({} bytes): ",
            self.target,
            self.seed,
            self.iteration,
            self.message,
            self.input.len()
        );
        let shown = &self.input[..self.input.len().min(4096)];
        let _ = write!(out, "b\"{}\"", shown.escape_ascii());
        if shown.len() < self.input.len() {
            out.push_str(" …");
        }
        out
    }
}

/// Inputs per progress step.
pub const PROGRESS_STEP: u64 = 1024;

/// Progress steps of a run of `inputs` inputs.
pub fn progress_steps(inputs: u64) -> u64 {
    inputs.div_ceil(PROGRESS_STEP)
}

/// The message of the last panic on any thread, set by [`run`]'s quiet hook.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Feeds `inputs` inputs, generated from `seed` and the target's name, to `target`.
/// Panics are caught and returned as findings; the default panic output is silenced
/// while the target runs.
pub fn run(
    target: &mut Target,
    seed: u64,
    inputs: u64,
    progress: &Progress,
) -> (Stats, Vec<Finding>) {
    let mut rng = Rng::stream(seed, target.name, 0);
    let mut stats = Stats {
        target: target.name,
        inputs: 0,
        accepted: 0,
        rejected: 0,
        panics: 0,
        elapsed: Duration::ZERO,
    };
    let mut findings = Vec::new();
    let previous_hook = panic::take_hook();
    panic::set_hook(Box::new(|info| {
        let mut last = LAST_PANIC.lock().unwrap_or_else(|p| p.into_inner());
        *last = Some(info.to_string());
    }));
    let started = Instant::now();
    for iteration in 0..inputs {
        let input = mutate::generate(&mut rng, &target.seeds);
        let check = &mut target.check;
        match panic::catch_unwind(AssertUnwindSafe(|| check(&input))) {
            Ok(Verdict::Accepted) => stats.accepted += 1,
            Ok(Verdict::Rejected) => stats.rejected += 1,
            Err(_) => {
                stats.panics += 1;
                let message = LAST_PANIC
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .take()
                    .unwrap_or_else(|| "panic without a message".to_owned());
                findings.push(Finding {
                    target: target.name,
                    seed,
                    iteration,
                    message,
                    input,
                });
            }
        }
        stats.inputs += 1;
        if iteration % PROGRESS_STEP == PROGRESS_STEP - 1 || iteration + 1 == inputs {
            progress.inc(target.name);
        }
    }
    stats.elapsed = started.elapsed();
    panic::set_hook(previous_hook);
    (stats, findings)
}
