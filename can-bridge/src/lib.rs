//! `can-bridge`: scores vehicle CAN traffic through `scorer-core` and puts protected warnings back
//! on the bus. Live on SocketCAN, or offline from candump logs; both run the same [`engine`].
//!
//! - [`map`]: the map file (which DBC signals feed the scorer), compiled against a DBC.
//! - [`cli_values`]: range and finiteness checks of numeric command-line options.
//! - [`engine`]: frames in, scored tracks / warning frames / warning events out (no I/O, no clock).
//! - [`model_file`]: loading and checking a model blob.
//! - [`timeline`]: late frames, timestamp glitches and new log segments.
//! - [`logfile`]: reading candump -L logs with line-numbered problems.
//! - [`offline`]: how a log's records reach the engine offline (bus routing, reorder window).
//! - [`losses`]: what a run lost, by log line, and the `--max-lost` verdict.
//! - [`events_out`]: JSON Lines warning events and the status line.
//! - [`sanity`]: the run-end report on decoded states that look like a map mistake.
//! - [`states_out`]: `decode`'s table of scored states (CSV/Parquet).
//! - [`check`]: bridge vs offline evaluation on an exported event folder.
//! - [`commands`]: the subcommands' options and bodies (the binary parses and dispatches).
//! - [`socket`], [`live`], [`replay`], [`monitor`]: SocketCAN (Linux).
//!
//! The CAN wire format (DBC signals, candump lines, E2E protection) lives in `can-codec`.
#[cfg(feature = "check")]
pub mod check;
pub mod cli_values;
pub mod commands;
pub mod engine;
pub mod events_out;
pub mod live;
pub mod logfile;
pub mod losses;
pub mod map;
pub mod model_file;
pub mod monitor;
pub mod offline;
pub mod replay;
pub mod sanity;
pub mod socket;
#[cfg(feature = "check")]
pub mod states_out;
pub mod timeline;

pub use engine::{Engine, EngineConfig, Output, Stats};
pub use map::{CompiledMap, MapFile};
pub use model_file::ModelFile;
