//! `can-codec`: the CAN wire codec shared by the bridge and `riskctl`.
//!
//! One layer per module, no socket and no scoring in here:
//! - [`frame`]: a CAN frame (standard/extended id; data, remote, FD, error).
//! - [`candump`]: `candump -L` log lines, parsed and written.
//! - [`signal`]: packing one DBC signal (Intel/Motorola, sign, float, scale/offset, range).
//! - [`dbc`]: a DBC file (parsed by `can-dbc`) compiled into messages and signals, with
//!   multiplexing.
//! - [`e2e`]: end-to-end protection (4-bit alive counter + CRC-8 SAE J1850 over data id and payload).
//! - [`project`]: the project's own DBC and the names the bridge and exporter use.
pub mod candump;
pub mod dbc;
pub mod e2e;
pub mod frame;
pub mod project;
pub mod signal;

pub use candump::{
    check_iface_name, format_line, parse_line, Direction, LineError, LogRecord, MAX_IFACE_BYTES,
};
pub use dbc::{Database, DbcError, DbcFileError, MessageSpec};
pub use e2e::{crc8_sae_j1850, E2eChecker, E2eConfig, E2eProtector, E2eStatus};
pub use frame::{CanId, Frame, FrameKind};
pub use signal::{ByteOrder, SignalError, SignalSpec, ValueKind};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_dbc_parses_and_round_trips_every_message() {
        let db = Database::parse(project::PROJECT_DBC).unwrap();
        for name in [
            project::EGO_MOTION,
            project::EGO_SIZE,
            project::OBJECT_POSITION,
            project::OBJECT_MOTION,
            project::OBJECT_SIZE,
            project::RISK_WARNING,
        ] {
            let m = db.message_by_name(name).unwrap();
            // Write a distinct in-range value into every signal and read it back.
            let values: Vec<(&str, f64)> = m
                .signals
                .iter()
                .enumerate()
                .map(|(i, s)| {
                    let v = if s.has_range() {
                        s.min + (s.max - s.min) * (0.1 + 0.07 * i as f64)
                    } else {
                        1.25 + i as f64
                    };
                    (s.name.as_str(), v)
                })
                .collect();
            let data = m.encode(&values).unwrap();
            assert_eq!(data.len(), m.size);
            for (i, (sig, v)) in values.iter().enumerate() {
                let got = m.value(i, &data).unwrap().unwrap();
                let step = m.signals[i].factor.abs();
                assert!(
                    (got - v).abs() <= step / 2.0 + 1e-9,
                    "{name}.{sig}: {got} vs {v}"
                );
            }
        }
    }
}
