//! riskscore-train: learning risk models from pairwise comparisons (candle), and turning them
//! into the model blobs `scorer-core` runs. Every feature, surrogate, quantised inference and
//! warning decision is computed by `scorer-core`; evaluation is `riskscore-eval`'s.
//!
//! - [`comparisons`]: pairwise comparisons, one module per source.
//! - [`train`]: objective and training for DRL and MSRA, event-level cross-validation, ablation.
//! - [`gssm`]: GSSM, SSRA and MSRA over GSSM (fit, align, combine, studies).
//! - [`nn`]: the shared candle kernel: the dense network and the early-stopping trainer.
//! - [`quantize`]: post-training int8 quantisation through the core's requantisation.
//! - [`export`]: writing and inspecting model blobs and checkpoints.
//! - [`final_models`]: DRL and MSRA trained on all data, quantised and written (`riskctl train`).
//! - [`transfer`]: the transfer benchmark (train on one data set, test on another).
//! - [`domains`]: the domain benchmark (slices by speed, geometry and source; hold one out).
//! - [`parallel`]: the folds of a benchmark on every core, results in fold order.
pub mod comparisons;
pub mod domains;
pub mod export;
pub mod fallback;
pub mod final_models;
pub mod gssm;
pub mod nn;
pub mod parallel;
pub mod quantize;
pub mod train;
pub mod transfer;
