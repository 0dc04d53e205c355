//! Match-log file names: `{prefix}-{UTC date-time}-{index:03}.mcap`, with the date-time
//! written as `20261123T235959Z` (the calendar from `jiff`).

use proto::Stamp;

#[cfg(test)]
const NS_PER_S: u64 = 1_000_000_000;

/// The file name of log file number `index` whose first log time is `first_log_time`.
pub(crate) fn log_file_name(prefix: &str, first_log_time: Stamp, index: u32) -> String {
    format!("{prefix}-{}-{index:03}.mcap", utc_compact(first_log_time))
}

/// `stamp` as a UTC date-time in the compact ISO 8601 form `YYYYMMDDTHHMMSSZ` (whole
/// seconds, the fraction dropped).
pub(crate) fn utc_compact(stamp: Stamp) -> String {
    // Every u64 of nanoseconds (up to 2554) is within jiff's range (years -9999..=9999).
    jiff::Timestamp::from_nanosecond(i128::from(stamp.0))
        .map(|t| t.strftime("%Y%m%dT%H%M%SZ").to_string())
        .unwrap_or_else(|_| format!("{}", stamp.0 / 1_000_000_000))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(secs: u64) -> Stamp {
        Stamp(secs * NS_PER_S)
    }

    #[test]
    fn formats_known_instants() {
        assert_eq!(utc_compact(at(0)), "19700101T000000Z");
        assert_eq!(utc_compact(at(1_700_000_000)), "20231114T221320Z");
        assert_eq!(utc_compact(at(1_795_478_399)), "20261123T235959Z");
        assert_eq!(utc_compact(at(951_782_400)), "20000229T000000Z");
        assert_eq!(utc_compact(at(1_709_211_661)), "20240229T130101Z");
        assert_eq!(utc_compact(at(4_102_444_800)), "21000101T000000Z");
    }

    #[test]
    fn drops_the_fraction_of_a_second() {
        assert_eq!(
            utc_compact(Stamp(1_795_478_399 * NS_PER_S + 999_999_999)),
            "20261123T235959Z"
        );
    }

    #[test]
    fn the_last_stamp_does_not_overflow() {
        assert_eq!(utc_compact(Stamp(u64::MAX)), "25540721T233433Z");
    }

    #[test]
    fn names_carry_prefix_time_and_index() {
        assert_eq!(
            log_file_name("match", at(1_795_478_399), 7),
            "match-20261123T235959Z-007.mcap"
        );
        assert_eq!(
            log_file_name("m", at(0), 1234),
            "m-19700101T000000Z-1234.mcap"
        );
    }
}
