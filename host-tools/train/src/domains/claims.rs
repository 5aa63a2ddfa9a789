//! A round's acceptance claims: the standard ones of its CV report (`riskscore_eval::claims`) and
//! one of its own, DRL warning no larger a share of the slice's real safe sequences at its
//! 90 %-recall threshold than TAdv at its own, each with its run-by-run tally.
use riskscore_eval::claims::{acceptance_claims, Claim, Rule};

use super::run::RoundResult;
use super::share::{summarise, ShareRun, SHARE_KEY};

/// The claims of `round`; `msra_inputs` as for [`acceptance_claims`]. The share claim is left
/// out where neither method has a share (no real safe test sequences).
pub fn round_claims(round: &RoundResult, msra_inputs: &[String]) -> Vec<Claim> {
    let mut claims = acceptance_claims(&round.report, &round.folds, msra_inputs);
    let mean = |method: &str| summarise(&round.shares, method).percent.map(|p| p.mean);
    let (drl, tadv) = (mean("DRL"), mean("TAdv"));
    if drl.is_some() || tadv.is_some() {
        let percent = |seed: u64, fold: usize, method: &str| {
            round
                .shares
                .iter()
                .find(|s| (s.seed, s.fold) == (seed, fold) && s.method == method)
                .and_then(ShareRun::percent)
        };
        let runs = round.folds.iter().map(|f| {
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
