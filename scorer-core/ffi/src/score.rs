//! Scoring one ego/partner pair: features, surrogates and the score of every loaded model.
use crate::convert::{status, vehicle};
use crate::ptr::{context_ref, read, write};
use crate::types::{RiskscoreContext, RiskscorePairResult, RiskscoreStatus, RiskscoreVehicleState};
use scorer_core::model::Model;
use scorer_core::Observation;

/// Scores one ego/partner pair: features, surrogates and the score of every loaded model.
///
/// # Safety
/// `context` must be NULL or initialised; `ego`, `partner` NULL or readable; `out` NULL or
/// writable.
#[no_mangle]
pub unsafe extern "C" fn riskscore_score_pair(
    context: *const RiskscoreContext,
    ego: *const RiskscoreVehicleState,
    partner: *const RiskscoreVehicleState,
    out: *mut RiskscorePairResult,
) -> RiskscoreStatus {
    let run = || {
        // SAFETY: caller contract above.
        let ctx = unsafe { context_ref(context) }?;
        // SAFETY: caller contract above.
        let (ego, partner) = unsafe { (read(ego)?, read(partner)?) };
        if out.is_null() {
            return Err(RiskscoreStatus::NullPointer);
        }
        let (ego, partner) = (vehicle(&ego)?, vehicle(&partner)?);
        if ctx.drl.is_none() && ctx.msra.is_none() && ctx.gssm.is_none() {
            return Err(RiskscoreStatus::NoModel);
        }
        let o = Observation::of(&ego, &partner);
        let s = o.surrogates;
        let score =
            |m: &Option<Model<'static>>| m.as_ref().map_or(f32::NAN, |m| m.score_observation(&o));
        let result = RiskscorePairResult {
            features: o.features,
            box_distance: s.box_distance,
            ttc2d: s.ttc2d,
            tadv: s.tadv,
            ei: s.ei,
            drl_score: score(&ctx.drl),
            msra_score: score(&ctx.msra),
            gssm_score: score(&ctx.gssm),
            has_drl: u8::from(ctx.drl.is_some()),
            has_msra: u8::from(ctx.msra.is_some()),
            has_gssm: u8::from(ctx.gssm.is_some()),
        };
        // SAFETY: `out` is non-null (checked) and writable per the caller contract.
        unsafe { write(out, result) }
    };
    status(run())
}
