//! Packing and unpacking one DBC signal: bit position, Intel/Motorola byte order, sign, IEEE
//! floats, scale and offset.
//!
//! Bit numbering is the DBC one: bit `b` is bit `b % 8` (LSB = 0) of byte `b / 8`. An Intel
//! (`@1`) signal's start bit is its least significant bit and it grows towards higher bytes; a
//! Motorola (`@0`) signal's start bit is its most significant bit and it grows towards lower bits,
//! continuing at bit 7 of the next byte.
//!
//! Physical value = raw * factor + offset, computed in `f64`, so decoding is exact for every
//! integer signal up to 53 bits.

/// Byte order of a signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ByteOrder {
    /// Little endian (`@1`).
    Intel,
    /// Big endian (`@0`).
    Motorola,
}

/// How the raw bits are interpreted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueKind {
    Unsigned,
    Signed,
    /// `SIG_VALTYPE_ ... : 1` (32-bit signals only).
    Float32,
    /// `SIG_VALTYPE_ ... : 2` (64-bit signals only).
    Float64,
}

/// Why a signal could not be read or written.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum SignalError {
    #[error("signal needs {needed} bytes but the frame has {len}")]
    FrameTooShort { needed: usize, len: usize },
    #[error("value is not finite")]
    NotFinite,
    #[error("value {value} is outside [{min}, {max}]")]
    OutOfRange { value: f64, min: f64, max: f64 },
    #[error("value {value} does not fit the signal's raw range")]
    RawOverflow { value: f64 },
}

/// One signal of a message, ready to pack and unpack.
#[derive(Clone, Debug, PartialEq)]
pub struct SignalSpec {
    pub name: String,
    pub start_bit: u16,
    /// Width in bits, 1..=64.
    pub size: u8,
    pub byte_order: ByteOrder,
    pub kind: ValueKind,
    pub factor: f64,
    pub offset: f64,
    /// Physical range from the DBC; only enforced when `min < max` (DBCs write `[0|0]` for "none").
    pub min: f64,
    pub max: f64,
    pub unit: String,
    /// `Some(v)`: the signal is present only when the message's multiplexor equals `v`.
    pub multiplexed_on: Option<u64>,
    // Precomputed for payloads of at most 8 bytes: the shift that brings the signal to bit 0 and
    // the number of bytes it needs.
    shift: u32,
    bytes_needed: usize,
}

impl SignalSpec {
    /// Builds a signal and precomputes its bit placement. `None` when the size is 0 or above 64,
    /// a float has the wrong width, or the factor is zero or not finite.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &str,
        start_bit: u16,
        size: u8,
        byte_order: ByteOrder,
        kind: ValueKind,
        factor: f64,
        offset: f64,
        min: f64,
        max: f64,
    ) -> Option<Self> {
        if size == 0 || size > 64 || factor == 0.0 || !factor.is_finite() || !offset.is_finite() {
            return None;
        }
        match kind {
            ValueKind::Float32 if size != 32 => return None,
            ValueKind::Float64 if size != 64 => return None,
            _ => {}
        }
        let (shift, bytes_needed) = match byte_order {
            ByteOrder::Intel => {
                let last = u32::from(start_bit) + u32::from(size) - 1;
                (u32::from(start_bit), (last / 8 + 1) as usize)
            }
            ByteOrder::Motorola => {
                // Position of the MSB counted from the left of the big-endian 64-bit word.
                let s = u32::from(start_bit);
                let from_left = (s / 8) * 8 + (7 - s % 8);
                let end = from_left + u32::from(size); // exclusive, counted from the left
                (from_left, end.div_ceil(8) as usize)
            }
        };
        Some(Self {
            name: name.to_string(),
            start_bit,
            size,
            byte_order,
            kind,
            factor,
            offset,
            min,
            max,
            unit: String::new(),
            multiplexed_on: None,
            shift,
            bytes_needed,
        })
    }

    /// Bytes of payload the signal needs to be present.
    pub fn bytes_needed(&self) -> usize {
        self.bytes_needed
    }

    fn mask(&self) -> u64 {
        if self.size == 64 {
            u64::MAX
        } else {
            (1u64 << self.size) - 1
        }
    }

    /// The raw bits of the signal (unsigned, right-aligned).
    pub fn raw(&self, data: &[u8]) -> Result<u64, SignalError> {
        if data.len() < self.bytes_needed {
            return Err(SignalError::FrameTooShort {
                needed: self.bytes_needed,
                len: data.len(),
            });
        }
        if data.len() <= 8 {
            let mut word = [0u8; 8];
            word[..data.len()].copy_from_slice(data);
            return Ok(match self.byte_order {
                ByteOrder::Intel => (u64::from_le_bytes(word) >> self.shift) & self.mask(),
                ByteOrder::Motorola => {
                    let be = u64::from_be_bytes(word) << self.shift;
                    be >> (64 - u32::from(self.size))
                }
            });
        }
        Ok(self.raw_bitwise(data))
    }

    // General path for CAN FD payloads longer than 8 bytes.
    fn raw_bitwise(&self, data: &[u8]) -> u64 {
        self.bit_positions().fold(0u64, |value, pos| {
            let byte = data.get((pos / 8) as usize).copied().unwrap_or(0);
            (value << 1) | u64::from((byte >> (pos % 8)) & 1)
        })
    }

    /// The payload bits the signal occupies (`byte * 8 + bit`, bit 0 the least significant of a
    /// byte, as DBC start bits count), most significant bit of the value first.
    pub fn bit_positions(&self) -> impl Iterator<Item = u32> + '_ {
        let start = u32::from(self.start_bit);
        let size = u32::from(self.size);
        let mut next = start;
        (0..size).map(move |i| match self.byte_order {
            ByteOrder::Intel => start + size - 1 - i,
            // Big-endian: from the MSB down through its byte, then on to the next byte's bit 7.
            ByteOrder::Motorola => {
                let pos = next;
                next = if pos % 8 == 0 { pos + 15 } else { pos - 1 };
                pos
            }
        })
    }

    /// True when the two signals share a payload bit and can be in the same frame (signals
    /// multiplexed on different values never are).
    pub fn overlaps(&self, other: &SignalSpec) -> bool {
        if let (Some(a), Some(b)) = (self.multiplexed_on, other.multiplexed_on) {
            if a != b {
                return false;
            }
        }
        let mut mine: Vec<u32> = self.bit_positions().collect();
        mine.sort_unstable();
        other
            .bit_positions()
            .any(|pos| mine.binary_search(&pos).is_ok())
    }

    /// Raw bits interpreted per [`ValueKind`], before scale and offset.
    pub fn raw_value(&self, raw: u64) -> f64 {
        match self.kind {
            ValueKind::Unsigned => raw as f64,
            ValueKind::Signed => {
                let unused = 64 - u32::from(self.size);
                (((raw << unused) as i64) >> unused) as f64
            }
            ValueKind::Float32 => f64::from(f32::from_bits(raw as u32)),
            ValueKind::Float64 => f64::from_bits(raw),
        }
    }

    /// The physical value, `raw * factor + offset`. Non-finite floats are an error; the DBC
    /// range is not checked here (see [`SignalSpec::check_range`]).
    pub fn decode(&self, data: &[u8]) -> Result<f64, SignalError> {
        let raw = self.raw(data)?;
        let value = self.raw_value(raw);
        let physical = if self.factor == 1.0 && self.offset == 0.0 {
            value
        } else {
            value * self.factor + self.offset
        };
        if physical.is_finite() {
            Ok(physical)
        } else {
            Err(SignalError::NotFinite)
        }
    }

    /// True when the DBC declares a range.
    pub fn has_range(&self) -> bool {
        self.min < self.max
    }

    /// Errors when the physical value is outside the DBC range (if the DBC declares one).
    pub fn check_range(&self, value: f64) -> Result<f64, SignalError> {
        if !value.is_finite() {
            return Err(SignalError::NotFinite);
        }
        if self.has_range() && !(self.min..=self.max).contains(&value) {
            return Err(SignalError::OutOfRange {
                value,
                min: self.min,
                max: self.max,
            });
        }
        Ok(value)
    }

    /// The raw integer a physical value encodes to (round half away from zero).
    pub fn to_raw(&self, value: f64) -> Result<u64, SignalError> {
        if !value.is_finite() {
            return Err(SignalError::NotFinite);
        }
        match self.kind {
            ValueKind::Float32 => Ok(u64::from(
                (((value - self.offset) / self.factor) as f32).to_bits(),
            )),
            ValueKind::Float64 => Ok(((value - self.offset) / self.factor).to_bits()),
            ValueKind::Unsigned => {
                let r = ((value - self.offset) / self.factor).round();
                if r < 0.0 || r > self.mask() as f64 {
                    return Err(SignalError::RawOverflow { value });
                }
                Ok(r as u64)
            }
            ValueKind::Signed => {
                let r = ((value - self.offset) / self.factor).round();
                let half = (1u64 << (self.size - 1)) as f64;
                if r < -half || r > half - 1.0 {
                    return Err(SignalError::RawOverflow { value });
                }
                Ok((r as i64 as u64) & self.mask())
            }
        }
    }

    /// Writes a physical value into `data` (range-checked against the DBC range and the raw width).
    pub fn encode(&self, value: f64, data: &mut [u8]) -> Result<(), SignalError> {
        self.check_range(value)?;
        let raw = self.to_raw(value)?;
        self.write_raw(raw, data)
    }

    /// Writes raw bits into `data`, leaving the other bits untouched.
    pub fn write_raw(&self, raw: u64, data: &mut [u8]) -> Result<(), SignalError> {
        if data.len() < self.bytes_needed {
            return Err(SignalError::FrameTooShort {
                needed: self.bytes_needed,
                len: data.len(),
            });
        }
        let raw = raw & self.mask();
        let mut set = |pos: u32, bit: u64| {
            if let Some(byte) = data.get_mut((pos / 8) as usize) {
                let m = 1u8 << (pos % 8);
                if bit != 0 {
                    *byte |= m;
                } else {
                    *byte &= !m;
                }
            }
        };
        for (pos, i) in self.bit_positions().zip((0..u32::from(self.size)).rev()) {
            set(pos, (raw >> i) & 1);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sig(start: u16, size: u8, order: ByteOrder, kind: ValueKind, f: f64, o: f64) -> SignalSpec {
        SignalSpec::new("s", start, size, order, kind, f, o, 0.0, 0.0).unwrap()
    }

    #[test]
    fn intel_and_motorola_known_layouts() {
        // Intel 16-bit at bit 8: bytes 1..3 little endian.
        let s = sig(8, 16, ByteOrder::Intel, ValueKind::Unsigned, 1.0, 0.0);
        assert_eq!(s.raw(&[0x00, 0x34, 0x12]).unwrap(), 0x1234);
        // Motorola 16-bit with MSB at bit 7 (start of byte 0): bytes 0..2 big endian.
        let m = sig(7, 16, ByteOrder::Motorola, ValueKind::Unsigned, 1.0, 0.0);
        assert_eq!(m.raw(&[0x12, 0x34]).unwrap(), 0x1234);
        // Motorola 12-bit with MSB at bit 3 of byte 0: low nibble of byte 0 then byte 1.
        let m = sig(3, 12, ByteOrder::Motorola, ValueKind::Unsigned, 1.0, 0.0);
        assert_eq!(m.raw(&[0xA5, 0xBC]).unwrap(), 0x5BC);
        // Signed with scale and offset: raw -2 (0b1110, 4 bits at bit 4) * 0.5 + 10.
        let s = sig(4, 4, ByteOrder::Intel, ValueKind::Signed, 0.5, 10.0);
        assert_eq!(s.decode(&[0xE0]).unwrap(), 9.0);
        // Float32 signal.
        let f = sig(0, 32, ByteOrder::Intel, ValueKind::Float32, 1.0, 0.0);
        assert_eq!(f.decode(&1.5f32.to_le_bytes()).unwrap(), 1.5);
        assert_eq!(
            f.decode(&f32::NAN.to_le_bytes()),
            Err(SignalError::NotFinite)
        );
    }

    #[test]
    fn overlapping_bit_ranges() {
        let intel = |start, size| sig(start, size, ByteOrder::Intel, ValueKind::Unsigned, 1.0, 0.0);
        let moto = |start, size| {
            sig(
                start,
                size,
                ByteOrder::Motorola,
                ValueKind::Unsigned,
                1.0,
                0.0,
            )
        };
        // Byte 0 and byte 1 (Intel) are apart; a 12-bit Intel signal at 0 reaches into byte 1.
        assert!(!intel(0, 8).overlaps(&intel(8, 8)));
        assert!(intel(0, 12).overlaps(&intel(8, 8)));
        // Motorola 16 bits with MSB at bit 7: bytes 0 and 1, so not byte 2 but byte 1.
        assert!(moto(7, 16).overlaps(&intel(8, 4)));
        assert!(!moto(7, 16).overlaps(&intel(16, 8)));
        // Motorola 4 bits with MSB at bit 3: bits 3..0, clear of the high nibble.
        assert!(!moto(3, 4).overlaps(&intel(4, 4)));
        assert!(moto(3, 4).overlaps(&intel(0, 1)));
        // Multiplexed on different values: never in the same frame.
        let mut a = intel(0, 8);
        let mut b = intel(0, 8);
        a.multiplexed_on = Some(1);
        b.multiplexed_on = Some(2);
        assert!(!a.overlaps(&b));
        b.multiplexed_on = Some(1);
        assert!(a.overlaps(&b));
    }

    #[test]
    fn short_frames_and_ranges_are_errors() {
        let s = sig(8, 16, ByteOrder::Intel, ValueKind::Unsigned, 1.0, 0.0);
        assert_eq!(
            s.raw(&[0, 0]),
            Err(SignalError::FrameTooShort { needed: 3, len: 2 })
        );
        let r = SignalSpec::new(
            "r",
            0,
            8,
            ByteOrder::Intel,
            ValueKind::Unsigned,
            1.0,
            0.0,
            0.0,
            100.0,
        )
        .unwrap();
        assert!(r.check_range(50.0).is_ok());
        assert!(matches!(
            r.check_range(101.0),
            Err(SignalError::OutOfRange { .. })
        ));
        assert!(matches!(
            r.encode(200.0, &mut [0u8; 1]),
            Err(SignalError::OutOfRange { .. })
        ));
        let u = sig(0, 8, ByteOrder::Intel, ValueKind::Unsigned, 1.0, 0.0);
        assert!(matches!(
            u.encode(256.0, &mut [0u8; 1]),
            Err(SignalError::RawOverflow { .. })
        ));
        assert!(matches!(
            u.encode(f64::NAN, &mut [0u8; 1]),
            Err(SignalError::NotFinite)
        ));
    }

    #[test]
    fn fd_payloads_use_the_bitwise_path_consistently() {
        let mut data = [0u8; 64];
        let s = sig(500, 12, ByteOrder::Intel, ValueKind::Signed, 0.1, 0.0);
        s.encode(-12.3, &mut data).unwrap();
        assert!((s.decode(&data).unwrap() + 12.3).abs() < 1e-9);
        let m = sig(447, 20, ByteOrder::Motorola, ValueKind::Unsigned, 1.0, 0.0);
        m.encode(0xABCDE as f64, &mut data).unwrap();
        assert_eq!(m.raw(&data).unwrap(), 0xABCDE);
        assert!((s.decode(&data).unwrap() + 12.3).abs() < 1e-9);
    }

    proptest! {
        #[test]
        fn encode_decode_round_trip(start in 0u16..64, size in 1u8..=64, motorola: bool, signed: bool, raw: u64, fill: u8) {
            let order = if motorola { ByteOrder::Motorola } else { ByteOrder::Intel };
            let kind = if signed { ValueKind::Signed } else { ValueKind::Unsigned };
            let s = sig(start, size, order, kind, 1.0, 0.0);
            prop_assume!(s.bytes_needed() <= 8);
            // Motorola signals that run past bit 63 do not exist in 8 bytes.
            let mut data = [fill; 8];
            let raw = raw & s.mask();
            s.write_raw(raw, &mut data).unwrap();
            prop_assert_eq!(s.raw(&data).unwrap(), raw);
            // The fast path and the bitwise path agree.
            prop_assert_eq!(s.raw_bitwise(&data), raw);
            // Other bits are untouched: writing back the fill elsewhere changes nothing.
            let mut cleared = [fill; 8];
            s.write_raw(0, &mut cleared).unwrap();
            let mut again = cleared;
            s.write_raw(raw, &mut again).unwrap();
            prop_assert_eq!(again, data);
        }
    }
}
