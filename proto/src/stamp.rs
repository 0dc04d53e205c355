//! Time on the wire: capture time in nanoseconds since the UNIX epoch.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Nanoseconds since the UNIX epoch. On an `Observation` it is the *capture* time of the
/// image, not the time it was sent.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    Default,
    Serialize,
    Deserialize,
    JsonSchema,
)]
#[serde(transparent)]
pub struct Stamp(pub u64);

impl Stamp {
    const NS_PER_S: f64 = 1e9;
    const NS_PER_S_U64: u64 = 1_000_000_000;

    /// A stamp from seconds since the epoch; negative or non-finite seconds give 0, seconds
    /// past the end of `u64` nanoseconds saturate.
    ///
    /// Whole seconds and the fraction are converted separately: present-day times are
    /// ~1.7e18 ns, beyond the 2^53 integers an `f64` holds exactly, so `secs * 1e9` would
    /// be off by up to a few hundred nanoseconds.
    pub fn from_secs_f64(secs: f64) -> Self {
        if !(secs.is_finite() && secs > 0.0) {
            return Stamp(0);
        }
        let whole = secs.trunc();
        let frac_ns = ((secs - whole) * Self::NS_PER_S).round() as u64;
        // `as` saturates for floats beyond u64::MAX.
        let whole_ns = (whole as u64).saturating_mul(Self::NS_PER_S_U64);
        Stamp(whole_ns.saturating_add(frac_ns))
    }

    /// Seconds since the epoch (whole seconds and fraction converted separately, so the
    /// result is within one ulp of the exact value).
    pub fn as_secs_f64(self) -> f64 {
        (self.0 / Self::NS_PER_S_U64) as f64 + (self.0 % Self::NS_PER_S_U64) as f64 / Self::NS_PER_S
    }

    /// `self - earlier` in seconds (negative when `earlier` is later).
    pub fn secs_since(self, earlier: Stamp) -> f64 {
        if self.0 >= earlier.0 {
            (self.0 - earlier.0) as f64 / Self::NS_PER_S
        } else {
            -((earlier.0 - self.0) as f64 / Self::NS_PER_S)
        }
    }

    /// This stamp moved by `dt_s` seconds (saturating at the epoch).
    pub fn offset_secs(self, dt_s: f64) -> Stamp {
        let dt_ns = (dt_s * Self::NS_PER_S).round();
        if dt_ns >= 0.0 {
            Stamp(self.0.saturating_add(dt_ns as u64))
        } else {
            Stamp(self.0.saturating_sub((-dt_ns) as u64))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_round_trip_and_differences() {
        let a = Stamp::from_secs_f64(1_700_000_000.25);
        assert_eq!(a.0, 1_700_000_000_250_000_000);
        let b = a.offset_secs(-0.75);
        assert!((a.secs_since(b) - 0.75).abs() < 1e-9);
        assert!((b.secs_since(a) + 0.75).abs() < 1e-9);
        assert_eq!(Stamp::from_secs_f64(f64::NAN), Stamp(0));
        assert_eq!(Stamp(5).offset_secs(-1.0), Stamp(0));
    }

    #[test]
    fn present_day_seconds_keep_nanosecond_precision() {
        let s = Stamp(1_700_000_000_123_456_789);
        let back = Stamp::from_secs_f64(s.as_secs_f64());
        // An f64 near 1.7e9 s resolves ~240 ns; the conversion must not add more error.
        assert!(back.0.abs_diff(s.0) <= 240, "{back:?} vs {s:?}");
        assert_eq!(Stamp::from_secs_f64(-1.0), Stamp(0));
        assert_eq!(Stamp::from_secs_f64(1e30), Stamp(u64::MAX));
        assert_eq!(Stamp::from_secs_f64(0.5), Stamp(500_000_000));
    }
}
