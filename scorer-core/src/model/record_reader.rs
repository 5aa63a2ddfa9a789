//! Reads the postcard primitives the metadata records are made of (varints, `f32`, borrowed byte
//! strings and `str`), by hand: the records' serde `Deserialize` impls would instantiate one
//! postcard deserialiser per record type, which costs the C ABI firmware image about a kilobyte of
//! its 32 KiB flash. Each read refuses exactly what postcard 1.x refuses, with the same
//! [`postcard::Error`], so a blob decodes (or fails) as it would through serde; the record types
//! keep their `Serialize`/`Deserialize` derives for the encoder and for the test that pins this
//! equivalence (`tests/record_reader.rs`).
use postcard::Error;

/// A cursor over a record body.
pub(crate) struct RecordReader<'a> {
    rest: &'a [u8],
}

impl<'a> RecordReader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { rest: bytes }
    }

    /// The bytes not read yet.
    pub(crate) fn rest(&self) -> &'a [u8] {
        self.rest
    }

    fn byte(&mut self) -> Result<u8, Error> {
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

    /// A `u32` (also an enum's variant index).
    pub(crate) fn u32(&mut self) -> Result<u32, Error> {
        // At most 32 bits were accepted.
        self.varint(u32::BITS)
            .map(|v| u32::try_from(v).unwrap_or(u32::MAX))
    }

    /// A length: postcard writes `usize` as a varint of the target's pointer width.
    fn len(&mut self) -> Result<usize, Error> {
        self.varint(usize::BITS)
            .map(|v| usize::try_from(v).unwrap_or(usize::MAX))
    }

    pub(crate) fn f32(&mut self) -> Result<f32, Error> {
        let b = self.take(4)?;
        let at = |i: usize| b.get(i).copied().unwrap_or(0);
        Ok(f32::from_le_bytes([at(0), at(1), at(2), at(3)]))
    }

    /// A length-prefixed byte string (`&[u8]`), borrowed.
    pub(crate) fn bytes(&mut self) -> Result<&'a [u8], Error> {
        let n = self.len()?;
        self.take(n)
    }

    /// A length-prefixed UTF-8 string (`&str`), borrowed.
    pub(crate) fn str(&mut self) -> Result<&'a str, Error> {
        let b = self.bytes()?;
        core::str::from_utf8(b).map_err(|_| Error::DeserializeBadUtf8)
    }
}
