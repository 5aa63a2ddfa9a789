//! The result files of `riskctl evaluate --out`, rendered in memory so the caller can write them
//! all through temporary files and rename them into place together.
use super::metrics::WarningCurve;
use super::plots::{curve_figures, trajectory_figures, FigureFile, PlotError, TrajectoryPanel};
use super::report::{write_curves_csv, EvaluationReport};

/// The tables among the result files (the figures are [`FIGURE_FILES`](super::plots::FIGURE_FILES)).
pub const RESULT_FILES: [&str; 4] = ["results.csv", "results.json", "results.md", "curves.csv"];

/// A result file could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{name}: {source}")]
    Table {
        name: &'static str,
        #[source]
        source: csv::Error,
    },
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// Every result file: the tables of `report` and `curves`, the ROC and PR figures, and the
/// trajectory figure when `panels` is not empty.
pub fn result_files(
    report: &EvaluationReport,
    curves: &[(String, WarningCurve)],
    panels: &[TrajectoryPanel],
) -> Result<Vec<FigureFile>, OutputError> {
    let table = |name: &'static str, bytes: Vec<u8>| FigureFile {
        name: name.to_owned(),
        bytes,
    };
    let mut csv = Vec::new();
    report
        .write_csv(&mut csv)
        .map_err(|source| OutputError::Table {
            name: "results.csv",
            source,
        })?;
    let mut curves_csv = Vec::new();
    write_curves_csv(curves, &mut curves_csv).map_err(|source| OutputError::Table {
        name: "curves.csv",
        source,
    })?;
    let mut files = vec![
        table("results.csv", csv),
        table(
            "results.json",
            (report.to_json_string() + "\n").into_bytes(),
        ),
        table("results.md", report.to_markdown().into_bytes()),
        table("curves.csv", curves_csv),
    ];
    files.extend(curve_figures(curves)?);
    if !panels.is_empty() {
        files.extend(trajectory_figures(panels)?);
    }
    Ok(files)
}
