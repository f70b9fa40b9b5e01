//! The command line's text arguments: whole numbers, sample ranges,
//! image sizes and durations. Each takes the text as the user typed it.

use anyhow::{anyhow, Result};
use reference::scene::MAX_SPP;
use std::ops::Range;

/// A whole number as the command line takes one: ASCII digits only (no
/// sign, space or other form `str::parse` would take: `+4`, ` 4` and `-1`
/// are refused), at most `u32::MAX`. The error says what was expected; clap
/// names the argument and the value before it (`value_parser`, with
/// `allow_hyphen_values` so that `-1` reaches it instead of being taken
/// for an option).
pub fn parse_count(s: &str) -> std::result::Result<u32, String> {
    if s.is_empty() || !s.bytes().all(|c| c.is_ascii_digit()) {
        return Err("expected a whole number written in digits, as in 64".into());
    }
    s.parse()
        .map_err(|_| format!("expected a whole number at most {}", u32::MAX))
}

/// [`parse_count`] for a count that fits a `usize` (worker threads).
pub fn parse_usize_count(s: &str) -> std::result::Result<usize, String> {
    parse_count(s).map(|n| n as usize)
}

/// A frame count, digits only ([`parse_count`]'s rule), at most `u64::MAX`.
pub fn parse_u64_count(s: &str) -> std::result::Result<u64, String> {
    if s.is_empty() || !s.bytes().all(|c| c.is_ascii_digit()) {
        return Err("expected a whole number written in digits, as in 64".into());
    }
    s.parse()
        .map_err(|_| format!("{s} is more than the most this takes ({})", u64::MAX))
}

/// Parses `A..B` (sample indices `A` up to, not including, `B`), with
/// `A < B ≤` [`MAX_SPP`].
pub fn parse_samples(s: &str) -> Result<Range<u32>> {
    let bad = || anyhow!("--samples `{s}`: expected A..B, as in 0..256 (A < B ≤ {MAX_SPP})");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let number = |t: &str| -> Result<u32> { parse_count(t).map_err(|_| bad()) };
    let (a, b) = (number(a)?, number(b)?);
    if a >= b || b > MAX_SPP {
        return Err(bad());
    }
    Ok(a..b)
}

/// Parses `WIDTHxHEIGHT` (`x` or `X`, no spaces inside): `1200x800`.
/// Zero sizes parse; `RenderSettings::validate` rejects them.
pub fn parse_size(s: &str) -> Result<(u32, u32)> {
    let bad = || anyhow!("`{s}`: expected WIDTHxHEIGHT, as in 1200x800");
    let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let parse = |t: &str| {
        if t.bytes().all(|b| b.is_ascii_digit()) {
            t.parse::<u32>().ok()
        } else {
            None
        }
    };
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(bad()),
    }
}

/// `--time DURATION`: `90s`, `2m`, `1.5h`, `500ms` or plain seconds.
pub fn parse_duration(text: &str) -> Result<std::time::Duration> {
    parse_duration_for("--time", text)
}

/// A duration given to `flag` (`--time`, `--checkpoint`), as
/// [`parse_duration`] reads it; the error names `flag`.
pub fn parse_duration_for(flag: &str, text: &str) -> Result<std::time::Duration> {
    let t = text.trim();
    let (number, scale) = [("ms", 1e-3), ("s", 1.0), ("m", 60.0), ("h", 3600.0)]
        .iter()
        .find_map(|(unit, scale)| t.strip_suffix(unit).map(|n| (n, *scale)))
        .unwrap_or((t, 1.0));
    // A duration below a nanosecond (`1e-12s`) is zero as a `Duration`:
    // not positive, so refused with the rest.
    match number.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v * scale < 1e9 => {
            Some(std::time::Duration::from_secs_f64(v * scale)).filter(|d| !d.is_zero())
        }
        _ => None,
    }
    .ok_or_else(|| {
        anyhow!("{flag} `{text}`: expected a positive duration such as 90s, 2m, 1.5h or 500ms")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_ranges_are_digits_only() {
        assert_eq!(parse_count("64"), Ok(64));
        assert_eq!(parse_count("4294967295"), Ok(u32::MAX));
        for bad in ["", "+4", " 4", "4 ", "-1", "1e3", "0x10", "4294967296"] {
            assert!(parse_count(bad).is_err(), "`{bad}` accepted");
        }
        assert_eq!(parse_samples("0..4").unwrap(), 0..4);
        for bad in ["0 .. 4", "-1..4", "+1..4", "4..2", "0..", "..4", "0...4"] {
            let e = parse_samples(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--samples `{bad}`")), "{e}");
        }
    }

    #[test]
    fn durations_are_positive() {
        assert_eq!(parse_duration("1.5h").unwrap().as_secs(), 5400);
        assert_eq!(parse_duration("500ms").unwrap().as_millis(), 500);
        assert_eq!(parse_duration("1e-9").unwrap().as_nanos(), 1);
        // Found by the fuzz target cli_text: positive numbers below a
        // nanosecond were accepted as a zero duration.
        for bad in [
            "0",
            "-1s",
            "nan",
            "inf",
            "1e9",
            "x",
            ".00000000008000000",
            "1e-12s",
            "1e-300ms",
        ] {
            let e = parse_duration(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--time `{bad}`")), "{bad}: {e}");
        }
    }
}
