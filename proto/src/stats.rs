//! The workspace's one definition of the summary statistics it reports: quantiles by
//! linear interpolation between order statistics (the evaluation's, the benchmarks' and
//! the agent's figures all use it), the mean and the root mean square; and the
//! nearest-rank percentile, for bounds that must be one of the samples.

/// The `q`-quantile (0..=1, linear interpolation between the order statistics) of the
/// finite values in `v`; `None` when there are none.
pub fn quantile(v: &[f64], q: f64) -> Option<f64> {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return None;
    }
    s.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    Some(s[lo] + (s[hi] - s[lo]) * (pos - lo as f64))
}

/// The median ([`quantile`] at 0.5).
pub fn median(v: &[f64]) -> Option<f64> {
    quantile(v, 0.5)
}

/// The nearest-rank percentile `p` (in percent, 0..=100) of samples sorted in ascending
/// order: always one of them; `None` for no samples.
pub fn nearest_rank(sorted: &[f64], p: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let rank = ((p.clamp(0.0, 100.0) / 100.0) * n as f64).ceil() as usize;
    Some(sorted[rank.clamp(1, n) - 1])
}

/// The arithmetic mean; `None` for no values.
pub fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The root mean square; `None` for no values.
pub fn rms(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let v = [3.0, 1.0, 2.0, 4.0, f64::NAN];
        assert_eq!(quantile(&v, 0.0), Some(1.0));
        assert_eq!(quantile(&v, 1.0), Some(4.0));
        assert_eq!(median(&v), Some(2.5));
        assert_eq!(quantile(&v, 0.9), Some(3.0 + 0.7));
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(quantile(&[f64::INFINITY], 0.5), None);
    }

    #[test]
    fn nearest_rank_is_a_sample() {
        let s = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];
        assert_eq!(nearest_rank(&s, 5.0), Some(1.0));
        assert_eq!(nearest_rank(&s, 50.0), Some(5.0));
        assert_eq!(nearest_rank(&s, 95.0), Some(10.0));
        assert_eq!(nearest_rank(&s, 0.0), Some(1.0));
        assert_eq!(nearest_rank(&[], 50.0), None);
    }

    #[test]
    fn mean_and_rms() {
        assert_eq!(mean(&[1.0, 3.0]), Some(2.0));
        assert_eq!(rms(&[3.0, 4.0]), Some((12.5f64).sqrt()));
        assert_eq!(mean(&[]), None);
    }
}
