//! End-to-end protection of a frame, in the style of AUTOSAR E2E profile 1:
//! a 4-bit alive counter and a CRC-8 SAE J1850 over the data id and the payload.
//!
//! Wire contract (what a receiver must implement, also in docs/can-bridge.md):
//! - byte `crc_byte` holds the CRC; the low nibble of byte `counter_byte` holds the counter,
//!   which increments by one (mod 16) for every frame the sender sends with this data id.
//! - CRC-8 SAE J1850: polynomial 0x1D, initial value 0xFF, final XOR 0xFF, no reflection
//!   (check value over ASCII "123456789" is 0x4B), computed over the data id as two bytes, low
//!   byte first, then every payload byte except the CRC byte, in order.
//! - The receiver classifies each frame ([`E2eStatus`]): CRC mismatch = corrupted; counter equal
//!   to the previous = repeated; counter jump of 1 = ok; a jump of 2..=`max_delta` = ok with
//!   frames lost; a larger jump = wrong sequence.

/// CRC-8 SAE J1850 (poly 0x1D, init 0xFF, xorout 0xFF).
pub fn crc8_sae_j1850(bytes: impl IntoIterator<Item = u8>) -> u8 {
    let mut crc: u8 = 0xFF;
    for b in bytes {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ 0x1D
            } else {
                crc << 1
            };
        }
    }
    crc ^ 0xFF
}

/// Where the protection lives in the payload and which data id it covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct E2eConfig {
    /// Data id: distinguishes messages so a frame of one cannot pass as another.
    pub data_id: u16,
    pub crc_byte: usize,
    /// Byte whose low nibble is the alive counter.
    pub counter_byte: usize,
    /// Largest counter jump still accepted as "frames lost" rather than a broken sequence.
    pub max_delta: u8,
}

impl E2eConfig {
    /// CRC of `payload` under this configuration (the CRC byte itself is skipped).
    pub fn crc(&self, payload: &[u8]) -> u8 {
        let id = self.data_id.to_le_bytes();
        let crc_byte = self.crc_byte;
        crc8_sae_j1850(
            id.into_iter().chain(
                payload
                    .iter()
                    .enumerate()
                    .filter(move |(i, _)| *i != crc_byte)
                    .map(|(_, b)| *b),
            ),
        )
    }
}

/// Sender side: stamps counter and CRC into outgoing payloads.
#[derive(Clone, Debug)]
pub struct E2eProtector {
    pub config: E2eConfig,
    counter: u8,
}

impl E2eProtector {
    pub fn new(config: E2eConfig) -> Self {
        Self { config, counter: 0 }
    }

    /// Writes the next counter value and the CRC into `payload` (which must contain both bytes).
    /// Returns the counter used, or `None` when the payload is too short.
    pub fn protect(&mut self, payload: &mut [u8]) -> Option<u8> {
        let counter = self.counter;
        let slot = payload.get_mut(self.config.counter_byte)?;
        *slot = (*slot & 0xF0) | counter;
        if self.config.crc_byte >= payload.len() {
            return None;
        }
        let crc = self.config.crc(payload);
        *payload.get_mut(self.config.crc_byte)? = crc;
        self.counter = (counter + 1) & 0x0F;
        Some(counter)
    }
}

/// Receiver's verdict on one frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum E2eStatus {
    /// First frame seen: CRC good, no sequence yet.
    Initial,
    Ok,
    /// CRC good, `lost` frames missing before this one.
    OkSomeLost {
        lost: u8,
    },
    /// Same counter as the previous frame.
    Repeated,
    /// Counter jumped by more than `max_delta`.
    WrongSequence,
    /// CRC mismatch (or payload too short to hold the protection).
    Corrupted,
}

/// Receiver side: checks CRC and counter continuity.
#[derive(Clone, Debug)]
pub struct E2eChecker {
    pub config: E2eConfig,
    last_counter: Option<u8>,
}

impl E2eChecker {
    pub fn new(config: E2eConfig) -> Self {
        Self {
            config,
            last_counter: None,
        }
    }

    pub fn check(&mut self, payload: &[u8]) -> E2eStatus {
        let (Some(crc), Some(counter_byte)) = (
            payload.get(self.config.crc_byte),
            payload.get(self.config.counter_byte),
        ) else {
            return E2eStatus::Corrupted;
        };
        if *crc != self.config.crc(payload) {
            return E2eStatus::Corrupted;
        }
        let counter = counter_byte & 0x0F;
        let status = match self.last_counter {
            None => E2eStatus::Initial,
            Some(last) => match counter.wrapping_sub(last) & 0x0F {
                0 => E2eStatus::Repeated,
                1 => E2eStatus::Ok,
                d if d <= self.config.max_delta => E2eStatus::OkSomeLost { lost: d - 1 },
                _ => E2eStatus::WrongSequence,
            },
        };
        if status != E2eStatus::Repeated {
            self.last_counter = Some(counter);
        }
        status
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: E2eConfig = E2eConfig {
        data_id: 0x0A51,
        crc_byte: 0,
        counter_byte: 1,
        max_delta: 3,
    };

    #[test]
    fn crc_check_value() {
        assert_eq!(crc8_sae_j1850(*b"123456789"), 0x4B);
        assert_eq!(crc8_sae_j1850([0u8; 0]), 0x00);
        assert_eq!(crc8_sae_j1850([0x00, 0x00, 0x00, 0x00]), 0x59);
    }

    #[test]
    fn detects_lost_repeated_and_corrupted_frames() {
        let mut tx = E2eProtector::new(CFG);
        let mut rx = E2eChecker::new(CFG);
        let mut frames = Vec::new();
        for i in 0..40u8 {
            let mut p = [0, 0x30, i, 0x12, 0x34, 0, 0, 0];
            assert_eq!(tx.protect(&mut p), Some(i % 16));
            assert_eq!(p[1] >> 4, 3, "high nibble of the counter byte is kept");
            frames.push(p);
        }
        assert_eq!(rx.check(&frames[0]), E2eStatus::Initial);
        for f in &frames[1..20] {
            assert_eq!(rx.check(f), E2eStatus::Ok);
        }
        assert_eq!(rx.check(&frames[19]), E2eStatus::Repeated);
        assert_eq!(rx.check(&frames[22]), E2eStatus::OkSomeLost { lost: 2 });
        assert_eq!(rx.check(&frames[30]), E2eStatus::WrongSequence);
        let mut bad = frames[31];
        bad[4] ^= 0x01;
        assert_eq!(rx.check(&bad), E2eStatus::Corrupted);
        assert_eq!(rx.check(&frames[31]), E2eStatus::Ok);
        // A frame protected under another data id does not pass.
        let mut other = E2eProtector::new(E2eConfig {
            data_id: 0x0A52,
            ..CFG
        });
        let mut p = [0u8; 8];
        other.protect(&mut p);
        assert_eq!(E2eChecker::new(CFG).check(&p), E2eStatus::Corrupted);
        assert_eq!(rx.check(&[0u8; 1]), E2eStatus::Corrupted);
    }
}
