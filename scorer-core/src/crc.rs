//! CRC-32 of the model blob payload.
//!
//! The parameterisation is CRC-32/ISO-HDLC (the zlib/PNG/Ethernet CRC): reflected polynomial
//! `0xEDB88320`, initial value `0xFFFF_FFFF`, final XOR `0xFFFF_FFFF`. Its check value
//! (`crc32(b"123456789")`) is `0xCBF4_3926`, so any standard tool (`python3 -c 'import zlib'`,
//! `crc32` from libarchive, ...) can verify a blob. Table driven; the table is built at compile time.

const POLY: u32 = 0xEDB8_8320;

const TABLE: [u32; 256] = build_table();

// `i < 256` bounds every index; `get_mut` is not usable in a const fn on our MSRV.
#[allow(clippy::indexing_slicing)]
const fn build_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
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
        for &byte in data {
            // `(c ^ byte) & 0xFF` is < 256, so the lookup cannot miss; `get` keeps the lint honest.
            let idx = ((c ^ u32::from(byte)) & 0xFF) as usize;
            c = TABLE.get(idx).copied().unwrap_or(0) ^ (c >> 8);
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

    #[test]
    fn incremental_equals_one_shot() {
        let data = b"riskscore model blob payload";
        let mut c = Crc32::new();
        c.update(&data[..7]);
        c.update(&data[7..]);
        assert_eq!(c.finish(), crc32(data));
    }
}
