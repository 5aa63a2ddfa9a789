//! The domain benchmark's report: per round the table and JSON of `riskctl evaluate` (mean ± std
//! over folds x seeds), each method row with the share of real safe sequences above its 90 %-recall
//! threshold, the slice's counts (flagged below [`SMALL_SLICE`]) and the acceptance claims with
//! their run tallies ([`super::claims`]); rounds without data say so.
use serde_json::{json, Value};

use super::rounds::{Round, SliceCounts, SMALL_SLICE};
use super::run::{DrawResult, RoundResult};
use super::share::{summarise, ShareSummary, SHARE_KEY, SHARE_RECALL_PERCENT};
use riskscore_eval::bundle::{BundleError, ReportBundle};
use riskscore_eval::claims::{self, Claim};
use riskscore_eval::report::{fixed, write_folds_csv};

/// What became of one round.
#[derive(Clone, Debug)]
pub enum RoundOutcome {
    Ran(Box<RoundResult>),
    /// The slice (or the training data without it) is empty in the data given: reported, not run.
    NoData {
        round: Round,
        counts: SliceCounts,
        /// In a run of several simulator draws, the first draw that cannot run the round (the
        /// others may have data for it).
        blocked_by: Option<String>,
    },
}

impl RoundOutcome {
    pub fn round(&self) -> &Round {
        match self {
            RoundOutcome::Ran(r) => &r.round,
            RoundOutcome::NoData { round, .. } => round,
        }
    }

    /// Added up over the draws in a run of several ([`super::draws::sum_counts`]).
    pub fn counts(&self) -> &SliceCounts {
        match self {
            RoundOutcome::Ran(r) => &r.counts,
            RoundOutcome::NoData { counts, .. } => counts,
        }
    }

    /// True when the slice is small on any draw ([`RoundResult::is_small`]).
    pub fn is_small(&self) -> bool {
        match self {
            RoundOutcome::Ran(r) => r.is_small(),
            RoundOutcome::NoData { counts, .. } => counts.is_small(),
        }
    }

    /// The draws of a round pooled over several; empty for a single draw or a round not run.
    pub fn pooled_draws(&self) -> &[DrawResult] {
        match self {
            RoundOutcome::Ran(r) if r.draws.len() > 1 => &r.draws,
            _ => &[],
        }
    }
}

/// Every round of one benchmark run.
#[derive(Clone, Debug, Default)]
pub struct DomainsResult {
    pub rounds: Vec<RoundOutcome>,
}

fn counts_json(counts: &SliceCounts) -> Value {
    json!({
        "test_conflicts": counts.test.conflicts,
        "test_safe": counts.test.safe,
        "real_safe": counts.real_safe,
        "train_conflicts": counts.train.conflicts,
        "train_safe": counts.train.safe,
    })
}

/// The round's counts and small flag; pooled over several draws, also each draw's counts.
fn slice_json(outcome: &RoundOutcome) -> Value {
    let mut slice = counts_json(outcome.counts());
    slice["small"] = outcome.is_small().into();
    let draws = outcome.pooled_draws();
    if !draws.is_empty() {
        slice["draws"] = draws
            .iter()
            .map(|d| {
                let mut v = counts_json(&d.counts);
                v["draw"] = d.draw.into();
                v["label"] = d.label.clone().into();
                v["first_seed"] = d.first_seed.into();
                v["small"] = d.counts.is_small().into();
                v
            })
            .collect();
    }
    slice
}

fn counts_sentence(c: &SliceCounts) -> String {
    format!(
        "{} conflicts and {} safe sequences to test on ({} real safe); training keeps {} conflicts and {} safe",
        c.test.conflicts, c.test.safe, c.real_safe, c.train.conflicts, c.train.safe
    )
}

fn share_json(s: &ShareSummary) -> Value {
    json!({
        "mean": s.percent.map(|p| p.mean),
        "std": s.percent.map(|p| p.std),
        "n": s.percent.map_or(0, |p| p.n),
        "above": s.above,
        "of": s.of,
    })
}

fn share_cell(s: &ShareSummary) -> String {
    match s.percent {
        Some(p) => format!(
            "{} ± {} ({} of {})",
            fixed(p.mean, 1),
            fixed(p.std, 1),
            s.above,
            s.of
        ),
        None if s.of == 0 => "no real safe sequences".into(),
        None => "n/a".into(),
    }
}

impl DomainsResult {
    /// Every run round, in round order.
    pub fn ran(&self) -> impl Iterator<Item = &RoundResult> {
        self.rounds.iter().filter_map(|outcome| match outcome {
            RoundOutcome::Ran(r) => Some(r.as_ref()),
            RoundOutcome::NoData { .. } => None,
        })
    }

    /// Every run round's warnings for the user, in round order ([`RoundResult::warnings`]).
    pub fn warnings(&self) -> impl Iterator<Item = &String> {
        self.ran().flat_map(|result| &result.warnings)
    }

    /// `{"rounds": [...]}`: a run round is `riskctl evaluate --json`'s CV object (`events`, `runs`,
    /// `methods`) plus `round`, `held_out`, `status: "ok"`, `slice`, `claims` and, in each method
    /// row, [`SHARE_KEY`]; a round without data has `status: "no data"`, its `slice` counts and,
    /// over several draws, `blocked_by` (the draw without data). Pooled over several draws, `slice.draws` holds each draw's counts and
    /// `claims_per_draw` each draw's claims; a single draw's JSON has neither.
    pub fn to_json(&self) -> Value {
        let rounds: Vec<Value> = self
            .rounds
            .iter()
            .map(|outcome| {
                let round = outcome.round();
                let mut object = match outcome {
                    RoundOutcome::Ran(r) => {
                        let mut v = r.report.to_json();
                        if let Some(Value::Array(rows)) = v.get_mut("methods") {
                            for row in rows {
                                let name = row["name"].as_str().unwrap_or_default().to_owned();
                                row[SHARE_KEY] = share_json(&summarise(&r.shares, &name));
                            }
                        }
                        v["domain"] = r.domain.iter().map(|d| d.to_json()).collect();
                        v["claims"] = serde_json::to_value(&r.claims).unwrap_or_default();
                        v["status"] = "ok".into();
                        v
                    }
                    RoundOutcome::NoData { blocked_by, .. } => {
                        let mut v = json!({"status": "no data"});
                        if let Some(draw) = blocked_by {
                            v["blocked_by"] = draw.clone().into();
                        }
                        v
                    }
                };
                object["round"] = round.name.clone().into();
                object["held_out"] = round.to_string().into();
                object["slice"] = slice_json(outcome);
                let draws = outcome.pooled_draws();
                if !draws.is_empty() {
                    object["claims_per_draw"] = draws
                        .iter()
                        .map(|d| json!({"draw": d.draw, "label": d.label, "claims": d.claims}))
                        .collect();
                }
                object
            })
            .collect();
        json!({ "rounds": rounds })
    }

    /// One section per round: counts, the results table, the real-safe shares, the claims.
    pub fn to_markdown(&self) -> String {
        let mut out = String::new();
        for outcome in &self.rounds {
            let round = outcome.round();
            out.push_str(&format!("### Held out: {round} (`{}`)\n\n", round.name));
            let draws = outcome.pooled_draws();
            if draws.is_empty() {
                out.push_str(&format!("Slice: {}.", counts_sentence(outcome.counts())));
            } else {
                out.push_str(&format!(
                    "Slice, over {} simulator draws: {}.",
                    draws.len(),
                    counts_sentence(outcome.counts())
                ));
                for d in draws {
                    out.push_str(&format!(
                        "\n- draw {} ({}, training seeds from {}): {}",
                        d.draw,
                        d.label,
                        d.first_seed,
                        counts_sentence(&d.counts)
                    ));
                }
                out.push_str("\n\n");
            }
            if outcome.is_small() {
                // After the list of draws it is a paragraph of its own.
                let (lead, on) = if draws.is_empty() {
                    (" ", "")
                } else {
                    ("", " on a draw")
                };
                out.push_str(&format!(
                    "{lead}**Small slice (< {SMALL_SLICE} conflicts or safe sequences{on}): read with care.**"
                ));
            }
            out.push_str("\n\n");
            match outcome {
                RoundOutcome::NoData { blocked_by, .. } => {
                    let which = blocked_by
                        .as_ref()
                        .map_or(String::new(), |draw| format!(", on the draw {draw}"));
                    out.push_str(&format!(
                        "**No data**: not run (nothing to test on or to train with{which}).\n\n"
                    ));
                }
                RoundOutcome::Ran(r) => {
                    out.push_str(&r.report.to_markdown());
                    out.push_str(&format!(
                        "\n| Method | real safe sequences above the {SHARE_RECALL_PERCENT} %-recall threshold (%) |\n|---|---|\n"
                    ));
                    for m in &r.report.methods {
                        out.push_str(&format!(
                            "| {} | {} |\n",
                            m.name,
                            share_cell(&summarise(&r.shares, &m.name))
                        ));
                    }
                    out.push_str(&riskscore_eval::domain_share::markdown(&r.domain));
                    out.push_str(&format!(
                        "\nClaims (on the fold means; runs = the {} folds x seeds, each method paired on the same test set):\n\n",
                        r.report.runs
                    ));
                    out.push_str(&claims::to_markdown(&r.claims));
                    out.push('\n');
                    let draws = outcome.pooled_draws();
                    if !draws.is_empty() {
                        out.push_str(
                            "Per draw (the verdict on that draw's own means; in brackets, the runs of that draw where it holds):\n\n",
                        );
                        let per_draw: Vec<&[Claim]> =
                            draws.iter().map(|d| d.claims.as_slice()).collect();
                        out.push_str(&claims::per_draw_markdown(&r.claims, &per_draw));
                        out.push('\n');
                    }
                }
            }
        }
        out
    }

    /// The report folder: `domains.md`, `domains.json`, `shares.csv` (every method, fold and
    /// seed), `claims.csv` (every round's claims), `splits.json` (the sets of every fold, each
    /// with its draw) and `<round>.folds.csv` per run round; over several simulator draws also
    /// `claims-per-draw.csv` (each round's claims on each draw's own means and runs, with the
    /// draw's number and label).
    pub fn bundle(&self) -> Result<ReportBundle, BundleError> {
        let mut bundle = ReportBundle::default();
        bundle.add("domains.md", self.to_markdown());
        bundle.add_json("domains.json", &self.to_json())?;
        let ran: Vec<&RoundResult> = self.ran().collect();
        bundle.add_csv("shares.csv", |w| {
            let mut w = csv::Writer::from_writer(w);
            w.write_record([
                "round",
                "seed",
                "fold",
                "method",
                "threshold",
                "above",
                "of",
            ])?;
            for r in &ran {
                for s in &r.shares {
                    w.write_record([
                        r.round.name.clone(),
                        s.seed.to_string(),
                        s.fold.to_string(),
                        s.method.clone(),
                        s.threshold.map_or_else(String::new, |t| t.to_string()),
                        s.above.to_string(),
                        s.of.to_string(),
                    ])?;
                }
            }
            w.flush()?;
            Ok(())
        })?;
        bundle.add_csv("claims.csv", |w| {
            claims::write_csv(
                w,
                &["round"],
                ran.iter()
                    .map(|r| (vec![r.round.name.clone()], r.claims.as_slice())),
            )
        })?;
        if self.rounds.iter().any(|o| !o.pooled_draws().is_empty()) {
            bundle.add_csv("claims-per-draw.csv", |w| {
                claims::write_csv(
                    w,
                    &["round", "draw", "label"],
                    self.rounds.iter().flat_map(|o| {
                        o.pooled_draws().iter().map(|d| {
                            (
                                vec![o.round().name.clone(), d.draw.to_string(), d.label.clone()],
                                d.claims.as_slice(),
                            )
                        })
                    }),
                )
            })?;
        }
        let splits: Vec<Value> = ran
            .iter()
            .map(|r| json!({"round": r.round.name, "folds": r.splits}))
            .collect();
        bundle.add_json("splits.json", &splits)?;
        for r in &ran {
            bundle.add_csv(&format!("{}.folds.csv", r.round.name), |w| {
                write_folds_csv(&r.folds, w)
            })?;
        }
        Ok(bundle)
    }
}
