//! `xs:dateTime` syntax check for `generationDateAndTime`.
//!
//! Hand-written: the workspace has no date crate, and checking one lexical form
//! (`[-]YYYY-MM-DDThh:mm:ss[.f+][Z|(+|-)hh:mm]`) with calendar ranges is a few lines.

/// Whether `text` is a valid `xs:dateTime` (XML Schema 1.0 lexical space).
pub(super) fn is_xs_date_time(text: &str) -> bool {
    let s = text.strip_prefix('-').unwrap_or(text);
    let Some((date, rest)) = s.split_once('T') else {
        return false;
    };
    let mut date_parts = date.split('-');
    let (Some(y), Some(mo), Some(d), None) = (
        date_parts.next(),
        date_parts.next(),
        date_parts.next(),
        date_parts.next(),
    ) else {
        return false;
    };
    // Years have at least four digits, no leading zero beyond four, and year 0000 is illegal.
    if y.len() < 4 || (y.len() > 4 && y.starts_with('0')) || !all_digits(y) {
        return false;
    }
    let Ok(year) = y.parse::<u64>() else {
        return false;
    };
    if year == 0 || !two_digits(mo) || !two_digits(d) {
        return false;
    }
    let (month, day) = (num(mo), num(d));
    if !(1..=12).contains(&month) || day < 1 || day > days_in_month(year, month) {
        return false;
    }
    let (time, zone) = split_zone(rest);
    if zone.is_some_and(|z| !valid_zone(z)) {
        return false;
    }
    let mut t = time.split(':');
    let (Some(h), Some(mi), Some(sec), None) = (t.next(), t.next(), t.next(), t.next()) else {
        return false;
    };
    let (whole, frac) = match sec.split_once('.') {
        Some((w, f)) => (w, Some(f)),
        None => (sec, None),
    };
    if !two_digits(h)
        || !two_digits(mi)
        || !two_digits(whole)
        || frac.is_some_and(|f| f.is_empty() || !all_digits(f))
    {
        return false;
    }
    let (hour, minute, second) = (num(h), num(mi), num(whole));
    let frac_zero = frac.is_none_or(|f| f.bytes().all(|b| b == b'0'));
    // 24:00:00 is the end of the day and allowed only exactly.
    if hour == 24 {
        return minute == 0 && second == 0 && frac_zero;
    }
    hour < 24 && minute < 60 && second < 60
}

fn split_zone(rest: &str) -> (&str, Option<&str>) {
    if let Some(time) = rest.strip_suffix('Z') {
        return (time, Some("Z"));
    }
    match rest.rfind(['+', '-']) {
        Some(i) => (&rest[..i], Some(&rest[i..])),
        None => (rest, None),
    }
}

fn valid_zone(zone: &str) -> bool {
    if zone == "Z" {
        return true;
    }
    let Some((h, m)) = zone[1..].split_once(':') else {
        return false;
    };
    two_digits(h) && two_digits(m) && (num(h) < 14 && num(m) < 60 || num(h) == 14 && num(m) == 0)
}

fn all_digits(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())
}

fn two_digits(s: &str) -> bool {
    s.len() == 2 && all_digits(s)
}

fn num(s: &str) -> u32 {
    s.bytes().fold(0, |acc, b| acc * 10 + u32::from(b - b'0'))
}

fn days_in_month(year: u64, month: u32) -> u32 {
    match month {
        2 if year % 4 == 0 && (year % 100 != 0 || year % 400 == 0) => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

#[cfg(test)]
mod tests {
    use super::is_xs_date_time;

    #[test]
    fn accepts_valid_forms() {
        for ok in [
            "2026-11-23T12:00:00Z",
            "2026-11-23T12:00:00",
            "2026-11-23T12:00:00.125+01:00",
            "2024-02-29T23:59:59-05:30",
            "2026-01-01T24:00:00Z",
            "2026-01-01T24:00:00.000Z",
            // Four-digit years may start with zeros, longer ones may not.
            "0026-01-01T00:00:00Z",
            "12026-01-01T00:00:00Z",
            "-0044-03-15T12:00:00Z",
            // The leap-year rule's century exception to the exception.
            "2000-02-29T00:00:00Z",
            "2026-12-31T23:59:59.999Z",
            "2026-11-23T12:00:00+14:00",
            "2026-11-23T12:00:00-13:59",
        ] {
            assert!(is_xs_date_time(ok), "{ok}");
        }
    }

    #[test]
    fn rejects_invalid_forms() {
        for bad in [
            "",
            "2026-11-23",
            "2026-11-23 12:00:00",
            "23.11.2026T12:00:00",
            "2026-13-01T00:00:00Z",
            "2025-02-29T00:00:00Z",
            "2026-11-23T25:00:00Z",
            "2026-11-23T12:60:00Z",
            "2026-11-23T24:00:01Z",
            "2026-11-23T12:00:00+1:00",
            "2026-11-23T12:00:00.Z",
            "0000-01-01T00:00:00Z",
            "yesterday",
            // Years: too short, a leading zero beyond four digits, a sign `parse` would take.
            "026-01-01T00:00:00Z",
            "02026-01-01T00:00:00Z",
            "+2026-01-01T00:00:00Z",
            // One digit where two belong, in each field.
            "2026-1-01T00:00:00Z",
            "2026-01-1T00:00:00Z",
            "2026-01-01T1:00:00Z",
            "2026-01-01T01:0:00Z",
            "2026-01-01T01:00:0Z",
            "2026-11-23T12:00:00.5x",
            "2026-11-23T12:00:60Z",
            "2026-11-23T24:00:00.5Z",
            // Month lengths, and 2100 is no leap year.
            "2026-04-31T00:00:00Z",
            "2026-11-31T00:00:00Z",
            "2100-02-29T00:00:00Z",
            // Zones reach +14:00 and no further; minutes stay below 60.
            "2026-11-23T12:00:00+14:30",
            "2026-11-23T12:00:00+15:00",
            "2026-11-23T12:00:00+05:60",
            "2026-11-23T12:00:00+0530",
        ] {
            assert!(!is_xs_date_time(bad), "{bad}");
        }
    }
}
