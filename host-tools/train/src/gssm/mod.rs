//! GSSM, SSRA and MSRA-with-GSSM on the host: learning the lognormal spacing model, aligning it with
//! comparisons, combining it with surrogates, and the studies that compare them. The deployed
//! inference is `scorer_core::gssm` (and `scorer_core::msra` for the combination); this module only
//! learns parameters, exports them in the core's model format and evaluates the blobs through the
//! core. The method and every default are written down in `docs/gssm.md`.
//!
//! - [`config`]: GSSM / SSRA / MSRA-with-GSSM hyper-parameters (TOML, documented defaults).
//! - [`net`]: the candle GSSM network (context MLP with the two heads `mu`, `log sigma^2`), its
//!   survival function `F_S` in the training graph, parameters and export to a GSSM blob.
//! - [`fit`]: lognormal negative log-likelihood training on safe-driving observations, with the
//!   optional smoothness regulariser.
//! - [`ssra`]: SSRA, the GSSM fine-tuned under the comparison objective through its CDF.
//! - [`msra`]: MSRA configurations that read the GSSM (EI+GSSM, TAdv+EI+GSSM, TTC2D variants), the
//!   learned weights after sigmoid normalisation, export with the embedded network.
//! - [`ship`]: the three shipped models (GSSM, SSRA, MSRA over GSSM) from one training set.
//! - [`study`]: event-level cross-validation of GSSM, SSRA and the MSRA configurations against the
//!   baselines, and the simulation-augmentation study.
pub mod config;
pub mod fit;
pub mod guard;
pub mod msra;
pub mod net;
pub mod ship;
pub mod ssra;
pub mod study;

pub use config::GssmConfig;
pub use fit::{fit_gssm, fit_gssm_on_observations, FitReport, TrainedGssm};
pub use msra::{
    align_msra_gssm, weights_table, MsraGssm, MsraGssmParams, TermWeight, TrainedMsraGssm,
};
pub use net::{GssmNet, GssmParams};
pub use ssra::{align_ssra, Ssra, TrainedSsra};

/// Failures of GSSM training, alignment, export and studies.
#[derive(Debug, thiserror::Error)]
pub enum GssmError {
    #[error("no safe-driving observations with a finite positive spacing to fit the GSSM on")]
    NoSafeObservations,
    #[error("GSSM training diverged: non-finite loss at epoch {epoch}")]
    Diverged { epoch: usize },
    #[error("invalid GSSM configuration: {0}")]
    Config(String),
    #[error("invalid GSSM configuration: smoothness_noise")]
    SmoothnessNoise(#[source] rand_distr::NormalError),
    #[error("invalid GSSM configuration: {0}")]
    Configuration(#[from] config::ConfigurationError),
    #[error("model blob: {0}")]
    Model(scorer_core::ModelError),
    #[error("{0}")]
    Train(#[from] crate::train::TrainError),
    #[error("tensor computation failed: {0}")]
    Candle(#[from] candle_core::Error),
    #[error("evaluation failed: {0}")]
    Eval(#[from] riskscore_eval::ProtocolError),
    #[error("{0}")]
    Export(#[from] crate::export::ExportError),
}

impl From<scorer_core::ModelError> for GssmError {
    fn from(e: scorer_core::ModelError) -> Self {
        GssmError::Model(e)
    }
}

/// Owned bytes of a model blob written by `scorer_core::model::encode` (decode with
/// `scorer_core::model::decode`).
pub fn encode_blob(model: &scorer_core::Model<'_>) -> Result<Vec<u8>, GssmError> {
    Ok(crate::export::encode_model(model)?)
}
