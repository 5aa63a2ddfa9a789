//! The `candump -L` log line format (can-utils), parsed and written.
//!
//! `(SECONDS.MICROS) IFACE FRAME [DIR]` where FRAME is one of
//! - `123#11223344`            classic data, 3 hex digits = standard id, 8 = extended id;
//!   bytes may be separated by `.`, an 8-byte frame may end in `_X` (raw DLC 9..F);
//! - `123#R`, `123#R4`         remote frame (optionally with its DLC);
//! - `123##1AABB`              CAN FD: one flags nibble (BRS=1, ESI=2) then the payload;
//! - `20000080#0000...`        error frame: 8 hex digits with the `CAN_ERR_FLAG` bit set.
//!
//! DIR is the optional direction field of `candump -x` (`R` received, `T` transmitted).
//! CAN XL (`###`) and anything else is a [`LineError`] that names what is wrong; callers report it
//! with the line number and carry on.
use crate::frame::{is_valid_fd_len, CanId, Frame, FrameKind, CAN_ERR_FLAG, CAN_ERR_MASK};
use core::fmt::Write as _;

/// Direction field of `candump -x` logs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Received,
    Transmitted,
}

/// One parsed log line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogRecord<'a> {
    /// Timestamp in microseconds since the epoch of the log.
    pub timestamp_us: u64,
    pub iface: &'a str,
    pub frame: Frame,
    pub direction: Option<Direction>,
}

/// Why a line is not a candump `-L` frame line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LineError {
    #[error("empty line")]
    Empty,
    #[error("expected `(SECONDS.MICROSECONDS)` timestamp, found `{0}`")]
    BadTimestamp(String),
    #[error("missing interface name")]
    MissingIface,
    #[error("missing frame (`ID#DATA`)")]
    MissingFrame,
    #[error("frame `{0}` has no `#` separator")]
    NoSeparator(String),
    #[error("bad CAN id `{0}` (3 hex digits standard, 8 hex digits extended)")]
    BadId(String),
    #[error("bad payload `{0}`: {1}")]
    BadData(String, &'static str),
    #[error("CAN XL frames (`###`) are not supported")]
    CanXl,
    #[error(
        "unexpected trailing field `{0}` (only the direction `R` or `T` may follow the frame)"
    )]
    Trailing(String),
}

impl LineError {
    /// A stable name of the kind of error (for per-kind counts).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Empty => "empty line",
            Self::BadTimestamp(_) => "bad timestamp",
            Self::MissingIface => "missing interface",
            Self::MissingFrame => "missing frame",
            Self::NoSeparator(_) => "no `#` separator",
            Self::BadId(_) => "bad CAN id",
            Self::BadData(..) => "bad payload",
            Self::CanXl => "CAN XL",
            Self::Trailing(_) => "trailing field",
        }
    }
}

/// Parses one line of a `candump -L` log.
pub fn parse_line(line: &str) -> Result<LogRecord<'_>, LineError> {
    let mut fields = line.split_ascii_whitespace();
    let ts = fields.next().ok_or(LineError::Empty)?;
    let timestamp_us = parse_timestamp(ts)?;
    let iface = fields.next().ok_or(LineError::MissingIface)?;
    let frame_text = fields.next().ok_or(LineError::MissingFrame)?;
    let frame = parse_frame(frame_text)?;
    let direction = match fields.next() {
        None => None,
        Some("R") => Some(Direction::Received),
        Some("T") => Some(Direction::Transmitted),
        Some(other) => return Err(LineError::Trailing(other.to_string())),
    };
    if let Some(extra) = fields.next() {
        return Err(LineError::Trailing(extra.to_string()));
    }
    Ok(LogRecord {
        timestamp_us,
        iface,
        frame,
        direction,
    })
}

fn parse_timestamp(text: &str) -> Result<u64, LineError> {
    let bad = || LineError::BadTimestamp(text.to_string());
    let inner = text
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or_else(bad)?;
    let (secs, frac) = inner.split_once('.').ok_or_else(bad)?;
    if secs.is_empty() || frac.is_empty() || frac.len() > 9 {
        return Err(bad());
    }
    if !secs.bytes().all(|b| b.is_ascii_digit()) || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad());
    }
    let secs: u64 = secs.parse().map_err(|_| bad())?;
    // candump writes 6 digits; accept fewer or more (nanosecond tools) and keep microseconds.
    let mut micros: u64 = 0;
    for i in 0..6 {
        let digit = frac.as_bytes().get(i).map_or(0, |b| u64::from(b - b'0'));
        micros = micros * 10 + digit;
    }
    secs.checked_mul(1_000_000)
        .and_then(|s| s.checked_add(micros))
        .ok_or_else(bad)
}

/// Parses the `ID#DATA` part of a line (also used by `cansend`-style arguments).
pub fn parse_frame(text: &str) -> Result<Frame, LineError> {
    let (id_text, rest) = text
        .split_once('#')
        .ok_or_else(|| LineError::NoSeparator(text.to_string()))?;
    if rest.starts_with("##") {
        return Err(LineError::CanXl);
    }
    if !id_text.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(LineError::BadId(id_text.to_string()));
    }
    let id_value =
        u32::from_str_radix(id_text, 16).map_err(|_| LineError::BadId(id_text.to_string()))?;
    let id = match id_text.len() {
        3 => {
            CanId::standard(id_value as u16).ok_or_else(|| LineError::BadId(id_text.to_string()))?
        }
        8 if id_value & CAN_ERR_FLAG != 0 => {
            if id_value & !(CAN_ERR_FLAG | CAN_ERR_MASK) != 0 {
                return Err(LineError::BadId(id_text.to_string()));
            }
            let data = parse_hex_bytes(rest, 8)?;
            return Frame::error_frame(id_value & CAN_ERR_MASK, &data)
                .ok_or_else(|| LineError::BadData(rest.to_string(), "error frame payload"));
        }
        8 => CanId::extended(id_value).ok_or_else(|| LineError::BadId(id_text.to_string()))?,
        _ => return Err(LineError::BadId(id_text.to_string())),
    };
    if let Some(fd) = rest.strip_prefix('#') {
        let mut chars = fd.chars();
        let flags = chars.next().and_then(|c| c.to_digit(16)).ok_or_else(|| {
            LineError::BadData(
                fd.to_string(),
                "CAN FD frame needs a flags nibble after `##`",
            )
        })?;
        let data = parse_hex_bytes(chars.as_str(), 64)?;
        if !is_valid_fd_len(data.len()) {
            return Err(LineError::BadData(
                fd.to_string(),
                "not a valid CAN FD length",
            ));
        }
        return Frame::fd_frame(id, flags as u8, &data)
            .ok_or_else(|| LineError::BadData(fd.to_string(), "invalid CAN FD frame"));
    }
    if let Some(remote) = rest.strip_prefix('R').or_else(|| rest.strip_prefix('r')) {
        let dlc = match remote {
            "" => 0,
            d if d.len() == 1 => d
                .chars()
                .next()
                .and_then(|c| c.to_digit(10))
                .filter(|d| *d <= 8)
                .ok_or_else(|| LineError::BadData(rest.to_string(), "remote DLC must be 0..8"))?
                as u8,
            // `R_X` (raw DLC) forms are rare; accept and clamp to 8.
            d if d.starts_with('_') => 8,
            _ => {
                return Err(LineError::BadData(
                    rest.to_string(),
                    "remote DLC must be 0..8",
                ))
            }
        };
        return Frame::remote_frame(id, dlc)
            .ok_or_else(|| LineError::BadData(rest.to_string(), "remote DLC must be 0..8"));
    }
    let (payload, len8_dlc) = match rest.split_once('_') {
        Some((p, d)) => {
            let dlc = u8::from_str_radix(d, 16)
                .ok()
                .filter(|d| (9..=15).contains(d))
                .ok_or_else(|| {
                    LineError::BadData(rest.to_string(), "raw DLC after `_` must be 9..F")
                })?;
            (p, Some(dlc))
        }
        None => (rest, None),
    };
    let data = parse_hex_bytes(payload, 8)?;
    if len8_dlc.is_some() && data.len() != 8 {
        return Err(LineError::BadData(
            rest.to_string(),
            "raw DLC `_X` only follows 8 data bytes",
        ));
    }
    let mut frame = Frame::data_frame(id, &data).ok_or_else(|| {
        LineError::BadData(rest.to_string(), "more than 8 bytes in a classic frame")
    })?;
    frame.kind = FrameKind::Data { len8_dlc };
    Ok(frame)
}

/// Up to 64 payload bytes parsed from hex, without allocating.
struct HexBytes {
    buf: [u8; crate::frame::MAX_DATA_LEN],
    len: usize,
}

impl core::ops::Deref for HexBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.buf[..self.len]
    }
}

fn nibble(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

fn parse_hex_bytes(text: &str, max: usize) -> Result<HexBytes, LineError> {
    let mut out = HexBytes {
        buf: [0; crate::frame::MAX_DATA_LEN],
        len: 0,
    };
    let mut digits = text.bytes().filter(|b| *b != b'.');
    while let Some(hi) = digits.next() {
        let lo = digits
            .next()
            .ok_or_else(|| LineError::BadData(text.to_string(), "odd number of hex digits"))?;
        if out.len >= max {
            return Err(LineError::BadData(text.to_string(), "too many bytes"));
        }
        match (nibble(hi), nibble(lo)) {
            (Some(h), Some(l)) => out.buf[out.len] = h * 16 + l,
            _ => return Err(LineError::BadData(text.to_string(), "not hexadecimal")),
        }
        out.len += 1;
    }
    Ok(out)
}

/// Longest interface name in bytes: Linux's `IFNAMSIZ` (16) less the terminating NUL.
pub const MAX_IFACE_BYTES: usize = 15;

/// Checks that `name` can be an interface name of a `candump -L` line that reads back: not empty,
/// at most [`MAX_IFACE_BYTES`] bytes, no whitespace, `#`, `(` or `)`. The error says why.
pub fn check_iface_name(name: &str) -> Result<(), String> {
    if name.is_empty() {
        return Err("an interface name cannot be empty".into());
    }
    if name.len() > MAX_IFACE_BYTES {
        return Err(format!(
            "interface name `{name}` is {} bytes long; at most {MAX_IFACE_BYTES} (IFNAMSIZ - 1)",
            name.len()
        ));
    }
    if let Some(c) = name
        .chars()
        .find(|c| c.is_whitespace() || matches!(c, '#' | '(' | ')'))
    {
        return Err(format!(
            "interface name `{name}` contains {}: a candump -L line with it cannot be read back",
            if c.is_whitespace() {
                "whitespace".to_string()
            } else {
                format!("`{c}`")
            }
        ));
    }
    Ok(())
}

/// Writes one `candump -L` line (no newline) into `out`.
pub fn format_line(out: &mut String, timestamp_us: u64, iface: &str, frame: &Frame) {
    let _ = write!(
        out,
        "({}.{:06}) {} ",
        timestamp_us / 1_000_000,
        timestamp_us % 1_000_000,
        iface
    );
    format_frame(out, frame);
}

/// Writes the `ID#DATA` part of a frame exactly as can-utils does.
pub fn format_frame(out: &mut String, frame: &Frame) {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    let push_data = |out: &mut String, data: &[u8]| {
        for b in data {
            out.push(HEX[usize::from(b >> 4)] as char);
            out.push(HEX[usize::from(b & 0xF)] as char);
        }
    };
    match frame.kind {
        FrameKind::Error { class } => {
            let _ = write!(out, "{:08X}#", class | CAN_ERR_FLAG);
            push_data(out, frame.data());
        }
        FrameKind::Data { len8_dlc } => {
            let _ = write!(out, "{}#", frame.id);
            push_data(out, frame.data());
            if let Some(dlc) = len8_dlc {
                let _ = write!(out, "_{dlc:X}");
            }
        }
        FrameKind::Remote { dlc } => {
            let _ = write!(out, "{}#R", frame.id);
            if dlc > 0 {
                let _ = write!(out, "{dlc}");
            }
        }
        FrameKind::Fd { flags } => {
            let _ = write!(out, "{}##{:X}", frame.id, flags);
            push_data(out, frame.data());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_standard_extended_remote_fd_error_and_direction() {
        let r = parse_line("(1436509052.249713) vcan0 123#DEADBEEF").unwrap();
        assert_eq!(r.timestamp_us, 1_436_509_052_249_713);
        assert_eq!(r.iface, "vcan0");
        assert_eq!(r.frame.id, CanId::Standard(0x123));
        assert_eq!(r.frame.data(), &[0xDE, 0xAD, 0xBE, 0xEF]);
        assert_eq!(r.direction, None);

        let r = parse_line("(0.000001) can1 18FEF100#0102030405060708 R").unwrap();
        assert_eq!(r.frame.id, CanId::Extended(0x18FE_F100));
        assert_eq!(r.direction, Some(Direction::Received));
        assert_eq!(r.frame.data().len(), 8);

        let r = parse_line("(10.5) can0 7FF#R T").unwrap();
        assert_eq!(r.timestamp_us, 10_500_000);
        assert_eq!(r.frame.kind, FrameKind::Remote { dlc: 0 });
        assert_eq!(r.direction, Some(Direction::Transmitted));
        assert_eq!(
            parse_line("(1.0) c 100#R5").unwrap().frame.kind,
            FrameKind::Remote { dlc: 5 }
        );

        let r = parse_line("(1.000000) can0 123##311223344556677889900AABB").unwrap();
        assert_eq!(r.frame.kind, FrameKind::Fd { flags: 3 });
        assert_eq!(r.frame.data().len(), 12);

        let r = parse_line("(1.000000) can0 20000040#0000000000000000").unwrap();
        assert!(r.frame.is_error());
        assert!(r.frame.is_bus_off());

        let r = parse_line("(1.0) c 123#11.22.33").unwrap();
        assert_eq!(r.frame.data(), &[0x11, 0x22, 0x33]);
        let r = parse_line("(1.0) c 123#1122334455667788_C").unwrap();
        assert_eq!(
            r.frame.kind,
            FrameKind::Data {
                len8_dlc: Some(0xC)
            }
        );
        let r = parse_line("(1.0) c 123#").unwrap();
        assert!(r.frame.data().is_empty());
    }

    #[test]
    fn rejects_bad_lines_with_a_reason() {
        assert_eq!(parse_line("   "), Err(LineError::Empty));
        for (line, reason) in [
            ("1.0 can0 123#00", "BadTimestamp"),
            ("(1.0) can0", "MissingFrame"),
            ("(1.0) can0 12#00", "BadId"),
            ("(1.0) can0 800#00", "BadId"),
            ("(1.0) can0 123#0", "BadData"),
            ("(1.0) can0 123#001122334455667788", "BadData"),
            ("(1.0) can0 123##0001122334455667788", "BadData"),
            ("(1.0) can0 123###00", "CanXl"),
            ("(1.0) can0 123#00 X", "Trailing"),
            ("(1.0) can0 123ZZ", "NoSeparator"),
            ("(1.0) can0 123#GG", "BadData"),
        ] {
            let err = parse_line(line).expect_err(line);
            assert!(
                format!("{err:?}").starts_with(reason),
                "{line:?}: {err:?}, not {reason}"
            );
        }
    }

    #[test]
    fn format_round_trips() {
        for line in [
            "(1436509052.249713) vcan0 123#DEADBEEF",
            "(0.000001) can1 18FEF100#0102030405060708",
            "(10.500000) can0 7FF#R",
            "(10.500000) can0 7FF#R3",
            "(1.000000) can0 123##311223344556677889900AABB",
            "(1.000000) can0 20000040#0000000000000000",
            "(1.000000) can0 123#1122334455667788_C",
            "(1.000000) can0 000#",
        ] {
            let r = parse_line(line).unwrap();
            let mut out = String::new();
            format_line(&mut out, r.timestamp_us, r.iface, &r.frame);
            assert_eq!(out, line);
        }
    }
}
