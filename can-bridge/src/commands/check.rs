//! `check`: the bridge's per-event warnings and the `riskctl evaluate` metrics for a log that
//! `riskctl events-to-candump` exported from an event folder.
use std::io::Write;
use std::path::Path;

use riskscore_output::{
    is_stdout, refuse_overlaps, refuse_overwriting_a_model, AtomicFile, NamedPath,
};

use super::args::CheckArgs;
use super::setup::{engine_config, load_map, print_inputs, scoring_inputs, summary};
use super::{writing, Failure, InputError, SetupError};
use crate::check::{self, CheckReport};
use crate::engine::Engine;
use crate::losses;
use crate::model_file::ModelFile;

pub fn run_check(args: CheckArgs) -> Result<(), Failure> {
    // Stdout carries the report: `-` (which would be a file or folder named `-`), `/dev/stdout`
    // or the file stdout is would mix the two.
    for (flag, p) in [
        ("--per-event-out", &args.per_event_out),
        ("--decoded-events-out", &args.decoded_events_out),
    ] {
        if let Some(p) = p.as_deref().filter(|p| is_stdout(p)) {
            return Err(SetupError::NotToStdout {
                flag,
                path: p.display().to_string(),
            }
            .into());
        }
    }
    let model_file = ModelFile::load(&args.scoring.model)?;
    let map = load_map(&args.scoring)?;
    print_inputs(&map);
    let config = engine_config(&args.scoring, &model_file)?;
    let mut engine = Engine::new(model_file.blob()?, map, config)?;
    let event_files = [
        args.events.join(riskscore_data::events::EVENTS_FILE),
        args.events.join(riskscore_data::events::FRAMES_FILE),
    ];
    let mut inputs = scoring_inputs(&args.scoring);
    inputs.push(("--log", args.log.as_path()));
    inputs.extend(event_files.iter().map(|p| ("--events", p.as_path())));
    // After its files, whose refusal is the more precise one: nothing is written into the
    // event folder, and no output folder may hold it (docs/outputs.md, guarantee 1).
    inputs.push(("--events", args.events.as_path()));
    let decoded_files = args.decoded_events_out.as_ref().map(|d| {
        [
            d.join(riskscore_data::events::EVENTS_FILE),
            d.join(riskscore_data::events::FRAMES_FILE),
        ]
    });
    // Each output file with its option and what it writes.
    let mut written: Vec<(&str, &Path, &str)> = decoded_files
        .iter()
        .flatten()
        .map(|p| ("--decoded-events-out", p.as_path(), "a decoded event table"))
        .collect();
    if let Some(p) = &args.per_event_out {
        written.push(("--per-event-out", p, "per-event verdicts (JSON Lines)"));
    }
    let outputs: Vec<NamedPath<'_>> = written.iter().map(|&(flag, p, _)| (flag, p)).collect();
    refuse_overlaps(&inputs, &outputs)?;
    // The folder itself too, against the data: a folder that holds the log or the event folder
    // (`--decoded-events-out .` beside them) is the user's project, not an output. Only its two
    // files are replaced, so a model, DBC or map inside it is no overlap.
    if let Some(d) = &args.decoded_events_out {
        refuse_overlaps(
            &[
                ("--log", args.log.as_path()),
                ("--events", args.events.as_path()),
            ],
            &[("--decoded-events-out", d.as_path())],
        )?;
    }
    for (flag, p, writes) in written {
        refuse_overwriting_a_model(flag, p, writes)?;
    }
    let (set, issues) = riskscore_data::events::load_events(&args.events).map_err(|source| {
        Failure::Input(InputError::Events {
            dir: args.events.clone(),
            source,
        })
    })?;
    for issue in issues
        .iter()
        .take(riskscore_data::events::LISTED_LOAD_ISSUES)
    {
        eprintln!("warning: {issue}");
    }
    let model = model_file.model()?;
    let report = check::check(
        &args.log,
        &set,
        &mut engine,
        riskscore_eval::scoring::model_row_name(&model),
        (args.gap * 1e6).round() as u64,
        args.tolerance,
        args.reorder.merge_wait_ms,
    )
    .map_err(|source| {
        Failure::Input(InputError::Check {
            log: args.log.clone(),
            events: args.events.clone(),
            source,
        })
    })?;
    losses::account(&args.log, &report.log, &report.losses, args.loss.max_lost)?;
    // Both outputs go to temporaries first and are renamed into place only when both are
    // written: a failure leaves the old per-event file and the old decoded folder alike.
    let per_event = match &args.per_event_out {
        Some(p) => Some(write_verdicts(p, &report).map_err(writing("--per-event-out", Some(p)))?),
        None => None,
    };
    match (&args.decoded_events_out, per_event) {
        (Some(dir), per_event) => {
            check::write_decoded_events_with(dir, &report.decoded, per_event.into_iter().collect())
                .map_err(|source| Failure::Input(InputError::DecodedEvents { source }))?
        }
        (None, Some(file)) => file
            .commit()
            .map_err(writing("--per-event-out", args.per_event_out.as_deref()))?,
        (None, None) => {}
    }
    print_report(&report, args.json);
    report.sanity.print("check");
    Ok(())
}

/// The verdicts, the one-line summary and the metrics (as JSON with `json`).
fn print_report(report: &CheckReport, json: bool) {
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
    let note = if fa > 0 {
        format!(
            "{note}\ncheck: the safe events warned are false alarms at this threshold ({:.0} %); how \
             often a threshold warns on real normal driving: `riskctl evaluate --threshold T` on a \
             real folder (the shipped models' rates are in models/README.md)",
            100.0 * fa as f64 / neg.max(1) as f64
        )
    } else {
        note
    };
    if json {
        println!("{}", report.report.to_json());
        eprintln!("{note}");
    } else {
        println!("{}", report.verdict_table());
        println!("{note}\n");
        println!("{}", report.report.to_markdown());
    }
}

/// The per-event verdicts as JSON Lines in a temporary file beside `path`, renamed into place
/// by the caller's commit (with the other output of the run).
fn write_verdicts(path: &Path, report: &CheckReport) -> std::io::Result<AtomicFile> {
    let mut w = AtomicFile::create(path)?;
    for v in &report.verdicts {
        writeln!(w, "{}", serde_json::to_string(v)?)?;
    }
    Ok(w)
}
