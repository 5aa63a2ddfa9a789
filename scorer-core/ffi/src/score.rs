//! Scoring one ego/partner pair: features, surrogates and the guarded score of every loaded model.
use crate::convert::{status, vehicle};
use crate::ptr::{context_ref, read, write};
use crate::types::{RiskscoreContext, RiskscorePairResult, RiskscoreStatus, RiskscoreVehicleState};
use scorer_core::model::ModelBlob;
use scorer_core::{Guarded, Observation};

/// Scores one ego/partner pair: features, surrogates and, for every loaded model, its score
/// through the blob's training-domain guard (`ModelBlob::score_guarded`, the score `riskctl`, the
/// CAN bridge and the Rust ECU path give) with whether the pair was inside the model's domain.
/// A state with a NaN/infinite field is refused (`RISKSCORE_STATUS_NON_FINITE_STATE`), one with a
/// zero heading vector or a negative length/width too (`RISKSCORE_STATUS_INVALID_INPUT`): without a
/// heading the box is lost and a stopped car close ahead would not warn.
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
        let (drl, msra, gssm) = (
            guarded(&ctx.drl, &o),
            guarded(&ctx.msra, &o),
            guarded(&ctx.gssm, &o),
        );
        let result = RiskscorePairResult {
            features: o.features,
            box_distance: s.box_distance,
            ttc2d: s.ttc2d,
            tadv: s.tadv,
            ei: s.ei,
            drl_score: drl.score,
            msra_score: msra.score,
            gssm_score: gssm.score,
            has_drl: u8::from(ctx.drl.is_some()),
            has_msra: u8::from(ctx.msra.is_some()),
            has_gssm: u8::from(ctx.gssm.is_some()),
            drl_in_domain: u8::from(drl.in_domain),
            msra_in_domain: u8::from(msra.in_domain),
            gssm_in_domain: u8::from(gssm.in_domain),
        };
        // SAFETY: `out` is non-null (checked) and writable per the caller contract.
        unsafe { write(out, result) }
    };
    status(run())
}

/// The guarded score of the slot's model; an empty slot reads as NaN and inside (there is no
/// domain to leave). Not inlined: one copy of the guard serves the three slots (flash).
#[inline(never)]
fn guarded(slot: &Option<ModelBlob<'static>>, o: &Observation) -> Guarded {
    slot.as_ref().map_or(
        Guarded {
            score: f32::NAN,
            in_domain: true,
            first_outside: None,
        },
        |b| b.score_guarded(o),
    )
}
