//! The project's own DBC (`can-bridge/dbc/riskscore.dbc`) embedded, and the names in it that the
//! exporter and the bridge's default map refer to.

/// Text of `can-bridge/dbc/riskscore.dbc`.
pub const PROJECT_DBC: &str = include_str!("../../dbc/riskscore.dbc");

pub const EGO_MOTION: &str = "EGO_MOTION";
pub const EGO_SIZE: &str = "EGO_SIZE";
pub const OBJECT_POSITION: &str = "OBJECT_POSITION";
pub const OBJECT_MOTION: &str = "OBJECT_MOTION";
pub const OBJECT_SIZE: &str = "OBJECT_SIZE";
pub const RISK_WARNING: &str = "RISK_WARNING";

/// Default E2E data id of `RISK_WARNING`.
pub const WARNING_DATA_ID: u16 = 0x0A51;

/// Default nominal cycle of the exporter (10 Hz).
pub const CYCLE_US: u64 = 100_000;
