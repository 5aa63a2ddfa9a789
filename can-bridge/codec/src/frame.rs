//! One CAN frame as the codec sees it: identifier, kind (data, remote, error, FD) and payload.
//!
//! Independent of any socket library so that logs, the bridge and riskctl share one type.

/// Flag bit for an extended (29-bit) id in Linux `can_id` words.
pub const CAN_EFF_FLAG: u32 = 0x8000_0000;
/// Flag bit for a remote transmission request in Linux `can_id` words.
pub const CAN_RTR_FLAG: u32 = 0x4000_0000;
/// Flag bit for an error frame in Linux `can_id` words.
pub const CAN_ERR_FLAG: u32 = 0x2000_0000;
/// Mask of the error class bits of an error frame's id.
pub const CAN_ERR_MASK: u32 = 0x1FFF_FFFF;
/// Error class: the controller went bus-off.
pub const CAN_ERR_BUSOFF: u32 = 0x0000_0040;
/// Error class: controller problems (error-passive, warnings, overflows).
pub const CAN_ERR_CRTL: u32 = 0x0000_0004;
/// Error class: the controller was restarted.
pub const CAN_ERR_RESTARTED: u32 = 0x0000_0100;
/// Largest CAN FD payload.
pub const MAX_DATA_LEN: usize = 64;

/// A CAN identifier: 11-bit standard or 29-bit extended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CanId {
    Standard(u16),
    Extended(u32),
}

impl CanId {
    /// Builds a standard id, `None` when it does not fit 11 bits.
    pub fn standard(id: u16) -> Option<Self> {
        (id <= 0x7FF).then_some(Self::Standard(id))
    }

    /// Builds an extended id, `None` when it does not fit 29 bits.
    pub fn extended(id: u32) -> Option<Self> {
        (id <= 0x1FFF_FFFF).then_some(Self::Extended(id))
    }

    /// The numeric id without flags.
    pub fn raw(self) -> u32 {
        match self {
            Self::Standard(id) => u32::from(id),
            Self::Extended(id) => id,
        }
    }

    pub fn is_extended(self) -> bool {
        matches!(self, Self::Extended(_))
    }

    /// The id as a Linux `can_id` word (extended flag set for extended ids).
    pub fn linux_word(self) -> u32 {
        match self {
            Self::Standard(id) => u32::from(id),
            Self::Extended(id) => id | CAN_EFF_FLAG,
        }
    }
}

impl core::fmt::Display for CanId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Standard(id) => write!(f, "{id:03X}"),
            Self::Extended(id) => write!(f, "{id:08X}"),
        }
    }
}

/// What a frame is, beyond its id and payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameKind {
    /// Classic data frame. `len8_dlc` is the raw DLC 9..=15 of an 8-byte frame when it was not 8.
    Data { len8_dlc: Option<u8> },
    /// Remote transmission request with the requested length (no payload).
    Remote { dlc: u8 },
    /// CAN FD data frame with its flags nibble (bit 0 BRS, bit 1 ESI).
    Fd { flags: u8 },
    /// Error frame reported by the controller/driver: `class` is the error class mask
    /// (id bits without `CAN_ERR_FLAG`), the payload carries the details.
    Error { class: u32 },
}

/// One CAN frame with up to 64 payload bytes, stored inline (no allocation).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Identifier; for error frames a placeholder `Standard(0)` (see [`FrameKind::Error`]).
    pub id: CanId,
    pub kind: FrameKind,
    len: u8,
    data: [u8; MAX_DATA_LEN],
}

impl core::fmt::Debug for Frame {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Frame")
            .field("id", &self.id)
            .field("kind", &self.kind)
            .field("data", &self.data())
            .finish()
    }
}

/// Valid CAN FD payload lengths.
pub fn is_valid_fd_len(len: usize) -> bool {
    matches!(len, 0..=8 | 12 | 16 | 20 | 24 | 32 | 48 | 64)
}

impl Frame {
    /// A classic data frame, `None` when `data` is longer than 8 bytes.
    pub fn data_frame(id: CanId, data: &[u8]) -> Option<Self> {
        (data.len() <= 8).then(|| Self::with_payload(id, FrameKind::Data { len8_dlc: None }, data))
    }

    /// A CAN FD frame, `None` when the length is not a valid FD length.
    pub fn fd_frame(id: CanId, flags: u8, data: &[u8]) -> Option<Self> {
        (is_valid_fd_len(data.len()) && flags <= 0xF)
            .then(|| Self::with_payload(id, FrameKind::Fd { flags }, data))
    }

    /// A remote frame requesting `dlc` bytes (0..=8).
    pub fn remote_frame(id: CanId, dlc: u8) -> Option<Self> {
        (dlc <= 8).then(|| Self::with_payload(id, FrameKind::Remote { dlc }, &[]))
    }

    /// An error frame with error class `class` (bits of `CAN_ERR_MASK`) and its 8 detail bytes.
    pub fn error_frame(class: u32, data: &[u8]) -> Option<Self> {
        (data.len() <= 8 && class & !CAN_ERR_MASK == 0)
            .then(|| Self::with_payload(CanId::Standard(0), FrameKind::Error { class }, data))
    }

    fn with_payload(id: CanId, kind: FrameKind, data: &[u8]) -> Self {
        let mut buf = [0u8; MAX_DATA_LEN];
        let len = data.len().min(MAX_DATA_LEN);
        buf[..len].copy_from_slice(&data[..len]);
        Self {
            id,
            kind,
            len: len as u8,
            data: buf,
        }
    }

    /// Payload bytes (empty for remote frames).
    pub fn data(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }

    pub fn is_error(&self) -> bool {
        matches!(self.kind, FrameKind::Error { .. })
    }

    /// True for an error frame that reports bus-off.
    pub fn is_bus_off(&self) -> bool {
        matches!(self.kind, FrameKind::Error { class } if class & CAN_ERR_BUSOFF != 0)
    }

    /// Number of bits on the wire of a classic data frame without stuffing (for load estimates).
    pub fn nominal_bits(&self) -> u32 {
        let header = if self.id.is_extended() { 67 } else { 47 };
        header + 8 * u32::from(self.len)
    }
}
