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

impl Database {
    /// Parses DBC text.
    pub fn parse(text: &str) -> Result<Self, DbcError> {
        let dbc = can_dbc::Dbc::try_from(text).map_err(|e| DbcError::Syntax(e.to_string()))?;
        let mut messages = Vec::with_capacity(dbc.messages.len());
        for m in &dbc.messages {
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
                .filter(|s| *s <= crate::frame::MAX_DATA_LEN)
                .ok_or_else(|| DbcError::BadMessage {
                    message: m.name.clone(),
                    reason: format!("size {} is above 64 bytes", m.size),
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
                if spec.bytes_needed() > size {
                    return Err(bad("extends past the end of the message"));
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
}
