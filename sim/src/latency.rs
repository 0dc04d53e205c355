//! Network and processing delay from capture to arrival at the server.
//!
//! Each robot has its own base delay (its CPU load and Wi-Fi link) plus per-packet jitter,
//! so packets from different robots arrive out of capture order; the heavy profile adds the
//! long tails a congested network produces, including packets older than a typical
//! late-buffer window.

use crate::rng::Rng;

/// Range of a robot's base delay.
pub const BASE_RANGE_S: (f64, f64) = (0.020, 0.060);
/// Mean of the exponential per-packet jitter.
pub const JITTER_MEAN_S: f64 = 0.025;
/// Base plus jitter never exceeds this (the agent drops older frames).
pub const CAP_S: f64 = 0.150;
/// Heavy profile: this fraction of packets gets an extra delay uniform in `HEAVY_EXTRA_S`...
pub const HEAVY_FRACTION: f64 = 0.60;
pub const HEAVY_EXTRA_S: (f64, f64) = (0.0, 0.400);
/// ...and this fraction (disjoint from the above) an extra delay in `VERY_LATE_EXTRA_S`.
pub const VERY_LATE_FRACTION: f64 = 0.03;
pub const VERY_LATE_EXTRA_S: (f64, f64) = (0.6, 1.0);

/// How delays are distributed in a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LatencyProfile {
    Normal,
    /// Heavy jitter: 60 % of packets delayed by up to 0.4 s more, 3 % by 0.6–1.0 s more.
    Heavy,
}

/// One robot's link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    pub base_s: f64,
    pub profile: LatencyProfile,
}

impl Link {
    pub fn draw(rng: &mut Rng, profile: LatencyProfile) -> Self {
        Link {
            base_s: rng.range(BASE_RANGE_S.0, BASE_RANGE_S.1),
            profile,
        }
    }

    /// Capture-to-arrival delay of one packet.
    pub fn delay_s(&self, rng: &mut Rng) -> f64 {
        let normal = (self.base_s + rng.exponential(JITTER_MEAN_S)).min(CAP_S);
        match self.profile {
            LatencyProfile::Normal => normal,
            LatencyProfile::Heavy => {
                let u = rng.uniform();
                let extra = if u < VERY_LATE_FRACTION {
                    rng.range(VERY_LATE_EXTRA_S.0, VERY_LATE_EXTRA_S.1)
                } else if u < VERY_LATE_FRACTION + HEAVY_FRACTION {
                    rng.range(HEAVY_EXTRA_S.0, HEAVY_EXTRA_S.1)
                } else {
                    0.0
                };
                normal + extra
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_delays_stay_within_bounds() {
        let mut rng = Rng::new(1);
        for _ in 0..20 {
            let link = Link::draw(&mut rng, LatencyProfile::Normal);
            for _ in 0..1000 {
                let d = link.delay_s(&mut rng);
                assert!((BASE_RANGE_S.0..=CAP_S).contains(&d), "{d}");
            }
        }
    }

    #[test]
    fn heavy_profile_has_its_tails() {
        let mut rng = Rng::new(2);
        let link = Link::draw(&mut rng, LatencyProfile::Heavy);
        let n = 100_000;
        let delays: Vec<f64> = (0..n).map(|_| link.delay_s(&mut rng)).collect();
        let very = delays.iter().filter(|&&d| d > 0.6).count() as f64 / n as f64;
        let over_cap = delays.iter().filter(|&&d| d > CAP_S).count() as f64 / n as f64;
        assert!((very - VERY_LATE_FRACTION).abs() < 0.003, "{very}");
        assert!(over_cap > 0.4, "{over_cap}");
        assert!(delays.iter().all(|&d| d <= CAP_S + VERY_LATE_EXTRA_S.1));
    }
}
