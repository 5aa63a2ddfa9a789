//! Per-method results, their mean ± std over folds and seeds, and the three output formats.
//!
//! [`EvaluationReport`] is one evaluation (one event set, e.g. `riskctl evaluate` or one CV fold);
//! its JSON is the stable `riskctl evaluate --json` schema. [`CvReport`] aggregates
//! [`FoldResult`]s (5-fold event-level CV × seeds) into `mean ± std`.
use std::io::Write;

use serde::{Deserialize, Serialize};
use serde_json::{json, Map, Value};

use super::metrics::{Metric, Metrics, WarningCurve, METRIC_KEYS};
use super::protocol::EventKind;

/// How many events of each kind were evaluated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EventCounts {
    pub crash: usize,
    pub near_crash: usize,
    pub safe: usize,
}

/// Counts of several data sets added up (e.g. the test sets of several simulator draws).
impl std::ops::AddAssign for EventCounts {
    fn add_assign(&mut self, other: EventCounts) {
        self.crash += other.crash;
        self.near_crash += other.near_crash;
        self.safe += other.safe;
    }
}

impl EventCounts {
    pub fn from_classes(classes: impl IntoIterator<Item = EventKind>) -> Self {
        let mut c = EventCounts::default();
        for kind in classes {
            match kind {
                EventKind::Crash => c.crash += 1,
                EventKind::NearCrash => c.near_crash += 1,
                EventKind::Safe => c.safe += 1,
            }
        }
        c
    }

    pub fn total(&self) -> usize {
        self.crash + self.near_crash + self.safe
    }

    fn to_json(self) -> Value {
        json!({"crash": self.crash, "near_crash": self.near_crash, "safe": self.safe})
    }

    fn sentence(&self) -> String {
        format!(
            "{} events: {} crash, {} near-crash, {} safe",
            self.total(),
            self.crash,
            self.near_crash,
            self.safe
        )
    }
}

/// One method's metrics on one event set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodResult {
    /// Row name: `DRL`, `MSRA`, `GSSM`, `SSRA`, `TTC2D`, `TAdv`, `EI`, or a model file stem.
    pub name: String,
    pub metrics: Metrics,
}

/// One evaluation of several methods on one event set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvaluationReport {
    pub events: EventCounts,
    pub methods: Vec<MethodResult>,
}

fn opt_number(x: Option<f64>) -> Value {
    x.filter(|v| v.is_finite()).map_or(Value::Null, Value::from)
}

fn metric_object(name: &str, values: impl IntoIterator<Item = (&'static str, Value)>) -> Value {
    let mut row = Map::new();
    row.insert("name".into(), Value::from(name));
    for (k, v) in values {
        row.insert(k.into(), v);
    }
    Value::Object(row)
}

const HEADER: &str =
    "| Method | A^ROC_90 (%) | A^ROC_80 (%) | P^PRC_90 (%) | P^PRC_80 (%) | mTTI^90_p (s) |\n\
     |---|---:|---:|---:|---:|---:|\n";

/// Decimal places per metric column: percentages to 0.1, lead time to 0.01 s.
const DECIMALS: [usize; 5] = [1, 1, 1, 1, 2];

/// A row of the `--json` output, fields in schema order.
#[derive(Serialize)]
struct JsonRow<'a> {
    name: &'a str,
    #[serde(rename = "A_ROC_90")]
    a_roc_90: Option<f64>,
    #[serde(rename = "A_ROC_80")]
    a_roc_80: Option<f64>,
    #[serde(rename = "P_PRC_90")]
    p_prc_90: Option<f64>,
    #[serde(rename = "P_PRC_80")]
    p_prc_80: Option<f64>,
    #[serde(rename = "mTTI_90")]
    mtti_90: Option<f64>,
}

#[derive(Serialize)]
struct JsonReport<'a> {
    events: EventCounts,
    methods: Vec<JsonRow<'a>>,
}

impl EvaluationReport {
    fn json_report(&self) -> JsonReport<'_> {
        let finite = |x: Option<f64>| x.filter(|v| v.is_finite());
        JsonReport {
            events: self.events,
            methods: self
                .methods
                .iter()
                .map(|m| JsonRow {
                    name: &m.name,
                    a_roc_90: finite(m.metrics.a_roc_90),
                    a_roc_80: finite(m.metrics.a_roc_80),
                    p_prc_90: finite(m.metrics.p_prc_90),
                    p_prc_80: finite(m.metrics.p_prc_80),
                    mtti_90: finite(m.metrics.mtti_90),
                })
                .collect(),
        }
    }

    /// [`Self::to_json`] as pretty-printed text with keys in schema order (`name` first): what
    /// `riskctl evaluate --json` prints.
    pub fn to_json_string(&self) -> String {
        serde_json::to_string_pretty(&self.json_report()).unwrap_or_default()
    }

    /// The `riskctl evaluate --json` object (stable schema):
    /// `{"events": {"crash", "near_crash", "safe"}, "methods": [{"name", "A_ROC_90", "A_ROC_80",
    /// "P_PRC_90", "P_PRC_80", "mTTI_90"}]}`, percentages 0-100, seconds, `null` where undefined.
    pub fn to_json(&self) -> Value {
        let methods: Vec<Value> = self
            .methods
            .iter()
            .map(|m| metric_object(&m.name, m.metrics.named().map(|(k, v)| (k, opt_number(v)))))
            .collect();
        json!({"events": self.events.to_json(), "methods": methods})
    }

    /// The Markdown results table (rows = methods), preceded by the event counts.
    pub fn to_markdown(&self) -> String {
        let mut out = format!("{}\n\n{HEADER}", self.events.sentence());
        for m in &self.methods {
            out.push_str(&format!("| {} |", m.name));
            for ((_, v), decimals) in m.metrics.named().iter().zip(DECIMALS) {
                out.push_str(&format!(" {} |", format_value(*v, decimals)));
            }
            out.push('\n');
        }
        out
    }

    /// CSV: `method,A_ROC_90,A_ROC_80,P_PRC_90,P_PRC_80,mTTI_90` (empty cell where undefined).
    pub fn write_csv<W: Write>(&self, writer: W) -> csv::Result<()> {
        let mut w = csv::Writer::from_writer(writer);
        let mut header = vec!["method"];
        header.extend(METRIC_KEYS);
        w.write_record(&header)?;
        for m in &self.methods {
            let mut row = vec![m.name.clone()];
            row.extend(m.metrics.named().iter().map(|(_, v)| csv_cell(*v)));
            w.write_record(&row)?;
        }
        w.flush()?;
        Ok(())
    }
}

/// A metric to `decimals` places by [`fixed`]; `n/a` for none.
pub fn format_value(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "n/a".to_owned(), |x| fixed(x, decimals))
}

/// Round-off below a millionth of the last printed place that [`fixed`] ignores.
const PRINT_SNAP: f64 = 1e6;

/// `x` to `decimals` places, as the value it stands for rounds: ties to even, after dropping
/// round-off below a millionth of the last place. The metrics are ratios of counts and means of
/// lead times read off a decimal clock, so an exact tie such as a mean lead of 23/8 = 2.875 s is
/// common, and summing `7.6 - 4.7` in `f64` lands it at 2.874999999999999, which `{:.2}` alone
/// prints as 2.87: the printed digit would depend on the order of a sum. Values too large to
/// snap (never a metric) and non-finite ones are printed as `{:.N}` prints them.
pub fn fixed(x: f64, decimals: usize) -> String {
    let scale = 10f64.powi(i32::try_from(decimals).unwrap_or(i32::MAX));
    let scaled = x * scale;
    if !scaled.is_finite() || scaled.abs() * PRINT_SNAP >= 2f64.powi(52) {
        return format!("{x:.decimals$}");
    }
    let snapped = (scaled * PRINT_SNAP).round() / PRINT_SNAP;
    format!("{:.decimals$}", snapped.round_ties_even() / scale)
}

pub(crate) fn csv_cell(v: Option<f64>) -> String {
    v.map_or_else(String::new, |x| x.to_string())
}

/// The results of one fold of one CV run (one seed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FoldResult {
    pub seed: u64,
    pub fold: usize,
    pub methods: Vec<MethodResult>,
}

/// Mean and sample standard deviation (`n - 1`; 0 when `n == 1`) over the runs where a metric is
/// defined.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stat {
    pub mean: f64,
    pub std: f64,
    /// Number of runs (folds × seeds) in which the metric was defined.
    pub n: usize,
}

impl Stat {
    /// `None` for an empty sample.
    pub fn of(values: &[f64]) -> Option<Stat> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let std = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        Some(Stat { mean, std, n })
    }
}

/// One method aggregated over runs, metrics in [`METRIC_KEYS`] order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodSummary {
    pub name: String,
    pub stats: [Option<Stat>; 5],
}

impl MethodSummary {
    /// The aggregate of one metric; `None` where it was never defined.
    pub fn stat(&self, metric: Metric) -> Option<Stat> {
        self.stats[metric as usize]
    }
}

/// mean ± std of every method over all folds and seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CvReport {
    /// Events of the whole data set (each is in exactly one test fold per seed).
    pub events: EventCounts,
    /// Number of fold results aggregated (folds × seeds).
    pub runs: usize,
    pub methods: Vec<MethodSummary>,
}

impl CvReport {
    /// The fold mean of `metric` for `method`; `None` if the method is missing or the metric was
    /// never defined.
    pub fn mean(&self, method: &str, metric: Metric) -> Option<f64> {
        self.methods
            .iter()
            .find(|m| m.name == method)
            .and_then(|m| m.stat(metric))
            .map(|s| s.mean)
    }
}

/// Aggregate per-fold results: each metric's mean ± std over the runs where it is defined (a run
/// where it is undefined, or where the method is missing, is left out and shows in `Stat::n`).
/// Methods keep the order in which they first appear.
pub fn aggregate(events: EventCounts, folds: &[FoldResult]) -> CvReport {
    let mut names: Vec<&str> = Vec::new();
    for m in folds.iter().flat_map(|f| &f.methods) {
        if !names.contains(&m.name.as_str()) {
            names.push(&m.name);
        }
    }
    let methods = names
        .iter()
        .map(|name| {
            let per_run: Vec<&Metrics> = folds
                .iter()
                .filter_map(|f| f.methods.iter().find(|m| m.name == *name))
                .map(|m| &m.metrics)
                .collect();
            let stats = Metric::ALL.map(|metric| {
                let values: Vec<f64> = per_run.iter().filter_map(|m| m.get(metric)).collect();
                Stat::of(&values)
            });
            MethodSummary {
                name: (*name).to_owned(),
                stats,
            }
        })
        .collect();
    CvReport {
        events,
        runs: folds.len(),
        methods,
    }
}

/// One `mean ± std` cell of a CV table, both to `decimals` places: `n/a` where the metric was never
/// defined, and `(k/n)` appended where it was defined in only `k` of the `runs` runs, or its
/// `± 0.00` would read as no spread over the runs ([`CvReport::to_markdown`], the ablation tables).
pub fn metric_cell(stat: Option<Stat>, runs: usize, decimals: usize) -> String {
    match stat {
        None => "n/a".to_owned(),
        Some(s) => {
            let d = decimals;
            let mut c = format!("{} ± {}", fixed(s.mean, d), fixed(s.std, d));
            if s.n < runs {
                c.push_str(&format!(" ({}/{runs})", s.n));
            }
            c
        }
    }
}

impl CvReport {
    /// Same shape as [`EvaluationReport::to_json`] with the means as values, plus `"runs"` and per
    /// method `"std"` and `"n"` objects keyed like the metrics.
    pub fn to_json(&self) -> Value {
        let methods: Vec<Value> = self
            .methods
            .iter()
            .map(|m| {
                let mut row = metric_object(
                    &m.name,
                    METRIC_KEYS
                        .iter()
                        .zip(&m.stats)
                        .map(|(k, s)| (*k, opt_number(s.map(|s| s.mean)))),
                );
                let std: Map<String, Value> = METRIC_KEYS
                    .iter()
                    .zip(&m.stats)
                    .map(|(k, s)| ((*k).to_owned(), opt_number(s.map(|s| s.std))))
                    .collect();
                let n: Map<String, Value> = METRIC_KEYS
                    .iter()
                    .zip(&m.stats)
                    .map(|(k, s)| ((*k).to_owned(), Value::from(s.map_or(0, |s| s.n))))
                    .collect();
                if let Value::Object(o) = &mut row {
                    o.insert("std".into(), Value::Object(std));
                    o.insert("n".into(), Value::Object(n));
                }
                row
            })
            .collect();
        json!({"events": self.events.to_json(), "runs": self.runs, "methods": methods})
    }

    /// The Markdown results table with `mean ± std` cells. A cell defined in fewer than all runs
    /// carries `(k/n)`.
    pub fn to_markdown(&self) -> String {
        let mut out = format!(
            "{}; mean ± std over {} runs (folds × seeds)\n\n{HEADER}",
            self.events.sentence(),
            self.runs
        );
        for m in &self.methods {
            out.push_str(&format!("| {} |", m.name));
            for (s, d) in m.stats.iter().zip(DECIMALS) {
                out.push_str(&format!(" {} |", metric_cell(*s, self.runs, d)));
            }
            out.push('\n');
        }
        out
    }

    /// CSV: `method,<key>_mean,<key>_std,<key>_n,...` for the five metrics.
    pub fn write_csv<W: Write>(&self, writer: W) -> csv::Result<()> {
        let mut w = csv::Writer::from_writer(writer);
        let mut header = vec!["method".to_owned()];
        for k in METRIC_KEYS {
            header.extend([format!("{k}_mean"), format!("{k}_std"), format!("{k}_n")]);
        }
        w.write_record(&header)?;
        for m in &self.methods {
            let mut row = vec![m.name.clone()];
            for s in &m.stats {
                row.push(csv_cell(s.map(|s| s.mean)));
                row.push(csv_cell(s.map(|s| s.std)));
                row.push(s.map_or(0, |s| s.n).to_string());
            }
            w.write_record(&row)?;
        }
        w.flush()?;
        Ok(())
    }
}

/// CSV of every fold result: `seed,fold,method,A_ROC_90,...` (empty cell where undefined).
pub fn write_folds_csv<W: Write>(folds: &[FoldResult], writer: W) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(writer);
    let mut header = vec!["seed", "fold", "method"];
    header.extend(METRIC_KEYS);
    w.write_record(&header)?;
    for f in folds {
        for m in &f.methods {
            let mut row = vec![f.seed.to_string(), f.fold.to_string(), m.name.clone()];
            row.extend(m.metrics.named().iter().map(|(_, v)| csv_cell(*v)));
            w.write_record(&row)?;
        }
    }
    w.flush()?;
    Ok(())
}

/// CSV of every operating point of every method:
/// `method,threshold,true_positives,false_positives,positives,negatives,tpr,fpr,precision,mean_lead_time`.
pub fn write_curves_csv<W: Write>(curves: &[(String, WarningCurve)], writer: W) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(writer);
    w.write_record([
        "method",
        "threshold",
        "true_positives",
        "false_positives",
        "positives",
        "negatives",
        "tpr",
        "fpr",
        "precision",
        "mean_lead_time",
    ])?;
    for (name, c) in curves {
        for p in &c.points {
            w.write_record([
                name.clone(),
                p.threshold.to_string(),
                p.true_positives.to_string(),
                p.false_positives.to_string(),
                c.positives.to_string(),
                c.negatives.to_string(),
                csv_cell(c.tpr(p)),
                csv_cell(c.fpr(p)),
                csv_cell(p.precision()),
                csv_cell(p.mean_lead_time()),
            ])?;
        }
    }
    w.flush()?;
    Ok(())
}

/// Per method and sequence: the maximum out-of-fold score inside the alert window and when it
/// occurred relative to the endpoint (what decides whether and how early a sequence is warned).
pub fn write_sequence_maxima<W: Write>(
    pooled: &[(String, Vec<super::protocol::ScoredSequence>)],
    writer: W,
) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(writer);
    w.write_record([
        "method",
        "event_id",
        "class",
        "max_score",
        "time_of_max_to_endpoint",
    ])?;
    for (name, seqs) in pooled {
        for s in seqs {
            let best = s
                .frames
                .iter()
                .filter(|f| super::protocol::in_alert_window(s.endpoint, f.time))
                .filter(|f| !f.score.is_nan())
                .fold(None::<(f32, f64)>, |acc, f| match acc {
                    Some((m, _)) if m >= f.score => acc,
                    _ => Some((f.score, f.time)),
                });
            let (max, at) = match best {
                Some((m, t)) => (
                    m.to_string(),
                    s.endpoint
                        .map_or(String::new(), |e| format!("{:.2}", t - e)),
                ),
                None => (String::new(), String::new()),
            };
            w.write_record([
                name.as_str(),
                s.event_id.as_str(),
                s.kind.as_str(),
                max.as_str(),
                at.as_str(),
            ])?;
        }
    }
    w.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{ScoredFrame, ScoredSequence};
    use crate::scoring::evaluate_scored;

    #[test]
    fn stat_of_small_samples() {
        assert_eq!(Stat::of(&[]), None);
        let one = Stat::of(&[4.0]).unwrap();
        assert_eq!((one.mean, one.std, one.n), (4.0, 0.0, 1));
        // 2, 4, 6: mean 4, sample variance (4 + 0 + 4) / 2 = 4.
        let three = Stat::of(&[2.0, 4.0, 6.0]).unwrap();
        assert_eq!((three.mean, three.std, three.n), (4.0, 2.0, 3));
    }

    #[test]
    fn single_report_table_prints_values_and_na() {
        let r = EvaluationReport {
            events: EventCounts::from_classes([EventKind::Crash, EventKind::Safe]),
            methods: vec![MethodResult {
                name: "EI".into(),
                metrics: Metrics {
                    a_roc_90: Some(12.345),
                    mtti_90: Some(1.234),
                    ..Metrics::default()
                },
            }],
        };
        let md = r.to_markdown();
        assert!(
            md.starts_with("2 events: 1 crash, 0 near-crash, 1 safe"),
            "{md}"
        );
        assert!(
            md.contains("| EI | 12.3 | n/a | n/a | n/a | 1.23 |"),
            "{md}"
        );
    }

    #[test]
    fn printed_digits_round_the_exact_value_not_its_round_off() {
        // Eight crashes, no safe sequence: seven warned 7.6 - 4.7 s and one 7.6 - 4.9 s before
        // impact, a mean lead of exactly 23 / 8 = 2.875 s, which the f64 sum puts at
        // 2.874999999999999.
        let crash = |t: f64| ScoredSequence {
            event_id: format!("c{t}"),
            kind: EventKind::Crash,
            endpoint: Some(7.6),
            frames: vec![ScoredFrame {
                time: t,
                score: 1.0,
            }],
        };
        let mut seqs: Vec<_> = (0..7).map(|_| crash(4.7)).collect();
        seqs.push(crash(4.9));
        let (report, _) = evaluate_scored(vec![("DRL".into(), seqs)]).unwrap();
        let mtti = report.methods[0].metrics.mtti_90.unwrap();
        assert!(mtti < 2.875 && 2.875 - mtti < 1e-12, "{mtti}");
        let md = report.to_markdown();
        assert!(
            md.contains("| DRL | n/a | n/a | 100.0 | 100.0 | 2.88 |"),
            "{md}"
        );
        // Ties go to even, as `{:.N}` rounds an exactly representable tie; a value that is not
        // a tie keeps its digit.
        assert_eq!(fixed(2.625, 2), "2.62");
        assert_eq!(fixed(83.75, 1), "83.8");
        assert_eq!(fixed(61.25, 1), "61.2");
        assert_eq!(fixed(2.7749999999999497, 2), "2.78");
        assert_eq!(fixed(17.999999999999993, 1), "18.0");
        assert_eq!(fixed(2.8749, 2), "2.87");
        assert_eq!(fixed(0.0, 2), "0.00");
        assert_eq!(fixed(f64::INFINITY, 1), "inf");
        // The CV cells too: a mean of 2.874999999999999 is 2.88.
        let stat = Stat {
            mean: mtti,
            std: 0.0149999999999999,
            n: 2,
        };
        assert_eq!(metric_cell(Some(stat), 2, 2), "2.88 ± 0.02");
    }

    #[test]
    fn cv_json_and_csv_carry_mean_std_and_n() {
        let m = Metrics {
            a_roc_90: Some(90.0),
            ..Metrics::default()
        };
        let folds: Vec<FoldResult> = [80.0, 100.0]
            .iter()
            .enumerate()
            .map(|(fold, a)| FoldResult {
                seed: 7,
                fold,
                methods: vec![MethodResult {
                    name: "DRL".into(),
                    metrics: Metrics {
                        a_roc_90: Some(*a),
                        ..m
                    },
                }],
            })
            .collect();
        let cv = aggregate(EventCounts::default(), &folds);
        let v = cv.to_json();
        assert_eq!(v["runs"], 2);
        assert_eq!(v["methods"][0]["A_ROC_90"], 90.0);
        assert_eq!(v["methods"][0]["std"]["A_ROC_90"], 200f64.sqrt());
        assert_eq!(v["methods"][0]["n"]["A_ROC_90"], 2);
        assert!(v["methods"][0]["P_PRC_90"].is_null());
        let mut csv = Vec::new();
        cv.write_csv(&mut csv).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        let mut lines = csv.lines();
        assert!(lines
            .next()
            .unwrap()
            .starts_with("method,A_ROC_90_mean,A_ROC_90_std,A_ROC_90_n,"));
        assert!(lines.next().unwrap().starts_with("DRL,90,14.14"));
        let mut folds_csv = Vec::new();
        write_folds_csv(&folds, &mut folds_csv).unwrap();
        assert_eq!(String::from_utf8(folds_csv).unwrap().lines().count(), 3);
    }
}
