//! `can-bridge`: the command line over the bridge library. Each subcommand is one function here.
use anyhow::{Context, Result};
#[cfg(feature = "check")]
use can_bridge::check;
use can_bridge::engine::{Engine, EngineConfig, Output};
use can_bridge::events_out::{EventWriter, ProblemPrinter, Sink};
use can_bridge::losses::{self, FrameLosses};
use can_bridge::map::{CompiledMap, MapFile, DEFAULT_MAP};
use can_bridge::model_file::ModelFile;
use can_bridge::{cli_values, live, logfile, monitor, replay};
use can_codec::output::{refuse_overlaps, AtomicFile, NamedPath};
use can_codec::Database;
use clap::{Args, Parser, Subcommand};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

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

/// Model, decoding and warning options shared by every scoring command.
#[derive(Args, Debug, Clone)]
struct ScoringArgs {
    /// Model blob (.rsk) written by `riskctl export-model`; refused at start if corrupt or
    /// built for another feature schema.
    #[arg(long)]
    model: PathBuf,
    /// DBC file of the bus; repeat for several (e.g. the radar's, the chassis DBC for the ego
    /// speed and `builtin:riskscore` for the warning message). An id defined in two files is an
    /// error. Default: the project's riskscore.dbc (`builtin:riskscore`).
    #[arg(long)]
    dbc: Vec<PathBuf>,
    /// Map file naming the DBC signals of each input (default: the project's map; see
    /// docs/can-bridge.md, "Bring your own vehicle").
    #[arg(long)]
    map: Option<PathBuf>,
    /// Warn when the score is >= this (default: 2.0 for DRL = r*/2, half the score range for
    /// MSRA/GSSM).
    #[arg(long, value_parser = cli_values::finite_f32)]
    threshold: Option<f32>,
    /// Warning level 2 (urgent) when the score is >= this.
    #[arg(long, value_parser = cli_values::finite_f32)]
    urgent: Option<f32>,
    /// Release a warning when the score falls below threshold - hysteresis (>= 0).
    #[arg(long, default_value_t = 0.0, value_parser = cli_values::non_negative_f32)]
    hysteresis: f32,
    /// A warning stays on at least this long (ms, 0..=3600000).
    #[arg(long, default_value_t = 500, value_parser = cli_values::ms)]
    min_on_ms: u64,
    /// Inputs older than this are stale (not scored); tracks not updated for this long are dropped
    /// and their warnings released (ms, 1..=3600000).
    #[arg(long, default_value_t = 500, value_parser = cli_values::positive_ms)]
    stale_ms: u64,
    /// Latch warnings for the life of a track (evaluation semantics) instead of releasing them.
    #[arg(long)]
    latch: bool,
    /// Print at most this many per-frame problems (decode errors, stale data, ...) on stderr.
    #[arg(long, default_value_t = 20)]
    max_problems: u64,
}

#[derive(Args, Debug)]
struct LiveArgs {
    /// SocketCAN interface, e.g. can0 or vcan0.
    #[arg(long)]
    iface: String,
    #[command(flatten)]
    scoring: ScoringArgs,
    /// Write JSON Lines warning events here instead of stdout.
    #[arg(long)]
    events_out: Option<PathBuf>,
    /// Also write one JSON line per scored track update.
    #[arg(long)]
    all_scores: bool,
    /// Seconds between status lines on stderr.
    #[arg(long, default_value_t = 1.0, value_parser = cli_values::positive_seconds)]
    status_every: f64,
    /// No status lines.
    #[arg(long)]
    no_status: bool,
    /// Stop after this many seconds.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    duration: Option<f64>,
    /// Stop after this many seconds without a received frame.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    idle_exit: Option<f64>,
}

#[derive(Args, Debug)]
struct ReplayArgs {
    /// candump -L log to send.
    #[arg(long)]
    log: PathBuf,
    /// Interface to send on.
    #[arg(long)]
    iface: String,
    /// Speed: 1.0 = original timing, 2.0 = twice as fast, `max` = as fast as possible.
    #[arg(long, default_value = "1.0")]
    rate: replay::Rate,
    #[command(flatten)]
    loss: LossArgs,
}

#[derive(Args, Debug)]
struct MonitorArgs {
    /// Interface to listen on.
    #[arg(long)]
    iface: String,
    /// DBC file(s), as for the bridge (default: the project's).
    #[arg(long)]
    dbc: Vec<PathBuf>,
    /// Map file naming the warning message and the trigger message (default: the project's).
    #[arg(long)]
    map: Option<PathBuf>,
    /// Write received warning frames as candump -L lines here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Stop after this many seconds.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    duration: Option<f64>,
    /// Stop after this many seconds without a frame.
    #[arg(long, value_parser = cli_values::positive_seconds)]
    idle_exit: Option<f64>,
    /// Exit with code 3 when any warning frame failed its E2E check.
    #[arg(long)]
    strict: bool,
}

#[derive(Args, Debug)]
struct ScoreLogArgs {
    /// candump -L log to score.
    #[arg(long)]
    log: PathBuf,
    #[command(flatten)]
    scoring: ScoringArgs,
    /// Write JSON Lines warning events here instead of stdout.
    #[arg(long)]
    events_out: Option<PathBuf>,
    /// Also write one JSON line per scored track update.
    #[arg(long)]
    all_scores: bool,
    /// Write the RISK_WARNING frames the bridge would send, as a candump -L log.
    #[arg(long)]
    warnings_out: Option<PathBuf>,
    /// Interface name for --warnings-out lines.
    #[arg(long, default_value = "vcan0")]
    warnings_iface: String,
    /// Print decode throughput (frames/s) with the summary.
    #[arg(long)]
    bench: bool,
    #[command(flatten)]
    loss: LossArgs,
}

/// How much of a log may be lost before the run fails.
#[derive(Args, Debug, Clone, Copy)]
struct LossArgs {
    /// Fail (exit 1) when more than this fraction of the log's lines is lost: lines that are not
    /// frames, not UTF-8 or too long, frames dropped as late or off the timeline, frames of
    /// mapped messages that do not decode (wrong length, signal out of range) and, for replay,
    /// frames the interface refused. Every loss is reported by line either way; 0 fails on any.
    #[arg(long, default_value_t = 0.01, value_parser = cli_values::fraction)]
    max_lost: f64,
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

/// Exit code 2: the CAN interface is missing or went away.
struct InterfaceError(anyhow::Error);

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
        Command::Live(a) => run_live(a),
        Command::Replay(a) => run_replay(a),
        Command::Monitor(a) => run_monitor(a),
        Command::ScoreLog(a) => run_score_log(a).map_err(Failure::Input),
        #[cfg(feature = "check")]
        Command::Check(a) => run_check(a).map_err(Failure::Input),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(e)) => {
            eprintln!("can-bridge: error: {e:#}");
            ExitCode::from(1)
        }
        Err(Failure::Interface(InterfaceError(e))) => {
            eprintln!("can-bridge: error: {e:#}");
            ExitCode::from(2)
        }
        Err(Failure::Protection(e)) => {
            eprintln!("can-bridge: error: {e:#}");
            ExitCode::from(3)
        }
    }
}

enum Failure {
    Input(anyhow::Error),
    Interface(InterfaceError),
    Protection(anyhow::Error),
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Input(e)
    }
}

impl From<can_bridge::model_file::ModelFileError> for Failure {
    fn from(e: can_bridge::model_file::ModelFileError) -> Self {
        Failure::Input(e.into())
    }
}

/// The project DBC, compiled in, as a `--dbc` argument.
const BUILTIN_DBC: &str = "builtin:riskscore";

/// Every `--dbc` file as one database; an id defined in two files names both.
fn load_dbcs(paths: &[PathBuf]) -> Result<Database> {
    let builtin = [PathBuf::from(BUILTIN_DBC)];
    let paths = if paths.is_empty() {
        &builtin[..]
    } else {
        paths
    };
    let mut db = Database::default();
    let mut origin: std::collections::HashMap<can_codec::CanId, (String, &PathBuf)> =
        std::collections::HashMap::new();
    for p in paths {
        let one = if p.as_os_str() == BUILTIN_DBC {
            Database::parse(can_codec::project::PROJECT_DBC).context("project DBC")?
        } else {
            Database::load(p)?
        };
        for m in &one.messages {
            if let Some((name, first)) = origin.get(&m.id) {
                anyhow::bail!(
                    "message id 0x{} is defined twice: `{name}` in {} and `{}` in {}",
                    m.id,
                    first.display(),
                    m.name,
                    p.display()
                );
            }
        }
        for m in &one.messages {
            origin.insert(m.id, (m.name.clone(), p));
        }
        db.merge(one)
            .map_err(|id| anyhow::anyhow!("message id 0x{id} is defined twice"))?;
    }
    Ok(db)
}

fn load_map(args: &ScoringArgs) -> Result<CompiledMap> {
    let db = load_dbcs(&args.dbc)?;
    let map = match &args.map {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("reading map {}", p.display()))?;
            MapFile::parse(&text).with_context(|| format!("map {}", p.display()))?
        }
        None => MapFile::parse(DEFAULT_MAP).context("default map")?,
    };
    CompiledMap::compile(&map, &db).with_context(|| {
        format!(
            "map {} against DBC {}",
            args.map
                .as_ref()
                .map_or("(default)".into(), |p| p.display().to_string()),
            if args.dbc.is_empty() {
                "(project)".to_string()
            } else {
                args.dbc
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(" + ")
            }
        )
    })
}

/// Says where every scorer input comes from and which are derived or defaulted.
fn print_inputs(map: &CompiledMap) {
    for line in map.input_report() {
        eprintln!("can-bridge: input {line}");
    }
}

fn engine_config(args: &ScoringArgs, model: &ModelFile) -> Result<EngineConfig> {
    let threshold = match args.threshold {
        Some(t) => t,
        None => can_bridge::default_threshold(&model.model()?),
    };
    anyhow::ensure!(threshold.is_finite(), "--threshold must be finite");
    Ok(EngineConfig {
        threshold,
        urgent: args.urgent,
        hysteresis: args.hysteresis,
        min_on_us: args.min_on_ms * 1000,
        stale_us: args.stale_ms * 1000,
        latch: args.latch,
    })
}

/// JSON Lines events to stdout or `path`: offline (`atomic`) through a temporary file renamed at
/// the end of a successful run, live written as it goes.
fn open_events(path: &Option<PathBuf>, all_scores: bool, atomic: bool) -> Result<EventWriter> {
    let out = match path {
        Some(p) if atomic => Sink::Atomic(
            AtomicFile::create(p).with_context(|| format!("creating {}", p.display()))?,
        ),
        Some(p) => Sink::Streaming(std::io::BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("creating {}", p.display()))?,
        )),
        None => Sink::Stdout(std::io::stdout()),
    };
    Ok(EventWriter::new(out, all_scores))
}

/// The files a scoring command reads, named by their option.
fn scoring_inputs(args: &ScoringArgs) -> Vec<NamedPath<'_>> {
    let mut v: Vec<NamedPath<'_>> = vec![("--model", args.model.as_path())];
    for p in args.dbc.iter().filter(|p| p.as_os_str() != BUILTIN_DBC) {
        v.push(("--dbc", p.as_path()));
    }
    if let Some(p) = &args.map {
        v.push(("--map", p.as_path()));
    }
    v
}

fn run_live(args: LiveArgs) -> Result<(), Failure> {
    let model_file = ModelFile::load(&args.scoring.model)?;
    let map = load_map(&args.scoring)?;
    print_inputs(&map);
    let config = engine_config(&args.scoring, &model_file)?;
    let mut engine = Engine::new(model_file.model()?, map, config).map_err(anyhow::Error::from)?;
    let outputs: Vec<NamedPath<'_>> = args
        .events_out
        .iter()
        .map(|p| ("--events-out", p.as_path()))
        .collect();
    refuse_overlaps(&scoring_inputs(&args.scoring), &outputs).map_err(anyhow::Error::from)?;
    let mut events = open_events(&args.events_out, args.all_scores, false)?;
    let mut problems = ProblemPrinter::new(args.scoring.max_problems);
    let secs = |s: Option<f64>| {
        s.filter(|s| s.is_finite() && *s > 0.0)
            .map(Duration::from_secs_f64)
    };
    let opts = live::LiveOptions {
        iface: args.iface.clone(),
        status_every: Duration::from_secs_f64(args.status_every.max(0.05)),
        duration: secs(args.duration),
        idle_exit: secs(args.idle_exit),
        status: !args.no_status,
    };
    eprintln!(
        "can-bridge: live on {} with {} ({}), threshold {}",
        args.iface,
        args.scoring.model.display(),
        model_file.kind().name(),
        config.threshold
    );
    match live::run(&mut engine, &opts, &mut events, &mut problems) {
        Ok((reason, stats)) => {
            eprintln!("can-bridge: stopped ({reason:?}); {}", summary(&stats));
            Ok(())
        }
        Err(e) => {
            eprintln!("can-bridge: {}", summary(engine.stats()));
            Err(Failure::Interface(InterfaceError(e.into())))
        }
    }
}

fn run_monitor(args: MonitorArgs) -> Result<(), Failure> {
    let scoring = ScoringArgs {
        model: PathBuf::new(),
        dbc: args.dbc.clone(),
        map: args.map.clone(),
        threshold: None,
        urgent: None,
        hysteresis: 0.0,
        min_on_ms: 0,
        stale_ms: 1,
        latch: false,
        max_problems: 0,
    };
    let map = load_map(&scoring)?;
    if let Some(out) = &args.out {
        let inputs = scoring_inputs(&scoring);
        refuse_overlaps(&inputs[1..], &[("--out", out.as_path())]).map_err(anyhow::Error::from)?;
    }
    let mut out: Box<dyn Write> = match &args.out {
        Some(p) => Box::new(std::io::BufWriter::new(
            std::fs::File::create(p)
                .with_context(|| format!("creating {}", p.display()))
                .map_err(Failure::Input)?,
        )),
        None => Box::new(std::io::sink()),
    };
    let secs = |s: Option<f64>| {
        s.filter(|s| s.is_finite() && *s > 0.0)
            .map(Duration::from_secs_f64)
    };
    let opts = monitor::MonitorOptions {
        iface: args.iface,
        duration: secs(args.duration),
        idle_exit: secs(args.idle_exit),
    };
    let report = monitor::run(&map, &opts, &mut out)
        .map_err(|e| Failure::Interface(InterfaceError(e.into())))?;
    out.flush()
        .context("writing --out")
        .map_err(Failure::Input)?;
    eprintln!("{}", report.summary());
    if args.strict && !report.all_protected_ok() {
        return Err(Failure::Protection(anyhow::anyhow!(
            "warning frames failed their E2E check"
        )));
    }
    Ok(())
}

fn summary(s: &can_bridge::Stats) -> String {
    format!(
        "{} frames, {} scored, {} warning frames, {} decode errors, {} stale drops, {} invalid objects, {} reordered, {} off the timeline, {} log segments, {} duplicates, {} unknown ids, {} remote, {} error frames ({} bus-off), {} tracks dropped, {} table full, {} new objects, {} awaiting motion",
        s.frames, s.scored, s.warning_frames, s.decode_errors, s.stale_drops, s.invalid_objects,
        s.reordered, s.out_of_window, s.segments + 1, s.duplicates, s.unknown_ids, s.remote_frames,
        s.error_frames, s.bus_off, s.tracks_dropped, s.table_full, s.new_objects, s.motion_pending
    )
}

fn run_replay(args: ReplayArgs) -> Result<(), Failure> {
    match replay::replay(&args.log, &args.iface, args.rate) {
        Ok(s) => {
            eprintln!(
                "replay: {} frames sent in {:.3} s ({} log segments), {} not sent, {} bad lines, max lateness {:.3} ms",
                s.sent,
                s.elapsed.as_secs_f64(),
                s.segments + 1,
                s.losses.total(),
                s.log.bad_lines(),
                s.max_late.as_secs_f64() * 1e3
            );
            losses::account(&args.log, &s.log, &s.losses, args.loss.max_lost)
                .map_err(|e| Failure::Input(e.into()))
        }
        Err(replay::ReplayError::Socket(e)) => Err(Failure::Interface(InterfaceError(e.into()))),
        Err(e) => Err(Failure::Input(e.into())),
    }
}

fn run_score_log(args: ScoreLogArgs) -> Result<()> {
    let model_file = ModelFile::load(&args.scoring.model)?;
    let map = load_map(&args.scoring)?;
    print_inputs(&map);
    let config = engine_config(&args.scoring, &model_file)?;
    let mut engine = Engine::new(model_file.model()?, map, config)?;
    let mut inputs = scoring_inputs(&args.scoring);
    inputs.push(("--log", args.log.as_path()));
    let outputs: Vec<NamedPath<'_>> = [
        ("--events-out", &args.events_out),
        ("--warnings-out", &args.warnings_out),
    ]
    .into_iter()
    .filter_map(|(flag, p)| p.as_deref().map(|p| (flag, p)))
    .collect();
    refuse_overlaps(&inputs, &outputs)?;
    let mut events = open_events(&args.events_out, args.all_scores, true)?;
    let mut problems = ProblemPrinter::new(args.scoring.max_problems);
    problems.skip_lost = true;
    let mut losses = FrameLosses::default();
    let mut warnings: Option<AtomicFile> = match &args.warnings_out {
        Some(p) => {
            Some(AtomicFile::create(p).with_context(|| format!("creating {}", p.display()))?)
        }
        None => None,
    };
    let mut io_error: Option<std::io::Error> = None;
    let mut line = String::new();
    let started = Instant::now();
    // --bench: time from handing a frame to the engine to its warning frame (compute latency).
    let mut warn_latency_ns: Vec<u64> = Vec::new();
    let bench = args.bench;
    let mut handle = |o: Output, frame_start: Option<Instant>| {
        if let (Output::WarningFrame { .. }, Some(t0)) = (&o, frame_start) {
            warn_latency_ns.push(t0.elapsed().as_nanos() as u64);
        }
        if let (Output::WarningFrame { t_us, frame, .. }, Some(w)) = (&o, warnings.as_mut()) {
            line.clear();
            can_codec::format_line(&mut line, *t_us, &args.warnings_iface, frame);
            line.push('\n');
            if let Err(e) = w.write_all(line.as_bytes()) {
                io_error.get_or_insert(e);
            }
        }
        if let Err(e) = events.handle(&o) {
            io_error.get_or_insert(e);
        }
        problems.handle(&o);
        losses.handle(&o);
    };
    let report = logfile::for_each_frame(&args.log, |line_no, rec| {
        let frame_start = bench.then(Instant::now);
        engine.process_from(
            rec.timestamp_us,
            &rec.frame,
            line_no as u64,
            &mut |o: Output| handle(o, frame_start),
        );
    })
    .with_context(|| format!("reading {}", args.log.display()))?;
    engine.finish(&mut |o: Output| handle(o, None));
    let elapsed = started.elapsed().as_secs_f64();
    if let Some(e) = io_error {
        return Err(anyhow::Error::from(e).context("writing outputs"));
    }
    let stats = engine.stats();
    eprintln!("score-log: {} lines; {}", report.lines, summary(stats));
    if problems.suppressed > 0 {
        eprintln!(
            "score-log: {} more per-frame problems not printed",
            problems.suppressed
        );
    }
    if args.bench {
        eprintln!(
            "score-log: {:.0} frames/s ({} frames in {:.3} s, one thread, parse + decode + score)",
            report.frames as f64 / elapsed.max(1e-9),
            report.frames,
            elapsed
        );
        warn_latency_ns.sort_unstable();
        let q = |p: f64| {
            let n = warn_latency_ns.len();
            (n > 0).then(|| warn_latency_ns[((p * n as f64).ceil() as usize).clamp(1, n) - 1])
        };
        if let (Some(p50), Some(p99)) = (q(0.5), q(0.99)) {
            eprintln!(
                "score-log: trigger frame -> warning frame in the engine: p50 {:.2} us, p99 {:.2} us ({} warning frames)",
                p50 as f64 / 1e3,
                p99 as f64 / 1e3,
                warn_latency_ns.len()
            );
        }
    }
    losses::account(&args.log, &report, &losses, args.loss.max_lost)?;
    if let Some(w) = warnings {
        w.commit().context("writing --warnings-out")?;
    }
    events.finish().context("writing --events-out")?;
    Ok(())
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
