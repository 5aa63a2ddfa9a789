//! `riskctl calibrate`: store a model's default warning threshold, chosen on normal driving by a
//! target false-alarm rate, in its blob.
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use riskscore_data::events::PrepareConfig;
use riskscore_eval::model_files::{named_models, ModelFile};
use riskscore_eval::streaming::{evaluate_folder, BadRowsWording, FolderRefusal};
use riskscore_eval::threshold::{calibrate_safe_share, safe_maxima};
use scorer_core::model::{self, DefaultThreshold, ModelBlob, ThresholdRule};

const ABOUT_CALIBRATION: &str = "\
The rule: score every safe sequence of the --normal folders (real, uneventful driving) exactly as on
the ECU, take each sequence's maximum, and choose the smallest of those maxima at which at most
--false-alarm-rate percent of the sequences warn. The threshold, the rule, the target, the share
measured and a description of the data are stored in the blob (format version 2; the model bytes
are unchanged). The CAN bridge, the C ABI (riskscore_model_default_threshold) and riskctl use it
whenever no --threshold is given; `riskctl inspect-model` prints it.

Calibrate on normal driving the model was not trained on where you can: a threshold measured on the
training sequences is optimistic. Check the operating point on other data with
`riskctl evaluate --model OUT --events DIR` (it reports recall, false alarms per hour and lead time
at the default threshold).

--never-warn DIR (repeatable) names safe driving that must never warn, e.g. passes beside
stationary roadside objects: when the rule's threshold would let a frame of DIR reach it, the
threshold is raised just above DIR's highest score. The printout says by how much and what share
of the --normal sequences warns then (stored in the blob as the measured share); the recall that
costs shows in `riskctl evaluate --model OUT --events CONFLICTS`.

Example:
  riskctl calibrate --model models/drl-default.rsk --normal data/ngsim-us101-safe \\
                    --normal data/ngsim-urban-safe --false-alarm-rate 5 --out drl-calibrated.rsk";

/// Choose and store a model's default warning threshold from real normal driving.
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_CALIBRATION)]
pub struct Args {
    /// Model blob to calibrate (`*.rsk`).
    #[arg(long, value_name = "FILE")]
    model: PathBuf,
    /// Event folder of normal driving (its safe sequences are used; repeatable).
    #[arg(long, value_name = "DIR", required = true)]
    normal: Vec<PathBuf>,
    /// Largest share of the normal-driving sequences allowed to warn, in percent (0-100).
    #[arg(long, allow_negative_numbers = true, value_name = "PERCENT")]
    false_alarm_rate: f64,
    /// Event folder of safe driving that must never warn (repeatable): the threshold goes just
    /// above its highest score when the false-alarm rule would put it lower.
    #[arg(long = "never-warn", value_name = "DIR")]
    never_warn: Vec<PathBuf>,
    /// Output blob; must not be the input (write to a new file, then move it). `-` writes the
    /// blob to standard output (the summary then goes to stderr). Missing parent folders are
    /// created.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

pub fn run(mut args: Args) -> anyhow::Result<()> {
    if !(0.0..=100.0).contains(&args.false_alarm_rate) {
        bail!(
            "--false-alarm-rate {}: must be a percentage from 0 to 100",
            args.false_alarm_rate
        );
    }
    let file = ModelFile::read(&args.model.display().to_string())?;
    refuse_overlaps(&args)?;
    // A folder named twice would count its sequences twice (in the share and the blob's record).
    args.normal = distinct_folders("--normal", &args.normal);
    args.never_warn = distinct_folders("--never-warn", &args.never_warn);
    let methods = named_models(std::slice::from_ref(&file))?;
    let mut maxima = Vec::new();
    for dir in &args.normal {
        maxima.extend(safe_maxima(&curve_of(dir, &methods)?));
    }
    let target = args.false_alarm_rate / 100.0;
    let Some(mut calibration) = calibrate_safe_share(&maxima, target) else {
        bail!("the --normal folders hold no safe sequence to calibrate on");
    };
    let by_rule = calibration.threshold;
    let mut never_warn_max = f32::NEG_INFINITY;
    let mut never_warn_sequences = 0;
    for dir in &args.never_warn {
        let curve = curve_of(dir, &methods)?;
        if curve.positives > 0 {
            bail!(
                "--never-warn {}: holds {} conflict sequences; only safe driving can be required \
                 never to warn",
                dir.display(),
                curve.positives
            );
        }
        let m = safe_maxima(&curve);
        never_warn_sequences += m.len();
        never_warn_max = m.into_iter().fold(never_warn_max, f32::max);
    }
    if never_warn_max >= calibration.threshold {
        calibration.threshold = never_warn_max.next_up();
        let warned = maxima
            .iter()
            .filter(|&&m| m >= calibration.threshold)
            .count();
        calibration.measured = warned as f64 / maxima.len() as f64;
    }
    if !args.never_warn.is_empty() {
        summaryln!(
            &args.out,
            "--never-warn: the highest score of its {never_warn_sequences} safe sequences is \
             {never_warn_max}; the false-alarm rule gives {by_rule}, {}",
            if calibration.threshold > by_rule {
                format!("raised to {}", calibration.threshold)
            } else {
                "kept".to_owned()
            }
        );
    }
    let data = describe(&args.normal);
    let blob = file.blob()?;
    let calibrated = ModelBlob {
        model: blob.model,
        meta: model::ModelMeta {
            // A stored training domain is kept: the threshold does not change what the model read.
            training_domain: blob.meta.training_domain,
            kinematic_fallback: blob.meta.kinematic_fallback,
            blend: blob.meta.blend,
            default_threshold: Some(DefaultThreshold {
                threshold: calibration.threshold,
                rule: ThresholdRule::SafeShare {
                    target: target as f32,
                    measured: calibration.measured as f32,
                    sequences: u32::try_from(calibration.sequences).unwrap_or(u32::MAX),
                },
                data: &data,
            }),
        },
    };
    let mut bytes = vec![0u8; model::encoded_blob_len(&calibrated)?];
    let n = model::encode_blob(&calibrated, &mut bytes)?;
    bytes.truncate(n);
    let summary = riskscore_train::export::inspect(&bytes)
        .map_err(|e| anyhow::anyhow!("the calibrated blob does not decode: {e}"))?;
    super::output::write_file_atomically(&args.out, &bytes)?;
    summaryln!(
        &args.out,
        "{} -> {}: default threshold {} ({} % of {} normal-driving sequences warn; target {} %)",
        args.model.display(),
        super::output::output_name(&args.out),
        calibration.threshold,
        riskscore_eval::report::fixed(100.0 * calibration.measured, 1),
        calibration.sequences,
        args.false_alarm_rate
    );
    super::output::summary(&args.out, format_args!("{summary}"));
    Ok(())
}

/// The model's warning curve on one event folder (scored exactly as on the ECU).
fn curve_of(
    dir: &Path,
    methods: &[riskscore_eval::Method],
) -> anyhow::Result<riskscore_eval::WarningCurve> {
    let folder = evaluate_folder(dir, methods, PrepareConfig::default(), workers())
        .with_context(|| format!("event folder {}", dir.display()))?;
    super::evaluate::report_load_issues(&folder.load_issues);
    match folder.check(false) {
        Err(FolderRefusal::BadRows { valid_events }) => bail!(
            "event folder {}: {}",
            dir.display(),
            FolderRefusal::bad_rows_message(
                valid_events,
                BadRowsWording {
                    listed: "above",
                    left_out_of: "calibration",
                    skip: None,
                }
            )
        ),
        refusal => refusal.with_context(|| format!("event folder {}", dir.display()))?,
    }
    super::evaluate::report_issues(
        &format!(
            "event(s) of {} yield no sequence under the preparation rules",
            dir.display()
        ),
        &folder.prepare_issues,
    );
    Ok(folder
        .curves
        .into_iter()
        .next()
        .context("no model row was evaluated")?
        .1)
}

/// `folders` with each folder once (the same canonical path named twice, as `d` and `./d/`, is
/// read once, with a note); a folder that cannot be resolved is kept (reading it names the error).
fn distinct_folders(flag: &str, folders: &[PathBuf]) -> Vec<PathBuf> {
    // (canonical path, as given) of each folder kept.
    let mut kept: Vec<(PathBuf, &PathBuf)> = Vec::new();
    for dir in folders {
        let key = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.clone());
        match kept.iter().find(|(k, _)| *k == key) {
            Some((_, first)) => eprintln!(
                "riskctl: note: {flag} {} is {} again; it is read once",
                dir.display(),
                first.display()
            ),
            None => kept.push((key, dir)),
        }
    }
    kept.into_iter().map(|(_, dir)| dir.clone()).collect()
}

fn workers() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// The folders' names (not their absolute paths: the blob travels), within the blob's limit.
/// The sequence count is stored in the rule itself.
fn describe(folders: &[PathBuf]) -> String {
    let names: Vec<String> = folders
        .iter()
        .map(|d| {
            d.file_name()
                .map_or_else(|| d.display().to_string(), |n| n.to_string_lossy().into())
        })
        .collect();
    let text = names.join(" + ");
    if text.len() > model::meta::MAX_DATA_DESCRIPTION {
        format!("{} folders", folders.len())
    } else {
        text
    }
}

/// The output must not be the model, a --normal or --never-warn folder's file or lie inside such
/// a folder, nor an existing file that is not a blob (checked last: the more precise refusal
/// first).
fn refuse_overlaps(args: &Args) -> anyhow::Result<()> {
    let folders: Vec<(&str, Option<&Path>)> = super::output::repeated("--normal", &args.normal)
        .chain(super::output::repeated("--never-warn", &args.never_warn))
        .collect();
    super::output::refuse_inputs_of(
        &folders,
        &[("--model", Some(&args.model))],
        &[("--out", &args.out)],
    )?;
    // After the overlaps: `--out ev/events.csv` is "the same file as --normal", first.
    Ok(super::output::refuse_replacing_a_non_blob(
        "--out", &args.out,
    )?)
}
