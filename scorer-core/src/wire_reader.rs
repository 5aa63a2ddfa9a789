//! Reads the postcard primitives a blob payload is made of (varints, `u8`/`i8`, `bool`, `f32`,
//! options, sequences, borrowed byte strings and `str`), by hand: the serde `Deserialize` impls of
//! the model kinds and metadata records would instantiate one postcard deserialiser per type,
//! which costs the C ABI firmware image kilobytes of its 32 KiB flash. Each read refuses exactly
//! what postcard 1.x refuses, with the same [`postcard::Error`], so a blob decodes (or fails) as it
//! would through serde (on the 32-bit ECU: lengths are read as `u32` varints on every target, so
//! the 64-bit host refuses a 6-byte length varint as the ECU does); the types keep their `Serialize`/`Deserialize` derives for the encoder and
//! for the tests that pin this equivalence (`tests/record_reader.rs`, `tests/payload_reader.rs`).
use postcard::Error;

use crate::bounded::BoundedVec;

/// A cursor over a payload.
pub(crate) struct WireReader<'a> {
    rest: &'a [u8],
}

impl<'a> WireReader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { rest: bytes }
    }

    /// The bytes not read yet.
    pub(crate) fn rest(&self) -> &'a [u8] {
        self.rest
    }

    pub(crate) fn byte(&mut self) -> Result<u8, Error> {
        let (&b, rest) = self
            .rest
            .split_first()
            .ok_or(Error::DeserializeUnexpectedEnd)?;
        self.rest = rest;
        Ok(b)
    }

    /// The next `n` bytes, borrowed.
    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], Error> {
        let (taken, rest) = self
            .rest
            .split_at_checked(n)
            .ok_or(Error::DeserializeUnexpectedEnd)?;
        self.rest = rest;
        Ok(taken)
    }

    /// A LEB128 varint of an unsigned integer of `bits` bits, as postcard reads it: at most
    /// `ceil(bits / 7)` bytes, and the last of that many may not carry bits beyond `bits`.
    #[inline(never)]
    fn varint(&mut self, bits: u32) -> Result<u64, Error> {
        let max_bytes = bits.div_ceil(7);
        let max_last = (u64::MAX >> (64 - bits)) >> (7 * (max_bytes - 1));
        let mut out = 0u64;
        for i in 0..max_bytes {
            let b = self.byte()?;
            out |= u64::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                if i == max_bytes - 1 && u64::from(b) > max_last {
                    return Err(Error::DeserializeBadVarint);
                }
                return Ok(out);
            }
        }
        Err(Error::DeserializeBadVarint)
    }

    pub(crate) fn i8(&mut self) -> Result<i8, Error> {
        self.byte().map(|b| b as i8)
    }

    pub(crate) fn bool(&mut self) -> Result<bool, Error> {
        match self.byte()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(Error::DeserializeBadBool),
        }
    }

    /// An `Option`'s tag: `true` when a value follows.
    pub(crate) fn is_some(&mut self) -> Result<bool, Error> {
        match self.byte()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(Error::DeserializeBadOption),
        }
    }

    pub(crate) fn u16(&mut self) -> Result<u16, Error> {
        // At most 16 bits were accepted.
        self.varint(u16::BITS)
            .map(|v| u16::try_from(v).unwrap_or(u16::MAX))
    }

    /// A `u32` (also an enum's variant index).
    pub(crate) fn u32(&mut self) -> Result<u32, Error> {
        // At most 32 bits were accepted.
        self.varint(u32::BITS)
            .map(|v| u32::try_from(v).unwrap_or(u32::MAX))
    }

    /// A length: postcard writes `usize` as a varint of the target's pointer width; read as a
    /// `u32` varint (at most 5 bytes, at most 32 bits) on every target, so the 64-bit host refuses
    /// exactly what the 32-bit ECU refuses (no blob length needs more).
    fn length(&mut self) -> Result<usize, Error> {
        self.varint(u32::BITS)
            .map(|v| usize::try_from(v).unwrap_or(usize::MAX))
    }

    pub(crate) fn f32(&mut self) -> Result<f32, Error> {
        let b = self.take(4)?;
        let at = |i: usize| b.get(i).copied().unwrap_or(0);
        Ok(f32::from_le_bytes([at(0), at(1), at(2), at(3)]))
    }

    /// A length-prefixed byte string (`&[u8]`), borrowed.
    pub(crate) fn bytes(&mut self) -> Result<&'a [u8], Error> {
        let n = self.length()?;
        self.take(n)
    }

    /// An enum's variant among `variants` (in wire order); an index past them is what serde's
    /// derived variant visitor reports through postcard.
    pub(crate) fn variant<T: Copy>(&mut self, variants: &[T]) -> Result<T, Error> {
        let index = usize::try_from(self.u32()?).unwrap_or(usize::MAX);
        variants.get(index).copied().ok_or(Error::SerdeDeCustom)
    }

    /// A sequence (varint length, then the elements) into a [`BoundedVec`], which keeps the first
    /// `N` elements and counts the rest (every element takes at least one byte, so the loop is
    /// bounded by the payload).
    pub(crate) fn bounded<T, const N: usize>(
        &mut self,
        item: fn(&mut Self) -> Result<T, Error>,
    ) -> Result<BoundedVec<T, N>, Error> {
        let mut out = BoundedVec::new();
        for _ in 0..self.length()? {
            out.push_or_count(item(self)?);
        }
        Ok(out)
    }

    /// A length-prefixed UTF-8 string (`&str`), borrowed.
    pub(crate) fn str(&mut self) -> Result<&'a str, Error> {
        let b = self.bytes()?;
        core::str::from_utf8(b).map_err(|_| Error::DeserializeBadUtf8)
    }
}
