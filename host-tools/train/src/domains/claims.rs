//! A round's acceptance claims: the standard ones of its CV report (`riskscore_eval::claims`) and
//! one of its own, DRL warning no larger a share of the slice's real safe sequences at its
//! 90 %-recall threshold than TAdv at its own, each with its run-by-run tally.
use riskscore_eval::claims::{acceptance_claims, Claim, Rule};
use riskscore_eval::{CvReport, FoldResult};

use super::share::{summarise, ShareRun, SHARE_KEY};

/// The claims of a round from its report, the fold results it aggregates and the real-safe shares
/// of every run; `msra_inputs` as for [`acceptance_claims`]. The share claim pairs DRL's and TAdv's
/// share of the same (seed, fold), and is left out where neither method has a share (no real safe
/// test sequences).
pub fn round_claims(
    report: &CvReport,
    folds: &[FoldResult],
    shares: &[ShareRun],
    msra_inputs: &[String],
) -> Vec<Claim> {
    let mut claims = acceptance_claims(report, folds, msra_inputs);
    let mean = |method: &str| summarise(shares, method).percent.map(|p| p.mean);
    let (drl, tadv) = (mean("DRL"), mean("TAdv"));
    if drl.is_some() || tadv.is_some() {
        let percent = |seed: u64, fold: usize, method: &str| {
            shares
                .iter()
                .find(|s| (s.seed, s.fold) == (seed, fold) && s.method == method)
                .and_then(ShareRun::percent)
        };
        let runs = folds.iter().map(|f| {
            (
                percent(f.seed, f.fold, "DRL"),
                percent(f.seed, f.fold, "TAdv"),
            )
        });
        claims.push(Claim::new(
            "DRL",
            "TAdv",
            SHARE_KEY.into(),
            Rule::AtMost,
            (drl, tadv),
            runs,
        ));
    }
    claims
}

#[cfg(test)]
mod tests {
    use super::*;
    use riskscore_eval::claims::RunTally;
    use riskscore_eval::EventCounts;

    fn share(seed: u64, fold: usize, method: &str, above: usize) -> ShareRun {
        ShareRun {
            seed,
            fold,
            method: method.into(),
            threshold: Some(1.0),
            above,
            of: 10,
        }
    }

    fn fold(seed: u64, fold: usize) -> FoldResult {
        FoldResult {
            seed,
            fold,
            methods: Vec::new(),
        }
    }

    #[test]
    fn the_share_claim_pairs_each_runs_drl_and_tadv_shares_whatever_their_order() {
        // Three runs; DRL warns fewer real safe sequences than TAdv in two of them. The shares
        // come in another order than the folds, TAdv's first.
        let folds = [fold(0, 0), fold(0, 1), fold(1, 0)];
        let shares = [
            share(1, 0, "TAdv", 1),
            share(0, 1, "TAdv", 5),
            share(0, 0, "TAdv", 2),
            share(0, 1, "DRL", 4),
            share(1, 0, "DRL", 3),
            share(0, 0, "DRL", 2),
        ];
        let report = riskscore_eval::aggregate(EventCounts::default(), &folds);
        let claims = round_claims(&report, &folds, &shares, &[]);
        let c = claims.iter().find(|c| c.metric == SHARE_KEY).unwrap();
        assert_eq!((c.method.as_str(), c.baseline.as_str()), ("DRL", "TAdv"));
        // Means 30 % vs 26.7 %: fails on the means, holds in the runs (0, 0) and (0, 1).
        assert_eq!(c.verdict, "FAIL");
        assert_eq!(
            c.runs,
            RunTally {
                holding: 2,
                compared: 3
            }
        );
    }

    #[test]
    fn no_real_safe_sequences_no_share_claim() {
        let folds = [fold(0, 0)];
        let mut empty = share(0, 0, "DRL", 0);
        empty.of = 0;
        let report = riskscore_eval::aggregate(EventCounts::default(), &folds);
        let claims = round_claims(&report, &folds, &[empty], &[]);
        assert!(claims.iter().all(|c| c.metric != SHARE_KEY));
    }
}
