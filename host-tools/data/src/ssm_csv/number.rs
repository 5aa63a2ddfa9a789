//! Reading and writing numbers fast without changing a byte: an f32 written exactly as Rust's
//! `Display` does (shortest round-trip digits, never an exponent; `zmij` finds the digits, this
//! module lays them out and breaks exact ties upwards like `Display`), and plain decimals parsed
//! to exactly the f64 `str::parse` gives (the exact fast path for up to 15 digits; anything else
//! goes to `str::parse`).
//!
//! `riskctl ssm` output must stay byte-identical to what `format!("{v}")` produced; the tests
//! compare the two on every special value and a few million random bit patterns.

/// Append `v` to `out`: `inf`, `-inf`, `nan`, or the shortest decimal that reads back to the same
/// f32, in plain positional notation (`1e-7` is written `0.0000001`, `1e20` in full, `1.0` as `1`).
pub fn push_f32(out: &mut Vec<u8>, v: f32) {
    if v.is_nan() {
        out.extend_from_slice(b"nan");
        return;
    }
    if v.is_infinite() {
        out.extend_from_slice(if v > 0.0 { b"inf" } else { b"-inf" });
        return;
    }
    if v.is_sign_negative() {
        out.push(b'-');
    }
    if v == 0.0 {
        out.push(b'0');
        return;
    }
    let mut buffer = zmij::Buffer::new();
    let text = buffer.format_finite(v.abs()).as_bytes();
    // Positional output ending in an odd digit is already what Display writes (no tie to break,
    // no trailing `.0`, no exponent): the common case. zmij writes an f32 positionally when its
    // decimal exponent is in -6..=12 (`FIXED_DEC_EXP`), which every value in POSITIONAL has:
    // no need to look. Outside it, digits never contain an `e`, and an f32 exponent (`e`, sign,
    // at most two digits) is within the last five bytes: looking there is exact.
    if POSITIONAL.contains(&v.abs()) || !text[text.len().saturating_sub(5)..].contains(&b'e') {
        match text.last() {
            Some(b'1' | b'3' | b'5' | b'7' | b'9') => {
                out.extend_from_slice(text);
                return;
            }
            // An even last digit is Display's too unless the value is an exact tie, which needs
            // the powers of two to line up: almost never, and cheap to rule out.
            Some(b'2' | b'4' | b'6' | b'8') if !twos_allow_tie_in(v.abs(), text) => {
                out.extend_from_slice(text);
                return;
            }
            _ => {}
        }
    }
    // zmij writes positional (`d.ddd`, `0.000ddd`, `ddd`) or scientific (`d.ddde[+-]xx`)
    // notation: collect the significant digits and where the decimal point falls.
    let (mantissa, exponent) = match text.iter().position(|&b| b == b'e') {
        Some(k) => (&text[..k], parse_exponent(&text[k + 1..])),
        None => (text, 0),
    };
    let mut digits = [0u8; 24];
    let mut count = 0usize;
    let mut point: i32 = -1;
    for &b in mantissa {
        if b == b'.' {
            point = count as i32;
        } else if count < digits.len() {
            digits[count] = b;
            count += 1;
        }
    }
    if point < 0 {
        point = count as i32;
    }
    // Drop leading zeros (`0.000123`) and trailing zeros (`120.0`), keeping the value.
    let lead = digits[..count].iter().take_while(|&&d| d == b'0').count();
    let digits_used = &digits[lead..count];
    let trail = digits_used.iter().rev().take_while(|&&d| d == b'0').count();
    let sig = &digits_used[..digits_used.len() - trail];
    // The value is 0.<sig> x 10^decimal_point.
    let decimal_point = point - lead as i32 + exponent;
    let mut n = sig.len() as i32;
    let mut rounded = [0u8; 24];
    rounded[..sig.len()].copy_from_slice(sig);
    // The digit generator breaks an exact tie between two shortest candidates towards the even
    // digit; Rust's Display rounds it up. Only an even last digit can differ.
    let last = sig[sig.len() - 1] - b'0';
    if last.is_multiple_of(2) && is_exact_tie(v.abs(), sig, decimal_point - n) {
        rounded[sig.len() - 1] += 1;
    }
    let mut sig = &rounded[..sig.len()];
    // An odd digit 1..9 plus one never carries; it can become a trailing zero only from 9, which
    // is odd, so `sig` keeps no trailing zero.
    while sig.len() > 1 && sig[sig.len() - 1] == b'0' {
        sig = &sig[..sig.len() - 1];
        n -= 1;
    }
    if decimal_point <= 0 {
        out.extend_from_slice(b"0.");
        out.extend(std::iter::repeat_n(b'0', (-decimal_point) as usize));
        out.extend_from_slice(sig);
    } else if decimal_point >= n {
        out.extend_from_slice(sig);
        out.extend(std::iter::repeat_n(b'0', (decimal_point - n) as usize));
    } else {
        let (int, frac) = sig.split_at(decimal_point as usize);
        out.extend_from_slice(int);
        out.push(b'.');
        out.extend_from_slice(frac);
    }
}

/// Magnitudes that zmij always writes without an exponent (well inside its -6..=12 decimal
/// exponents, so that no rounding at either end can leave the range).
const POSITIONAL: std::ops::Range<f32> = 1e-5..1e11;

/// Texts of recently written f32 values, so that a value seen again is copied instead of
/// formatted again: a direct-mapped table keyed by the value's bits (an entry holds exactly
/// what [`push_f32`] wrote for those bits, so the output does not change). Pair data repeats
/// many values (vehicle sizes, the ego's features for each of its partners, whole-number
/// speeds): on the NGSIM US-101 pairs about half of the finite computed values are hits.
pub struct F32Texts {
    entries: Vec<F32Text>,
}

#[derive(Clone, Copy, Default)]
struct F32Text {
    bits: u32,
    /// 0: empty (no value's text is empty).
    len: u8,
    text: [u8; F32Texts::LONGEST],
}

impl Default for F32Texts {
    fn default() -> Self {
        Self {
            entries: vec![F32Text::default(); 1 << F32Texts::SLOT_BITS],
        }
    }
}

impl F32Texts {
    const SLOT_BITS: u32 = 12;
    /// Longer texts (huge or tiny values in positional notation) are not kept.
    const LONGEST: usize = 27;

    /// [`push_f32`], through the table.
    pub fn push(&mut self, out: &mut Vec<u8>, v: f32) {
        let bits = v.to_bits();
        let slot = (bits.wrapping_mul(0x9e37_79b1) >> (32 - Self::SLOT_BITS)) as usize;
        let entry = &mut self.entries[slot];
        let start = out.len();
        if entry.bits == bits && entry.len > 0 {
            // A fixed-size copy, cut back: no `memcpy` call for a few bytes.
            out.extend_from_slice(&entry.text);
            out.truncate(start + usize::from(entry.len));
            return;
        }
        push_f32(out, v);
        let text = &out[start..];
        if text.len() <= Self::LONGEST {
            entry.bits = bits;
            entry.len = text.len() as u8;
            entry.text[..text.len()].copy_from_slice(text);
        }
    }
}

/// Whether `v` (finite, > 0) lies exactly halfway between `digits x 10^k` and the next decimal
/// with as many digits, i.e. `2 v = (2 digits + 1) x 10^k`. Both sides are reduced to
/// `core x 2^a x 5^b` with `core` coprime to 10 and compared exactly.
fn is_exact_tie(v: f32, digits: &[u8], k: i32) -> bool {
    let (mut core_v, exp2_v) = odd_mantissa(v);
    // Midpoint = (2d + 1) x 2^(k-1) x 5^k, and 2d + 1 is odd: the powers of two must agree.
    if exp2_v != k - 1 {
        return false;
    }
    let mut fives_v = 0i32;
    while core_v % 5 == 0 {
        core_v /= 5;
        fives_v += 1;
    }
    let mut core_mid = digits
        .iter()
        .fold(0u64, |acc, &d| acc * 10 + u64::from(d - b'0'))
        * 2
        + 1;
    let mut fives_mid = k;
    while core_mid % 5 == 0 {
        core_mid /= 5;
        fives_mid += 1;
    }
    core_v == core_mid && fives_v == fives_mid
}

/// `v` (finite, > 0) as `odd x 2^exp`.
fn odd_mantissa(v: f32) -> (u64, i32) {
    let bits = v.to_bits();
    let (mantissa, exp2) = match (bits >> 23) & 0xff {
        0 => (bits & 0x7f_ffff, -149),
        e => ((bits & 0x7f_ffff) | 0x80_0000, e as i32 - 150),
    };
    let twos = mantissa.trailing_zeros();
    (u64::from(mantissa >> twos), exp2 + twos as i32)
}

/// False when `v` cannot be an exact tie between two decimals written like its positional
/// `text` (the first, 2-adic test of [`is_exact_tie`], with `k` = minus the number of
/// decimals): the tie needs `v`'s odd-mantissa exponent to be `k - 1`, so that exponent says
/// how many decimals there must be, and one byte says whether there are (instead of searching
/// the text for its point).
fn twos_allow_tie_in(v: f32, text: &[u8]) -> bool {
    let decimals = -odd_mantissa(v).1 - 1;
    if decimals < 0 {
        return false;
    }
    let d = decimals as usize;
    // The last point is `d` bytes before the end (no point, or a final one, when `d` is 0).
    match d {
        0 => text.last() == Some(&b'.') || !text.contains(&b'.'),
        _ => {
            d < text.len()
                && text[text.len() - 1 - d] == b'.'
                && !text[text.len() - d..].contains(&b'.')
        }
    }
}

/// Powers of ten that are exact in f64.
const EXACT_POWERS: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// `text` as f64 when it is a plain decimal (`[+-]digits[.digits]`, at least one digit, at most
/// 15 digits in all): then the digits are an exact integer below 2^53 and one division by an exact
/// power of ten is correctly rounded, so the result is bit-identical to `str::parse::<f64>`.
/// `None` for anything else (exponents, spaces, `inf`, long numbers): use `str::parse`.
pub fn parse_plain_decimal(text: &[u8]) -> Option<f64> {
    let (negative, body) = match text.first()? {
        b'-' => (true, &text[1..]),
        b'+' => (false, &text[1..]),
        _ => (false, text),
    };
    // Two tight digit loops (integer part, fraction) instead of one loop that asks of every
    // byte whether it is the point: this runs 18 times a row. Wrapping arithmetic: more than
    // 19 digits would overflow, and more than 15 are refused below anyway.
    let mut mantissa = 0u64;
    let mut rest = body;
    while let [d @ b'0'..=b'9', tail @ ..] = rest {
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
        rest = tail;
    }
    let integer_digits = body.len() - rest.len();
    let mut fraction_digits = 0;
    if let [b'.', tail @ ..] = rest {
        rest = tail;
        while let [d @ b'0'..=b'9', tail @ ..] = rest {
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
            rest = tail;
            fraction_digits += 1;
        }
    }
    let digits = integer_digits + fraction_digits;
    if !rest.is_empty() || digits == 0 || digits > 15 {
        return None;
    }
    // Below 2^53 either way; from i64 the conversion is one instruction, from u64 several.
    let value = mantissa as i64 as f64 / EXACT_POWERS[fraction_digits];
    Some(if negative { -value } else { value })
}

fn parse_exponent(text: &[u8]) -> i32 {
    let (negative, digits) = match text.first() {
        Some(b'-') => (true, &text[1..]),
        Some(b'+') => (false, &text[1..]),
        _ => (false, text),
    };
    let magnitude = digits
        .iter()
        .fold(0i32, |acc, &d| acc * 10 + i32::from(d - b'0'));
    if negative {
        -magnitude
    } else {
        magnitude
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(v: f32) {
        let mut out = Vec::new();
        push_f32(&mut out, v);
        let expected = if v.is_infinite() {
            if v > 0.0 { "inf" } else { "-inf" }.to_string()
        } else {
            format!("{v}")
        };
        assert_eq!(
            std::str::from_utf8(&out).unwrap(),
            expected,
            "bits {:#010x}",
            v.to_bits()
        );
    }

    #[test]
    fn the_text_table_writes_what_push_f32_writes() {
        let mut table = F32Texts::default();
        let (mut direct, mut cached) = (Vec::new(), Vec::new());
        // Few distinct values (so most are hits, and slots are reused by other values), plus
        // long texts that are never kept.
        let mut s: u32 = 0x2545_f491;
        for k in 0..200_000u32 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let v = match k % 5 {
                0 => f32::from_bits(s),
                1 => 3.4e38 / (1 + s % 7) as f32,
                _ => (s % 3000) as f32 / 16.0 - 90.0,
            };
            direct.clear();
            cached.clear();
            push_f32(&mut direct, v);
            table.push(&mut cached, v);
            assert_eq!(direct, cached, "bits {:#010x}", v.to_bits());
        }
    }

    #[test]
    fn special_values_match_display() {
        for v in [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            0.1,
            10.0,
            100.0,
            123456.0,
            1e7,
            1e-7,
            1.5e-7,
            1e20,
            3.4028235e38,
            -3.4028235e38,
            f32::MIN_POSITIVE,
            1e-45,
            f32::EPSILON,
            20159736.0,
            core::f32::consts::PI,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e6,
            999999.94,
            0.000123,
            16777216.0,
            0.5,
            2.5,
            0.125,
        ] {
            check(v);
        }
    }

    #[test]
    fn random_bit_patterns_match_display() {
        // xorshift: two million patterns over the whole f32 range, plus every power of ten.
        let mut s: u32 = 0x9e37_79b9;
        for _ in 0..2_000_000 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let v = f32::from_bits(s);
            if !v.is_nan() {
                check(v);
            }
        }
        // Exact ties between two shortest candidates: Display rounds up.
        for text in ["2209.90625", "-0.000244140625"] {
            check(text.parse().unwrap());
        }
        for e in -45..=38 {
            check(format!("1e{e}").parse().unwrap());
        }
    }

    #[test]
    fn plain_decimals_parse_like_str_parse() {
        for text in [
            "0",
            "-0",
            "+5",
            ".5",
            "5.",
            "87.4187",
            "-0.651970",
            "123456789012345",
            "0.00000000000001",
            "999999999999999",
            "-1.0000000000001",
            "3.14159265358979",
            "0.1",
            "0.2",
            "0.3",
            "1234.5678",
            "00012.500",
        ] {
            let fast = parse_plain_decimal(text.as_bytes()).unwrap();
            let std: f64 = text.parse().unwrap();
            assert_eq!(fast.to_bits(), std.to_bits(), "{text}");
        }
        for text in [
            "",
            "-",
            ".",
            "1e5",
            " 1",
            "1 ",
            "inf",
            "1.2.3",
            "1234567890123456",
            "0x1",
        ] {
            assert!(parse_plain_decimal(text.as_bytes()).is_none(), "{text}");
        }
        // Random decimals of up to 15 digits.
        let mut s: u64 = 0x2545_f491_4f6c_dd1d;
        for _ in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let digits = (s % 15 + 1) as usize;
            let mantissa = (s >> 8) % 10u64.pow(digits as u32);
            let point = ((s >> 40) as usize) % (digits + 1);
            let mut text = format!("{mantissa:0digits$}");
            text.insert(point, '.');
            if s & 1 == 1 {
                text.insert(0, '-');
            }
            let fast = parse_plain_decimal(text.as_bytes()).unwrap();
            let std: f64 = text.parse().unwrap();
            assert_eq!(fast.to_bits(), std.to_bits(), "{text}");
        }
    }

    #[test]
    fn the_tie_test_from_the_exponent_agrees_with_the_one_from_the_point() {
        let searched = |v: f32, text: &[u8]| {
            let decimals = text
                .iter()
                .rposition(|&b| b == b'.')
                .map_or(0, |p| text.len() - p - 1);
            odd_mantissa(v).1 == -(decimals as i32) - 1
        };
        let mut s: u32 = 0x1234_5679;
        let mut allowed = 0;
        for k in 0..2_000_000u32 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            // Random bits, and values with few mantissa bits (halves, quarters: tie candidates).
            let v = match k % 2 {
                0 => f32::from_bits(s & 0x7fff_ffff),
                _ => (s % 100_000) as f32 / (1u32 << (s >> 28)) as f32,
            };
            if !v.is_finite() || v == 0.0 {
                continue;
            }
            let mut buffer = zmij::Buffer::new();
            let text = buffer.format_finite(v).as_bytes();
            if text.contains(&b'e') {
                continue;
            }
            let fast = twos_allow_tie_in(v, text);
            assert_eq!(fast, searched(v, text), "{v}");
            allowed += usize::from(fast);
        }
        for text in [&b"5"[..], b"5.", b"2.5", b"0.125", b"1.2.5", b"25", b"."] {
            for v in [0.5f32, 2.5, 0.125, 0.0625, 5.0, 1.0e-3] {
                assert_eq!(
                    twos_allow_tie_in(v, text),
                    searched(v, text),
                    "{v} {text:?}"
                );
            }
        }
        assert!(allowed > 1000, "only {allowed} tie candidates were tried");
    }

    /// Every 7th f32 bit pattern (614 M values; about 2 minutes in release on one core):
    /// `cargo test --release -p riskscore-data --lib -- --ignored every_seventh`.
    #[test]
    #[ignore]
    fn every_seventh_f32_matches_display() {
        let mut out = Vec::new();
        let mut expected = String::new();
        for bits in (0..=u32::MAX).step_by(7) {
            let v = f32::from_bits(bits);
            if !v.is_finite() {
                continue;
            }
            out.clear();
            push_f32(&mut out, v);
            expected.clear();
            use std::fmt::Write as _;
            let _ = write!(expected, "{v}");
            assert_eq!(out, expected.as_bytes(), "bits {bits:#010x}");
        }
    }
}
