//! Line handling, number parsing and formatting, dates: shared by the three formats.

use crate::error::{parse_error, SpectrumError};

/// Lines with their 1-based numbers; a leading UTF-8 BOM and trailing `\r` removed.
pub(crate) fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// Fields of a delimited line; trailing empty fields (a trailing delimiter) dropped,
/// each field trimmed and stripped of surrounding double quotes.
pub(crate) fn fields(line: &str, delimiter: char) -> Vec<&str> {
    let mut out: Vec<&str> = line.split(delimiter).map(clean_field).collect();
    while out.last().is_some_and(|f| f.is_empty()) {
        out.pop();
    }
    out
}

pub(crate) fn clean_field(field: &str) -> &str {
    let f = field.trim();
    f.strip_prefix('"')
        .and_then(|g| g.strip_suffix('"'))
        .map(str::trim)
        .unwrap_or(f)
}

/// A finite number; with `decimal_comma` a lone `,` is read as the decimal point.
pub(crate) fn parse_number(
    field: &str,
    line: usize,
    what: &str,
    decimal_comma: bool,
) -> Result<f64, SpectrumError> {
    let f = field.trim();
    let parsed = if decimal_comma && f.contains(',') && !f.contains('.') {
        f.replacen(',', ".", 1).parse::<f64>()
    } else {
        f.parse::<f64>()
    };
    match parsed {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(parse_error(line, format!("a number ({what})"), field)),
    }
}

/// `x` in the `1.5303003E+3` style of the I-MON software: `decimals` digits after the
/// point, upper-case `E`, signed exponent without padding.
pub(crate) fn fmt_sci(x: f64, decimals: usize) -> String {
    let s = format!("{:.*e}", decimals, x);
    match s.split_once('e') {
        Some((mantissa, exp)) => {
            let (sign, digits) = match exp.strip_prefix('-') {
                Some(d) => ('-', d),
                None => ('+', exp),
            };
            format!("{mantissa}E{sign}{digits}")
        }
        None => s,
    }
}

/// Which of the two first date numbers is the month.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum DateOrder {
    DayFirst,
    MonthFirst,
}

/// Days since 1970-01-01 of a proleptic Gregorian date.
pub(crate) fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (month + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// (year, month, day) of a day count since 1970-01-01.
pub(crate) fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

/// The three numbers of `a/b/yyyy` (also `-` or `.` separated).
pub(crate) fn date_parts(date: &str) -> Option<(i64, i64, i64)> {
    let parts: Vec<&str> = date.trim().split(['/', '-', '.']).collect();
    if parts.len() != 3 {
        return None;
    }
    let a = parts[0].trim().parse::<i64>().ok()?;
    let b = parts[1].trim().parse::<i64>().ok()?;
    let y = parts[2].trim().parse::<i64>().ok()?;
    Some((a, b, y))
}

/// Seconds since midnight of `h:mm:ss[.fff] [am|pm]` (also with decimal comma).
pub(crate) fn time_of_day_s(time: &str) -> Option<f64> {
    let t = time.trim();
    let lower = t.to_ascii_lowercase();
    let (clock, meridiem) = if let Some(c) = lower.strip_suffix("pm") {
        (c.trim().to_string(), Some(true))
    } else if let Some(c) = lower.strip_suffix("am") {
        (c.trim().to_string(), Some(false))
    } else {
        (lower.clone(), None)
    };
    let parts: Vec<&str> = clock.split(':').collect();
    if parts.len() != 3 {
        return None;
    }
    let mut h = parts[0].parse::<u32>().ok()?;
    let m = parts[1].parse::<u32>().ok()?;
    let s = parts[2].replace(',', ".").parse::<f64>().ok()?;
    if m > 59 || !(0.0..61.0).contains(&s) {
        return None;
    }
    match meridiem {
        Some(pm) => {
            if !(1..=12).contains(&h) {
                return None;
            }
            h %= 12;
            if pm {
                h += 12;
            }
        }
        None if h > 23 => return None,
        None => {}
    }
    Some(f64::from(h * 3600 + m * 60) + s)
}

/// Seconds since 1970 of a date (`a/b/yyyy`, order given) and a time of day.
pub(crate) fn date_time_s(parts: (i64, i64, i64), time: &str, order: DateOrder) -> Option<f64> {
    let (a, b, year) = parts;
    let (day, month) = match order {
        DateOrder::DayFirst => (a, b),
        DateOrder::MonthFirst => (b, a),
    };
    if !(1..=12).contains(&month) || !(1..=31).contains(&day) || year < 1900 {
        return None;
    }
    let days = days_from_civil(year, month, day);
    Some(days as f64 * 86_400.0 + time_of_day_s(time)?)
}

/// `(date, time)` strings for whole seconds since 1970: `a/b/yyyy` (order given,
/// unpadded month and day as in `10/30/2020`) and `h:mm:ss AM` (12-hour clock; lower
/// case `am/pm` with `lower_meridiem`).
pub(crate) fn format_date_time(
    time_s: f64,
    order: DateOrder,
    lower_meridiem: bool,
) -> (String, String) {
    let total = time_s.floor() as i64;
    let days = total.div_euclid(86_400);
    let secs = total.rem_euclid(86_400);
    let (year, month, day) = civil_from_days(days);
    let date = match order {
        DateOrder::DayFirst => format!("{day:02}/{month:02}/{year}"),
        DateOrder::MonthFirst => format!("{month}/{day}/{year}"),
    };
    let (h, m, s) = (secs / 3600, (secs / 60) % 60, secs % 60);
    let h12 = if h % 12 == 0 { 12 } else { h % 12 };
    let meridiem = match (h >= 12, lower_meridiem) {
        (true, true) => "pm",
        (false, true) => "am",
        (true, false) => "PM",
        (false, false) => "AM",
    };
    (date, format!("{h12}:{m:02}:{s:02} {meridiem}"))
}

/// Checks that `wavelengths` (with the line each came from) change strictly
/// monotonically; returns true if they decrease.
pub(crate) fn check_monotonic(wavelengths: &[f64], lines: &[usize]) -> Result<bool, SpectrumError> {
    if wavelengths.len() < 2 {
        return Err(SpectrumError::Invalid(format!(
            "a spectrum needs at least 2 samples, found {}",
            wavelengths.len()
        )));
    }
    let decreasing = wavelengths[1] < wavelengths[0];
    for i in 1..wavelengths.len() {
        let ok = if decreasing {
            wavelengths[i] < wavelengths[i - 1]
        } else {
            wavelengths[i] > wavelengths[i - 1]
        };
        if !ok {
            return Err(SpectrumError::NotMonotonic {
                line: lines[i],
                previous_nm: wavelengths[i - 1],
                current_nm: wavelengths[i],
            });
        }
    }
    Ok(decreasing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_round_trip_and_known_day() {
        // 2020-10-30 is 18565 days after 1970-01-01 (50 years of 365 days + 13 leap days + 302 days).
        assert_eq!(days_from_civil(2020, 10, 30), 50 * 365 + 13 + 302);
        for d in [-1000, 0, 59, 60, 18_565, 20_000, 40_000] {
            let (y, m, dd) = civil_from_days(d);
            assert_eq!(days_from_civil(y, m, dd), d);
        }
    }

    #[test]
    fn twelve_hour_clock() {
        assert_eq!(time_of_day_s("12:00:00 AM"), Some(0.0));
        assert_eq!(time_of_day_s("12:00:01 pm"), Some(43_201.0));
        assert_eq!(
            time_of_day_s("4:44:10 PM"),
            Some(16.0 * 3600.0 + 44.0 * 60.0 + 10.0)
        );
        assert_eq!(time_of_day_s("13:00:00 PM"), None);
        let t = date_time_s((10, 30, 2020), "4:44:10 PM", DateOrder::MonthFirst).unwrap();
        let (d, h) = format_date_time(t, DateOrder::MonthFirst, false);
        assert_eq!((d.as_str(), h.as_str()), ("10/30/2020", "4:44:10 PM"));
    }

    #[test]
    fn scientific_format() {
        assert_eq!(fmt_sci(1530.3003, 7), "1.5303003E+3");
        assert_eq!(fmt_sci(0.0, 7), "0.0000000E+0");
        assert_eq!(fmt_sci(1349.0, 3), "1.349E+3");
        assert_eq!(fmt_sci(0.00125, 2), "1.25E-3");
    }
}
