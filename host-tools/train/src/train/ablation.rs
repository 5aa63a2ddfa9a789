//! Source ablation: cross-validated metrics when training on each comparison source alone and on
//! every combination of sources, over fractions of the training events.
//!
//! Each (source set, fraction) cell runs the same event-level CV as the demo (same folds, same
//! seeds), with the other sources' pair targets set to zero, and keeps each fold's training events
//! down to `fraction` (stratified by kind). Baselines are evaluated once per fraction-free run since
//! they do not train.
use riskscore_eval::metrics::Metric;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::cv::{self, CvOptions, Models};
use super::{Progress, TrainConfig};
use crate::comparisons::Source;
use riskscore_data::events::Sequence;
use riskscore_eval::{self as eval, CvReport, EventCounts};

/// Ablation settings.
#[derive(Clone, Debug)]
pub struct AblationOptions {
    /// Source sets to train on (each non-empty).
    pub source_sets: Vec<Vec<Source>>,
    /// Fractions of each fold's training events.
    pub fractions: Vec<f64>,
    pub folds: usize,
    pub models: Models,
    pub progress: Progress,
}

/// Every non-empty subset of `sources`, singletons first, then pairs, ... (stable order).
pub fn all_combinations(sources: &[Source]) -> Vec<Vec<Source>> {
    let n = sources.len();
    let mut sets: Vec<Vec<Source>> = (1u32..(1 << n))
        .map(|mask| {
            (0..n)
                .filter(|i| mask & (1 << i) != 0)
                .map(|i| sources[i])
                .collect()
        })
        .collect();
    sets.sort_by_key(|s| s.len());
    sets
}

/// Display name of a source set (`temporal+physics`).
pub fn set_name(set: &[Source]) -> String {
    set.iter().map(|s| s.name()).collect::<Vec<_>>().join("+")
}

/// One cell of the ablation: the CV report of one source set at one fraction.
#[derive(Clone, Debug, Serialize)]
pub struct AblationCell {
    pub sources: String,
    pub fraction: f64,
    pub report: CvReport,
    pub seconds: f64,
    /// Every fold's warnings for the user ([`cv::FoldOutcome::warnings`]); not in the tables.
    #[serde(skip)]
    pub warnings: Vec<String>,
}

/// Run the ablation; `on_cell` is called after each cell (for incremental output).
pub fn run(
    seqs: &[Sequence],
    augmentation: Option<&[Sequence]>,
    config: &TrainConfig,
    opts: &AblationOptions,
    mut on_cell: impl FnMut(&AblationCell),
) -> Result<Vec<AblationCell>, cv::CvError> {
    let events = EventCounts::from_classes(seqs.iter().map(|s| s.kind));
    let mut cells = Vec::new();
    for &fraction in &opts.fractions {
        for set in &opts.source_sets {
            let started = std::time::Instant::now();
            let mut cfg = config.clone();
            cfg.comparisons = config.comparisons.restricted_to(set);
            let cv_opts = CvOptions {
                folds: opts.folds,
                seed: config.seed,
                train_fraction: fraction,
                models: Models {
                    drl_f32: false,
                    ..opts.models
                },
                baselines: false,
                progress: opts.progress,
            };
            let folds = cv::cross_validate(seqs, augmentation, &cfg, &cv_opts)?;
            let mut warnings = Vec::new();
            let results: Vec<_> = folds
                .into_iter()
                .map(|f| {
                    warnings.extend(f.warnings);
                    f.result
                })
                .collect();
            let cell = AblationCell {
                sources: set_name(set),
                fraction,
                report: eval::aggregate(events, &results),
                seconds: started.elapsed().as_secs_f64(),
                warnings,
            };
            on_cell(&cell);
            cells.push(cell);
        }
    }
    Ok(cells)
}

/// Baseline rows (no training) under the same folds, for reference.
pub fn baselines(seqs: &[Sequence], folds: usize, seed: u64) -> Result<CvReport, cv::CvError> {
    let events = EventCounts::from_classes(seqs.iter().map(|s| s.kind));
    let split = riskscore_data::events::kfold_by_event(seqs, folds, seed);
    let mut results = Vec::new();
    for fold in 0..split.k() {
        let test: Vec<Sequence> = split
            .test(fold)
            .into_iter()
            .map(|i| seqs[i].clone())
            .collect();
        let observed = eval::observe(&test);
        let (report, _) = eval::evaluate_methods(&observed, &eval::Method::baselines())
            .map_err(|source| cv::CvError::Eval { fold, source })?;
        results.push(eval::FoldResult {
            seed,
            fold,
            methods: report.methods,
        });
    }
    Ok(eval::aggregate(events, &results))
}

/// The ablation's tables: `ablation.csv` (one row per cell, method and metric:
/// `sources,fraction,method,metric,mean,std,n`) and `ablation.md` (the baselines, then one row per
/// cell and method). Written through the output layer: the old tables stay as they were until
/// [`AblationTables::finish`] renames both new ones into place (a second run writing the same
/// folder is refused; the cells' console lines are the live record of a long run).
pub struct AblationTables {
    csv: riskscore_output::AtomicFile,
    csv_path: PathBuf,
    md: String,
    md_path: PathBuf,
    /// The first write error; later cells are still tried so the console output goes on.
    error: Option<std::io::Error>,
}

impl AblationTables {
    /// Creates `ablation.csv` and `ablation.md` in `dir`; `data` describes the event folder and its
    /// counts in the Markdown header.
    pub fn create(
        dir: &Path,
        data: &str,
        folds: usize,
        baselines: &CvReport,
    ) -> std::io::Result<Self> {
        let csv_path = dir.join("ablation.csv");
        let mut csv = riskscore_output::AtomicFile::create(&csv_path)?;
        writeln!(csv, "sources,fraction,method,metric,mean,std,n")?;
        let mut md = String::from("# Comparison-source ablation\n\n");
        md.push_str(&format!(
            "Data: {data}; {folds}-fold event-level CV; fractions of each fold's training events.\n\n"
        ));
        md.push_str("## Baselines (no training)\n\n");
        md.push_str(&baselines.to_markdown());
        md.push_str("\n## Learned models\n\n| sources | fraction | method | A_ROC_90 | P_PRC_90 | mTTI_90 (s) |\n|---|---|---|---|---|---|\n");
        Ok(AblationTables {
            csv,
            csv_path,
            md,
            md_path: dir.join("ablation.md"),
            error: None,
        })
    }

    /// Adds one cell to both tables; returns its console lines (one per method).
    pub fn add(&mut self, cell: &AblationCell) -> Vec<String> {
        let mut lines = Vec::new();
        let runs = cell.report.runs;
        for m in &cell.report.methods {
            // Cells as the CV tables write them, to 0.01 (`(k/n)` where defined in fewer runs).
            let [aroc, pprc, mtti] = [Metric::ARoc90, Metric::PPrc90, Metric::MTti90]
                .map(|metric| eval::report::metric_cell(m.stat(metric), runs, 2));
            lines.push(format!(
                "{:<40} {:>4.0}%  {:<5} A_ROC_90 {aroc:<16} P_PRC_90 {pprc:<16} mTTI_90 {mtti}  ({:.0} s)",
                cell.sources,
                cell.fraction * 100.0,
                m.name,
                cell.seconds
            ));
            self.md.push_str(&format!(
                "| {} | {:.0} % | {} | {aroc} | {pprc} | {mtti} |\n",
                cell.sources,
                cell.fraction * 100.0,
                m.name,
            ));
            for metric in Metric::ALL {
                if let Some(s) = m.stat(metric) {
                    if let Err(e) = writeln!(
                        self.csv,
                        "{},{},{},{},{},{},{}",
                        cell.sources,
                        cell.fraction,
                        m.name,
                        metric.key(),
                        s.mean,
                        s.std,
                        s.n
                    ) {
                        self.error.get_or_insert(e);
                    }
                }
            }
        }
        lines
    }

    /// Renames both tables into place; returns their paths, or the first write error (naming
    /// the file; the old tables are then unchanged).
    pub fn finish(mut self) -> std::io::Result<(PathBuf, PathBuf)> {
        let named = |path: &Path, e: std::io::Error| {
            std::io::Error::new(e.kind(), format!("{}: {e}", path.display()))
        };
        if let Some(e) = self.error.take() {
            return Err(named(&self.csv_path, e));
        }
        let mut set = riskscore_output::AtomicSet::default();
        set.push(self.csv);
        set.create(&self.md_path)
            .and_then(|md| md.write_all(self.md.as_bytes()))
            .map_err(|e| named(&self.md_path, e))?;
        set.commit()?;
        Ok((self.csv_path, self.md_path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use riskscore_eval::report::{MethodSummary, Stat};

    /// A metric defined in one of two runs (DRL's mTTI when one fold has no threshold of 90 %
    /// precision) was written `2.79 ± 0.00` in the console line and ablation.md: no spread over
    /// the runs, where there was one run. It carries `(1/2)` now, as the CV tables do; the CSV
    /// has its `n` column.
    #[test]
    fn a_cell_defined_in_fewer_than_all_runs_says_in_how_many() {
        let dir = tempfile::tempdir().unwrap();
        let stat = |mean: f64, std: f64, n: usize| Some(Stat { mean, std, n });
        let report = CvReport {
            events: EventCounts::default(),
            runs: 2,
            methods: vec![MethodSummary {
                name: "DRL".into(),
                stats: [
                    stat(46.47, 53.94, 2),
                    None,
                    stat(75.77, 19.38, 2),
                    None,
                    stat(2.79, 0.0, 1),
                ],
            }],
        };
        let mut tables = AblationTables::create(dir.path(), "sim", 2, &report).unwrap();
        let lines = tables.add(&AblationCell {
            sources: "temporal".into(),
            fraction: 0.5,
            report,
            seconds: 0.0,
            warnings: Vec::new(),
        });
        assert!(
            lines[0].contains("mTTI_90 2.79 ± 0.00 (1/2)"),
            "{}",
            lines[0]
        );
        assert!(lines[0].contains("A_ROC_90 46.47 ± 53.94 "), "{}", lines[0]);
        let (_, md) = tables.finish().unwrap();
        let md = std::fs::read_to_string(md).unwrap();
        assert!(
            md.contains(
                "| temporal | 50 % | DRL | 46.47 ± 53.94 | 75.77 ± 19.38 | 2.79 ± 0.00 (1/2) |"
            ),
            "{md}"
        );
    }
}
