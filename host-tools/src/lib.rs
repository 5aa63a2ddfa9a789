//! Host side of riskscore. Every feature, surrogate, quantised inference and warning decision is
//! computed by `scorer-core`; this crate only moves data around it, learns parameters and reports.
//!
//! - [`ssm_csv`]: streaming CSV scoring of ego/partner pairs (`riskctl ssm`).
//! - [`arrow_kernel`] (feature `arrow`): surrogates, features and model scores over Arrow batches.
//! - [`parquet_io`] (feature `parquet`): Parquet input and output for `riskctl ssm` / `score`.
//! - [`events`]: the event-folder format (loading, validation, sequence preparation).
//! - [`sim`]: the scenario simulator that writes event folders.
//! - [`comparisons`]: pairwise comparisons, one module per source.
//! - [`train`]: objective and training (candle) for DRL and MSRA.
//! - [`eval`]: the proactive-warning evaluation protocol, metrics, reports and plots.
//! - [`quantize`]: post-training int8 quantisation through the core's requantisation.
//! - [`export`]: writing and inspecting model blobs.
//! - [`gssm`]: GSSM, SSRA and MSRA over GSSM (fit, align, combine, studies).
//! - [`import`]: recorded data from other formats (CommonRoad scenarios) as event folders.
//! - [`candump_export`]: event tables as 10 Hz vehicle CAN traffic in candump format.
//! - [`demo`]: the end-to-end main job.
#[cfg(feature = "arrow")]
pub mod arrow_kernel;
pub mod candump_export;
pub mod comparisons;
pub mod demo;
pub mod eval;
pub mod events;
pub mod export;
pub mod gssm;
pub mod import;
#[cfg(feature = "parquet")]
pub mod parquet_io;
pub mod quantize;
pub mod sim;
pub mod ssm_csv;
pub mod train;
pub mod transfer;
