//! Time as the records keep it (Unix milliseconds), RFC 3339 for people and JSON, and
//! random identifiers.

use std::time::{SystemTime, UNIX_EPOCH};

/// Milliseconds since the Unix epoch.
pub fn now_ms() -> i64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_millis() as i64).unwrap_or(0)
}

const DAY_MS: i64 = 86_400_000;

/// `ms` as RFC 3339 UTC with milliseconds (`2026-11-22T05:00:00.000Z`).
pub fn rfc3339(ms: i64) -> String {
    let days = ms.div_euclid(DAY_MS);
    let in_day = ms.rem_euclid(DAY_MS);
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    let (h, m, s, milli) = (in_day / 3_600_000, in_day / 60_000 % 60, in_day / 1000 % 60, in_day % 1000);
    format!("{year:04}-{month:02}-{day:02}T{h:02}:{m:02}:{s:02}.{milli:03}Z")
}

/// `ms` as an HTTP date (RFC 9110 IMF-fixdate: `Sun, 22 Nov 2026 05:00:00 GMT`).
pub fn http_date(ms: i64) -> String {
    const DAYS: [&str; 7] = ["Thu", "Fri", "Sat", "Sun", "Mon", "Tue", "Wed"]; // 1970-01-01 was a Thursday
    const MONTHS: [&str; 12] = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"];
    let stamp = rfc3339(ms);
    let (year, month, day, time) = (&stamp[0..4], &stamp[5..7], &stamp[8..10], &stamp[11..19]);
    let weekday = DAYS[ms.div_euclid(DAY_MS).rem_euclid(7) as usize];
    let month = MONTHS[month.parse::<usize>().expect("two digits") - 1];
    format!("{weekday}, {day} {month} {year} {time} GMT")
}

const ALPHANUMERIC: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";

/// `n` random characters from [A-Za-z0-9], from the operating system's generator.
pub fn random_alphanumeric(n: usize) -> String {
    let mut out = String::with_capacity(n);
    let mut buf = [0u8; 64];
    while out.len() < n {
        getrandom::fill(&mut buf).expect("the operating system's random generator works");
        // 62 * 4 = 248: bytes above are dropped so every character is equally likely.
        for &b in buf.iter().filter(|&&b| b < 248) {
            if out.len() < n {
                out.push(ALPHANUMERIC[(b % 62) as usize] as char);
            }
        }
    }
    out
}

/// A new identifier with a readable prefix (`sub_…`, `team_…`, `job_…`).
pub fn new_id(prefix: &str) -> String {
    format!("{prefix}_{}", random_alphanumeric(16).to_ascii_lowercase())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_matches_known_instants() {
        assert_eq!(rfc3339(0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339(951_782_400_000), "2000-02-29T00:00:00.000Z");
        assert_eq!(rfc3339(1_795_323_723_456), "2026-11-22T05:02:03.456Z");
    }

    #[test]
    fn http_dates_are_imf_fixdate() {
        assert_eq!(http_date(0), "Thu, 01 Jan 1970 00:00:00 GMT");
        assert_eq!(http_date(951_782_400_000), "Tue, 29 Feb 2000 00:00:00 GMT");
        assert_eq!(http_date(1_795_323_723_456), "Sun, 22 Nov 2026 05:02:03 GMT");
    }

    #[test]
    fn random_identifiers_differ_and_use_the_alphabet() {
        let a = random_alphanumeric(32);
        assert_eq!(a.len(), 32);
        assert!(a.bytes().all(|b| b.is_ascii_alphanumeric()));
        assert_ne!(a, random_alphanumeric(32));
    }
}
