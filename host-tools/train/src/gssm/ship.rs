//! The three shipped models of the GSSM family from one training set (`riskctl gssm ship`): the
//! GSSM fitted on normal driving, SSRA aligned from it under the comparison objective, and MSRA over
//! it with the configuration's shipped terms, as model blobs with a JSON summary.
use std::path::{Path, PathBuf};

use scorer_core::gssm::GssmScore;
use scorer_core::msra::MsraTerm;
use scorer_core::SurrogateKind;

use super::guard::guard_blobs;
use super::msra::{configuration_name, parse_configuration};
use super::{
    align_msra_gssm, align_ssra, fit_gssm, GssmConfig, GssmError, TrainedGssm, TrainedMsraGssm,
    TrainedSsra,
};
use crate::export::write_blob;
use crate::train::{prepare_comparisons, Progress, TrainConfig};
use riskscore_data::events::Sequence;

/// File names of the shipped models, in the order [`Shipped::blobs`] returns them.
pub const SHIPPED_FILES: [&str; 3] = ["gssm-default.rsk", "ssra-default.rsk", "msra-gssm.rsk"];
/// File name of the summary written beside them.
pub const SUMMARY_FILE: &str = "gssm-ship.json";

/// The trained models and their blobs.
#[derive(Clone, Debug)]
pub struct Shipped {
    /// The MSRA terms (`msra.shipped` of the GSSM configuration).
    pub kinds: Vec<SurrogateKind>,
    pub sequences: usize,
    pub gssm: TrainedGssm,
    pub ssra: TrainedSsra,
    pub msra: TrainedMsraGssm,
    /// GSSM (scoring its intensity), SSRA and MSRA blobs, as named by [`SHIPPED_FILES`], each
    /// with its training-domain record.
    pub blobs: [Vec<u8>; 3],
    /// Models whose kinematic fallback could not be fitted (their guard became `flag-only`).
    pub warnings: Vec<String>,
}

/// Fits the GSSM on `normal` (safe sequences are used), aligns SSRA and trains MSRA over it on the
/// comparisons of `train`; every blob carries the training domain of `normal` under
/// `config.guard.policy` ([`guard_blobs`]), with `fallback_terms` (an MSRA's, the kinematic
/// ones are kept) as the kinematic fallback; without them a `fallback` policy is written as
/// `flag-only`.
pub fn ship(
    train: &[Sequence],
    normal: &[Sequence],
    config: &TrainConfig,
    gssm_config: &GssmConfig,
    fallback_terms: Option<&[MsraTerm]>,
    progress: Progress,
) -> Result<Shipped, GssmError> {
    let kinds = parse_configuration(&gssm_config.msra.shipped)?;
    let gssm = fit_gssm(
        normal,
        config.optimiser.validation_fraction,
        config.seed,
        &gssm_config.fit,
        progress,
    )?;
    let prepared = prepare_comparisons(train, None, config);
    let ssra = align_ssra(&gssm.params, &prepared, config, &gssm_config.ssra, progress)?;
    let msra = align_msra_gssm(
        &kinds,
        &gssm.params,
        train,
        &prepared,
        config,
        gssm_config.msra.learning_rate,
        progress,
    )?;
    let mut named = [
        (
            "gssm".to_string(),
            gssm.params.gssm_blob(GssmScore::Intensity)?,
        ),
        ("ssra".to_string(), ssra.blob()?),
        ("msra-gssm".to_string(), msra.params.blob()?),
    ];
    let warnings = guard_blobs(&mut named, normal, config.guard.policy, fallback_terms)?;
    let blobs = named.map(|(_, bytes)| bytes);
    Ok(Shipped {
        kinds,
        sequences: train.len(),
        gssm,
        ssra,
        msra,
        blobs,
        warnings,
    })
}

impl Shipped {
    /// Writes the three blobs into `dir` ([`SHIPPED_FILES`]); returns their paths.
    pub fn write_models(&self, dir: &Path) -> Result<Vec<PathBuf>, GssmError> {
        let mut written = Vec::new();
        for (name, blob) in SHIPPED_FILES.iter().zip(&self.blobs) {
            let path = dir.join(name);
            write_blob(&path, blob)?;
            written.push(path);
        }
        Ok(written)
    }

    /// What was trained, for `gssm-ship.json`: the event folders (`events`, `normal`), shapes,
    /// reports, learned weights, sizes and both configurations.
    pub fn summary(
        &self,
        config: &TrainConfig,
        gssm_config: &GssmConfig,
        events: &[PathBuf],
        normal: &[PathBuf],
    ) -> serde_json::Value {
        let (g, s, m) = (&self.gssm, &self.ssra, &self.msra);
        serde_json::json!({
            "events": events.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "normal": normal.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "sequences": self.sequences,
            "seed": config.seed,
            "gssm": {"shape": g.params.shape(), "parameters": g.params.parameter_count(),
                     "fit": g.report, "bytes": self.blobs[0].len()},
            "ssra": {"epochs": s.report.epochs, "best_epoch": s.report.best_epoch, "pairs": s.report.pairs,
                     "validation_before": s.initial_validation.map(|p| p.total),
                     "validation_after": s.final_validation.map(|p| p.total),
                     "kept_initial": s.kept_initial, "bytes": self.blobs[1].len()},
            "msra": {"configuration": configuration_name(&self.kinds), "weights": m.params.weights(),
                     "epochs": m.report.epochs, "bytes": self.blobs[2].len()},
            "train_config": config, "gssm_config": gssm_config,
        })
    }
}
