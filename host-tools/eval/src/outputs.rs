//! The result files of `riskctl evaluate --out`, rendered in memory so the caller can write them
//! all through temporary files and rename them into place together.
use super::bundle::{BundleError, ReportBundle};
use super::metrics::WarningCurve;
use super::plots::{curve_figures, trajectory_figures, PlotError, TrajectoryPanel};
use super::report::{write_curves_csv, EvaluationReport};

/// The tables among the result files (the figures are [`FIGURE_FILES`](super::plots::FIGURE_FILES)).
pub const RESULT_FILES: [&str; 4] = ["results.csv", "results.json", "results.md", "curves.csv"];

/// What the figures of `riskctl evaluate --out` plot: the scores behind the table, so the legend's
/// A^ROC_90 and P^PRC_90 are the table's.
const TABLE_SCORES: &str =
    "scores: every sequence of the folder, scored once (the same scores as results.md)";

/// A result file could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error(transparent)]
    Table(#[from] BundleError),
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// Every result file: `report` as results.csv, `json` and `markdown` as results.json and
/// results.md (the caller's full text of the run: `riskctl evaluate` adds its operating points
/// and domain shares to the report's), the table of `curves`, the ROC and PR figures, and the
/// trajectory figure when `panels` is not empty.
pub fn result_files(
    report: &EvaluationReport,
    json: String,
    markdown: String,
    curves: &[(String, WarningCurve)],
    panels: &[TrajectoryPanel],
) -> Result<ReportBundle, OutputError> {
    let mut bundle = ReportBundle::default();
    bundle.add_csv("results.csv", |w| report.write_csv(w))?;
    bundle.add("results.json", json);
    bundle.add("results.md", markdown);
    bundle.add_csv("curves.csv", |w| write_curves_csv(curves, w))?;
    bundle.files.extend(curve_figures(curves, TABLE_SCORES)?);
    if !panels.is_empty() {
        bundle
            .files
            .extend(trajectory_figures(panels, TABLE_SCORES)?);
    }
    Ok(bundle)
}
