//! `riskctl calibrate-domain`: attach (or refresh) a model's training-domain record, measured on
//! the event folders it was trained on.
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use riskscore_eval::domain_ranges::{Tails, DEFAULT_TAILS};
use riskscore_eval::model_files::ModelFile;
use scorer_core::model::{
    Blend, KinematicFallback, Model, ModelBlob, ModelMeta, OutsidePolicy, ThresholdRule,
    TrainingDomain,
};
use scorer_core::msra::MsraTerm;

const ABOUT_DOMAIN: &str = "\
The record: for every input the model reads (DRL: its DRL inputs; GSSM/SSRA: its context features;
MSRA: all 13 features), the range between the --tail-percent and 100 - --tail-percent quantiles of
that input over every frame of the prepared sequences of the --events folders, widened to every
value at least --sequence-percent of those sequences reached (a one-frame glitch in one track
stays outside; the touching boxes every crash reaches at impact, far fewer than 0.1 % of the
frames, stay inside), plus the policy for an observation outside. Give the folders the model was
trained on: the record says where the model has seen data. A GSSM or SSRA models normal driving:
its record is measured on the safe sequences of those folders alone. DRL, GSSM and SSRA records
also list the geometry cells (where the partner is, which way it heads, how far) that at least
--cell-sequences of those sequences reached. The model bytes and a stored default threshold are
kept (format version 2).

Policies: flag-only scores as an unguarded model does and reports the flag; clamp moves each input
into its range first, so the model never extrapolates; fallback (DRL, GSSM and SSRA) scores a
kinematic MSRA outside instead of the model: the kinematic terms of the --fallback-from blob (an
MSRA's terms, or the fallback record of a blob that has one: the shipped DRL's reads the reference
TAdv and EI, the shipped MSRA TAdv-corridor and EI), mapped to the model's scale by the affine map that matches the mean and spread of its
scores on the frames of the --events folders inside the new record (docs/domain-guard.md); blend
(DRL only, the training default) does the same outside and, inside, scores --blend-weight of the
model plus the rest of that fallback, so a network that extrapolates between what it saw keeps a
kinematic ordering. A blend changes the scores inside: run `riskctl calibrate` again afterwards
(a stored default threshold is kept as it was). Either way `riskctl score` writes a
<model>_in_domain column, `riskctl evaluate` reports the share of frames outside and the CAN
bridge counts out-of-domain track updates. `riskctl inspect-model` prints the record.

Examples, run from the repository's root: a simulated folder of the simulator's default set and
the real freeway driving shipped in data/, two of the folders the shipped DRL was trained on
(models/README.md lists them all):
  riskctl simulate --out sim
  riskctl calibrate-domain --model models/drl-default.rsk --events sim \\
                           --events data/ngsim-us101-safe --policy clamp --out drl-guarded.rsk
  riskctl calibrate-domain --model models/drl-default.rsk --events sim \\
                           --events data/ngsim-us101-safe --policy fallback \\
                           --fallback-from models/msra-default.rsk --out drl-fallback.rsk
  riskctl calibrate-domain --model models/drl-default.rsk --events sim \\
                           --events data/ngsim-us101-safe --policy blend --blend-weight 0.7 \\
                           --fallback-from models/drl-default.rsk --out drl-blend.rsk";

/// Attach a model's training domain (the input ranges of its training data and the policy
/// outside) to its blob.
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_DOMAIN)]
pub struct Args {
    /// Model blob (`*.rsk`).
    #[arg(long, value_name = "FILE")]
    model: PathBuf,
    /// Event folder of the model's training data (repeatable).
    #[arg(long, value_name = "DIR", required = true)]
    events: Vec<PathBuf>,
    /// What scoring does outside the domain: flag-only, clamp, fallback or blend.
    #[arg(long, value_name = "POLICY", default_value = "flag-only", value_parser = parse_policy)]
    policy: OutsidePolicy,
    /// MSRA blob whose kinematic terms are the fallback, or a blob whose fallback record's terms
    /// are (required by, and only with, `--policy fallback` and `--policy blend`).
    #[arg(long, value_name = "FILE")]
    fallback_from: Option<PathBuf>,
    /// `--policy blend` only: the model's share of the score inside the domain (the kinematic
    /// fallback has the rest), strictly between 0 and 1 [default: the blob's own weight, else
    /// 0.7, training's default].
    #[arg(long, allow_negative_numbers = true, value_name = "W")]
    blend_weight: Option<f32>,
    /// Share of the frames left outside at each end of each range, in percent (0 = min/max).
    #[arg(long, allow_negative_numbers = true, value_name = "PERCENT", default_value_t = 100.0 * DEFAULT_TAILS.frames)]
    tail_percent: f64,
    /// Every value at least this share of the sequences reached is inside, in percent (100 =
    /// the frame quantiles alone).
    #[arg(long, allow_negative_numbers = true, value_name = "PERCENT", default_value_t = 100.0 * DEFAULT_TAILS.sequences)]
    sequence_percent: f64,
    /// DRL, GSSM and SSRA models: a geometry cell (where the partner is, which way it heads, how
    /// far) is inside when at least this many sequences reached it (at least 1).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_TAILS.cell_sequences,
          value_parser = parse_cell_sequences)]
    cell_sequences: usize,
    /// Output blob; must not be the input (write to a new file, then move it). `-` writes the
    /// blob to standard output (the summary then goes to stderr).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

fn parse_cell_sequences(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!(
            "{text:?}: expected a whole number of sequences, at least 1"
        )),
    }
}

fn parse_policy(text: &str) -> Result<OutsidePolicy, String> {
    OutsidePolicy::from_name(text)
        .ok_or_else(|| format!("{text:?}: expected flag-only, clamp, fallback or blend"))
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(0.0..50.0).contains(&args.tail_percent) {
        bail!(
            "--tail-percent {}: must be at least 0 and below 50",
            args.tail_percent
        );
    }
    if !(0.0..=100.0).contains(&args.sequence_percent) {
        bail!(
            "--sequence-percent {}: must be between 0 and 100",
            args.sequence_percent
        );
    }
    let file = ModelFile::read(&args.model.display().to_string())?;
    let blob = file.blob()?;
    let model = &blob.model;
    let fallback_terms = fallback_terms(&args, model)?;
    let blend = blend(&args, &blob)?;
    refuse_overlaps(&args)?;
    let mut sequences = Vec::new();
    for dir in &args.events {
        // Its problems are listed (also when they leave no sequence: they are why).
        let folder =
            super::load_prepared(dir).with_context(|| format!("event folder {}", dir.display()))?;
        sequences.extend(folder.sequences);
    }
    let measured_on = riskscore_train::export::domain_sequences(model, &sequences);
    let frames: usize = measured_on.iter().map(|s| s.frames.len()).sum();
    let tails = Tails {
        frames: args.tail_percent / 100.0,
        sequences: args.sequence_percent / 100.0,
        cell_sequences: args.cell_sequences,
    };
    let guarded = riskscore_train::export::with_domain_measured(
        &file.bytes,
        &sequences,
        tails,
        (args.policy, blend),
        fallback_terms.as_deref(),
    )?;
    // Training writes `flag-only` where a fallback cannot be fitted; asked for one, this fails.
    if let Some(reason) = guarded.fallback_refused {
        bail!("{reason}");
    }
    if let Some(fitted) = &guarded.fallback {
        summaryln!(
            &args.out,
            "fallback: {} * MSRA + {} (mean and spread of the model on {} frames inside, r^2 {:.3})",
            fitted.scale, fitted.offset, fitted.frames, fitted.r_squared
        );
    }
    if let Some(b) = &blend {
        summaryln!(
            &args.out,
            "blend: inside the domain {}",
            riskscore_train::export::blend_text(b)
        );
    }
    let bytes = guarded.bytes;
    let summary = riskscore_train::export::inspect(&bytes)
        .map_err(|e| anyhow::anyhow!("the new blob does not decode: {e}"))?;
    super::output::write_file_atomically(&args.out, &bytes)?;
    // An MSRA's domain has no cells: saying how they were counted would mislead.
    let cells = if model.runs_a_network() {
        format!(
            "; geometry cells of at least {} sequences",
            args.cell_sequences
        )
    } else {
        String::new()
    };
    summaryln!(
        &args.out,
        "{} -> {}: training domain of {frames} frames in {} sequences ({} % tails, widened to what {} % of the sequences reached{cells}), {}",
        args.model.display(),
        super::output::output_name(&args.out),
        measured_on.len(),
        args.tail_percent,
        args.sequence_percent,
        riskscore_train::export::policy_text(args.policy)
    );
    super::output::summary(&args.out, format_args!("{summary}"));
    // A threshold calibrated on the old scores no longer has the false-alarm rate its record
    // states once the guard scores differently (another policy, ranges, cells, fallback or
    // blend); the kind's rule of thumb claims no rate.
    let new = scorer_core::model::decode_blob(&bytes)
        .map_err(|e| anyhow::anyhow!("the new blob does not decode: {e}"))?;
    let calibrated = blob
        .meta
        .default_threshold
        .is_some_and(|t| matches!(t.rule, ThresholdRule::SafeShare { .. }));
    if calibrated && scoring_records(&blob.meta) != scoring_records(&new.meta) {
        eprintln!(
            "riskctl: {}: the stored default threshold was calibrated on scores this guard \
             changes (its policy, ranges, cells, fallback or blend); run `riskctl calibrate` on \
             it again",
            args.out.display()
        );
    }
    Ok(())
}

/// The records that move a blob's scores: none without a training domain or under flag-only
/// (which scores as unguarded).
fn scoring_records<'m>(
    meta: &ModelMeta<'m>,
) -> Option<(
    TrainingDomain<'m>,
    Option<KinematicFallback<'m>>,
    Option<Blend>,
)> {
    let domain = meta
        .training_domain
        .filter(|d| d.policy != OutsidePolicy::FlagOnly)?;
    Some((domain, meta.kinematic_fallback, meta.blend))
}

/// The MSRA terms of `--fallback-from` under `--policy fallback` or `blend` (for a DRL or GSSM
/// model), else `None`; either without the other is an error.
fn fallback_terms(args: &Args, model: &Model<'_>) -> anyhow::Result<Option<Vec<MsraTerm>>> {
    let policy = args.policy.name();
    let path = match (args.policy.uses_fallback(), &args.fallback_from) {
        (true, Some(path)) => path,
        (true, None) => {
            bail!("--policy {policy} needs --fallback-from MSRA.rsk (the kinematic terms)")
        }
        (false, Some(_)) => {
            bail!("--fallback-from is only used with --policy fallback or blend")
        }
        (false, None) => return Ok(None),
    };
    if !model.runs_a_network() {
        bail!(
            "{}: --policy {policy} is for DRL and GSSM models (this is {}, itself kinematic)",
            args.model.display(),
            model.kind().name()
        );
    }
    read_kinematic_terms(path).map(Some)
}

/// The blend record under `--policy blend`: `--blend-weight`, else the blob's own, else
/// training's default. `--blend-weight` with another policy, or outside (0, 1), is an error, and
/// so is blend on a GSSM or SSRA (they stay the model of normal driving they were fitted as).
fn blend(args: &Args, blob: &ModelBlob<'_>) -> anyhow::Result<Option<Blend>> {
    let blend_policy = args.policy == OutsidePolicy::Blend;
    let weight = match (blend_policy, args.blend_weight) {
        (false, None) => return Ok(None),
        (false, Some(_)) => bail!("--blend-weight is only used with --policy blend"),
        (true, w) => w
            .or(blob.meta.blend.map(|b| b.network_weight))
            .unwrap_or(riskscore_train::train::DEFAULT_BLEND_WEIGHT),
    };
    if matches!(blob.model, Model::Gssm(_)) {
        bail!(
            "{}: --policy blend is for DRL models; a GSSM or SSRA takes --policy fallback \
             (inside its domain it stays the model of normal driving it was fitted as)",
            args.model.display()
        );
    }
    let blend = Blend {
        network_weight: weight,
    };
    if blend.validate().is_err() {
        bail!("--blend-weight {weight}: must lie strictly between 0 and 1");
    }
    Ok(Some(blend))
}

/// The terms of `--fallback-from` (the fallback keeps the kinematic ones): an MSRA blob's, or the
/// kinematic-fallback record's of any other blob (a DRL's own fallback, refitted: the shipped
/// DRL's reads the reference TAdv, which the shipped MSRA does not).
pub fn read_kinematic_terms(path: &std::path::Path) -> anyhow::Result<Vec<MsraTerm>> {
    let source = ModelFile::read(&path.display().to_string())?;
    let blob = source.blob()?;
    match (&blob.model, &blob.meta.kinematic_fallback) {
        (Model::Msra(msra), _) => Ok(msra.terms.to_vec()),
        (_, Some(fallback)) => Ok(fallback.terms().collect()),
        (model, None) => bail!(
            "--fallback-from {}: a {} blob without a kinematic fallback; give an MSRA blob or one \
             that carries a fallback",
            path.display(),
            riskscore_eval::scoring::model_row_name(model)
        ),
    }
}

/// The output must not be the model, an --events folder's file or lie inside one, nor an
/// existing file that is not a blob.
fn refuse_overlaps(args: &Args) -> anyhow::Result<()> {
    let folders: Vec<(&str, Option<&Path>)> =
        super::output::repeated("--events", &args.events).collect();
    super::output::refuse_inputs_of(
        &folders,
        &[
            ("--model", Some(&args.model)),
            ("--fallback-from", args.fallback_from.as_deref()),
        ],
        &[("--out", &args.out)],
    )?;
    // After the overlaps, as calibrate: the more precise refusal first.
    Ok(super::output::refuse_replacing_a_non_blob(
        "--out", &args.out,
    )?)
}
