//! Acceptance claims: "method beats baseline on a metric", checked on the fold means and, run by
//! run, on every fold × seed, so a report says both whether a claim holds and how consistently.
//!
//! A mean can fail on two outlying folds while the method wins most runs, or pass on one lucky
//! fold; the run tally (`holds in k of n runs`) tells the two apart without a second tool. Each run
//! compares the two methods on the same test set, so the tally is paired.
//!
//! The standard list ([`acceptance_claims`]): DRL beats each kinematic baseline on A_ROC_90,
//! P_PRC_90 and mTTI_90; MSRA beats each of its inputs on the same; where the report has them,
//! SSRA is at least GSSM on A_ROC_90 and P_PRC_90 and GSSM beats TTC2D on A_ROC_90.
use std::io::Write;

use serde::Serialize;

use crate::bundle::{BundleError, ReportBundle};
use crate::metrics::Metric;
use crate::protocol::Baseline;
use crate::report::{csv_cell, format_value, CvReport, FoldResult};

/// How a claim compares the method's value `m` with the baseline's `b`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Rule {
    /// `m > b`: strictly better, where larger is better.
    Greater,
    /// `m >= b`.
    AtLeast,
    /// `m <= b`: no worse, where smaller is better (a false-alarm share).
    AtMost,
}

impl Rule {
    fn holds(self, m: f64, b: f64) -> bool {
        match self {
            Rule::Greater => m > b,
            Rule::AtLeast => m >= b,
            Rule::AtMost => m <= b,
        }
    }

    /// The comparison as printed: `>`, `>=`, `<=`.
    pub fn symbol(self) -> &'static str {
        match self {
            Rule::Greater => ">",
            Rule::AtLeast => ">=",
            Rule::AtMost => "<=",
        }
    }
}

/// Whether `m` satisfies `rule` against `b`: a baseline without a value has nothing to beat (the
/// claim holds, and [`Claim::verdict`] says `n/a`); a method without a value loses to one with.
fn holds(rule: Rule, m: Option<f64>, b: Option<f64>) -> bool {
    match (m, b) {
        (Some(m), Some(b)) => rule.holds(m, b),
        (Some(_), None) => true,
        (None, _) => false,
    }
}

/// In how many runs (folds × seeds) a claim holds, paired run by run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RunTally {
    /// Runs in which the claim holds.
    pub holding: usize,
    /// Runs in which the baseline has a value (the others have nothing to beat).
    pub compared: usize,
}

impl RunTally {
    /// The tally of `runs`, each `(method value, baseline value)` of one run.
    pub fn of(rule: Rule, runs: impl IntoIterator<Item = (Option<f64>, Option<f64>)>) -> Self {
        let mut tally = RunTally::default();
        for (m, b) in runs {
            if b.is_some() {
                tally.compared += 1;
                tally.holding += usize::from(holds(rule, m, b));
            }
        }
        tally
    }
}

/// One claim, checked on the fold means and run by run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Claim {
    pub method: String,
    pub baseline: String,
    /// What is compared: a metric key (`A_ROC_90`) or another report key.
    pub metric: String,
    pub rule: Rule,
    pub method_mean: Option<f64>,
    pub baseline_mean: Option<f64>,
    /// The claim on the fold means (also where the baseline has no mean: nothing to beat).
    pub holds: bool,
    /// `ok`, `FAIL`, or `n/a` where the baseline has no value on the means (e.g. a baseline that
    /// never reaches 90 % precision has no mTTI_90, so there is nothing to beat).
    pub verdict: &'static str,
    pub runs: RunTally,
}

impl Claim {
    /// The comparison as tables print it: `DRL > TAdv on A_ROC_90`.
    pub fn comparison(&self) -> String {
        format!(
            "{} {} {} on {}",
            self.method,
            self.rule.symbol(),
            self.baseline,
            self.metric
        )
    }

    /// True when `other` makes the same comparison (methods, metric and rule), e.g. the same
    /// claim on another draw.
    pub fn same_comparison(&self, other: &Claim) -> bool {
        (&self.method, &self.baseline, &self.metric, self.rule)
            == (&other.method, &other.baseline, &other.metric, other.rule)
    }

    /// The metric as printed: marked ` (>=)` / ` (<=)` when the rule is not strict improvement.
    pub fn label(&self) -> String {
        match self.rule {
            Rule::Greater => self.metric.clone(),
            rule => format!("{} ({})", self.metric, rule.symbol()),
        }
    }

    /// A claim on `metric` from the two means and the per-run value pairs.
    pub fn new(
        method: &str,
        baseline: &str,
        metric: String,
        rule: Rule,
        means: (Option<f64>, Option<f64>),
        runs: impl IntoIterator<Item = (Option<f64>, Option<f64>)>,
    ) -> Self {
        let holds = holds(rule, means.0, means.1);
        Claim {
            method: method.into(),
            baseline: baseline.into(),
            metric,
            rule,
            method_mean: means.0,
            baseline_mean: means.1,
            holds,
            verdict: match means {
                (Some(_), None) => "n/a",
                _ if holds => "ok",
                _ => "FAIL",
            },
            runs: RunTally::of(rule, runs),
        }
    }

    /// `method` against `baseline` on `metric` of a CV report and the fold results it aggregates.
    pub fn on_metric(
        report: &CvReport,
        folds: &[FoldResult],
        method: &str,
        baseline: &str,
        metric: Metric,
        rule: Rule,
    ) -> Self {
        let value = |fold: &FoldResult, name: &str| {
            fold.methods
                .iter()
                .find(|m| m.name == name)
                .and_then(|m| m.metrics.get(metric))
        };
        Claim::new(
            method,
            baseline,
            metric.key().to_string(),
            rule,
            (report.mean(method, metric), report.mean(baseline, metric)),
            folds.iter().map(|f| (value(f, method), value(f, baseline))),
        )
    }
}

/// The standard claims (module doc) of a CV report; `msra_inputs` are the display names of the
/// surrogates MSRA combines. DRL's and MSRA's claims are always made (a report without the method
/// fails them); SSRA's and GSSM's only where the report has both rows (the transfer and domain
/// benchmarks).
pub fn acceptance_claims(
    report: &CvReport,
    folds: &[FoldResult],
    msra_inputs: &[String],
) -> Vec<Claim> {
    let has = |name: &str| report.methods.iter().any(|m| m.name == name);
    let mut claims = Vec::new();
    let mut add = |method: &str, baseline: &str, metric: Metric, rule: Rule| {
        claims.push(Claim::on_metric(
            report, folds, method, baseline, metric, rule,
        ));
    };
    if has("SSRA") && has("GSSM") {
        for metric in [Metric::ARoc90, Metric::PPrc90] {
            add("SSRA", "GSSM", metric, Rule::AtLeast);
        }
    }
    if has("GSSM") && has(Baseline::Ttc2d.name()) {
        add(
            "GSSM",
            Baseline::Ttc2d.name(),
            Metric::ARoc90,
            Rule::Greater,
        );
    }
    let beats = [Metric::ARoc90, Metric::PPrc90, Metric::MTti90];
    for baseline in Baseline::ALL.map(Baseline::name) {
        for metric in beats {
            add("DRL", baseline, metric, Rule::Greater);
        }
    }
    for input in msra_inputs {
        for metric in beats {
            add("MSRA", input, metric, Rule::Greater);
        }
    }
    claims
}

/// `holds in k of n runs`, or `no run to compare` when the baseline never had a value.
pub fn tally_text(t: RunTally) -> String {
    if t.compared == 0 {
        "no run to compare".into()
    } else {
        format!("holds in {} of {} runs", t.holding, t.compared)
    }
}

/// `[ok] DRL A_ROC_90 91.10 vs TAdv 85.80 (holds in 14 of 15 runs)`, one line per claim, under
/// `title`, and a blank line.
pub fn to_text(title: &str, claims: &[Claim]) -> String {
    let mut out = format!("{title}\n");
    for c in claims {
        out.push_str(&format!(
            "  [{}] {} {} {} vs {} {} ({})\n",
            c.verdict,
            c.method,
            c.label(),
            format_value(c.method_mean, 2),
            c.baseline,
            format_value(c.baseline_mean, 2),
            tally_text(c.runs)
        ));
    }
    out.push('\n');
    out
}

/// A Markdown table of `claims`: the comparison, both means, the verdict and the run tally.
pub fn to_markdown(claims: &[Claim]) -> String {
    let mut out = String::from(
        "| Claim | Method mean | Baseline mean | On the means | Runs where it holds |\n|---|---:|---:|---|---:|\n",
    );
    for c in claims {
        let runs = if c.runs.compared == 0 {
            "n/a".to_string()
        } else {
            format!("{} of {}", c.runs.holding, c.runs.compared)
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} |\n",
            c.comparison(),
            format_value(c.method_mean, 2),
            format_value(c.baseline_mean, 2),
            c.verdict,
            runs
        ));
    }
    out
}

/// A Markdown table of each claim of `pooled` (a run pooled over several simulator draws) on each
/// draw's own claims (`draws`, in draw order, numbered from 1): the verdict on that draw's means,
/// with its run tally; "not checked" where a draw has no such claim.
pub fn per_draw_markdown(pooled: &[Claim], draws: &[&[Claim]]) -> String {
    let mut out = String::from("| Claim |");
    let mut rule = String::from("|---|");
    for k in 1..=draws.len() {
        out.push_str(&format!(" draw {k} |"));
        rule.push_str("---|");
    }
    out.push('\n');
    out.push_str(&rule);
    out.push('\n');
    for c in pooled {
        out.push_str(&format!("| {} |", c.comparison()));
        for claims in draws {
            match claims.iter().find(|x| x.same_comparison(c)) {
                Some(x) => out.push_str(&format!(
                    " {} ({}/{}) |",
                    x.verdict, x.runs.holding, x.runs.compared
                )),
                None => out.push_str(" not checked |"),
            }
        }
        out.push('\n');
    }
    out
}

/// The columns of `claims.csv`, after the caller's leading ones ([`write_csv`]).
pub const CSV_COLUMNS: [&str; 9] = [
    "method",
    "baseline",
    "metric",
    "rule",
    "method_mean",
    "baseline_mean",
    "verdict",
    "runs_holding",
    "runs_compared",
];

/// `claims.csv`: the header `lead_columns` + [`CSV_COLUMNS`], then one row per claim of each
/// group, led by the group's cells (e.g. a round's name); empty cells for values that do not
/// exist, `rule` as `>`, `>=`, `<=`.
pub fn write_csv<'c, W: Write>(
    writer: W,
    lead_columns: &[&str],
    groups: impl IntoIterator<Item = (Vec<String>, &'c [Claim])>,
) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(writer);
    let mut header = lead_columns.to_vec();
    header.extend(CSV_COLUMNS);
    w.write_record(&header)?;
    for (lead, claims) in groups {
        for c in claims {
            let mut row = lead.clone();
            row.extend([
                c.method.clone(),
                c.baseline.clone(),
                c.metric.clone(),
                c.rule.symbol().to_string(),
                csv_cell(c.method_mean),
                csv_cell(c.baseline_mean),
                c.verdict.to_string(),
                c.runs.holding.to_string(),
                c.runs.compared.to_string(),
            ]);
            w.write_record(&row)?;
        }
    }
    w.flush()?;
    Ok(())
}

/// Adds `claims.md` ([`to_markdown`]) and `claims.csv` ([`CSV_COLUMNS`], one row per claim) to
/// a report folder.
///
/// Pooled over several simulator draws (`per_draw`: each draw's label and own claims in draw
/// order; empty or one for a single draw), `claims.md` also names the draws and gets
/// [`per_draw_markdown`], and the folder `claims-per-draw.csv` ([`CSV_COLUMNS`] after `draw` and
/// `label` columns).
pub fn add_to(
    bundle: &mut ReportBundle,
    claims: &[Claim],
    per_draw: &[(&str, &[Claim])],
) -> Result<(), BundleError> {
    let mut md = to_markdown(claims);
    if per_draw.len() > 1 {
        md.push_str("\nPer draw (the verdict on that draw's own means; in brackets, its runs where the claim holds):\n\n");
        for (k, (label, _)) in per_draw.iter().enumerate() {
            md.push_str(&format!("- draw {}: {label}\n", k + 1));
        }
        md.push('\n');
        let tables: Vec<&[Claim]> = per_draw.iter().map(|(_, c)| *c).collect();
        md.push_str(&per_draw_markdown(claims, &tables));
        bundle.add_csv("claims-per-draw.csv", |w| {
            let groups = per_draw
                .iter()
                .enumerate()
                .map(|(k, (label, c))| (vec![(k + 1).to_string(), label.to_string()], *c));
            write_csv(w, &["draw", "label"], groups)
        })?;
    }
    bundle.add("claims.md", md);
    bundle.add_csv("claims.csv", |w| write_csv(w, &[], [(Vec::new(), claims)]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_baseline_without_a_value_is_na_and_not_counted_in_the_runs() {
        let c = Claim::new(
            "DRL",
            "TTC2D",
            "mTTI_90".into(),
            Rule::Greater,
            (Some(3.4), None),
            [(Some(3.0), None), (Some(3.5), Some(0.7)), (None, Some(0.7))],
        );
        assert_eq!(c.verdict, "n/a");
        assert_eq!(
            c.runs,
            RunTally {
                holding: 1,
                compared: 2
            }
        );
        assert_eq!(tally_text(c.runs), "holds in 1 of 2 runs");
    }

    #[test]
    fn each_rule_decides_ties_its_own_way() {
        let tie = |rule| Claim::new("A", "B", "m".into(), rule, (Some(1.0), Some(1.0)), []);
        assert_eq!(tie(Rule::Greater).verdict, "FAIL");
        assert_eq!(tie(Rule::AtLeast).verdict, "ok");
        assert_eq!(tie(Rule::AtMost).verdict, "ok");
        let below = Claim::new(
            "A",
            "B",
            "m".into(),
            Rule::AtMost,
            (Some(2.0), Some(1.0)),
            [],
        );
        assert_eq!(below.verdict, "FAIL");
        assert_eq!(tally_text(below.runs), "no run to compare");
    }

    #[test]
    fn the_per_draw_table_reads_each_pooled_claim_off_each_draw() {
        let claim = |metric: &str, m: f64, runs: &[(f64, f64)]| {
            Claim::new(
                "DRL",
                "TAdv",
                metric.into(),
                Rule::Greater,
                (Some(m), Some(1.0)),
                runs.iter().map(|&(a, b)| (Some(a), Some(b))),
            )
        };
        let pooled = [claim("A", 2.0, &[]), claim("P", 2.0, &[])];
        // Draw 1 wins A in 1 of 2 runs; draw 2 loses A on its mean and has no P claim.
        let first = [
            claim("A", 2.0, &[(2.0, 1.0), (0.0, 1.0)]),
            claim("P", 0.5, &[]),
        ];
        let second = [claim("A", 0.5, &[(0.0, 1.0)])];
        let table = per_draw_markdown(&pooled, &[&first, &second]);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines[0], "| Claim | draw 1 | draw 2 |");
        assert_eq!(lines[2], "| DRL > TAdv on A | ok (1/2) | FAIL (0/1) |");
        assert_eq!(lines[3], "| DRL > TAdv on P | FAIL (0/0) | not checked |");
    }
}
