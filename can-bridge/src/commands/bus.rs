//! The SocketCAN subcommands: `live` (score an interface), `monitor` (check the warning frames on
//! one) and `replay` (play a log onto one).
use super::setup::{
    creating, engine_config, load_map, nothing_scored, open_events, print_inputs, refuse_empty_log,
    scoring_inputs, summary, unsent_note, NothingScored,
};
use super::{writing, Failure, InputError, LiveArgs, MonitorArgs, ReplayArgs, ScoringArgs};
use crate::engine::Engine;
use crate::events_out::ProblemPrinter;
use crate::model_file::ModelFile;
use crate::{live, losses, monitor, replay};
use riskscore_output::{refuse_overlaps, NamedPath};
use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

/// A positive, finite number of seconds as a duration; anything else is "not set".
fn secs(s: Option<f64>) -> Option<Duration> {
    s.filter(|s| s.is_finite() && *s > 0.0)
        .map(Duration::from_secs_f64)
}

/// `can-bridge live`: scores the traffic of an interface until stopped.
pub fn run_live(args: LiveArgs) -> Result<(), Failure> {
    let model_file = ModelFile::load(&args.scoring.model)?;
    let map = load_map(&args.scoring)?;
    print_inputs(&map);
    let config = engine_config(&args.scoring, &model_file)?;
    let mut engine = Engine::new(model_file.blob()?, map, config)?;
    let outputs: Vec<NamedPath<'_>> = args
        .events_out
        .iter()
        .map(|p| ("--events-out", p.as_path()))
        .collect();
    refuse_overlaps(&scoring_inputs(&args.scoring), &outputs)?;
    let mut events = open_events(&args.events_out, args.all_scores, false)?;
    let mut problems = ProblemPrinter::new(args.scoring.max_problems);
    let opts = live::LiveOptions {
        ifaces: args.iface.clone(),
        merge_wait: Duration::from_millis(args.merge_wait_ms),
        status_every: Duration::from_secs_f64(args.status_every.max(0.05)),
        duration: secs(args.duration),
        idle_exit: secs(args.idle_exit),
        status: !args.no_status,
    };
    eprintln!(
        "can-bridge: live on {} with {} ({}), threshold {}",
        args.iface.join(" + "),
        args.scoring.model.display(),
        model_file.kind().name(),
        config.threshold
    );
    match live::run(&mut engine, &opts, &mut events, &mut problems) {
        Ok((reason, stats)) => {
            eprintln!("can-bridge: stopped ({reason:?}); {}", summary(&stats));
            if let Some(note) = unsent_note(&stats, engine.map()) {
                eprintln!("can-bridge: {note}");
            }
            problems.sanity.print("can-bridge");
            if let Some(NothingScored::NothingMapped(m) | NothingScored::NoUpdate(m)) =
                nothing_scored(&stats, 0)
            {
                eprintln!("can-bridge: {m}");
            }
            Ok(())
        }
        Err(e) => {
            eprintln!("can-bridge: {}", summary(engine.stats()));
            Err(Failure::Interface(e))
        }
    }
}

/// `can-bridge monitor`: receives the warning frames of an interface, checks their protection and
/// logs them.
pub fn run_monitor(args: MonitorArgs) -> Result<(), Failure> {
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
        refuse_overlaps(&inputs[1..], &[("--out", out.as_path())])?;
        riskscore_output::refuse_overwriting_a_model("--out", out, "a candump log")?;
    }
    let mut out: Box<dyn Write> = match &args.out {
        Some(p) => Box::new(std::io::BufWriter::new(
            riskscore_output::create_live_file(p).map_err(creating(p))?,
        )),
        None => Box::new(std::io::sink()),
    };
    let opts = monitor::MonitorOptions {
        iface: args.iface,
        duration: secs(args.duration),
        idle_exit: secs(args.idle_exit),
    };
    let report = monitor::run(&map, &opts, &mut out).map_err(Failure::Interface)?;
    out.flush().map_err(writing("--out", args.out.as_deref()))?;
    eprintln!("{}", report.summary());
    if args.strict && !report.all_protected_ok() {
        return Err(Failure::Protection);
    }
    Ok(())
}

/// `can-bridge replay`: sends a candump log onto an interface with its original timing.
pub fn run_replay(args: ReplayArgs) -> Result<(), Failure> {
    match replay::replay(&args.log, &args.iface, args.rate) {
        Ok(s) => {
            // An empty log is refused as score-log and check refuse it (no socket was opened for
            // one): a failed capture or a wrong path, never "0 frames sent".
            refuse_empty_log(&args.log, &s.log, "sent")?;
            eprintln!(
                "replay: {} frames sent in {:.3} s ({} log segments), {} not sent, {} bad lines, max lateness {:.3} ms",
                s.sent,
                s.elapsed.as_secs_f64(),
                crate::timeline::segment_count(s.log.frames as u64, s.segments),
                s.losses.total(),
                s.log.bad_lines(),
                s.max_late.as_secs_f64() * 1e3
            );
            Ok(losses::account(
                &args.log,
                &s.log,
                &s.losses,
                args.loss.max_lost,
            )?)
        }
        Err(replay::ReplayError::Socket(e)) => Err(Failure::Interface(e)),
        Err(e) => Err(Failure::Input(InputError::Replay(e))),
    }
}
