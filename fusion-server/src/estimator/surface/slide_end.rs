//! Where a kicked ball stops sliding: the share of the kick's speed it still has when it
//! starts to roll (`roll_ratio`), measured from the sightings of the first moments after a
//! kick.
//!
//! A hard kick slides for the better part of a second, and where the slide ends decides
//! where the ball stops: a ball that rolls from 0.64 of a 6 m/s kick instead of from 0.55
//! goes metres farther. The sightings from the kick on are split at every candidate instant
//! into a slide (a parabola) and a roll (a line decelerating at the rolling value); the split
//! whose two fits leave the smallest χ² is where the slide ended, and the speed there over
//! the kick's is a sample of the ratio. Only a clear two-phase run counts: enough sightings
//! on either side, and a slide markedly harder than the roll.

use super::{Moments, Seen};

/// The sightings after a kick, until the slide must have ended.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct KickRun {
    pub t_s: f64,
    pub until_s: f64,
    pub seen: Vec<Seen>,
}

/// Each side of the split holds at least this many sightings...
const MIN_SIDE: usize = 8;
/// ... over at least this long (the slide; the roll).
const MIN_SLIDE_S: f64 = 0.12;
const MIN_ROLL_S: f64 = 0.2;
/// The split must explain the sightings this much better (in χ²) than one parabola over
/// the whole run: a clear change, not a fit to the noise.
const MIN_CHI2_GAIN: f64 = 25.0;
/// The slide must decelerate this much more than the roll.
const MIN_SLIDE_EXCESS_MPS2: f64 = 1.0;
/// At most this many candidate splits are tried.
const MAX_SPLITS: usize = 80;
/// Most sightings a run keeps (a flood of them is thinned, not followed without end).
pub(super) const MAX_RUN: usize = 2048;

/// The ratio and its variance the run measures, if it shows one clear end of a slide.
pub(super) fn ratio_sample(run: &KickRun, rolling_mps2: f64) -> Option<(f64, f64)> {
    let seen = &run.seen;
    let n = seen.len();
    if n < 2 * MIN_SIDE {
        return None;
    }
    let step = (n / MAX_SPLITS).max(1);
    let splits: Vec<usize> = (MIN_SIDE..=n - MIN_SIDE).step_by(step).collect();
    let mut best: Option<(f64, f64, f64, usize)> = None;
    for (k, &i) in splits.iter().enumerate() {
        let (slide, roll) = (&seen[..i], &seen[i..]);
        let span = |s: &[Seen]| s[s.len() - 1].t_s - s[0].t_s;
        if span(slide) < MIN_SLIDE_S || span(roll) < MIN_ROLL_S {
            continue;
        }
        let t_split = 0.5 * (seen[i - 1].t_s + seen[i].t_s);
        let Some(a) = Moments::of(run.t_s, slide).and_then(|m| m.quadratic()) else {
            continue;
        };
        let Some(b) = Moments::of(t_split, roll).and_then(|m| m.decelerating_line(rolling_mps2))
        else {
            continue;
        };
        let chi2 = a.chi2_dof * 2.0 * (slide.len() as f64 - 3.0)
            + b.chi2_dof * 2.0 * (roll.len() as f64 - 2.0);
        let v_kick = a.velocity_at(0.0);
        let v_kick = v_kick[0].hypot(v_kick[1]);
        let v_end = b.v[0].hypot(b.v[1]);
        if v_kick <= 0.0 {
            continue;
        }
        let u = [a.v[0] / v_kick, a.v[1] / v_kick];
        let slide_decel = -(a.a[0] * u[0] + a.a[1] * u[1]);
        if slide_decel < rolling_mps2 + MIN_SLIDE_EXCESS_MPS2 || v_end >= v_kick {
            continue;
        }
        let r = v_end / v_kick;
        let var_end = b.var_v[0].max(b.var_v[1]);
        let var_kick = a.var_v[0].max(a.var_v[1]);
        let var = (var_end + r * r * var_kick) / (v_kick * v_kick);
        if best.is_none_or(|(c, ..)| chi2 < c) {
            best = Some((chi2, r, var, k));
        }
    }
    // A best split at either end of the run is no end of a slide seen inside it.
    let (chi2, r, var, k) = best?;
    let whole = Moments::of(run.t_s, seen.iter())?.quadratic()?;
    let chi2_whole = whole.chi2_dof * 2.0 * (n as f64 - 3.0);
    (k > 0 && k + 1 < splits.len() && chi2_whole - chi2 >= MIN_CHI2_GAIN).then_some((r, var))
}
