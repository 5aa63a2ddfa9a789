//! CRC-32 of the model blob payload.
//!
//! The parameterisation is CRC-32/ISO-HDLC (the zlib/PNG/Ethernet CRC): reflected polynomial
//! `0xEDB88320`, initial value `0xFFFF_FFFF`, final XOR `0xFFFF_FFFF`. Its check value
//! (`crc32(b"123456789")`) is `0xCBF4_3926`, so any standard tool (`python3 -c 'import zlib'`,
//! `crc32` from libarchive, ...) can verify a blob.
//!
//! Driven by a 16-entry table, four bits a step (built at compile time): a blob is checked once,
//! when it is loaded, and the usual 256-entry byte table would cost the firmware images 960 bytes
//! of their 32 KiB flash for a few thousand instructions saved per load.

const POLY: u32 = 0xEDB8_8320;

const TABLE: [u32; 16] = build_table();

// `i < 16` bounds every index; `get_mut` is not usable in a const fn on our MSRV.
#[allow(clippy::indexing_slicing)]
const fn build_table() -> [u32; 16] {
    let mut table = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 4 {
            c = if c & 1 != 0 { POLY ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

/// Incremental CRC-32/ISO-HDLC: feed bytes with [`Crc32::update`], read with [`Crc32::finish`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc32 {
    state: u32,
}

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    /// A fresh checksum (no bytes seen).
    pub const fn new() -> Self {
        Self { state: 0xFFFF_FFFF }
    }

    /// Feeds `data`.
    pub fn update(&mut self, data: &[u8]) {
        let mut c = self.state;
        // `c & 0xF` is < 16, so the lookup cannot miss; `get` keeps the lint honest.
        let step = |c: u32| TABLE.get((c & 0xF) as usize).copied().unwrap_or(0) ^ (c >> 4);
        for &byte in data {
            c = step(step(c ^ u32::from(byte)));
        }
        self.state = c;
    }

    /// The checksum of every byte fed so far.
    pub const fn finish(&self) -> u32 {
        self.state ^ 0xFFFF_FFFF
    }
}

/// CRC-32/ISO-HDLC of `data` in one call.
pub fn crc32(data: &[u8]) -> u32 {
    let mut c = Crc32::new();
    c.update(data);
    c.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        // zlib.crc32(b"The quick brown fox jumps over the lazy dog")
        assert_eq!(
            crc32(b"The quick brown fox jumps over the lazy dog"),
            0x414F_A339
        );
    }

    /// The definition, one bit at a time.
    fn bitwise(data: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &byte in data {
            c ^= u32::from(byte);
            for _ in 0..8 {
                c = if c & 1 != 0 { POLY ^ (c >> 1) } else { c >> 1 };
            }
        }
        c ^ 0xFFFF_FFFF
    }

    #[test]
    fn every_byte_value_and_length_matches_the_bitwise_definition() {
        let mut data = [0u8; 512];
        for (i, d) in data.iter_mut().enumerate() {
            // Every byte value, ascending then descending.
            *d = if i < 256 { i as u8 } else { (511 - i) as u8 };
        }
        for len in 0..=data.len() {
            assert_eq!(crc32(&data[..len]), bitwise(&data[..len]), "length {len}");
        }
    }

    #[test]
    fn incremental_equals_one_shot() {
        let data = b"riskscore model blob payload";
        let mut c = Crc32::new();
        c.update(&data[..7]);
        c.update(&data[7..]);
        assert_eq!(c.finish(), crc32(data));
    }
}
