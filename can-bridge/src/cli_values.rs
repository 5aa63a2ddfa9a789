//! Value parsers for numeric command-line options: every number is checked for range and
//! finiteness when the command line is parsed, so `--stale-ms 18446744073709552` or `--urgent nan`
//! are refused with the option's name instead of wrapping or poisoning comparisons.

/// Longest duration option in milliseconds (one hour): longer staleness or hold times make no
/// sense for a collision warning, and `ms * 1000` stays far from `u64` overflow.
pub const MAX_MS: u64 = 3_600_000;
/// Longest duration option in seconds (about 31 years): above it `Duration` conversion and
/// microsecond arithmetic lose meaning.
pub const MAX_SECONDS: f64 = 1e9;

/// `-` given as a path: standard input for `--log`, standard output for an output flag. It
/// picks the stream a command writes through; whether an output *is* standard output under any
/// name (`/dev/stdout`, the file it is redirected to), for the refusals, is
/// `riskscore_output::is_stdout`.
pub fn is_std_stream(path: &std::path::Path) -> bool {
    riskscore_output::is_dash(path)
}

fn number<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    s.trim()
        .parse::<T>()
        .map_err(|_| format!("`{s}` is not a number"))
}

/// A finite `f32` (thresholds: any sign, scores of some models are negative).
pub fn finite_f32(s: &str) -> Result<f32, String> {
    let v: f32 = number(s)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("`{s}` is not finite"))
    }
}

/// A finite `f32 >= 0`.
pub fn non_negative_f32(s: &str) -> Result<f32, String> {
    let v = finite_f32(s)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("`{s}` is negative"))
    }
}

/// Milliseconds in `1..=MAX_MS`.
pub fn positive_ms(s: &str) -> Result<u64, String> {
    let v: u64 = number(s)?;
    if (1..=MAX_MS).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} ms is outside 1..={MAX_MS} ms"))
    }
}

/// Milliseconds in `0..=MAX_MS`.
pub fn ms(s: &str) -> Result<u64, String> {
    let v: u64 = number(s)?;
    if v <= MAX_MS {
        Ok(v)
    } else {
        Err(format!("{v} ms is above {MAX_MS} ms"))
    }
}

/// An interface name: what a candump -L line can carry and read back (can_codec::check_iface_name).
pub fn iface(s: &str) -> Result<String, String> {
    can_codec::check_iface_name(s).map(|()| s.to_string())
}

/// The `BUS` and `FILE` of a `--dbc BUS=FILE` argument: the part before the first `=` is a bus
/// when it is made of interface-name characters (letters, digits, `_`, `-`, `.`), so a path such
/// as `/data/run=3/radar.dbc` stays a path (and `./a=b.dbc` is how to name a file `a=b.dbc`).
pub fn dbc_bus(arg: &str) -> Option<(&str, &str)> {
    let (bus, file) = arg.split_once('=')?;
    let bus_like = !bus.is_empty()
        && bus
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
    (bus_like && !file.is_empty()).then_some((bus, file))
}

/// A `--dbc` value, `FILE` or `BUS=FILE`: a BUS that no interface can have (longer than
/// IFNAMSIZ - 1 bytes) is refused, not read as part of a file name.
pub fn dbc(s: &str) -> Result<std::path::PathBuf, String> {
    if let Some((bus, _)) = dbc_bus(s) {
        can_codec::check_iface_name(bus).map_err(|e| {
            format!("the bus of BUS=FILE is an interface name, and {e}; a file whose name has `=` in it: write ./{s}")
        })?;
    }
    Ok(std::path::PathBuf::from(s))
}

/// Milliseconds in `0..=1000` (how long `live` lets a frame wait for the other interfaces).
pub fn merge_wait_ms(s: &str) -> Result<u64, String> {
    let v: u64 = number(s)?;
    if v <= 1000 {
        Ok(v)
    } else {
        Err(format!("{v} ms is above 1000 ms"))
    }
}

/// Seconds, finite, in `(0, MAX_SECONDS]`.
pub fn positive_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = number(s)?;
    if v.is_finite() && v > 0.0 && v <= MAX_SECONDS {
        Ok(v)
    } else {
        Err(format!("`{s}` is not a duration in (0, {MAX_SECONDS}] s"))
    }
}

/// Seconds, finite, in `[0, MAX_SECONDS]`.
pub fn seconds(s: &str) -> Result<f64, String> {
    let v: f64 = number(s)?;
    if v.is_finite() && (0.0..=MAX_SECONDS).contains(&v) {
        Ok(v)
    } else {
        Err(format!("`{s}` is not a duration in [0, {MAX_SECONDS}] s"))
    }
}

/// A distance in metres, finite, in `[0, 1000]` (a position tolerance).
pub fn tolerance_m(s: &str) -> Result<f64, String> {
    let v: f64 = number(s)?;
    if (0.0..=1000.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("`{s}` is not a distance in [0, 1000] m"))
    }
}

/// A fraction in `[0, 1]`.
pub fn fraction(s: &str) -> Result<f64, String> {
    let v: f64 = number(s)?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("`{s}` is not a fraction in [0, 1]"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_overflow_nan_and_out_of_range() {
        assert!(positive_ms("18446744073709552").is_err());
        assert!(positive_ms("0").is_err());
        assert_eq!(positive_ms("500"), Ok(500));
        assert!(finite_f32("nan").is_err());
        assert!(finite_f32("inf").is_err());
        assert_eq!(finite_f32("-1.5"), Ok(-1.5));
        assert!(non_negative_f32("-0.1").is_err());
        assert!(positive_seconds("0").is_err());
        assert!(positive_seconds("1e300").is_err());
        assert!(seconds("-1").is_err());
        assert!(fraction("1.5").is_err());
        assert!(fraction("NaN").is_err());
    }

    #[test]
    fn a_dbc_bus_longer_than_an_interface_name_is_refused() {
        let e = dbc("averyveryverylongbus=radar.dbc").unwrap_err();
        assert!(
            e.contains("is 20 bytes long; at most 15 (IFNAMSIZ - 1)"),
            "{e}"
        );
        assert!(e.contains("./averyveryverylongbus=radar.dbc"), "{e}");
        let fifteen = "abcdefghijklmno=radar.dbc";
        assert_eq!(dbc(fifteen), Ok(fifteen.into()));
        assert_eq!(dbc_bus(fifteen), Some(("abcdefghijklmno", "radar.dbc")));
        // Paths with `=` that are no binding stay paths.
        assert_eq!(dbc_bus("/data/run=3/radar.dbc"), None);
        assert!(dbc("./averyveryverylongbus=radar.dbc").is_ok());
    }
}
