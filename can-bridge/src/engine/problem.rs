//! What the engine reports as going wrong ([`Output::Problem`](super::Output::Problem)): one
//! variant per data-quality rule, whose text is the diagnostic printed on stderr and in loss lists.
use crate::map::PartnerField;
use can_codec::{CanId, SignalError};
use scorer_core::warning::WarningError;

/// A frame or track update the engine could not use, and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Problem {
    /// Up to 1 s older than the newest frame ([`crate::timeline`]).
    #[error(
        "frame {id} at {t_us} us is older than the newest frame ({newest_us} us{}): dropped",
        source_note(*.newest_source)
    )]
    Late {
        id: CanId,
        t_us: u64,
        newest_us: u64,
        /// The newest frame's log line (0: unknown, e.g. live).
        newest_source: u64,
    },
    /// Far off the timeline and not confirmed as a new segment ([`crate::timeline`]).
    #[error(
        "frame {id} at {t_us} us is far outside the log's timeline (newest frame {newest_us} us) and fewer than 3 frames after it continue from it (no new log segment): dropped"
    )]
    OffTimeline {
        id: CanId,
        t_us: u64,
        newest_us: u64,
    },
    /// The timestamps jumped and the following frames confirmed it: every track was dropped.
    #[error("timestamps jump to {t_us} us: a new log segment starts, all tracks dropped")]
    NewSegment { t_us: u64 },
    /// An error frame on the bus.
    #[error("error frame (class 0x{class:08X}{})", bus_off_note(*.bus_off))]
    ErrorFrame { class: u32, bus_off: bool },
    /// A frame of a mapped message that does not decode; the whole frame is dropped.
    #[error("{message} ({id}): {cause}: frame dropped")]
    Undecodable {
        message: String,
        id: CanId,
        cause: DecodeError,
    },
    /// A second trigger for a track at the same timestamp.
    #[error("track {track}: second update at the same timestamp: dropped")]
    Duplicate { track: u32 },
    /// The map has a valid flag, but none arrived within the staleness limit.
    #[error("track {track}: valid flag missing or stale: not scored")]
    ValidFlagMissing { track: u32 },
    /// The ego speed has not arrived (reported once until it does).
    #[error(
        "waiting for ego.vel_long: {origin} not received in the last {stale_ms} ms; no track is scored until it arrives (reported once)"
    )]
    EgoSpeedMissing { origin: String, stale_ms: u64 },
    /// A required input of a track has not arrived (reported once per track until it does).
    #[error(
        "track {track}: waiting for {}: {origin} not received in the last {stale_ms} ms; not scored until it arrives (reported once)",
        .field.name()
    )]
    InputMissing {
        track: u32,
        field: PartnerField,
        origin: String,
        stale_ms: u64,
    },
    /// The assembled ego or partner state is not finite or has a non-positive size.
    #[error("track {track}: state not finite or non-positive size: not scored")]
    BadState { track: u32 },
    /// No room for a new track in the warning table.
    #[error("track {track}: track table full ({capacity}): not scored")]
    TableFull { track: u32, capacity: usize },
    /// The core's warning table refused the update.
    #[error("{0}")]
    Rejected(WarningError),
    /// The track warns but its id does not fit the warning message's track-id signal: its warning
    /// frames are not sent (sending a clamped id would warn about another track).
    #[error(
        "track {track}: warning frames not sent: the id does not fit the warning message's {signal} ([{}, {}]); reported once per track",
        .range.0, .range.1
    )]
    TrackIdDoesNotFit {
        track: u32,
        signal: String,
        range: (f64, f64),
    },
    /// The warning frame could not be built from the map's warning message.
    #[error("track {track}: warning frame not encodable: {cause}")]
    WarningFrame { track: u32, cause: EncodeError },
}

fn bus_off_note(bus_off: bool) -> &'static str {
    if bus_off {
        ", bus-off"
    } else {
        ""
    }
}

/// `, line N` for a known log line (0: unknown).
fn source_note(source: u64) -> String {
    if source == 0 {
        String::new()
    } else {
        format!(", line {source}")
    }
}

/// Why a frame of a mapped message does not decode.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DecodeError {
    #[error("wrong DLC: {len} bytes, DBC says {expected}")]
    WrongLength { len: usize, expected: usize },
    #[error("signal {signal}: not finite")]
    NotFinite { signal: String },
    #[error("signal {signal}: {cause}")]
    Signal { signal: String, cause: SignalError },
    #[error("track id {id} is not a non-negative integer")]
    TrackId { id: f64 },
}

/// Why a warning frame could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EncodeError {
    #[error("{signal}: {cause}")]
    Signal { signal: String, cause: SignalError },
    #[error("payload too short for E2E protection")]
    TooShortForE2e,
    #[error("invalid frame length")]
    FrameLength,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The texts are what users see on stderr and in loss listings: each variant reads exactly as
    /// the engine's problems did when they were built as strings.
    #[test]
    fn every_problem_reads_as_its_diagnostic() {
        let id = CanId::Standard(0x201);
        let cases = [
            (
                Problem::Late {
                    id,
                    t_us: 5,
                    newest_us: 9,
                    newest_source: 0,
                },
                "frame 201 at 5 us is older than the newest frame (9 us): dropped",
            ),
            (
                Problem::Late {
                    id,
                    t_us: 5,
                    newest_us: 9,
                    newest_source: 17,
                },
                "frame 201 at 5 us is older than the newest frame (9 us, line 17): dropped",
            ),
            (
                Problem::OffTimeline {
                    id: CanId::Extended(0x18FF_0001),
                    t_us: 7,
                    newest_us: 3,
                },
                "frame 18FF0001 at 7 us is far outside the log's timeline (newest frame 3 us) and fewer than 3 frames after it continue from it (no new log segment): dropped",
            ),
            (
                Problem::NewSegment { t_us: 42 },
                "timestamps jump to 42 us: a new log segment starts, all tracks dropped",
            ),
            (
                Problem::ErrorFrame {
                    class: 0x40,
                    bus_off: true,
                },
                "error frame (class 0x00000040, bus-off)",
            ),
            (
                Problem::ErrorFrame {
                    class: 0x4,
                    bus_off: false,
                },
                "error frame (class 0x00000004)",
            ),
            (
                Problem::Undecodable {
                    message: "OBJECT_SIZE".into(),
                    id,
                    cause: DecodeError::WrongLength {
                        len: 7,
                        expected: 8,
                    },
                },
                "OBJECT_SIZE (201): wrong DLC: 7 bytes, DBC says 8: frame dropped",
            ),
            (
                Problem::Undecodable {
                    message: "M".into(),
                    id,
                    cause: DecodeError::Signal {
                        signal: "ObjLength".into(),
                        cause: SignalError::OutOfRange {
                            value: 40.0,
                            min: 0.0,
                            max: 30.0,
                        },
                    },
                },
                "M (201): signal ObjLength: value 40 is outside [0, 30]: frame dropped",
            ),
            (
                Problem::Undecodable {
                    message: "M".into(),
                    id,
                    cause: DecodeError::NotFinite {
                        signal: "S".into(),
                    },
                },
                "M (201): signal S: not finite: frame dropped",
            ),
            (
                Problem::Undecodable {
                    message: "M".into(),
                    id,
                    cause: DecodeError::TrackId { id: 1.5 },
                },
                "M (201): track id 1.5 is not a non-negative integer: frame dropped",
            ),
            (
                Problem::Duplicate { track: 4 },
                "track 4: second update at the same timestamp: dropped",
            ),
            (
                Problem::ValidFlagMissing { track: 4 },
                "track 4: valid flag missing or stale: not scored",
            ),
            (
                Problem::EgoSpeedMissing {
                    origin: "signal `V` of message `E` (0x100)".into(),
                    stale_ms: 500,
                },
                "waiting for ego.vel_long: signal `V` of message `E` (0x100) not received in the last 500 ms; no track is scored until it arrives (reported once)",
            ),
            (
                Problem::InputMissing {
                    track: 3,
                    field: PartnerField::PosY,
                    origin: "signal `Y` of message `P` (0x200)".into(),
                    stale_ms: 200,
                },
                "track 3: waiting for object.pos_y: signal `Y` of message `P` (0x200) not received in the last 200 ms; not scored until it arrives (reported once)",
            ),
            (
                Problem::BadState { track: 2 },
                "track 2: state not finite or non-positive size: not scored",
            ),
            (
                Problem::TableFull {
                    track: 2,
                    capacity: 128,
                },
                "track 2: track table full (128): not scored",
            ),
            (
                Problem::Rejected(WarningError::NonFiniteScore { id: 2 }),
                "track 2: score is NaN",
            ),
            (
                Problem::WarningFrame {
                    track: 2,
                    cause: EncodeError::Signal {
                        signal: "Score".into(),
                        cause: SignalError::RawOverflow { value: 1e30 },
                    },
                },
                "track 2: warning frame not encodable: Score: value 1000000000000000000000000000000 does not fit the signal's raw range",
            ),
            (
                Problem::TrackIdDoesNotFit {
                    track: 501,
                    signal: "WarnTrackId".into(),
                    range: (0.0, 255.0),
                },
                "track 501: warning frames not sent: the id does not fit the warning message's WarnTrackId ([0, 255]); reported once per track",
            ),
            (
                Problem::WarningFrame {
                    track: 2,
                    cause: EncodeError::TooShortForE2e,
                },
                "track 2: warning frame not encodable: payload too short for E2E protection",
            ),
            (
                Problem::WarningFrame {
                    track: 2,
                    cause: EncodeError::FrameLength,
                },
                "track 2: warning frame not encodable: invalid frame length",
            ),
        ];
        for (problem, text) in cases {
            assert_eq!(problem.to_string(), text);
        }
    }
}
