//! riskscore-eval: the proactive-warning evaluation (protocol, metrics, cross-validation
//! aggregation, reports, plots) and scoring of data through scorer-core, from event folders or from
//! tables of pairs.
//!
//! - [`protocol`]: alert windows, the first-threshold rule, lead times, baseline risk directions.
//! - [`metrics`]: operating points over all thresholds; A^ROC_alpha, P^PRC_alpha, mTTI^90_p.
//! - [`report`]: per-method results, mean ± std over folds/seeds; Markdown, CSV and JSON.
//! - [`plots`] (feature `plots`): ROC and PR curves, risk trajectories (SVG and PNG).
//! - [`event_figure`] (feature `plots`): one event's paths, boxes and every method's risk.
//! - [`palette`]: one colour and line style per method in every figure.
//! - [`domain_ranges`]: a model's training-domain record, measured on its training observations.
//! - [`domain_share`]: the share of frames each guarded model saw outside its training domain.
//! - [`scoring`]: scoring an event folder with model blobs and the baselines through scorer-core.
//! - [`streaming`]: evaluating an event folder one event at a time, in bounded memory.
//! - [`staircase`]: one method's alert profiles of a folder, packed for the streamed evaluation.
//! - [`sketch`]: a bounded, mergeable summary of a method's scores (the trajectory plot's scale).
//! - [`threshold`]: one method at one threshold (recall, false alarms per hour, lead time) and the
//!   calibration rule of a model's default threshold.
//! - [`trajectory`]: the trajectory plot's data (each drawn frame at its method's percentile).
//! - [`outputs`] (feature `plots`): the result files of `riskctl evaluate --out`, rendered in memory.
//! - [`arrow_kernel`] (feature `arrow`): surrogates, features and model scores over Arrow batches.
//! - [`parquet_io`] (feature `parquet`): Parquet input and output for `riskctl ssm` / `score`.
//!
//! Event folders come from `riskscore-data`; this crate has no training dependency (no candle),
//! and without the `plots` feature no plotters either, which is how `can-bridge check` links it.
//!
//! The formulas and every edge-case convention are written down in `docs/evaluation.md`.
#[cfg(feature = "arrow")]
pub mod arrow_kernel;
pub mod bundle;
pub mod claims;
pub mod domain_ranges;
pub mod domain_share;
#[cfg(feature = "plots")]
pub mod event_figure;
pub mod metrics;
pub mod model_files;
#[cfg(feature = "plots")]
pub mod outputs;
pub mod palette;
#[cfg(feature = "parquet")]
pub mod parquet_io;
#[cfg(feature = "plots")]
pub mod plots;
pub mod protocol;
pub mod report;
#[cfg(feature = "parquet")]
pub mod score_table;
pub mod scoring;
pub mod sketch;
pub mod staircase;
pub mod streaming;
pub mod threshold;
pub mod trajectory;

pub use metrics::{
    evaluate_profiles, evaluate_sequences, warning_curve, warning_curve_reference, Metrics,
    OperatingPoint, WarningCurve,
};
pub use protocol::{
    AlertProfile, AlertProfileBuilder, Baseline, EventKind, ProtocolError, ScoredFrame,
    ScoredSequence,
};
pub use report::{
    aggregate, CvReport, EvaluationReport, EventCounts, FoldResult, MethodResult, MethodSummary,
    Stat,
};
pub use scoring::{
    evaluate_methods, evaluate_scored, observe, observe_frames, report_from_profiles, Method,
    MethodRun, ObservedFrame, ObservedSequence, Scorer,
};
