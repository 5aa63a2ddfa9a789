//! The proactive-warning evaluation: protocol, metrics, cross-validation aggregation, reports, plots.
//!
//! - [`protocol`]: alert windows, the first-threshold rule, lead times, baseline risk directions.
//! - [`metrics`]: operating points over all thresholds; A^ROC_alpha, P^PRC_alpha, mTTI^90_p.
//! - [`report`]: per-method results, mean ± std over folds/seeds; Markdown, CSV and JSON.
//! - [`plots`]: ROC and PR curves, risk trajectories (SVG and PNG).
//! - [`scoring`]: scoring an event folder with model blobs and the baselines through scorer-core.
//! - [`streaming`]: evaluating an event folder one event at a time, in bounded memory.
//! - [`staircase`]: one method's alert profiles of a folder, packed for the streamed evaluation.
//! - [`sketch`]: a bounded, mergeable summary of a method's scores (the trajectory plot's scale).
//! - [`outputs`]: the result files of `riskctl evaluate --out`, rendered in memory.
//!
//! The formulas and every edge-case convention are written down in `docs/evaluation.md`.
pub mod metrics;
pub mod outputs;
pub mod plots;
pub mod protocol;
pub mod report;
pub mod scoring;
pub mod sketch;
pub mod staircase;
pub mod streaming;

pub use metrics::{
    evaluate_profiles, evaluate_sequences, warning_curve, warning_curve_reference, Metrics,
    OperatingPoint, WarningCurve,
};
pub use protocol::{
    AlertProfile, AlertProfileBuilder, Baseline, ProtocolError, ScoredFrame, ScoredSequence,
    SequenceClass,
};
pub use report::{
    aggregate, CvReport, EvaluationReport, EventCounts, FoldResult, MethodResult, MethodSummary,
    Stat,
};
pub use scoring::{
    evaluate_methods, evaluate_scored, observe, observe_frames, report_from_profiles, Method,
    MethodRun, ObservedFrame, ObservedSequence, Scorer,
};
