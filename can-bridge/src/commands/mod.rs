//! The bridge's subcommands over the library: each takes its parsed options, runs, and says how it
//! failed; the binary only parses, dispatches and turns a [`Failure`] into its exit code.
//!
//! Files: `args` (the options), `setup` (DBCs, map, configuration, files), `bus` (`live`,
//! `monitor`, `replay`: SocketCAN), `score_log` (offline scoring of a candump log), `check` (the
//! bridge against `riskctl evaluate` on an exported event folder; feature `check`).
mod args;
mod bus;
#[cfg(feature = "check")]
mod check;
#[cfg(feature = "check")]
mod decode;
mod score_log;
mod setup;

#[cfg(feature = "check")]
pub use args::{CheckArgs, DecodeArgs, DecodeScoringArgs};
pub use args::{
    LiveArgs, LossArgs, MonitorArgs, ReorderArgs, ReplayArgs, ScoreLogArgs, ScoringArgs,
};
pub use bus::{run_live, run_monitor, run_replay};
#[cfg(feature = "check")]
pub use check::run_check;
#[cfg(feature = "check")]
pub use decode::run_decode;
pub use score_log::run_score_log;
pub use setup::{
    engine_config, load_dbcs, load_map, open_events, print_inputs, scoring_inputs, summary,
    SetupError, BUILTIN_DBC,
};

use crate::engine::ConfigError;
use crate::losses::TooMuchLost;
use crate::model_file::ModelFileError;
use crate::replay::ReplayError;
use crate::socket::SocketError;
use riskscore_output::SamePathError;

/// How a command failed; the exit code follows from the kind ([`Failure::exit_code`]).
#[derive(Debug, thiserror::Error)]
pub enum Failure {
    /// Bad input or configuration.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The CAN interface is missing or went away.
    #[error(transparent)]
    Interface(SocketError),
    /// `monitor --strict`: a warning frame failed its E2E check.
    #[error("warning frames failed their E2E check")]
    Protection,
}

impl Failure {
    /// 1 bad input or configuration, 2 CAN interface missing or gone, 3 a warning frame failed
    /// its E2E check.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Input(_) => 1,
            Self::Interface(_) => 2,
            Self::Protection => 3,
        }
    }
}

/// Bad input or configuration: a file, an option, or too much of a log lost.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error(transparent)]
    Setup(#[from] SetupError),
    #[error(transparent)]
    Model(#[from] ModelFileError),
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    SamePath(#[from] SamePathError),
    #[error("reading {path}")]
    Read {
        path: String,
        #[source]
        cause: std::io::Error,
    },
    #[error("writing {what} {path}")]
    Write {
        what: &'static str,
        path: String,
        #[source]
        cause: std::io::Error,
    },
    #[error(transparent)]
    Lost(#[from] TooMuchLost),
    /// Every frame of the log carries one timestamp (`drive.log: the timestamps do not advance...`).
    #[error("{0}")]
    StuckTimestamps(String),
    /// Frames came in but none was a message the map reads: the wrong DBC, map or bus names.
    #[error("{0}")]
    NothingMapped(String),
    #[error(transparent)]
    Replay(ReplayError),
    /// `check`: the event folder could not be loaded.
    #[cfg(feature = "check")]
    #[error("loading events from {}", dir.display())]
    Events {
        dir: std::path::PathBuf,
        #[source]
        source: riskscore_data::events::EventsError,
    },
    /// `check`: the decoded event folder could not be written.
    #[cfg(feature = "check")]
    #[error("writing --decoded-events-out")]
    DecodedEvents {
        #[source]
        source: riskscore_data::events::EventsError,
    },
    /// `check`: the log and the event folder do not line up.
    #[cfg(feature = "check")]
    #[error("--log {} with --events {}", log.display(), events.display())]
    Check {
        log: std::path::PathBuf,
        events: std::path::PathBuf,
        #[source]
        source: crate::check::CheckError,
    },
}

/// `?` on a setup step of a command.
impl From<SetupError> for Failure {
    fn from(e: SetupError) -> Self {
        Self::Input(e.into())
    }
}

impl From<ModelFileError> for Failure {
    fn from(e: ModelFileError) -> Self {
        Self::Input(e.into())
    }
}

impl From<ConfigError> for Failure {
    fn from(e: ConfigError) -> Self {
        Self::Input(e.into())
    }
}

impl From<SamePathError> for Failure {
    fn from(e: SamePathError) -> Self {
        Self::Input(e.into())
    }
}

/// A model blob or checkpoint an output would replace (`riskscore_output::refuse_overwriting_a_model`).
impl From<riskscore_output::ExistingFileError> for Failure {
    fn from(e: riskscore_output::ExistingFileError) -> Self {
        SetupError::from(e).into()
    }
}

impl From<TooMuchLost> for Failure {
    fn from(e: TooMuchLost) -> Self {
        Self::Input(e.into())
    }
}

/// A write to the output of option `what` (`path`; `None`: standard output) failed.
fn writing(
    what: &'static str,
    path: Option<&std::path::Path>,
) -> impl FnOnce(std::io::Error) -> Failure {
    let path = path.map_or("(standard output)".to_string(), |p| p.display().to_string());
    move |cause| Failure::Input(InputError::Write { what, path, cause })
}
