//! Match-log file names: `{prefix}-{UTC date-time}-{index:03}.mcap`, with the date-time
//! written as `20261123T235959Z` and computed from the stamp without a calendar crate.

use proto::Stamp;

const NS_PER_S: u64 = 1_000_000_000;
const S_PER_DAY: u64 = 86_400;

/// The file name of log file number `index` whose first log time is `first_log_time`.
pub(crate) fn log_file_name(prefix: &str, first_log_time: Stamp, index: u32) -> String {
    format!("{prefix}-{}-{index:03}.mcap", utc_compact(first_log_time))
}

/// `stamp` as a UTC date-time in the compact ISO 8601 form `YYYYMMDDTHHMMSSZ` (whole
/// seconds, the fraction dropped).
pub(crate) fn utc_compact(stamp: Stamp) -> String {
    let secs = stamp.0 / NS_PER_S;
    let days = secs / S_PER_DAY;
    let secs_of_day = secs % S_PER_DAY;
    let (year, month, day) = civil_from_days(days);
    format!(
        "{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z",
        secs_of_day / 3600,
        secs_of_day % 3600 / 60,
        secs_of_day % 60
    )
}

/// The proleptic Gregorian (year, month 1..=12, day 1..=31) of `days` days after
/// 1970-01-01 (H. Hinnant's `civil_from_days`, restricted to dates after the epoch).
fn civil_from_days(days: u64) -> (u64, u64, u64) {
    // Shift the epoch to 0000-03-01 so that leap days fall at the end of a year.
    const DAYS_0000_03_01_TO_1970_01_01: u64 = 719_468;
    const DAYS_PER_ERA: u64 = 146_097; // 400 Gregorian years
    let z = days + DAYS_0000_03_01_TO_1970_01_01;
    let era = z / DAYS_PER_ERA;
    let day_of_era = z % DAYS_PER_ERA;
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let month_from_march = (5 * day_of_year + 2) / 153; // 0 = March … 11 = February
    let day = day_of_year - (153 * month_from_march + 2) / 5 + 1;
    let month = if month_from_march < 10 {
        month_from_march + 3
    } else {
        month_from_march - 9
    };
    let year = year_of_era + era * 400 + u64::from(month <= 2);
    (year, month, day)
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
    fn every_day_follows_the_previous_one() {
        // Walk 1970..2500 day by day: the date must advance by exactly one calendar day.
        let mut prev = civil_from_days(0);
        assert_eq!(prev, (1970, 1, 1));
        for days in 1..(530 * 366) {
            let (y, m, d) = civil_from_days(days);
            let (py, pm, pd) = prev;
            let next_day = (y, m, d) == (py, pm, pd + 1);
            let next_month = y == py && m == pm + 1 && d == 1 && pd >= 28;
            let next_year = y == py + 1 && m == 1 && d == 1 && (pm, pd) == (12, 31);
            assert!(
                next_day || next_month || next_year,
                "{prev:?} -> {:?}",
                (y, m, d)
            );
            let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
            let month_len = [
                31,
                if leap { 29 } else { 28 },
                31,
                30,
                31,
                30,
                31,
                31,
                30,
                31,
                30,
                31,
            ];
            assert!(d <= month_len[(m - 1) as usize]);
            prev = (y, m, d);
        }
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
