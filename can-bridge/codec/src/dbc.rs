//! A DBC database compiled for decoding: messages by id and name, signals with their packing and
//! multiplexing. Parsing is done by the maintained `can-dbc` crate; this module turns its syntax
//! tree into [`MessageSpec`]/[`SignalSpec`] values and refuses what it cannot decode faithfully.
//!
//! Supported: standard and extended ids, Intel and Motorola signals, signed/unsigned integers,
//! IEEE float/double signals (`SIG_VALTYPE_`), simple multiplexing (one `M` switch per message).
//! Refused with a clear error: extended multiplexing (`SG_MUL_VAL_`), signals wider than 64 bits or
//! outside the message. Value tables and attributes are ignored (they do not change decoding).
use crate::frame::CanId;
use crate::signal::{ByteOrder, SignalError, SignalSpec, ValueKind};
use std::collections::HashMap;

/// A DBC file that could not be used: the file, the line (when known) and why.
#[derive(Debug, thiserror::Error)]
pub enum DbcFileError {
    // `cause`, not `source`: the OS error is part of this message and must not be printed again
    // as its cause.
    #[error("DBC {}: {cause}", path.display())]
    Read {
        path: std::path::PathBuf,
        cause: std::io::Error,
    },
    #[error("DBC {}{}: {error}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid {
        path: std::path::PathBuf,
        line: Option<usize>,
        error: DbcError,
    },
}

/// Why a DBC file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum DbcError {
    #[error("DBC syntax: {0}")]
    Syntax(String),
    #[error("message {message}: signal {signal}: {reason}")]
    BadSignal {
        message: String,
        signal: String,
        reason: String,
    },
    #[error("message {message}: {reason}")]
    BadMessage { message: String, reason: String },
    /// Two definitions of one signal name in one message: which one decodes would be a guess.
    #[error("message {message}: signal {signal}: defined twice in the message; remove or rename one definition")]
    DuplicateSignal { message: String, signal: String },
}

/// One message of the database.
#[derive(Clone, Debug, PartialEq)]
pub struct MessageSpec {
    pub id: CanId,
    pub name: String,
    /// Declared payload length (DLC in bytes).
    pub size: usize,
    pub signals: Vec<SignalSpec>,
    /// Index into `signals` of the multiplexor switch, if the message is multiplexed.
    pub multiplexor: Option<usize>,
}

impl MessageSpec {
    /// Index of a signal by name.
    pub fn signal_index(&self, name: &str) -> Option<usize> {
        self.signals.iter().position(|s| s.name == name)
    }

    /// The physical value of signal `index` in `data`. `Ok(None)` when the signal is multiplexed
    /// and the frame carries another multiplexor value.
    pub fn value(&self, index: usize, data: &[u8]) -> Result<Option<f64>, SignalError> {
        let Some(signal) = self.signals.get(index) else {
            return Ok(None);
        };
        if let Some(wanted) = signal.multiplexed_on {
            if !self.multiplexor_is(wanted, data)? {
                return Ok(None);
            }
        }
        signal.decode(data).map(Some)
    }

    fn multiplexor_is(&self, wanted: u64, data: &[u8]) -> Result<bool, SignalError> {
        match self.multiplexor.and_then(|m| self.signals.get(m)) {
            Some(switch) => Ok(switch.raw(data)? == wanted),
            None => Ok(false),
        }
    }

    /// Encodes the given `(signal name, physical value)` pairs into a zero-filled payload of the
    /// message's declared size. Unknown names are an error, so typos cannot silently send zeros.
    pub fn encode(&self, values: &[(&str, f64)]) -> Result<Vec<u8>, DbcError> {
        let mut data = vec![0u8; self.size];
        self.encode_into(values, &mut data)?;
        Ok(data)
    }

    /// Like [`MessageSpec::encode`] into a caller buffer of at least `size` bytes.
    pub fn encode_into(&self, values: &[(&str, f64)], data: &mut [u8]) -> Result<(), DbcError> {
        for (name, value) in values {
            let signal = self
                .signals
                .iter()
                .find(|s| s.name == *name)
                .ok_or_else(|| DbcError::BadSignal {
                    message: self.name.clone(),
                    signal: (*name).to_string(),
                    reason: "no such signal".into(),
                })?;
            signal
                .encode(*value, data)
                .map_err(|e| DbcError::BadSignal {
                    message: self.name.clone(),
                    signal: (*name).to_string(),
                    reason: e.to_string(),
                })?;
        }
        Ok(())
    }
}

/// A compiled DBC.
#[derive(Clone, Debug, Default)]
pub struct Database {
    pub messages: Vec<MessageSpec>,
    by_id: HashMap<CanId, usize>,
}

/// DBC bytes as text: a UTF-8 byte-order mark is dropped, and a file that is not UTF-8 is read as
/// Latin-1 (vendor DBC files are often Windows-1252/Latin-1, with accents in comments; the
/// syntax itself is ASCII, so nothing that matters for decoding changes).
pub fn dbc_text(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    match std::str::from_utf8(bytes) {
        Ok(text) => std::borrow::Cow::Borrowed(text),
        Err(_) => std::borrow::Cow::Owned(bytes.iter().map(|&b| char::from(b)).collect()),
    }
}

/// Where messages and signals are defined in the text (1-based lines), for error messages.
#[derive(Default)]
struct SourceLines {
    /// `BO_` lines: (line, id as written, name).
    messages: Vec<(usize, u64, String)>,
    /// `SG_` lines: (line, message name, signal name).
    signals: Vec<(usize, String, String)>,
}

impl SourceLines {
    fn scan(text: &str) -> Self {
        let mut out = Self::default();
        let mut current = String::new();
        for (n, line) in text.lines().enumerate() {
            let mut words = line.split_whitespace();
            match words.next() {
                Some("BO_") => {
                    let id = words.next().and_then(|w| w.parse::<u64>().ok());
                    let name = words.next().unwrap_or("").trim_end_matches(':').to_string();
                    current = name.clone();
                    if let Some(id) = id {
                        out.messages.push((n + 1, id, name));
                    }
                }
                Some("SG_") => {
                    let name = words.next().unwrap_or("").to_string();
                    out.signals.push((n + 1, current.clone(), name));
                }
                _ => {}
            }
        }
        out
    }

    fn line_of(&self, error: &DbcError) -> Option<usize> {
        match error {
            DbcError::BadSignal {
                message, signal, ..
            } => self
                .signals
                .iter()
                .find(|(_, m, s)| m == message && s == signal)
                .map(|x| x.0),
            // The second definition is the one to look at.
            DbcError::DuplicateSignal { message, signal } => self
                .signals
                .iter()
                .filter(|(_, m, s)| m == message && s == signal)
                .nth(1)
                .map(|x| x.0),
            DbcError::BadMessage { message, .. } => self
                .messages
                .iter()
                .find(|(_, _, m)| m == message)
                .map(|x| x.0),
            DbcError::Syntax(text) => text
                .split_once("--> ")
                .and_then(|(_, rest)| rest.split(':').next())
                .and_then(|l| l.trim().parse().ok()),
        }
    }
}

/// Payload sizes a CAN or CAN FD frame can have.
/// The pseudo-message CANdb++ exports hold unplaced signals in (id 0xC0000000, often with
/// signals): skipped whole, it is no frame.
const INDEPENDENT_SIGNALS_MESSAGE: &str = "VECTOR__INDEPENDENT_SIG_MSG";

fn is_frame_size(size: u64) -> bool {
    size <= 8 || matches!(size, 12 | 16 | 20 | 24 | 32 | 48 | 64)
}

impl Database {
    /// Reads and parses the DBC file at `path` (see [`dbc_text`] for encodings); errors name the
    /// file and line.
    pub fn load(path: &std::path::Path) -> Result<Self, DbcFileError> {
        let bytes = std::fs::read(path).map_err(|cause| DbcFileError::Read {
            path: path.to_path_buf(),
            cause,
        })?;
        let text = dbc_text(&bytes);
        Self::parse(&text).map_err(|error| DbcFileError::Invalid {
            path: path.to_path_buf(),
            line: SourceLines::scan(&text).line_of(&error),
            error,
        })
    }

    /// Parses DBC text. Refuses what no bus can carry (ids outside 11/29 bits, payload sizes that
    /// are no CAN/CAN FD length, signal ranges with min > max) rather than decode it wrongly.
    pub fn parse(text: &str) -> Result<Self, DbcError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let dbc = can_dbc::Dbc::try_from(text).map_err(|e| DbcError::Syntax(e.to_string()))?;
        // can-dbc masks an id's bits 29-30 away; check the ids as written.
        for (_, raw, name) in SourceLines::scan(text).messages {
            const EXTENDED: u64 = 1 << 31;
            let ok = if raw & EXTENDED != 0 {
                raw & !EXTENDED <= 0x1FFF_FFFF
            } else {
                raw <= 0x7FF
            };
            if !ok && name != INDEPENDENT_SIGNALS_MESSAGE {
                return Err(DbcError::BadMessage {
                    message: name,
                    reason: format!(
                        "id {raw} is neither a standard (11-bit) id nor 0x80000000 + an extended (29-bit) id"
                    ),
                });
            }
        }
        let mut messages = Vec::with_capacity(dbc.messages.len());
        for m in &dbc.messages {
            // CANdb++'s pseudo-message for signals not placed in any frame: no bus carries it.
            if m.name == INDEPENDENT_SIGNALS_MESSAGE {
                continue;
            }
            let id = match m.id {
                can_dbc::MessageId::Standard(id) => CanId::standard(id),
                can_dbc::MessageId::Extended(id) => CanId::extended(id),
            }
            .ok_or_else(|| DbcError::BadMessage {
                message: m.name.clone(),
                reason: format!("id {:?} out of range", m.id),
            })?;
            if dbc.extended_multiplex.iter().any(|x| x.message_id == m.id) {
                return Err(DbcError::BadMessage {
                    message: m.name.clone(),
                    reason: "extended multiplexing (SG_MUL_VAL_) is not supported".into(),
                });
            }
            let size = usize::try_from(m.size)
                .ok()
                .filter(|_| is_frame_size(m.size))
                .ok_or_else(|| DbcError::BadMessage {
                    message: m.name.clone(),
                    reason: format!(
                        "size {} bytes is no CAN (0-8) or CAN FD (12, 16, 20, 24, 32, 48, 64) payload length",
                        m.size
                    ),
                })?;
            let mut signals = Vec::with_capacity(m.signals.len());
            let mut multiplexor = None;
            for s in &m.signals {
                let bad = |reason: &str| DbcError::BadSignal {
                    message: m.name.clone(),
                    signal: s.name.clone(),
                    reason: reason.to_string(),
                };
                let kind = match dbc.extended_value_type_for_signal(m.id, &s.name) {
                    Some(can_dbc::SignalExtendedValueType::IEEEfloat32Bit) => ValueKind::Float32,
                    Some(can_dbc::SignalExtendedValueType::IEEEdouble64bit) => ValueKind::Float64,
                    _ => match s.value_type {
                        can_dbc::ValueType::Signed => ValueKind::Signed,
                        can_dbc::ValueType::Unsigned => ValueKind::Unsigned,
                    },
                };
                let order = match s.byte_order {
                    can_dbc::ByteOrder::LittleEndian => ByteOrder::Intel,
                    can_dbc::ByteOrder::BigEndian => ByteOrder::Motorola,
                };
                let start = u16::try_from(s.start_bit)
                    .ok()
                    .filter(|b| usize::from(*b) < size * 8)
                    .ok_or_else(|| bad("start bit outside the message"))?;
                let width = u8::try_from(s.size).map_err(|_| bad("wider than 64 bits"))?;
                let mut spec = SignalSpec::new(
                    &s.name,
                    start,
                    width,
                    order,
                    kind,
                    s.factor,
                    s.offset,
                    numeric(&s.min),
                    numeric(&s.max),
                )
                .ok_or_else(|| bad("invalid size, float width or factor"))?;
                if spec.min > spec.max {
                    return Err(bad(&format!(
                        "range [{}|{}] has min > max",
                        spec.min, spec.max
                    )));
                }
                if spec.bytes_needed() > size {
                    return Err(bad("extends past the end of the message"));
                }
                if signals
                    .iter()
                    .any(|earlier: &SignalSpec| earlier.name == s.name)
                {
                    return Err(DbcError::DuplicateSignal {
                        message: m.name.clone(),
                        signal: s.name.clone(),
                    });
                }
                spec.unit = s.unit.clone();
                match s.multiplexer_indicator {
                    can_dbc::MultiplexIndicator::Multiplexor => {
                        if multiplexor.is_some() {
                            return Err(bad("second multiplexor in one message"));
                        }
                        multiplexor = Some(signals.len());
                    }
                    can_dbc::MultiplexIndicator::MultiplexedSignal(v) => {
                        spec.multiplexed_on = Some(v)
                    }
                    can_dbc::MultiplexIndicator::MultiplexorAndMultiplexedSignal(_) => {
                        return Err(bad("nested multiplexing is not supported"))
                    }
                    can_dbc::MultiplexIndicator::Plain => {}
                }
                signals.push(spec);
            }
            if multiplexor.is_none() && signals.iter().any(|s| s.multiplexed_on.is_some()) {
                return Err(DbcError::BadMessage {
                    message: m.name.clone(),
                    reason: "multiplexed signals without a multiplexor (M)".into(),
                });
            }
            messages.push(MessageSpec {
                id,
                name: m.name.clone(),
                size,
                signals,
                multiplexor,
            });
        }
        let mut by_id = HashMap::with_capacity(messages.len());
        for (i, m) in messages.iter().enumerate() {
            if by_id.insert(m.id, i).is_some() {
                return Err(DbcError::BadMessage {
                    message: m.name.clone(),
                    reason: format!("duplicate id {}", m.id),
                });
            }
        }
        Ok(Self { messages, by_id })
    }

    /// Adds the messages of `other` (another DBC file of the same bus). `Err(id)`: both define
    /// `id`; nothing is added then.
    pub fn merge(&mut self, other: Database) -> Result<(), CanId> {
        if let Some(m) = other
            .messages
            .iter()
            .find(|m| self.by_id.contains_key(&m.id))
        {
            return Err(m.id);
        }
        for m in other.messages {
            self.by_id.insert(m.id, self.messages.len());
            self.messages.push(m);
        }
        Ok(())
    }

    pub fn message_by_id(&self, id: CanId) -> Option<&MessageSpec> {
        self.by_id.get(&id).and_then(|i| self.messages.get(*i))
    }

    pub fn message_by_name(&self, name: &str) -> Option<&MessageSpec> {
        self.messages.iter().find(|m| m.name == name)
    }
}

fn numeric(v: &can_dbc::NumericValue) -> f64 {
    match v {
        can_dbc::NumericValue::Uint(u) => *u as f64,
        can_dbc::NumericValue::Int(i) => *i as f64,
        can_dbc::NumericValue::Double(d) => *d,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RADAR: &str = r#"VERSION ""

NS_ :

BS_:

BU_: RADAR GW

BO_ 2147484160 RADAR_OBJ: 8 RADAR
 SG_ Page M : 7|2@0+ (1,0) [0|3] "" GW
 SG_ ObjId : 5|6@0+ (1,0) [0|63] "" GW
 SG_ DistLong m0 : 15|13@0+ (0.2,-500) [-500|1138.2] "m" GW
 SG_ DistLat m0 : 18|11@0+ (0.2,-204.6) [-204.6|204.8] "m" GW
 SG_ Length m1 : 15|8@0+ (0.2,0) [0|51] "m" GW
 SG_ Speed : 32|32@1- (1,0) [0|0] "m/s" GW

SIG_VALTYPE_ 2147484160 Speed : 1;
"#;

    #[test]
    fn parses_extended_ids_multiplexing_motorola_and_floats() {
        let db = Database::parse(RADAR).unwrap();
        let m = db.message_by_name("RADAR_OBJ").unwrap();
        assert_eq!(m.id, CanId::Extended(0x200));
        assert!(db.message_by_id(CanId::Extended(0x200)).is_some());
        assert!(db.message_by_id(CanId::Standard(0x200)).is_none());
        let long = m.signal_index("DistLong").unwrap();
        let len = m.signal_index("Length").unwrap();
        let speed = m.signal_index("Speed").unwrap();
        assert_eq!(m.signals[speed].kind, ValueKind::Float32);

        let page0 = m
            .encode(&[
                ("Page", 0.0),
                ("ObjId", 17.0),
                ("DistLong", 12.4),
                ("DistLat", -3.0),
                ("Speed", 2.5),
            ])
            .unwrap();
        assert!((m.value(long, &page0).unwrap().unwrap() - 12.4).abs() < 1e-9);
        assert_eq!(m.value(len, &page0).unwrap(), None);
        assert_eq!(m.value(speed, &page0).unwrap(), Some(2.5));
        assert_eq!(
            m.value(m.signal_index("ObjId").unwrap(), &page0).unwrap(),
            Some(17.0)
        );

        let page1 = m
            .encode(&[("Page", 1.0), ("ObjId", 17.0), ("Length", 4.6)])
            .unwrap();
        assert_eq!(m.value(long, &page1).unwrap(), None);
        assert!((m.value(len, &page1).unwrap().unwrap() - 4.6).abs() < 1e-9);
        assert!(m.encode(&[("Nope", 1.0)]).is_err());
    }

    #[test]
    fn refuses_broken_databases() {
        assert!(matches!(Database::parse("BO_ x"), Err(DbcError::Syntax(_))));
        let past_end =
            "VERSION \"\"\n\nBU_:\n\nBO_ 256 M: 2 X\n SG_ S : 8|16@1+ (1,0) [0|0] \"\" X\n";
        assert!(matches!(
            Database::parse(past_end),
            Err(DbcError::BadSignal { .. })
        ));
        let dup = "VERSION \"\"\n\nBU_:\n\nBO_ 256 A: 2 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n\nBO_ 256 B: 2 X\n SG_ T : 0|8@1+ (1,0) [0|0] \"\" X\n";
        assert!(matches!(
            Database::parse(dup),
            Err(DbcError::BadMessage { .. })
        ));
    }

    #[test]
    fn impossible_definitions_are_refused_and_located() {
        let base = "VERSION \"\"\n\nBU_:\n\nBO_ 256 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|10] \"\" X\n";
        let cases = [
            (base.replace("[0|10]", "[10|0]"), 6, "min > max"),
            (base.replace("BO_ 256", "BO_ 2048"), 5, "standard (11-bit)"),
            (
                base.replace("BO_ 256", "BO_ 4294967295"),
                5,
                "extended (29-bit)",
            ),
            (base.replace(": 8 X", ": 9 X"), 5, "size 9"),
            (base.replace("SG_ S :", "SG_ S ::"), 6, "DBC syntax"),
            (
                base.replace(
                    " X\n SG_ S",
                    " X\n SG_ T : 8|8@1+ (1,0) [0|10] \"\" X\n SG_ S : 16|8@1+ (2,0) [0|20] \"\" X\n SG_ S",
                ),
                8,
                "message M: signal S: defined twice",
            ),
        ];
        for (text, line, why) in cases {
            let err = Database::parse(&text).unwrap_err();
            assert!(err.to_string().contains(why), "{why}: {err}");
            assert_eq!(
                SourceLines::scan(&text).line_of(&err),
                Some(line),
                "{why}: {err}"
            );
        }
        assert!(Database::parse(&base.replace(": 8 X", ": 64 X")).is_ok());
    }

    #[test]
    fn byte_order_mark_and_latin1_comments_are_read() {
        let mut bytes = b"\xEF\xBB\xBFVERSION \"\"\n\nBU_:\n\nBO_ 256 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|10] \"\" X\n".to_vec();
        bytes.extend_from_slice(b"\nCM_ SG_ 256 S \"Vitesse du v\xe9hicule\";\n");
        let text = dbc_text(&bytes);
        let db = Database::parse(&text).unwrap();
        assert_eq!(db.messages.len(), 1);
        assert!(text.contains("v\u{e9}hicule"));
    }
}
