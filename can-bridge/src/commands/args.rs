//! The command-line options of the bridge's subcommands (clap), shared by the binary and its
//! tests; each is checked when parsed ([`crate::cli_values`]).
use crate::{cli_values, replay};
use clap::Args;
use std::path::PathBuf;

/// Model, decoding and warning options shared by every scoring command.
#[derive(Args, Debug, Clone)]
pub struct ScoringArgs {
    /// Model blob (.rsk) written by `riskctl export-model`; refused at start if corrupt or
    /// built for another feature schema.
    #[arg(long)]
    pub model: PathBuf,
    /// DBC file, as `[BUS=]FILE`; repeat for several (e.g. the radar's, the chassis DBC for the
    /// ego speed and `builtin:riskscore` for the warning message). `FILE` describes every bus;
    /// `BUS=FILE` binds it to the interface BUS (`--dbc can1=radar.dbc`): a log line or live
    /// frame of that interface reads its messages and the unbound ones. An id defined in two
    /// files is an error only where they share a bus (same BUS, or one of them unbound). Default:
    /// the map's `[bus]` table, else the project's riskscore.dbc (`builtin:riskscore`).
    #[arg(long, value_name = "[BUS=]FILE", value_parser = cli_values::dbc)]
    pub dbc: Vec<PathBuf>,
    /// Map file naming the DBC signals of each input (default: the project's map; see
    /// docs/can-bridge.md, "Bring your own vehicle").
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Warn when the score is >= this (default: the model's default threshold stored in its blob,
    /// printed at start; for blobs without one, 2.0 for DRL = r*/2, half the score range for
    /// MSRA/GSSM).
    #[arg(long, value_parser = cli_values::finite_f32, allow_negative_numbers = true)]
    pub threshold: Option<f32>,
    /// Warning level 2 (urgent) when the score is >= this (at or above the warning threshold).
    #[arg(long, value_parser = cli_values::finite_f32, allow_negative_numbers = true)]
    pub urgent: Option<f32>,
    /// Release a warning when the score falls below threshold - hysteresis (>= 0).
    #[arg(long, default_value_t = 0.0, value_parser = cli_values::non_negative_f32)]
    pub hysteresis: f32,
    /// A warning stays on at least this long (ms, 0..=3600000).
    #[arg(long, default_value_t = 500, value_parser = cli_values::ms)]
    pub min_on_ms: u64,
    /// Inputs older than this are stale (not scored); tracks not updated for this long are dropped
    /// and their warnings released (ms, 1..=3600000).
    #[arg(long, default_value_t = 500, value_parser = cli_values::positive_ms)]
    pub stale_ms: u64,
    /// Latch warnings for the life of a track (evaluation semantics) instead of releasing them.
    #[arg(long)]
    pub latch: bool,
    /// Print at most this many per-frame problems (decode errors, stale data, ...) on stderr.
    #[arg(long, default_value_t = 20)]
    pub max_problems: u64,
}

#[derive(Args, Debug)]
pub struct LiveArgs {
    /// SocketCAN interface, e.g. can0 or vcan0; repeat for several buses (one timeline).
    #[arg(long, required = true, value_parser = cli_values::iface)]
    pub iface: Vec<String>,
    /// Several interfaces: how long (ms) a frame waits for the other interfaces to pass its
    /// timestamp before it is processed anyway (0..=1000).
    #[arg(long, default_value_t = crate::offline::DEFAULT_REORDER_MS, value_parser = cli_values::merge_wait_ms)]
    pub merge_wait_ms: u64,
    #[command(flatten)]
    pub scoring: ScoringArgs,
    /// Write JSON Lines warning events here instead of stdout (`-`: stdout).
    #[arg(long)]
    pub events_out: Option<PathBuf>,
    /// Also write one JSON line per scored track update.
    #[arg(long)]
    pub all_scores: bool,
    /// Seconds between status lines on stderr.
    #[arg(long, default_value_t = 1.0, value_parser = cli_values::positive_seconds)]
    pub status_every: f64,
    /// No status lines.
    #[arg(long)]
    pub no_status: bool,
    /// Stop after this many seconds.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    pub duration: Option<f64>,
    /// Stop after this many seconds without a received frame.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    pub idle_exit: Option<f64>,
}

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// candump -L log to send (`-`: standard input, e.g. `riskctl events-to-candump --out - |
    /// can-bridge replay --log - ...`).
    #[arg(long)]
    pub log: PathBuf,
    /// Interface to send on; repeat for several: each line goes to the interface it names.
    #[arg(long, required = true, value_parser = cli_values::iface)]
    pub iface: Vec<String>,
    /// Speed: 1.0 = original timing, 2.0 = twice as fast, `max` = as fast as possible.
    #[arg(long, default_value = "1.0")]
    pub rate: replay::Rate,
    #[command(flatten)]
    pub loss: LossArgs,
}

#[derive(Args, Debug)]
pub struct MonitorArgs {
    /// Interface to listen on.
    #[arg(long, value_parser = cli_values::iface)]
    pub iface: String,
    /// DBC file(s), as for the bridge: `[BUS=]FILE`, repeatable (default: the project's).
    #[arg(long, value_name = "[BUS=]FILE", value_parser = cli_values::dbc)]
    pub dbc: Vec<PathBuf>,
    /// Map file naming the warning message and the trigger message (default: the project's).
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Write received warning frames as candump -L lines here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Stop after this many seconds.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    pub duration: Option<f64>,
    /// Stop after this many seconds without a frame.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    pub idle_exit: Option<f64>,
    /// Exit with code 3 when any warning frame failed its E2E check.
    #[arg(long)]
    pub strict: bool,
}

#[derive(Args, Debug)]
pub struct ScoreLogArgs {
    /// candump -L log to score (`-`: standard input).
    #[arg(long)]
    pub log: PathBuf,
    #[command(flatten)]
    pub scoring: ScoringArgs,
    /// Write JSON Lines warning events here instead of stdout (`-`: stdout).
    #[arg(long)]
    pub events_out: Option<PathBuf>,
    /// Also write one JSON line per scored track update.
    #[arg(long)]
    pub all_scores: bool,
    /// Write the RISK_WARNING frames the bridge would send, as a candump -L log (`-`: stdout,
    /// then the events need --events-out FILE).
    #[arg(long)]
    pub warnings_out: Option<PathBuf>,
    /// Interface name for --warnings-out lines (at most 15 bytes; no whitespace, `#`, `(`, `)`).
    #[arg(long, default_value = "vcan0", value_parser = cli_values::iface)]
    pub warnings_iface: String,
    /// Print decode throughput (frames/s) with the summary.
    #[arg(long)]
    pub bench: bool,
    #[command(flatten)]
    pub reorder: ReorderArgs,
    #[command(flatten)]
    pub loss: LossArgs,
}

/// The reorder window of the offline commands (`score-log`, `check`, `decode`).
#[derive(Args, Debug, Clone, Copy)]
pub struct ReorderArgs {
    /// A log with several interfaces (`candump -L can0 can1` interleaves them with inversions of
    /// a few ms): frames are put in timestamp order within this window (ms, 0..=1000, 0 = off)
    /// before scoring, like live's merge; a frame further behind the newest is late (dropped).
    /// A log of one interface is read as it is.
    #[arg(long, default_value_t = crate::offline::DEFAULT_REORDER_MS, value_parser = cli_values::merge_wait_ms)]
    pub merge_wait_ms: u64,
}

/// How much of a log may be lost before the run fails.
#[derive(Args, Debug, Clone, Copy)]
pub struct LossArgs {
    /// Fail (exit 1) when more than this fraction of the log's lines is lost: lines that are not
    /// frames, not UTF-8 or too long, frames dropped as late or off the timeline, frames of
    /// mapped messages that do not decode (wrong length, signal out of range) and, for replay,
    /// frames the interface refused. Every loss is reported by line either way; 0 fails on any.
    #[arg(long, default_value_t = 0.01, value_parser = cli_values::fraction)]
    pub max_lost: f64,
}

/// Options of `check`: a log exported from an event folder, and that folder.
#[cfg(feature = "check")]
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// candump -L log written by `riskctl events-to-candump` (or a recording of its replay);
    /// `-`: standard input.
    #[arg(long)]
    pub log: PathBuf,
    /// The event folder the log was made from.
    #[arg(long)]
    pub events: PathBuf,
    #[command(flatten)]
    pub scoring: ScoringArgs,
    /// Print the metrics as JSON: `{"events": {...}, "methods": [...]}` with the same keys and
    /// values as those two members of `riskctl evaluate --json` (the model's row only); the
    /// other members of that object (`operating_points`, `domain`) are not part of it.
    #[arg(long)]
    pub json: bool,
    /// Pause between events used by events-to-candump (s).
    #[arg(long, default_value_t = riskscore_data::candump_export::DEFAULT_GAP_US as f64 / 1e6, value_parser = cli_values::seconds)]
    pub gap: f64,
    /// Write the event set as the bridge decoded it (an event folder); `riskctl evaluate --events`
    /// on it gives exactly this command's metrics.
    #[arg(long)]
    pub decoded_events_out: Option<PathBuf>,
    /// Write the per-event verdicts as JSON Lines here (with --json they are not printed).
    #[arg(long)]
    pub per_event_out: Option<PathBuf>,
    /// How far (m) a decoded partner position may lie from its event frame's (default: one
    /// resolution step of the mapped position signals, at least 0.01 m).
    #[arg(long, value_parser = cli_values::tolerance_m)]
    pub tolerance: Option<f64>,
    #[command(flatten)]
    pub reorder: ReorderArgs,
    #[command(flatten)]
    pub loss: LossArgs,
}

/// Options of `decode`: the decoding options of the scoring commands, the model optional.
#[cfg(feature = "check")]
#[derive(Args, Debug)]
pub struct DecodeArgs {
    /// candump -L log to decode (`-`: standard input).
    #[arg(long)]
    pub log: PathBuf,
    /// The state table: `.parquet` for Parquet, `-` for CSV on stdout, any other name CSV.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub scoring: DecodeScoringArgs,
    #[command(flatten)]
    pub reorder: ReorderArgs,
    #[command(flatten)]
    pub loss: LossArgs,
}

/// The [`ScoringArgs`] that decide which updates are scored; the model only adds a score column.
#[cfg(feature = "check")]
#[derive(Args, Debug, Clone)]
pub struct DecodeScoringArgs {
    /// Model blob: adds the `score` and `warning` columns (without it the states are the same).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// DBC file, as for `score-log`: `[BUS=]FILE`, repeatable; an id clash is an error only on
    /// the same bus (default: the map's `[bus]` table, else `builtin:riskscore`).
    #[arg(long, value_name = "[BUS=]FILE", value_parser = cli_values::dbc)]
    pub dbc: Vec<PathBuf>,
    /// Map file, as for `score-log` (default: the project's map).
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Warning threshold for the `warning` column (default: the model's); needs --model.
    #[arg(
        long,
        value_parser = cli_values::finite_f32,
        allow_negative_numbers = true,
        requires = "model"
    )]
    pub threshold: Option<f32>,
    /// Inputs older than this are stale (ms), as for `score-log`.
    #[arg(long, default_value_t = 500, value_parser = cli_values::positive_ms)]
    pub stale_ms: u64,
    /// Print at most this many per-frame problems on stderr.
    #[arg(long, default_value_t = 20)]
    pub max_problems: u64,
}

#[cfg(feature = "check")]
impl DecodeScoringArgs {
    /// The same options as a scoring command's (warning options at their defaults).
    pub fn as_scoring(&self) -> ScoringArgs {
        ScoringArgs {
            model: self.model.clone().unwrap_or_default(),
            dbc: self.dbc.clone(),
            map: self.map.clone(),
            threshold: self.threshold,
            urgent: None,
            hysteresis: 0.0,
            min_on_ms: 500,
            stale_ms: self.stale_ms,
            latch: false,
            max_problems: self.max_problems,
        }
    }
}
