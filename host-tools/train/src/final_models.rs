//! The final models of a training run: DRL and MSRA trained on every sequence, the DRL quantised
//! (and checked against its float network), both written as checkpoints and model blobs. What
//! `riskctl train` and the demo's last training step produce.
use std::path::{Path, PathBuf};

use serde_json::json;

use crate::export::{self, Checkpoint, CheckpointModel, DrlFormat, ExportError};
use crate::quantize::{self, Agreement};
use crate::train::{self, Progress, TrainConfig, TrainError, TrainedDrl, TrainedMsra};
use riskscore_data::events::Sequence;

/// Why the final models could not be trained or written.
#[derive(Debug, thiserror::Error)]
pub enum FinalModelsError {
    #[error("final training: {0}")]
    Train(#[from] TrainError),
    #[error("export: {0}")]
    Export(#[from] ExportError),
}

/// The final models: trained on every sequence, quantised and exported.
pub struct FinalModels {
    pub drl: TrainedDrl,
    pub msra: TrainedMsra,
    pub agreement: Agreement,
    pub pairs_per_second: f64,
    /// What the caller should show its user: a DRL whose kinematic fallback could not be fitted
    /// (its guard became `flag-only`).
    pub warnings: Vec<String>,
}

/// The files [`train_and_export`] writes into its folder (and only these: other files there are
/// left alone): the DRL and MSRA checkpoints, then the int8 DRL, f32 DRL and MSRA blobs.
pub const FINAL_MODEL_FILES: [&str; 5] = [
    "drl.json",
    "msra.json",
    "drl.rsk",
    "drl-f32.rsk",
    "msra.rsk",
];

/// Train DRL and MSRA on all of `train` (DRL also on `drl_only`), write checkpoints and blobs into `dir`: `drl.json`,
/// `msra.json`, `drl.rsk` (int8), `drl-f32.rsk` and `msra.rsk` (each with its training domain under
/// `config.guard`). `meta` goes into both checkpoints.
/// Returns the models and the files written.
pub fn train_and_export(
    train: &[Sequence],
    drl_only: &[Sequence],
    augmentation: Option<&[Sequence]>,
    config: &TrainConfig,
    dir: &Path,
    meta: serde_json::Value,
    progress: Progress,
) -> Result<(FinalModels, Vec<PathBuf>), FinalModelsError> {
    // Made now (a bad --out fails before training), removed again if the run fails.
    let new_folders =
        riskscore_output::NewFolders::create(dir).map_err(|source| ExportError::Io {
            path: dir.display().to_string(),
            source,
        })?;
    let prepared = train::prepare_comparisons(train, augmentation, config);
    let drl_own = train::drl_own_side(train, drl_only, augmentation, config);
    let (drl_train, drl_comparisons) = match &drl_own {
        Some((sequences, comparisons)) => (sequences.as_slice(), comparisons),
        None => (train, &prepared),
    };
    let drl = train::train_drl(drl_train, drl_comparisons, config, progress)?;
    let msra = train::train_msra(train, &prepared, config, progress)?;
    let fallback_msra = train::train_fallback_msra(
        (drl_train, drl_comparisons),
        (train, &prepared),
        config,
        progress,
    )?;
    let q = quantize::quantize(&drl.params, &drl.calibration).map_err(ExportError::from)?;
    let obs = train::calibration_observations(drl_train, usize::MAX);
    let agreement = quantize::verify(&drl.params, &q, &obs).map_err(ExportError::from)?;
    let mut files = Vec::new();
    let drl_ck = Checkpoint::new(
        CheckpointModel::Drl {
            params: drl.params.clone(),
            calibration: drl.calibration.clone(),
        },
        json!({"model": "DRL", "meta": meta, "training": drl.report, "comparisons": drl_comparisons.fit.stats}),
    );
    let msra_ck = Checkpoint::new(
        CheckpointModel::Msra {
            params: msra.params.clone(),
        },
        json!({"model": "MSRA", "meta": meta, "training": msra.report, "comparisons": prepared.fit.stats}),
    );
    let msra_terms = export::msra_terms(&fallback_msra.as_ref().unwrap_or(&msra).params)?;
    let mut contents = Vec::new();
    let mut warnings = Vec::new();
    let [drl_json, msra_json, drl_rsk, drl_f32_rsk, msra_rsk] = FINAL_MODEL_FILES;
    for (name, ck) in [(drl_json, &drl_ck), (msra_json, &msra_ck)] {
        let p = dir.join(name);
        contents.push((p.clone(), ck.to_json(&p)?));
    }
    for (name, blob, trained_on) in [
        (
            drl_rsk,
            export::export(&drl_ck, DrlFormat::Int8)?,
            drl_train,
        ),
        (
            drl_f32_rsk,
            export::export(&drl_ck, DrlFormat::F32)?,
            drl_train,
        ),
        (msra_rsk, export::export(&msra_ck, DrlFormat::Int8)?, train),
    ] {
        let guarded = export::with_measured_domain(
            &blob,
            trained_on,
            &config.guard,
            Some(msra_terms.as_slice()),
        )?;
        warnings.extend(guarded.warning(name));
        if name == drl_rsk {
            warnings.extend(outside_share_warning(name, &guarded, trained_on));
        }
        contents.push((dir.join(name), guarded.bytes));
    }
    // The five files are one output: all new or all old.
    export::write_set(dir, &contents)?;
    new_folders.keep();
    files.extend(contents.into_iter().map(|(p, _)| p));
    Ok((
        FinalModels {
            drl,
            msra,
            agreement,
            pairs_per_second: prepared.fit.stats.pairs_per_second(),
            warnings,
        },
        files,
    ))
}

/// Share of a model's training frames outside the domain it carries above which training warns:
/// the full default folder leaves 8 % of its frames outside, a 30-event one 61 %.
const OUTSIDE_SHARE_WARNING: f64 = 0.25;

/// A warning when more than [`OUTSIDE_SHARE_WARNING`] of the frames a guarded model was trained
/// on lie outside the training domain it carries: there its score is the kinematic fallback's,
/// not the network's. A small folder does that (a geometry cell counts only where at least 5
/// training sequences reached it), and nothing else would tell the user who trained it.
fn outside_share_warning(
    name: &str,
    guarded: &export::GuardedBlob,
    trained_on: &[Sequence],
) -> Option<String> {
    let inside = guarded.fallback.as_ref()?.frames;
    let total: usize = trained_on.iter().map(|s| s.frames.len()).sum();
    let outside = total.saturating_sub(inside);
    let share = outside as f64 / total.max(1) as f64;
    (share > OUTSIDE_SHARE_WARNING).then(|| {
        format!(
            "{name}: {outside} of its {total} training frames ({:.0} %) lie outside the training \
             domain it carries (a geometry cell counts only where at least 5 training sequences \
             reached it, and {} sequences reach few): there it scores with its kinematic \
             fallback, not the network (riskctl evaluate lists the share outside); train on more \
             events, or choose another [guard] policy (docs/domain-guard.md)",
            100.0 * share,
            trained_on.len()
        )
    })
}
