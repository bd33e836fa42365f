//! Allocation-free parsing of numbers and timestamps from byte slices.
//!
//! Interrogator logs hold millions of fields; parsing each through a `String` would
//! dominate the run time. These parsers read straight from the file's bytes. Floats use
//! Clinger's fast path (an exact integer mantissa scaled by an exact power of ten is
//! correctly rounded) and fall back to the standard library for anything longer.
//! Timestamps are split into a date (kept unresolved until the whole file has been
//! seen, because `03/04/2025` is ambiguous) and a time of day in seconds.

/// Exact powers of ten representable in an f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Trim ASCII spaces, tabs and a carriage return from both ends.
pub fn trim(mut s: &[u8]) -> &[u8] {
    while let [first, rest @ ..] = s {
        if first.is_ascii_whitespace() {
            s = rest;
        } else {
            break;
        }
    }
    while let [rest @ .., last] = s {
        if last.is_ascii_whitespace() {
            s = rest;
        } else {
            break;
        }
    }
    s
}

/// Parse a decimal number. `decimal_comma` also accepts `,` as the decimal separator
/// (the recording PC's locale; safe in tab- or semicolon-separated files). Accepts an
/// exponent (`1.5303003E+3`) and `NaN`. Returns None for anything else, including an
/// empty field.
pub fn parse_f64(s: &[u8], decimal_comma: bool) -> Option<f64> {
    let s = trim(s);
    if s.is_empty() {
        return None;
    }
    match parse_f64_prefix(s, decimal_comma) {
        Some((v, n)) if n == s.len() => Some(v),
        Some(_) => None,
        None => special(s),
    }
}

/// Parse the number at the start of `s` (no leading spaces); returns the value and
/// the number of bytes it took, or None if `s` does not start with a number.
// Always inlined: it is the hot loop of every reader (one call per field); once
// logs/ was split into files it was no longer inlined, and parsing took 3–4 % more
// instructions.
#[inline(always)]
pub(crate) fn parse_f64_prefix(s: &[u8], decimal_comma: bool) -> Option<(f64, usize)> {
    let mut i = 0;
    let neg = match s.first() {
        Some(b'-') => {
            i = 1;
            true
        }
        Some(b'+') => {
            i = 1;
            false
        }
        _ => false,
    };
    let mut mantissa: u64 = 0;
    let mut digits = 0u32;
    let mut frac_digits = 0i32;
    let mut seen_point = false;
    let mut any_digit = false;
    let mut overflow = false;
    while i < s.len() {
        let c = s[i];
        if c.is_ascii_digit() {
            any_digit = true;
            if digits < 19 {
                mantissa = mantissa * 10 + (c - b'0') as u64;
                if mantissa != 0 {
                    digits += 1;
                }
                if seen_point {
                    frac_digits += 1;
                }
            } else {
                overflow = true;
            }
        } else if (c == b'.' || (decimal_comma && c == b',')) && !seen_point {
            seen_point = true;
        } else {
            break;
        }
        i += 1;
    }
    if !any_digit {
        return None;
    }
    let mut exp: i32 = 0;
    if i < s.len() && (s[i] == b'e' || s[i] == b'E') {
        let mut j = i + 1;
        let mut eneg = false;
        if j < s.len() && (s[j] == b'+' || s[j] == b'-') {
            eneg = s[j] == b'-';
            j += 1;
        }
        let start = j;
        while j < s.len() && s[j].is_ascii_digit() {
            exp = exp.saturating_mul(10).saturating_add((s[j] - b'0') as i32);
            j += 1;
        }
        if j == start {
            return None;
        }
        if eneg {
            exp = -exp;
        }
        i = j;
    }
    let e10 = exp - frac_digits;
    if !overflow && mantissa < (1u64 << 53) && (-22..=22).contains(&e10) {
        let m = mantissa as f64;
        let v = if e10 >= 0 {
            m * POW10[e10 as usize]
        } else {
            m / POW10[(-e10) as usize]
        };
        return Some((if neg { -v } else { v }, i));
    }
    slow_parse(&s[..i], decimal_comma).map(|v| (v, i))
}

fn special(s: &[u8]) -> Option<f64> {
    if s.eq_ignore_ascii_case(b"nan") || s.eq_ignore_ascii_case(b"-nan") {
        Some(f64::NAN)
    } else {
        None
    }
}

fn slow_parse(s: &[u8], decimal_comma: bool) -> Option<f64> {
    let text = std::str::from_utf8(s).ok()?;
    if decimal_comma {
        text.replace(',', ".").parse().ok()
    } else {
        text.parse().ok()
    }
}

/// A calendar date as written, before the day/month order is known.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RawDate {
    /// First number (day or month; the year for ISO dates).
    pub first: u32,
    /// Second number (month or day).
    pub second: u32,
    /// Third number (the year, or the day for ISO dates).
    pub third: u32,
    /// `yyyy-mm-dd`: order unambiguous.
    pub iso: bool,
}

/// Order of day and month in slash dates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum DateOrder {
    /// `17/04/2025`.
    DayMonthYear,
    /// `10/30/2020`.
    MonthDayYear,
}

fn read_uint(s: &[u8], i: &mut usize) -> Option<u32> {
    let start = *i;
    let mut v: u32 = 0;
    while *i < s.len() && s[*i].is_ascii_digit() && *i - start < 9 {
        v = v * 10 + (s[*i] - b'0') as u32;
        *i += 1;
    }
    if *i == start {
        None
    } else {
        Some(v)
    }
}

/// Parse a date `dd/mm/yyyy`, `mm/dd/yyyy`, `dd.mm.yyyy` or `yyyy-mm-dd`; returns the
/// date and the number of bytes read.
pub fn parse_date(s: &[u8]) -> Option<(RawDate, usize)> {
    let mut i = 0;
    let a = read_uint(s, &mut i)?;
    let a_len = i;
    let sep = *s.get(i)?;
    if !matches!(sep, b'/' | b'-' | b'.') {
        return None;
    }
    i += 1;
    let b = read_uint(s, &mut i)?;
    if s.get(i) != Some(&sep) {
        return None;
    }
    i += 1;
    let c = read_uint(s, &mut i)?;
    let iso = a_len == 4;
    let date = RawDate {
        first: a,
        second: b,
        third: c,
        iso,
    };
    Some((date, i))
}

/// Parse a time of day `H:MM[:SS[.fff]]` with an optional `am`/`pm` (any case, with or
/// without a space, `a.m.` too). The fraction may use `.` or `,`. Returns seconds since
/// midnight.
pub(crate) fn parse_time_of_day(s: &[u8]) -> Option<f64> {
    let s = trim(s);
    let mut i = 0;
    let h = read_uint(s, &mut i)?;
    if s.get(i) != Some(&b':') {
        return None;
    }
    i += 1;
    let m = read_uint(s, &mut i)?;
    let mut sec = 0.0;
    if s.get(i) == Some(&b':') {
        i += 1;
        let start = i;
        let whole = read_uint(s, &mut i)? as f64;
        let _ = start;
        sec = whole;
        if matches!(s.get(i), Some(b'.') | Some(b',')) {
            i += 1;
            let fs = i;
            let mut frac: u64 = 0;
            let mut scale = 1.0;
            while i < s.len() && s[i].is_ascii_digit() {
                if i - fs < 15 {
                    frac = frac * 10 + (s[i] - b'0') as u64;
                    scale *= 10.0;
                }
                i += 1;
            }
            sec += frac as f64 / scale;
        }
    }
    let rest = trim(&s[i..]);
    let mut hour = h;
    if !rest.is_empty() {
        let mut letters = [0u8; 2];
        let mut n = 0;
        for &c in rest {
            if c == b'.' {
                continue;
            }
            if n == 2 {
                return None;
            }
            letters[n] = c.to_ascii_lowercase();
            n += 1;
        }
        if n != 2 || letters[1] != b'm' || h == 0 || h > 12 {
            return None;
        }
        match letters[0] {
            b'a' => hour = h % 12,
            b'p' => hour = h % 12 + 12,
            _ => return None,
        }
    }
    if hour > 23 || m > 59 || sec >= 61.0 {
        return None;
    }
    Some(hour as f64 * 3600.0 + m as f64 * 60.0 + sec)
}

/// Parse `date time` in one field (date, then spaces or a `T`, then the time).
pub fn parse_datetime(s: &[u8]) -> Option<(RawDate, f64)> {
    let s = trim(s);
    let (date, n) = parse_date(s)?;
    let rest = s.get(n..)?;
    let rest = match rest.first() {
        Some(b'T') | Some(b' ') => &rest[1..],
        _ => return None,
    };
    Some((date, parse_time_of_day(rest)?))
}

/// Days since 1970-01-01 of a proleptic Gregorian date (Howard Hinnant's algorithm).
pub fn days_from_civil(year: i64, month: u32, day: u32) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = if y >= 0 { y } else { y - 399 } / 400;
    let yoe = y - era * 400;
    let m = month as i64;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + day as i64 - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146097 + doe - 719468
}

/// Inverse of [`days_from_civil`]: (year, month, day).
pub fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719468;
    let era = if z >= 0 { z } else { z - 146096 } / 146097;
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

/// Decide the day/month order from every distinct date in a file: a first number
/// above 12 means day-first, a second number above 12 means month-first; if neither
/// occurs, `default` (the format's convention) applies. Err if both occur.
pub(crate) fn resolve_order(dates: &[RawDate], default: DateOrder) -> Result<DateOrder, String> {
    let slash: Vec<&RawDate> = dates.iter().filter(|d| !d.iso).collect();
    let day_first = slash.iter().any(|d| d.first > 12);
    let month_first = slash.iter().any(|d| d.second > 12);
    match (day_first, month_first) {
        (true, true) => Err("the dates mix day-first and month-first order".into()),
        (true, false) => Ok(DateOrder::DayMonthYear),
        (false, true) => Ok(DateOrder::MonthDayYear),
        (false, false) => Ok(default),
    }
}

/// Days since 1970-01-01 of a raw date under an order; Err names what is wrong.
pub fn date_to_days(d: &RawDate, order: DateOrder) -> Result<i64, String> {
    let (y, m, day) = if d.iso {
        (d.first, d.second, d.third)
    } else {
        match order {
            DateOrder::DayMonthYear => (d.third, d.second, d.first),
            DateOrder::MonthDayYear => (d.third, d.first, d.second),
        }
    };
    // Two-digit years are read as 20yy.
    let y = if y < 100 { y + 2000 } else { y };
    if !(1..=12).contains(&m) || day == 0 || day > 31 || y > 9999 {
        return Err(format!("not a valid date (year {y}, month {m}, day {day})"));
    }
    Ok(days_from_civil(y as i64, m, day))
}

/// Format seconds since 1970 as `dd/mm/yyyy HH:MM:SS.ffffff` (24 h).
pub fn format_dmy_24h(t: f64) -> String {
    let (d, y, m, day, sod) = split_epoch(t);
    let _ = d;
    let h = (sod / 3600.0).floor();
    let mi = ((sod - h * 3600.0) / 60.0).floor();
    let s = sod - h * 3600.0 - mi * 60.0;
    format!(
        "{day:02}/{m:02}/{y:04} {:02}:{:02}:{:09.6}",
        h as u32,
        mi as u32,
        s.max(0.0)
    )
}

/// Split an epoch time into (days, year, month, day, seconds of day).
pub(crate) fn split_epoch(t: f64) -> (i64, i64, u32, u32, f64) {
    let days = (t / 86400.0).floor() as i64;
    let sod = t - days as f64 * 86400.0;
    let (y, m, d) = civil_from_days(days);
    (days, y, m, d, sod)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_match_std_and_accept_locale_forms() {
        for s in [
            "1546.295",
            "-0.0123",
            "1.5303003E+3",
            "12",
            "1e-5",
            "0.000000001",
            "+3.5",
        ] {
            assert_eq!(
                parse_f64(s.as_bytes(), false),
                Some(s.parse::<f64>().unwrap()),
                "{s}"
            );
        }
        assert_eq!(parse_f64(b"1546,295", true), Some(1546.295));
        assert_eq!(parse_f64(b"1546,295", false), None);
        assert_eq!(parse_f64(b"12.3.4", false), None);
        assert_eq!(parse_f64(b"abc", false), None);
        assert_eq!(parse_f64(b"", false), None);
        assert!(parse_f64(b"NaN", false).unwrap().is_nan());
        assert_eq!(parse_f64_prefix(b"1546.295\t2", false), Some((1546.295, 8)));
        // More than 19 digits goes through the slow path, still exact.
        let long = "1546.29512345678901234567";
        assert_eq!(
            parse_f64(long.as_bytes(), false),
            Some(long.parse().unwrap())
        );
    }

    #[test]
    fn times_of_day_in_both_clocks() {
        assert_eq!(
            parse_time_of_day(b"3:44:56 pm"),
            Some(15.0 * 3600.0 + 44.0 * 60.0 + 56.0)
        );
        assert_eq!(parse_time_of_day(b"12:00:01 AM"), Some(1.0));
        assert_eq!(
            parse_time_of_day(b"12:00:01 p.m."),
            Some(12.0 * 3600.0 + 1.0)
        );
        assert_eq!(
            parse_time_of_day(b"15:44:56.250"),
            Some(15.0 * 3600.0 + 44.0 * 60.0 + 56.25)
        );
        assert_eq!(
            parse_time_of_day(b"15:44:56,5"),
            Some(15.0 * 3600.0 + 44.0 * 60.0 + 56.5)
        );
        assert_eq!(parse_time_of_day(b"13:00:00 pm"), None);
        assert_eq!(parse_time_of_day(b"25:00:00"), None);
    }

    #[test]
    fn civil_days_round_trip_and_known_epochs() {
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        assert_eq!(days_from_civil(2000, 3, 1), 11017);
        for z in [-1000, 0, 11017, 20000, 20195] {
            let (y, m, d) = civil_from_days(z);
            assert_eq!(days_from_civil(y, m, d), z);
        }
    }

    #[test]
    fn date_order_is_resolved_from_the_whole_file() {
        let (d1, _) = parse_date(b"17/04/2025").unwrap();
        let (d2, _) = parse_date(b"10/30/2020").unwrap();
        let (d3, _) = parse_date(b"03/04/2025").unwrap();
        assert_eq!(
            resolve_order(&[d1, d3], DateOrder::MonthDayYear),
            Ok(DateOrder::DayMonthYear)
        );
        assert_eq!(
            resolve_order(&[d2, d3], DateOrder::DayMonthYear),
            Ok(DateOrder::MonthDayYear)
        );
        assert_eq!(
            resolve_order(&[d3], DateOrder::DayMonthYear),
            Ok(DateOrder::DayMonthYear)
        );
        assert!(resolve_order(&[d1, d2], DateOrder::DayMonthYear).is_err());
        assert_eq!(
            date_to_days(&d1, DateOrder::DayMonthYear),
            Ok(days_from_civil(2025, 4, 17))
        );
        let (iso, _) = parse_date(b"2025-04-17").unwrap();
        assert_eq!(
            date_to_days(&iso, DateOrder::MonthDayYear),
            Ok(days_from_civil(2025, 4, 17))
        );
        let (dt, sod) = parse_datetime(b"17/04/2025 3:44:56 pm").unwrap();
        assert_eq!(dt, d1);
        assert_eq!(sod, 56696.0);
    }

    #[test]
    fn formatting_round_trips() {
        let t = days_from_civil(2025, 4, 17) as f64 * 86400.0 + 56696.125;
        let s = format_dmy_24h(t);
        assert_eq!(s, "17/04/2025 15:44:56.125000");
        let (d, sod) = parse_datetime(s.as_bytes()).unwrap();
        assert_eq!(
            date_to_days(&d, DateOrder::DayMonthYear).unwrap() as f64 * 86400.0 + sod,
            t
        );
    }
}
