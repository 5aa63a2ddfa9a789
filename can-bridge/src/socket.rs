//! SocketCAN glue (Linux): converting frames between `socketcan` and `can-codec`, opening a bridge
//! socket with kernel filters, error frames and receive timestamps, and classifying I/O errors.
use can_codec::{CanId, Frame, FrameKind};
use socketcan::{
    CanAnyFrame, CanDataFrame, CanErrorFrame, CanFdFrame, CanFdSocket, CanFilter, CanRemoteFrame,
    EmbeddedFrame, ExtendedId, Id, Socket, SocketOptions, StandardId,
};
use std::time::{Duration, SystemTime};

/// Why a socket operation failed, in words for the user.
#[derive(Debug, thiserror::Error)]
pub enum SocketError {
    #[error("interface {iface}: cannot open CAN socket: {cause}{hint}")]
    Open {
        iface: String,
        cause: std::io::Error,
        hint: String,
    },
    #[error("interface {iface}: {what}: {cause}")]
    Setup {
        iface: String,
        what: &'static str,
        cause: std::io::Error,
    },
    #[error("interface {iface} went away ({cause}); stopping")]
    Gone {
        iface: String,
        cause: std::io::Error,
    },
    #[error("interface {iface}: {what}: {cause}")]
    Io {
        iface: String,
        what: &'static str,
        cause: std::io::Error,
    },
}

/// True for errors that mean the interface is down or removed.
pub fn is_interface_gone(e: &std::io::Error) -> bool {
    // ENODEV 19, ENXIO 6, ENETDOWN 100, EBADF 9 (socket invalidated).
    matches!(e.raw_os_error(), Some(19 | 6 | 100 | 9))
}

/// What to do about a failed open of `iface`: the hint names that interface, and suggests
/// creating a virtual one only for a `vcan` name (a missing `can0` is hardware or a driver).
fn open_hint(e: &std::io::Error, iface: &str) -> String {
    match e.raw_os_error() {
        Some(97) => {
            " (this kernel has no SocketCAN support: use a VM, see tests/vm/README.md)".to_string()
        }
        Some(19) if iface.starts_with("vcan") => format!(
            " (no such interface; create it with `ip link add dev {iface} type vcan && ip link set up {iface}`)"
        ),
        Some(19) => format!(
            " (no such interface; `ip link show` lists them: check the name and that the adapter and its driver are up; a virtual bus for testing: `ip link add dev {iface} type vcan && ip link set up {iface}`)"
        ),
        _ => String::new(),
    }
}

/// Opens a CAN FD-capable raw socket on `iface`.
pub fn open(iface: &str) -> Result<CanFdSocket, SocketError> {
    CanFdSocket::open(iface).map_err(|cause| SocketError::Open {
        iface: iface.to_string(),
        hint: open_hint(&cause, iface),
        cause,
    })
}

/// Opens the bridge's socket: kernel filters for `ids` only, all error frames, receive
/// timestamps, and a read timeout so the caller can print status while the bus is quiet.
pub fn open_bridge_socket(
    iface: &str,
    ids: &[CanId],
    timeout: Duration,
) -> Result<CanFdSocket, SocketError> {
    let sock = open(iface)?;
    let setup = |what: &'static str| {
        let iface = iface.to_string();
        move |cause| SocketError::Setup { iface, what, cause }
    };
    const EFF_FLAG: u32 = 0x8000_0000;
    const RTR_FLAG: u32 = 0x4000_0000;
    let filters: Vec<CanFilter> = ids
        .iter()
        .map(|id| match id {
            CanId::Standard(s) => CanFilter::new(u32::from(*s), 0x7FF | EFF_FLAG | RTR_FLAG),
            CanId::Extended(e) => CanFilter::new(e | EFF_FLAG, 0x1FFF_FFFF | EFF_FLAG | RTR_FLAG),
        })
        .collect();
    sock.set_filters(&filters)
        .map_err(setup("setting receive filters"))?;
    sock.set_error_filter_accept_all()
        .map_err(setup("enabling error frames"))?;
    sock.set_recv_timestamp(true)
        .map_err(setup("enabling receive timestamps"))?;
    sock.set_read_timeout(timeout)
        .map_err(setup("setting the read timeout"))?;
    // A deep receive queue (about 2 s of a saturated bus) rides out scheduling hiccups without
    // dropping frames; the kernel caps it at net.core.rmem_max, so raise that on the target.
    sock.as_raw_socket()
        .set_recv_buffer_size(16 << 20)
        .map_err(setup("setting the receive buffer"))?;
    Ok(sock)
}

fn id_of(id: Id) -> CanId {
    match id {
        Id::Standard(s) => CanId::Standard(s.as_raw()),
        Id::Extended(e) => CanId::Extended(e.as_raw()),
    }
}

fn embedded_id(id: CanId) -> Option<Id> {
    match id {
        CanId::Standard(s) => StandardId::new(s).map(Id::Standard),
        CanId::Extended(e) => ExtendedId::new(e).map(Id::Extended),
    }
}

/// A received socketcan frame as a codec frame.
pub fn from_socketcan(frame: &CanAnyFrame) -> Option<Frame> {
    match frame {
        CanAnyFrame::Normal(f) => Frame::data_frame(id_of(f.id()), f.data()),
        CanAnyFrame::Remote(f) => Frame::remote_frame(id_of(f.id()), f.dlc() as u8),
        CanAnyFrame::Error(f) => Frame::error_frame(f.error_bits(), f.data()),
        CanAnyFrame::Fd(f) => Frame::fd_frame(id_of(f.id()), f.flags().bits() & 0x3, f.data()),
    }
}

/// A codec frame as a socketcan frame for sending.
pub fn to_socketcan(frame: &Frame) -> Option<CanAnyFrame> {
    match frame.kind {
        FrameKind::Data { .. } => {
            CanDataFrame::new(embedded_id(frame.id)?, frame.data()).map(CanAnyFrame::Normal)
        }
        FrameKind::Remote { dlc } => {
            CanRemoteFrame::new_remote(embedded_id(frame.id)?, usize::from(dlc))
                .map(CanAnyFrame::Remote)
        }
        FrameKind::Fd { flags } => CanFdFrame::with_flags(
            embedded_id(frame.id)?,
            frame.data(),
            socketcan::id::FdFlags::from_bits_truncate(flags),
        )
        .map(CanAnyFrame::Fd),
        FrameKind::Error { class } => CanErrorFrame::new_error(class, frame.data())
            .ok()
            .map(CanAnyFrame::Error),
    }
}

/// Microseconds since the epoch of a receive timestamp.
pub fn micros(t: SystemTime) -> u64 {
    t.duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

/// Sends one frame; retries briefly when the transmit queue is full (ENOBUFS).
pub fn send(sock: &CanFdSocket, iface: &str, frame: &CanAnyFrame) -> Result<(), SocketError> {
    let mut tries = 0;
    loop {
        match sock.write_frame(frame) {
            Ok(()) => return Ok(()),
            Err(e) if e.raw_os_error() == Some(105) && tries < 1000 => {
                tries += 1;
                std::thread::sleep(Duration::from_micros(100));
            }
            Err(cause) if is_interface_gone(&cause) => {
                return Err(SocketError::Gone {
                    iface: iface.to_string(),
                    cause,
                })
            }
            Err(cause) => {
                return Err(SocketError::Io {
                    iface: iface.to_string(),
                    what: "sending a frame",
                    cause,
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::open_hint;

    #[test]
    fn a_missing_interface_hint_names_that_interface() {
        let enodev = std::io::Error::from_raw_os_error(19);
        let hint = open_hint(&enodev, "vcan1");
        assert!(
            hint.contains("ip link add dev vcan1 type vcan && ip link set up vcan1"),
            "{hint}"
        );
        let hint = open_hint(&enodev, "can1");
        assert!(!hint.contains("vcan0"), "{hint}");
        assert!(hint.contains("ip link show"), "{hint}");
        assert!(hint.contains("ip link add dev can1 type vcan"), "{hint}");
        assert_eq!(
            open_hint(&std::io::Error::from_raw_os_error(13), "can0"),
            ""
        );
    }
}
