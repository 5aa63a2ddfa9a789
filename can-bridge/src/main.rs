//! `can-bridge`: the command line over the bridge library: parses, dispatches to
//! [`can_bridge::commands`] (or `check`, below) and turns a failure into its exit code.
use can_bridge::commands::{self, LiveArgs, MonitorArgs, ReplayArgs, ScoreLogArgs};
use clap::{Parser, Subcommand};
use std::process::ExitCode;
#[cfg(feature = "check")]
use {
    anyhow::{Context, Result},
    can_bridge::check,
    can_bridge::cli_values,
    can_bridge::commands::{
        engine_config, load_map, print_inputs, scoring_inputs, summary, LossArgs, ScoringArgs,
    },
    can_bridge::engine::Engine,
    can_bridge::losses,
    can_bridge::model_file::ModelFile,
    can_codec::output::{refuse_overlaps, AtomicFile, NamedPath},
    clap::Args,
    std::io::Write,
    std::path::PathBuf,
};

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
}

#[cfg(feature = "check")]
#[derive(Args, Debug)]
struct CheckArgs {
    /// candump -L log written by `riskctl events-to-candump` (or a recording of its replay).
    #[arg(long)]
    log: PathBuf,
    /// The event folder the log was made from.
    #[arg(long)]
    events: PathBuf,
    #[command(flatten)]
    scoring: ScoringArgs,
    /// Print the metrics as the `riskctl evaluate --json` object (same schema).
    #[arg(long)]
    json: bool,
    /// Pause between events used by events-to-candump (s).
    #[arg(long, default_value_t = riskscore_data::candump_export::DEFAULT_GAP_US as f64 / 1e6, value_parser = cli_values::seconds)]
    gap: f64,
    /// Write the event set as the bridge decoded it (an event folder); `riskctl evaluate --events`
    /// on it gives exactly this command's metrics.
    #[arg(long)]
    decoded_events_out: Option<PathBuf>,
    /// Write the per-event verdicts as JSON Lines here (with --json they are not printed).
    #[arg(long)]
    per_event_out: Option<PathBuf>,
    #[command(flatten)]
    loss: LossArgs,
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
    let result = match cli.command {
        Command::Live(a) => commands::run_live(a).map_err(failure),
        Command::Replay(a) => commands::run_replay(a).map_err(failure),
        Command::Monitor(a) => commands::run_monitor(a).map_err(failure),
        Command::ScoreLog(a) => commands::run_score_log(a).map_err(failure),
        #[cfg(feature = "check")]
        Command::Check(a) => run_check(a).map_err(|e| (1, e)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err((code, e)) => {
            eprintln!("can-bridge: error: {e:#}");
            ExitCode::from(code)
        }
    }
}

/// The exit code of a failed command, and what to print.
fn failure(f: commands::Failure) -> (u8, anyhow::Error) {
    (f.exit_code(), f.into())
}

#[cfg(feature = "check")]
fn run_check(args: CheckArgs) -> Result<()> {
    let model_file = ModelFile::load(&args.scoring.model)?;
    let map = load_map(&args.scoring)?;
    print_inputs(&map);
    let config = engine_config(&args.scoring, &model_file)?;
    let mut engine = Engine::new(model_file.model()?, map, config)?;
    let event_files = [
        args.events.join(riskscore_data::events::EVENTS_FILE),
        args.events.join(riskscore_data::events::FRAMES_FILE),
    ];
    let mut inputs = scoring_inputs(&args.scoring);
    inputs.push(("--log", args.log.as_path()));
    inputs.extend(event_files.iter().map(|p| ("--events", p.as_path())));
    let decoded_files = args.decoded_events_out.as_ref().map(|d| {
        [
            d.join(riskscore_data::events::EVENTS_FILE),
            d.join(riskscore_data::events::FRAMES_FILE),
        ]
    });
    let mut outputs: Vec<NamedPath<'_>> = decoded_files
        .iter()
        .flatten()
        .map(|p| ("--decoded-events-out", p.as_path()))
        .collect();
    if let Some(p) = &args.per_event_out {
        outputs.push(("--per-event-out", p.as_path()));
    }
    refuse_overlaps(&inputs, &outputs)?;
    let (set, issues) = riskscore_data::events::load_events(&args.events)
        .with_context(|| format!("loading events from {}", args.events.display()))?;
    for issue in issues.iter().take(20) {
        eprintln!("warning: {issue}");
    }
    let model = model_file.model()?;
    let report = check::check(
        &args.log,
        &set,
        &mut engine,
        riskscore_eval::scoring::model_row_name(&model),
        (args.gap * 1e6).round() as u64,
    )
    .with_context(|| {
        format!(
            "--log {} with --events {}",
            args.log.display(),
            args.events.display()
        )
    })?;
    losses::account(&args.log, &report.log, &report.losses, args.loss.max_lost)?;
    if let Some(dir) = &args.decoded_events_out {
        check::write_decoded_events(dir, &report.decoded)
            .with_context(|| format!("writing {}", dir.display()))?;
    }
    if let Some(p) = &args.per_event_out {
        write_verdicts(p, &report)?;
    }
    let (tp, pos, fa, neg) = report.warning_counts();
    let missing: usize = report
        .verdicts
        .iter()
        .map(|v| v.frames - v.scored.min(v.frames))
        .sum();
    let note = format!(
        "check: threshold {}: warned in time on {tp}/{pos} conflict events, false alarms on {fa}/{neg} safe events; {} event frames not scored by the bridge, {} bridge outputs not traced to an event; {}",
        report.threshold,
        missing,
        report.untraced,
        summary(&report.stats)
    );
    if args.json {
        println!("{}", report.report.to_json());
        eprintln!("{note}");
    } else {
        println!("{}", report.verdict_table());
        println!("{note}\n");
        println!("{}", report.report.to_markdown());
    }
    Ok(())
}

#[cfg(feature = "check")]
fn write_verdicts(path: &std::path::Path, report: &check::CheckReport) -> Result<()> {
    let mut w = AtomicFile::create(path).with_context(|| format!("creating {}", path.display()))?;
    for v in &report.verdicts {
        writeln!(w, "{}", serde_json::to_string(v)?)?;
    }
    w.commit()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
