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

    /// A stamp from seconds since the epoch; negative or non-finite seconds give 0.
    pub fn from_secs_f64(secs: f64) -> Self {
        if secs.is_finite() && secs > 0.0 {
            Stamp((secs * Self::NS_PER_S).round() as u64)
        } else {
            Stamp(0)
        }
    }

    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 / Self::NS_PER_S
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
}
