//! `riskctl export-model`: a trained checkpoint to the core's model blob.
use std::path::PathBuf;

use anyhow::Context;
use riskscore_train::export::{self, Checkpoint, CheckpointModel, DrlFormat};

/// What `--help` says after the options (a doc comment of [`Args`] is not shown: the
/// subcommand's one-line description in `main.rs` takes its place).
const ABOUT_EXPORT: &str = "\
DRL is quantised to int8 with the activation calibration stored in the checkpoint (measured on
the training observations), using scorer-core's own requantisation; `--f32` writes the float
network instead. MSRA is written as is: its blob always holds its parameters as f32 (there is
no int8 MSRA), so `--f32` changes nothing for it and says so in a note on stderr. The blob is
decoded again (header, CRC, validation) before the command succeeds.

A checkpoint holds no data, so the blob carries no training domain (guard) and no calibrated
threshold. An --out blob that carries either (the drl.rsk of a training run, a calibrated blob) is
therefore not replaced: the run is refused and the blob left as it is, unless
--replace-calibrated says to replace it with the bare export (a warning names what was dropped).
An --out that holds anything but a blob (a training checkpoint such as msra.json beside
drl.json, a table, notes) is never replaced.";

/// Write a trained checkpoint (drl.json / msra.json from `riskctl train`) as a model blob (see
/// [`ABOUT_EXPORT`]).
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_EXPORT)]
pub struct Args {
    /// Checkpoint written by `riskctl train` (JSON), as `inspect-model` takes its file.
    #[arg(value_name = "CHECKPOINT", required_unless_present = "checkpoint")]
    pub file: Option<PathBuf>,
    /// The checkpoint as an option (the older spelling; same as the positional CHECKPOINT).
    #[arg(long, value_name = "CHECKPOINT", conflicts_with = "file")]
    pub checkpoint: Option<PathBuf>,
    /// Output blob (conventionally `*.rsk`); `-` writes the blob to standard output (the summary
    /// then goes to stderr).
    #[arg(long)]
    pub out: PathBuf,
    /// Export DRL as the f32 network instead of int8. An MSRA blob is always f32: for an MSRA
    /// checkpoint the flag changes nothing (a note on stderr says so).
    #[arg(long)]
    pub f32: bool,
    /// Replace an --out blob that carries a training domain or a calibrated threshold with the
    /// bare export (without it, such a blob is left as it is and the run refused).
    #[arg(long)]
    pub replace_calibrated: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let checkpoint = args
        .file
        .or(args.checkpoint)
        .context("no checkpoint given")?;
    super::output::refuse(&[("CHECKPOINT", &checkpoint)], &[("--out", &args.out)])?;
    // `-` (or another name of standard output) streams the blob, as `calibrate --out -` does;
    // there is no file there to protect.
    let to_stdout = super::output::is_stdout(&args.out);
    // A checkpoint at --out (the other model's, `export-model run/drl.json --out run/msra.json`)
    // holds trained parameters no export can give back: a blob over it would lose a training run.
    // Any other file that is not a blob is refused the same way.
    super::output::refuse_replacing_a_non_blob("--out", &args.out)?;
    // What the old blob carries that a checkpoint cannot give (it holds no data).
    let lost = (!to_stdout)
        .then(|| std::fs::read(&args.out).ok())
        .flatten()
        .and_then(|old| lost_records(&old));
    if let (Some((lost, how)), false) = (&lost, args.replace_calibrated) {
        anyhow::bail!(
            "--out {} holds {lost}, which an export from a checkpoint cannot give (it holds no \
             data); it is left as it is. Export to another file (and attach them with {how}), or \
             pass --replace-calibrated to replace it with the bare blob",
            args.out.display()
        );
    }
    let ck = Checkpoint::load(&checkpoint)?;
    if args.f32 && matches!(ck.model, CheckpointModel::Msra { .. }) {
        eprintln!(
            "riskctl: note: --f32 changes nothing for {}, an MSRA checkpoint: an MSRA blob always holds its parameters as f32 (only DRL has an int8 form)",
            checkpoint.display()
        );
    }
    let format = if args.f32 {
        DrlFormat::F32
    } else {
        DrlFormat::Int8
    };
    let blob = export::export(&ck, format)
        .with_context(|| format!("{}: cannot export", checkpoint.display()))?;
    let summary = export::inspect(&blob)
        .map_err(|e| anyhow::anyhow!("the written blob does not decode: {e}"))?;
    // Through the output layer: a file is renamed into place whole, `-` is standard output.
    super::output::write_file_atomically(&args.out, &blob)?;
    if let Some((lost, how)) = lost {
        eprintln!(
            "riskctl: warning: --replace-calibrated: {} held {lost}; the new blob has none: \
             attach it again with {how}",
            args.out.display()
        );
    }
    // On stderr when the blob is on standard output, so the stream is the blob alone.
    summaryln!(
        &args.out,
        "{} ({}) -> {} ({} bytes)",
        checkpoint.display(),
        ck.kind_name(),
        super::output::output_name(&args.out),
        blob.len()
    );
    super::output::summary(&args.out, format_args!("{summary}"));
    Ok(())
}

/// The metadata records of the blob `old` that an export from a checkpoint does not write (a
/// training domain with its guard, a calibrated default threshold), as words, and the commands
/// that attach them; `None` when it holds none or is no blob.
fn lost_records(old: &[u8]) -> Option<(String, String)> {
    let meta = scorer_core::model::decode_blob(old).ok()?.meta;
    let mut lost = Vec::new();
    let mut how = Vec::new();
    if meta.training_domain.is_some() {
        lost.push("a training domain (its guard)");
        how.push("`riskctl calibrate-domain`");
    }
    if meta.default_threshold.is_some() {
        lost.push("a calibrated default threshold");
        how.push("`riskctl calibrate`");
    }
    (!lost.is_empty()).then(|| (lost.join(" and "), how.join(" and ")))
}
