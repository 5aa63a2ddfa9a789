//! riskscore-data: the data riskscore learns from and scores, with no training or plotting
//! dependency. Every feature and surrogate is computed by `scorer-core`.
//!
//! - [`events`]: the event-folder format (load, validate, write, prepare sequences, folds).
//! - [`sim`]: the scenario simulator that writes event folders.
//! - [`import`]: recorded data from other formats (CommonRoad scenarios) as event folders.
//! - [`ssm_csv`]: streaming CSV scoring of ego/partner pairs (`riskctl ssm`).
//! - [`candump_export`]: event tables as 10 Hz vehicle CAN traffic in candump format.
//! - [`limits`]: user-set sizes checked against the cores, memory and disk before a run.
pub mod candump_export;
pub mod events;
pub mod import;
pub mod limits;
pub mod sim;
pub mod ssm_csv;
