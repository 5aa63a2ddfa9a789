//! `can-bridge`: the command line over the bridge library: parses, dispatches to
//! [`can_bridge::commands`] and turns a failure into its exit code.
use can_bridge::commands::{self, LiveArgs, MonitorArgs, ReplayArgs, ScoreLogArgs};
#[cfg(feature = "check")]
use can_bridge::commands::{CheckArgs, DecodeArgs};
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Score vehicle CAN traffic with a riskscore model and put protected warnings back on the bus.
///
/// Live: `can-bridge --iface vcan0 --model models/drl-default.rsk` (same as `can-bridge live ...`).
/// Logs: `score-log` scores a candump -L log offline, `replay` plays one onto an interface,
/// `check` compares the bridge with `riskctl evaluate` on an exported event folder.
///
/// Inputs are decoded with a DBC (default: the project's can-bridge/dbc/riskscore.dbc) through a
/// map file that names the signals (default: can-bridge/maps/riskscore.toml). Exit codes: 0 done,
/// 1 bad input or configuration (model, DBC, map, files), 2 CAN interface missing or gone,
/// 3 (`monitor --strict`) a warning frame failed its E2E check.
#[derive(Parser, Debug)]
#[command(name = "can-bridge", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Score live traffic on a SocketCAN interface (the default command).
    Live(LiveArgs),
    /// Send a candump -L log onto an interface with its original timing (per log segment; late
    /// and far-off frames are not sent, as score-log does not score them).
    Replay(ReplayArgs),
    /// Score a candump -L log offline (no CAN socket); same engine and results as live.
    ScoreLog(ScoreLogArgs),
    /// Receive the bridge's warning frames on a second socket: verify their E2E protection (CRC,
    /// alive counter), log them as candump -L, measure trigger-frame-to-warning latency.
    Monitor(MonitorArgs),
    /// Per-event warnings of the bridge and the `riskctl evaluate` metrics for a log made by
    /// `riskctl events-to-candump`.
    #[cfg(feature = "check")]
    Check(CheckArgs),
    /// Write every scored track update of a candump log as the scorer saw it (ego and partner
    /// state in the ego frame, derived/defaulted flags) to CSV or Parquet, and check it for
    /// signs of a map mistake (units, signs, sensor offsets).
    #[cfg(feature = "check")]
    Decode(DecodeArgs),
}

/// `can-bridge --iface ...` means `can-bridge live --iface ...`.
fn args_with_default_command() -> Vec<std::ffi::OsString> {
    let mut argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let starts_with_option = argv.get(1).is_some_and(|a| {
        let a = a.to_string_lossy();
        a.starts_with('-') && !matches!(a.as_ref(), "-h" | "--help" | "-V" | "--version")
    });
    if starts_with_option {
        argv.insert(1, "live".into());
    }
    argv
}

fn main() -> ExitCode {
    // Usage errors exit 1 (bad input), not clap's 2, which means "CAN interface missing" here.
    let cli = match Cli::try_parse_from(args_with_default_command()) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    // The commands that write files: Ctrl-C / SIGTERM remove the output layer's temporaries
    // and leave old outputs as they were (N166). Live and monitor keep the default signals.
    if matches!(cli.command, Command::ScoreLog(_)) || writes_check_outputs(&cli.command) {
        if let Err(e) = riskscore_output::remove_temporaries_on_signals() {
            eprintln!("can-bridge: warning: cannot install the Ctrl-C handler: {e}");
        }
    }
    let result = match cli.command {
        Command::Live(a) => commands::run_live(a).map_err(failure),
        Command::Replay(a) => commands::run_replay(a).map_err(failure),
        Command::Monitor(a) => commands::run_monitor(a).map_err(failure),
        Command::ScoreLog(a) => commands::run_score_log(a).map_err(failure),
        #[cfg(feature = "check")]
        Command::Check(a) => commands::run_check(a).map_err(failure),
        #[cfg(feature = "check")]
        Command::Decode(a) => commands::run_decode(a).map_err(failure),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err((code, e)) => {
            eprintln!("can-bridge: error: {}", chain_text(&e));
            ExitCode::from(code)
        }
    }
}

/// The error and its causes joined by ": ", like `{:#}`, but a cause is left out when the text
/// before it already ends with it (an error that prints its source, then the source itself).
fn chain_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let cause = cause.to_string();
        if text.ends_with(&cause) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&cause);
    }
    text
}

#[cfg(feature = "check")]
fn writes_check_outputs(c: &Command) -> bool {
    matches!(c, Command::Check(_) | Command::Decode(_))
}

#[cfg(not(feature = "check"))]
fn writes_check_outputs(_: &Command) -> bool {
    false
}

/// The exit code of a failed command, and what to print.
fn failure(f: commands::Failure) -> (u8, anyhow::Error) {
    (f.exit_code(), f.into())
}
