//! `riskctl train`: build comparisons and train DRL and MSRA on an event folder.
use std::path::{Path, PathBuf};

use riskscore_data::events::Sequence;
use riskscore_train::final_models::{train_and_export, FinalModelsError, FINAL_MODEL_FILES};
use riskscore_train::train::{Progress, TrainConfig, TrainError};
use serde_json::json;

/// What `riskctl train --help` says after the options (the doc comment of [`Args`] is not
/// shown: the subcommand's one-line description in `main.rs` takes its place).
const ABOUT_TRAIN: &str = "\
Trains DRL and MSRA on every event of the folder. The events are split by event into fit and
validation parts (early stopping); comparisons are built from the fit part only. Writes into
--out: drl.json and msra.json (float checkpoints, see docs/training.md), drl.rsk (int8, calibrated
on the training observations), drl-f32.rsk and msra.rsk (model blobs for scorer-core, the bridge
and the firmware). The five files are replaced together at the end of a successful run; a failed
or interrupted run leaves the old ones, and other files in the folder are never touched (a
--config kept there is fine). None of the five may be an input or lie inside --events or
--augment, and --out must not be a file.

Without a conflict (crash or near-crash) sequence, in the folder or in --augment, only physics
counterfactual pairs can be built: the models still learn which of two states is physically
riskier, but nothing ties their scale to a conflict, so the run warns on stderr; calibrate a
threshold on normal driving (`riskctl calibrate`) before using them. When no comparison at all
can be built (physics pairs off in the configuration too), it fails and writes nothing. Without
a safe sequence (a folder of conflicts only, or one whose safe rows were all dropped) no
conflict-over-safe pair can be built and the models never see normal driving: that warns too. A
folder too small to hold out validation events trains with a warning. Problems in the folder are
listed on stderr and their events left out.";

/// Train DRL and MSRA on every event of a folder and write checkpoints and model blobs (see
/// [`ABOUT_TRAIN`]).
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_TRAIN)]
pub struct Args {
    /// Event folder (events.csv + frames.csv).
    #[arg(long)]
    pub events: PathBuf,
    /// Training configuration (TOML); default: the built-in defaults (= configs/train.toml).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder for checkpoints and blobs.
    #[arg(long)]
    pub out: PathBuf,
    /// A second event folder (e.g. simulated) whose comparisons form the simulation source.
    #[arg(long)]
    pub augment: Option<PathBuf>,
    /// Override the training seed of the configuration.
    #[arg(long)]
    pub seed: Option<u64>,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // The files train writes, not the folder: it leaves every other file in --out alone, so a
    // configuration kept beside the models (`--config runs/x/cfg.toml --out runs/x`) is no overlap.
    let written: Vec<PathBuf> = FINAL_MODEL_FILES.iter().map(|f| args.out.join(f)).collect();
    let outputs: Vec<(&str, &Path)> = written.iter().map(|p| ("--out", p.as_path())).collect();
    super::output::refuse_inputs_of(
        &[
            ("--events", Some(&args.events)),
            ("--augment", args.augment.as_deref()),
        ],
        &[("--config", args.config.as_deref())],
        &outputs,
    )?;
    super::output::refuse_file_as_folder(
        "--out",
        &args.out,
        "drl.json, msra.json, drl.rsk, drl-f32.rsk and msra.rsk",
    )?;
    super::refuse_augmenting_with_itself(&args.events, args.augment.as_deref())?;
    let config = TrainConfig::load_or_default(args.config.as_deref(), args.seed)?;
    let folder = super::load_prepared(&args.events)?;
    let (seqs, counts) = (folder.sequences, folder.counts.to_string());
    eprintln!(
        "{}: {counts}; {} sequences",
        args.events.display(),
        seqs.len()
    );
    let augmentation = match &args.augment {
        Some(dir) => {
            let folder = super::load_prepared(dir)?;
            let (aug, c) = (folder.sequences, folder.counts);
            eprintln!(
                "{} (augmentation): {c}; {} sequences",
                dir.display(),
                aug.len()
            );
            Some(aug)
        }
        None => None,
    };
    let progress = if args.quiet {
        Progress::Hidden
    } else {
        Progress::Bar
    };
    let meta = json!({
        "data": args.events.display().to_string(),
        "augmentation": args.augment.as_ref().map(|p| p.display().to_string()),
        "events": counts,
        "config": config,
    });
    // No conflict sequence anywhere: say so with the folder's counts (an error when nothing at
    // all can be learnt, a warning when physics pairs are all there is).
    let conflicts = |s: &[Sequence]| s.iter().filter(|s| s.kind.is_conflict()).count();
    let no_conflict = (conflicts(&seqs) == 0
        && augmentation.as_deref().is_none_or(|a| conflicts(a) == 0))
    .then(|| {
        let augment = match (&args.augment, &augmentation) {
            (Some(dir), Some(aug)) => format!(
                " (and --augment {}: {} safe sequences, 0 conflicts)",
                dir.display(),
                aug.len()
            ),
            _ => String::new(),
        };
        format!(
            "--events {}: {} safe sequences, 0 conflicts (crash / near-crash sequences){augment}",
            args.events.display(),
            seqs.len()
        )
    });
    // The mirror case: conflicts but no safe sequence anywhere (a folder of conflicts only, or
    // one whose safe rows were all dropped, e.g. `t_impact` written as `NA`): no cross-sequence
    // pair, so the models never saw normal driving.
    let safe = |s: &[Sequence]| s.iter().filter(|s| !s.kind.is_conflict()).count();
    let no_safe = (no_conflict.is_none()
        && safe(&seqs) == 0
        && augmentation.as_deref().is_none_or(|a| safe(a) == 0))
    .then(|| {
        let augment = match (&args.augment, &augmentation) {
            (Some(dir), Some(aug)) => format!(
                " (and --augment {}: {} conflict sequences, 0 safe)",
                dir.display(),
                aug.len()
            ),
            _ => String::new(),
        };
        format!(
            "--events {}: {} conflict sequences (crash / near-crash), 0 safe sequences{augment}",
            args.events.display(),
            seqs.len()
        )
    });
    let started = std::time::Instant::now();
    let (finals, files) = train_and_export(
        &seqs,
        &[],
        augmentation.as_deref(),
        &config,
        &args.out,
        meta,
        progress,
    )
    .map_err(|e| match (&e, &no_conflict) {
        (FinalModelsError::Train(TrainError::NoPairs), Some(what)) => anyhow::anyhow!(
            "{what}: no comparison can be built (temporal and cross-sequence pairs need conflict sequences, and the configuration builds no physics pairs); nothing written to {}",
            args.out.display()
        ),
        _ => anyhow::Error::new(e).context("training failed"),
    })?;
    if let Some(what) = &no_conflict {
        eprintln!(
            "riskctl: warning: {what}: the models learnt from physics counterfactual pairs alone ({} fit pairs): no temporal or cross-sequence comparison and no impact anchor, so they rank states by physics but their scale is tied to no conflict and the default warning threshold means nothing; calibrate one on normal driving (riskctl calibrate) or train with conflict events (in the folder or with --augment DIR)",
            finals.drl.report.pairs
        );
    }
    if let Some(what) = &no_safe {
        eprintln!(
            "riskctl: warning: {what}: the models never saw normal driving: no cross-sequence pair (a conflict frame over a safe one), only temporal and physics pairs, so nothing tells them how low a safe state scores and the default warning threshold's false-alarm rate is unknown; train with safe events (in the folder or with --augment DIR), or calibrate a threshold on normal driving (riskctl calibrate)"
        );
    }
    host_tools::warnings::print(&finals.warnings);
    let d = &finals.drl.report;
    if d.validation_pairs == 0 && config.optimiser.validation_fraction > 0.0 {
        eprintln!(
            "riskctl: warning: --events {}: {} sequences are too few to hold out validation events \
             (optimiser.validation_fraction {}): early stopping followed the training loss itself \
             (DRL kept epoch {} of {}), so over-fitting goes unseen; train on more events",
            args.events.display(),
            seqs.len(),
            config.optimiser.validation_fraction,
            d.best_epoch,
            d.epochs
        );
    }
    let m = &finals.msra.report;
    outln!(
        "comparisons: {} fit pairs, {} validation pairs, {:.0} pairs/s",
        d.pairs,
        d.validation_pairs,
        finals.pairs_per_second
    );
    outln!(
        "DRL : {} epochs (best {}), {:.1} epochs/s, final validation loss {}",
        d.epochs,
        d.best_epoch,
        d.epochs_per_second,
        d.history
            .get(d.best_epoch.saturating_sub(1))
            .and_then(|e| e.validation)
            .map_or("n/a".into(), |v| format!("{:.4}", v.total))
    );
    outln!(
        "MSRA: {} epochs (best {}), {:.1} epochs/s",
        m.epochs,
        m.best_epoch,
        m.epochs_per_second
    );
    for t in &finals.msra.params.terms {
        outln!(
            "      {:<6} w = {:+.3}  a = {:+.4}  b = {:+.3}  clip [{}, {}]",
            t.surrogate,
            t.w,
            t.a,
            t.b,
            t.lo,
            t.hi
        );
    }
    outln!(
        "int8 vs f32 DRL on the training observations: corr {:.5}, mean |diff| {:.4}, max |diff| {:.4}",
        finals.agreement.correlation, finals.agreement.mean_abs_error, finals.agreement.max_abs_error
    );
    outln!("wrote ({:.1} s):", started.elapsed().as_secs_f64());
    for f in files {
        outln!("  {}", f.display());
    }
    Ok(())
}
