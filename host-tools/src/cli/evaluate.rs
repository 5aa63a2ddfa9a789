//! `riskctl evaluate`: score an event folder with model blobs and the surrogate baselines through
//! the deployed scorer-core path, and report the proactive-warning metrics. No training.
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use riskscore_data::events::PrepareConfig;
use riskscore_eval::model_files::{named_models, ModelFile};
use riskscore_eval::outputs::{result_files, RESULT_FILES};
use riskscore_eval::plots::FIGURE_FILES;
use riskscore_eval::sketch::DEFAULT_CAPACITY;
use riskscore_eval::streaming::{
    evaluate_folder_gathering, FolderEvaluation, FolderRefusal, Gather, TrajectoryEvents,
    TrajectoryRequest,
};
use riskscore_eval::Method;

/// What `riskctl evaluate --help` explains after the options.
const ABOUT_EVALUATION: &str = "\
Every sequence is scored frame by frame exactly as on the ECU (DRL through the int8 network, MSRA
through the core's transforms, baselines TTC2D, TAdv, EI, and TAdv-corridor where a model reads it,
through the core's surrogates). A sequence
is warned at threshold T at its first frame with R >= T up to and including its endpoint; over all
thresholds (the distinct sequence maxima) this gives A^ROC_90/80 (%), P^PRC_90/80 (%) and mTTI^90_p
(s). Formulas and edge cases: docs/evaluation.md.

Rows are named from the model (DRL, DRL-f32, MSRA, GSSM, SSRA); when two models share a name each
row takes its file stem, and --model NAME=FILE sets a name explicitly. The baselines follow.

Operating points: the metrics above sweep every threshold; a deployed model warns at one. Each
model row is also reported at one threshold (by default the model's own default threshold, the one
the CAN bridge and the C ABI use; `riskctl inspect-model` says how it was chosen): per event kind
the sequences warned and not warned, recall (conflicts) or false-alarm rate (safe), false alarms
per hour of safe driving (the alert windows' spans), and the mean lead time. --threshold T puts
every model at T, --threshold NAME=T one row (baselines too), --threshold none reports no
operating point. On a folder of real normal driving only (no conflicts) the metrics are n/a but
the false-alarm rate at the threshold is what a user wants to know.

Output: the Markdown tables, or with --json one JSON object (stable schema):
  {\"events\": {\"crash\": n, \"near_crash\": n, \"safe\": n},
   \"methods\": [{\"name\", \"A_ROC_90\", \"A_ROC_80\", \"P_PRC_90\", \"P_PRC_80\", \"mTTI_90\"}, ...],
   \"operating_points\": [{\"name\", \"threshold\",
       \"crash\" and \"near_crash\": {\"sequences\", \"warned\", \"not_warned\", \"driving_hours\",
                                   \"recall\", \"mean_lead_time\"},
       \"safe\": {\"sequences\", \"warned\", \"not_warned\", \"driving_hours\",
                \"false_alarm_rate\", \"false_alarms_per_hour\"}}, ...],
   \"domain\": [{\"name\", \"frames\", \"outside\", \"outside_share\",
               \"first_outside\": {\"<input>\": frames}}, ...]}
percentages 0-100, lead time in seconds, null where undefined. Problems in the event folder are
listed on stderr (file:line, the first of each kind and a count) and fail the run: the metrics
would silently leave those events out. With --skip-bad-events the valid events are evaluated.

Examples:
  riskctl evaluate --model models/drl-default.rsk --model models/msra-default.rsk \\
                   --events data/events --out report/
  riskctl evaluate --model models/drl-default.rsk --events data/ngsim-us101-safe \\
                   --threshold 2.0 --json        # false alarms on real driving at T = 2.0";

/// Score an event folder with model files and the TTC2D, TAdv and EI baselines (and TAdv-corridor
/// where a model reads it).
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_EVALUATION)]
pub struct Args {
    /// Model blob to evaluate (repeatable); `NAME=FILE` names its row.
    #[arg(long = "model", value_name = "[NAME=]FILE")]
    models: Vec<String>,
    /// Event folder (events.csv + frames.csv, see docs/event-format.md).
    #[arg(long, value_name = "DIR")]
    events: PathBuf,
    /// Print one JSON object instead of the Markdown table.
    #[arg(long)]
    json: bool,
    /// Also write results.{md,csv,json}, curves.csv and the ROC, PR and trajectory plots
    /// (SVG and PNG) into DIR. They are written under temporary names and renamed into place
    /// together at the end: a failed run changes none of them. A name that is one of the
    /// input files, or that holds a model blob or training checkpoint, is refused (the folder's
    /// other files are kept). The folder is still read one event at a time: the trajectory
    /// plot's percentiles are exact up to 65,536 frames per method and beyond that within a
    /// small error that is printed (see docs/scale.md).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Evaluate the valid events of a folder that has bad rows (each listed on stderr) instead of
    /// failing; the metrics then leave out the events those rows name.
    #[arg(long)]
    skip_bad_events: bool,
    /// Report the model rows at this threshold (`T`, default: each model's own default
    /// threshold), one row at it (`NAME=T`, baselines too), or `none` (repeatable; later ones
    /// win for the same row). See the operating points below.
    #[arg(
        long = "threshold",
        value_name = "T|NAME=T|default|none",
        allow_negative_numbers = true
    )]
    thresholds: Vec<String>,
    /// Crash or near-crash event whose risk trajectory (against time to its impact or endpoint)
    /// is plotted (repeatable; default: the first three crash events of the folder). A safe
    /// event has no endpoint to plot against and is refused.
    #[arg(long = "trajectory-event", value_name = "ID", requires = "out")]
    trajectory_events: Vec<String>,
}

pub fn report_issues<T: std::fmt::Display>(what: &str, issues: &[T]) {
    if issues.is_empty() {
        return;
    }
    eprintln!("riskctl: {} {what}:", issues.len());
    for issue in issues
        .iter()
        .take(riskscore_data::events::LISTED_LOAD_ISSUES)
    {
        eprintln!("  {issue}");
    }
    if issues.len() > riskscore_data::events::LISTED_LOAD_ISSUES {
        eprintln!(
            "  ... and {} more",
            issues.len() - riskscore_data::events::LISTED_LOAD_ISSUES
        );
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Models first: a bad model file is found before a large event folder is read.
    let files = ModelFile::read_all(&args.models)?;
    let mut methods = named_models(&files)?;
    let baselines = Method::baselines_for(&methods);
    methods.extend(baselines);
    let thresholds = operating_thresholds(&args.thresholds, &files, &methods)?;

    let dir = &args.events;
    // Locked before the folder is read: a second run into the same --out is refused now, not
    // after both have computed (the final swap takes the same lock again, as its holder).
    let _out_lock = match &args.out {
        Some(out) => {
            refuse_output_overlaps(&files, dir, out)?;
            // What the final swap would refuse (a file, a link, a read-only folder), said now.
            riskscore_output::refuse_unswappable(out)?;
            Some(
                riskscore_output::OutputLock::acquire_for_run(out)
                    .with_context(|| format!("--out {}", out.display()))?,
            )
        }
        None => None,
    };
    refuse_unknown_trajectory_events(&args.trajectory_events, dir)?;
    // With --out, the same pass also gathers the trajectory plot's events and percentile scales.
    let trajectories = args.out.as_ref().map(|_| TrajectoryRequest {
        events: if args.trajectory_events.is_empty() {
            TrajectoryEvents::FirstCrashes(DEFAULT_TRAJECTORIES)
        } else {
            TrajectoryEvents::Named(args.trajectory_events.clone())
        },
        sketch_capacity: DEFAULT_CAPACITY,
    });
    let gather = Gather {
        trajectories: trajectories.as_ref(),
        thresholds: &thresholds,
    };
    let folder = evaluate_checked(dir, &methods, gather, args.skip_bad_events)?;
    // Printed, and with --out also results.json and results.md: the same text.
    let (json, md) = (folder.to_json_text()?, folder.to_markdown());
    if args.json {
        outln!("{json}");
    } else {
        out!("{md}");
    }
    let Some(out) = &args.out else {
        return Ok(());
    };
    let written = write_outputs(out, folder, json + "\n", md)?;
    eprintln!(
        "riskctl: wrote {} files to {}:",
        written.len(),
        out.display()
    );
    for p in written {
        eprintln!("  {}", p.display());
    }
    Ok(())
}

/// Crash events drawn when no --trajectory-event is given.
const DEFAULT_TRAJECTORIES: usize = 3;

/// The threshold of each row (in `methods` order) that `--threshold` asks for: by default every
/// model row at its own default threshold.
pub(super) fn operating_thresholds(
    specs: &[String],
    files: &[ModelFile],
    methods: &[Method<'_>],
) -> anyhow::Result<Vec<Option<f32>>> {
    let defaults = files
        .iter()
        .map(|f| f.default_threshold().map(Some))
        .collect::<Result<Vec<_>, _>>()?;
    // Model rows come first, in file order; the baselines follow and have no default.
    let default_of = |row: usize| defaults.get(row).copied().flatten();
    let mut chosen: Vec<Option<f32>> = (0..methods.len()).map(default_of).collect();
    let value = |text: &str, spec: &str| -> anyhow::Result<f32> {
        match text.parse::<f32>() {
            Ok(t) if t.is_finite() => Ok(t),
            _ => bail!("--threshold {spec}: {text:?} is not a finite number, `default` or `none`"),
        }
    };
    for spec in specs {
        // At the last `=`: a value never holds one, a row name may (the file stem of
        // `sweep/drl_lr=0.1.rsk` names its row `drl_lr=0.1`).
        match spec.rsplit_once('=') {
            Some((name, text)) => {
                let Some(row) = methods.iter().position(|m| m.name == name) else {
                    let names: Vec<&str> = methods.iter().map(|m| m.name.as_str()).collect();
                    bail!(
                        "--threshold {spec}: no row named {name:?} (rows: {})",
                        names.join(", ")
                    );
                };
                chosen[row] = match text {
                    "none" => None,
                    "default" => Some(default_of(row).with_context(|| {
                        format!(
                            "--threshold {spec}: {name} is a baseline and has no default threshold"
                        )
                    })?),
                    _ => Some(value(text, spec)?),
                };
            }
            None => {
                let all: Option<Option<f32>> = match spec.as_str() {
                    "none" => Some(None),
                    "default" => None,
                    text => Some(Some(value(text, spec)?)),
                };
                // `none` clears every row; a value or `default` applies to the model rows.
                let rows = if all == Some(None) {
                    methods.len()
                } else {
                    files.len()
                };
                for (row, slot) in chosen.iter_mut().enumerate().take(rows) {
                    *slot = all.unwrap_or_else(|| default_of(row));
                }
            }
        }
    }
    Ok(chosen)
}

/// Evaluates `dir` one event at a time ([`evaluate_folder_gathering`]) and refuses, after
/// listing them, problems that would leave events out of the metrics.
fn evaluate_checked(
    dir: &Path,
    methods: &[Method<'_>],
    gather: Gather<'_>,
    skip_bad_events: bool,
) -> anyhow::Result<FolderEvaluation> {
    // The calling thread reads frames.csv; one scoring worker per core.
    let workers = std::thread::available_parallelism().map_or(1, usize::from);
    let folder = evaluate_folder_gathering(dir, methods, PrepareConfig::default(), workers, gather)
        .with_context(|| format!("event folder {}", dir.display()))?;
    if !folder.streamed {
        eprintln!(
            "riskctl: note: the frames of {} are not grouped by event, so the folder was read whole (more memory)",
            dir.display()
        );
    }
    report_load_issues(&folder.load_issues);
    let refusal = folder.check(skip_bad_events);
    if !matches!(
        refusal,
        Err(FolderRefusal::NoValidEvents | FolderRefusal::BadRows { .. })
    ) {
        report_issues(
            "event(s) yield no sequence under the preparation rules",
            &folder.prepare_issues,
        );
    }
    refusal.with_context(|| format!("event folder {}", dir.display()))?;
    Ok(folder)
}

/// The loader keeps the first problems of each kind (and counts the rest), so all are listed:
/// the first of every kind (and so every kind of dropped event) is named, and the total is the
/// number of problems, not of listed lines.
///
/// Notes (a file without a final newline) skip nothing: each is a warning line of its own.
/// Every problem says what it leaves out ([`left_out`]): most skip their event, but frames of
/// an id that events.csv does not have drop only those rows.
pub(super) fn report_load_issues(issues: &[riskscore_data::events::LoadIssue]) {
    let (notes, problems): (Vec<_>, Vec<_>) = issues.iter().partition(|i| i.problem.is_note());
    for note in notes {
        eprintln!("riskctl: warning: {note}");
    }
    if !problems.is_empty() {
        let total: u64 = problems.iter().map(|i| i.count()).sum();
        eprintln!("riskctl: {total} problem(s) in the event folder:");
        for issue in problems {
            eprintln!("  {issue} ({})", super::left_out(issue));
        }
    }
}

/// Refuses an `--out` folder that holds a model or event file, or whose result files would
/// overwrite one: an input, or any model blob or training checkpoint stored under a result
/// file's name.
fn refuse_output_overlaps(models: &[ModelFile], events: &Path, out: &Path) -> anyhow::Result<()> {
    let files: Vec<PathBuf> = RESULT_FILES
        .iter()
        .chain(&FIGURE_FILES)
        .map(|n| out.join(n))
        .collect();
    let mut outputs: Vec<(&str, &Path)> = files.iter().map(|p| ("--out", p.as_path())).collect();
    // The folder itself last (its files first: "same file as" says more than "contains"): it is
    // swapped whole, so it must not hold an input either.
    outputs.push(("--out", out));
    super::output::refuse_overwriting_inputs(models, events, &outputs)?;
    // The swap carries every other file of the old folder over (riskscore_output::OutputDir), so
    // a model there under another name is kept; only a result file's name is replaced. A link
    // of that name is replaced itself, never the file it points to.
    for file in &files {
        // A folder of the user's under a result file's name would go with the old output: the
        // swap refuses it at the end; said now, before the folder is scored.
        riskscore_output::refuse_kind_clash(file, false)?;
        if !std::fs::symlink_metadata(file).is_ok_and(|m| m.file_type().is_symlink()) {
            super::output::refuse_overwriting_a_model(
                "--out",
                file,
                "a result file of `riskctl evaluate`",
            )?;
        }
    }
    Ok(())
}

/// Refuses a `--trajectory-event` id that names no crash or near-crash row of `events.csv`, before
/// the run (it was found after the whole folder was scored). One whose frames turn out invalid is
/// still found at the end ([`write_outputs`]).
fn refuse_unknown_trajectory_events(ids: &[String], dir: &Path) -> anyhow::Result<()> {
    if ids.is_empty() {
        return Ok(());
    }
    let kinds = riskscore_data::events::event_kinds(dir)
        .with_context(|| format!("event folder {}", dir.display()))?;
    for id in ids {
        if !kinds.iter().any(|(k, kind)| k == id && kind.is_conflict()) {
            bail!(
                "--trajectory-event {id}: no crash or near-crash event with that id in {} \
                 (nothing computed or written)",
                dir.join("events.csv").display()
            );
        }
    }
    Ok(())
}

/// Writes the `--out` folder as a whole: a complete new folder is swapped in for the old one.
/// `json` and `markdown` are what the run prints (`--json` or not), so results.json and
/// results.md also hold the operating points and the frames outside the training domain (the
/// answer on a folder of normal driving only).
fn write_outputs(
    out: &Path,
    folder: FolderEvaluation,
    json: String,
    markdown: String,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut panels = Vec::new();
    if let Some(mut trajectories) = folder.trajectories {
        if let Some(id) = trajectories.unknown.first() {
            bail!(
                "--trajectory-event {id}: no crash or near-crash sequence with that event id (nothing written to {})",
                out.display()
            );
        }
        if trajectories.event_ids.is_empty() {
            eprintln!(
                "riskctl: no crash sequence, so no trajectory plot (by default the first {DEFAULT_TRAJECTORIES} crash sequences are drawn; --trajectory-event ID draws a crash or near-crash one)"
            );
        }
        let error = trajectories.percentile_error();
        if error > 0.0 {
            eprintln!(
                "riskctl: note: the trajectory percentiles are summarised (bounded memory): each is within {:.4} percentile points of the exact value",
                100.0 * error
            );
        }
        panels = trajectories.panels();
    }
    let bundle = result_files(&folder.report, json, markdown, &folder.curves, &panels)?;
    Ok(bundle.write_to(out)?)
}
