//! `can-bridge score-log`: a candump log scored offline by the same engine as live, with its
//! warning events, warning frames, losses and (with `--bench`) throughput and latency.
use super::setup::{
    creating, engine_config, load_map, open_events, print_inputs, refuse_empty_log,
    refuse_nothing_scored, refuse_stuck_timestamps, scoring_inputs, summary, unsent_note,
};
use super::{writing, Failure, InputError, ScoreLogArgs, SetupError};
use crate::cli_values::is_std_stream;
use crate::engine::{Engine, Output};
use crate::events_out::{ProblemPrinter, Sink};
use crate::logfile;
use crate::losses::{self, FrameLosses};
use crate::model_file::ModelFile;
use crate::offline::LogFeed;
use riskscore_output::{
    is_stdout, refuse_overlaps, refuse_overwriting_a_model, AtomicFile, NamedPath,
};
use std::io::Write;
use std::time::Instant;

/// Scores the log of `args`; every output is written only when the run succeeds.
pub fn run_score_log(args: ScoreLogArgs) -> Result<(), Failure> {
    let model_file = ModelFile::load(&args.scoring.model)?;
    let map = load_map(&args.scoring)?;
    print_inputs(&map);
    let config = engine_config(&args.scoring, &model_file)?;
    let mut engine = Engine::new(model_file.blob()?, map, config)?;
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
    if let Some(p) = &args.warnings_out {
        refuse_overwriting_a_model("--warnings-out", p, "a candump log of warning frames")?;
    }
    let mut events = open_events(&args.events_out, args.all_scores, true)?;
    let mut problems = ProblemPrinter::new(args.scoring.max_problems);
    problems.skip_lost = true;
    problems.log = Some(crate::logfile::line_name(&args.log));
    let mut losses = FrameLosses::default();
    // Frames on stdout (`-`, `/dev/stdout`, the file stdout is): then the events must go
    // elsewhere, else the two streams interleave.
    if let Some(warnings) = args.warnings_out.as_deref().filter(|p| is_stdout(p)) {
        if args.events_out.as_deref().is_none_or(is_stdout) {
            return Err(SetupError::BothToStdout {
                warnings: warnings.display().to_string(),
            }
            .into());
        }
    }
    let mut warnings: Option<Sink> = match &args.warnings_out {
        Some(p) if is_std_stream(p) => Some(Sink::Stdout(std::io::stdout())),
        Some(p) => Some(Sink::Atomic(AtomicFile::create(p).map_err(creating(p))?)),
        None => None,
    };
    // The first write error of each output (each names its own file).
    let mut warnings_error: Option<std::io::Error> = None;
    let mut events_error: Option<std::io::Error> = None;
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
                warnings_error.get_or_insert(e);
            }
        }
        if let Err(e) = events.handle(&o) {
            events_error.get_or_insert(e);
        }
        problems.handle(&o);
        losses.handle(&o);
    };
    let mut feed = LogFeed::new(args.reorder.merge_wait_ms);
    let report = logfile::for_each_frame(&args.log, |line_no, rec| {
        let frame_start = bench.then(Instant::now);
        feed.push(&mut engine, line_no as u64, rec, &mut |o: Output| {
            handle(o, frame_start)
        });
    })
    .map_err(|cause| InputError::Read {
        path: logfile::describe(&args.log),
        cause,
    })?;
    feed.finish(&mut engine, &mut |o: Output| handle(o, None));
    let elapsed = started.elapsed().as_secs_f64();
    let warnings_out = args.warnings_out.as_deref();
    let events_out = args.events_out.as_deref();
    if let Some(e) = warnings_error {
        return Err(writing("--warnings-out", warnings_out)(e));
    }
    if let Some(e) = events_error {
        return Err(writing("--events-out", events_out)(e));
    }
    let stats = engine.stats();
    eprintln!("score-log: {} lines; {}", report.lines, summary(stats));
    if let Some(note) = unsent_note(stats, engine.map()) {
        eprintln!("score-log: {note}");
    }
    if problems.suppressed > 0 {
        eprintln!(
            "score-log: {} more per-frame problems not printed",
            problems.suppressed
        );
    }
    problems.sanity.print("score-log");
    // The reasons first: a log nothing could be read from says why, line by line.
    losses::print_lost(&args.log, &report, &losses);
    refuse_empty_log(&args.log, &report, "scored")?;
    refuse_stuck_timestamps(&args.log, &report, stats)?;
    refuse_nothing_scored(stats, "score-log", report.bad_lines())?;
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
    losses::verdict(&args.log, &report, &losses, args.loss.max_lost)?;
    if let Some(w) = warnings {
        w.finish()
            .map_err(writing("--warnings-out", warnings_out))?;
    }
    events
        .finish()
        .map_err(writing("--events-out", events_out))?;
    Ok(())
}
