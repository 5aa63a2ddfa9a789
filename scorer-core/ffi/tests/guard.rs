//! `riskscore_score_pair` scores every model through its blob's training-domain guard: the same
//! bits and the same flag as `ModelBlob::score_guarded` on the host, for the shipped models, for
//! each outside policy, and for a blob without records (unguarded, inside everywhere).
use std::path::Path;

use scorer_core::model::{self, Blend, ModelBlob, ModelMeta, OutsidePolicy, TrainingDomain};
use scorer_core::Observation;
use scorer_ffi::*;

mod common;
use common::{config, context, core_state, EGO, LEAD};

/// Ego at 30 m/s, 60 m behind an 18.75 m articulated truck at 22 m/s: the shipped DRL's (and
/// MSRA's) training data has no partner longer than 16.5 m.
const TRUCK_EGO: RiskscoreVehicleState = RiskscoreVehicleState { vy: 30.0, ..EGO };
const LONG_TRUCK: RiskscoreVehicleState = RiskscoreVehicleState {
    y: 60.0,
    vy: 22.0,
    length: 18.75,
    width: 2.55,
    ..EGO
};

fn shipped(name: &str) -> &'static [u8] {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../models/{name}"));
    let blob = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Box::leak(blob.into_boxed_slice())
}

fn encoded(blob: &ModelBlob<'_>) -> &'static [u8] {
    let mut out = vec![0u8; model::encoded_blob_len(blob).expect("blob length")];
    model::encode_blob(blob, &mut out).expect("blob encodes");
    Box::leak(out.into_boxed_slice())
}

/// A context holding `blobs` (any kinds).
fn context_with(blobs: &[&'static [u8]]) -> Box<RiskscoreContext> {
    let mut ctx = context();
    // SAFETY: a live, aligned context of the right size; the blobs are leaked ('static).
    unsafe {
        assert_eq!(
            riskscore_init(&mut *ctx, RISKSCORE_CONTEXT_SIZE, &config()),
            RiskscoreStatus::Ok
        );
        for blob in blobs {
            assert_eq!(
                riskscore_load_model(&mut *ctx, blob.as_ptr(), blob.len(), std::ptr::null_mut()),
                RiskscoreStatus::Ok
            );
        }
    }
    ctx
}

fn score_pair(
    ctx: &RiskscoreContext,
    ego: &RiskscoreVehicleState,
    partner: &RiskscoreVehicleState,
) -> RiskscorePairResult {
    let mut r = std::mem::MaybeUninit::<RiskscorePairResult>::uninit();
    // SAFETY: initialised context, live states, writable output (read only after success).
    unsafe {
        assert_eq!(
            riskscore_score_pair(ctx, ego, partner, r.as_mut_ptr()),
            RiskscoreStatus::Ok
        );
        r.assume_init()
    }
}

/// The host's guarded score and flag of `blob` for the pair.
fn host(
    blob: &[u8],
    ego: &RiskscoreVehicleState,
    partner: &RiskscoreVehicleState,
) -> scorer_core::Guarded {
    let decoded = model::decode_blob(blob).expect("blob decodes");
    decoded.score_guarded(&Observation::of(&core_state(ego), &core_state(partner)))
}

fn unguarded(blob: &[u8], ego: &RiskscoreVehicleState, partner: &RiskscoreVehicleState) -> f32 {
    let m = model::decode(blob).expect("blob decodes");
    m.score_observation(&Observation::of(&core_state(ego), &core_state(partner)))
}

fn assert_same(what: &str, c_score: f32, c_flag: u8, host: scorer_core::Guarded) {
    assert_eq!(
        (c_score.to_bits(), c_flag),
        (host.score.to_bits(), u8::from(host.in_domain)),
        "{what}: C ABI {c_score:e} (in domain {c_flag}), host score_guarded {:e} (in domain {})",
        host.score,
        host.in_domain
    );
}

#[test]
fn shipped_models_score_as_the_hosts_guard_inside_and_outside() {
    let (drl, msra, gssm) = (
        shipped("drl-default.rsk"),
        shipped("msra-default.rsk"),
        shipped("gssm-default.rsk"),
    );
    let ctx = context_with(&[drl, msra, gssm]);
    let inside = host(drl, &EGO, &LEAD);
    let outside = host(drl, &TRUCK_EGO, &LONG_TRUCK);
    assert!(
        inside.in_domain,
        "the following pair is inside the DRL's domain"
    );
    assert!(
        !outside.in_domain,
        "an 18.75 m truck: outside the DRL's domain"
    );
    // The GSSM carries the domain of its normal driving too and falls back there.
    assert!(
        !host(gssm, &TRUCK_EGO, &LONG_TRUCK).in_domain,
        "an 18.75 m truck: outside the GSSM's domain"
    );
    for (what, ego, partner) in [
        ("inside", &EGO, &LEAD),
        ("outside", &TRUCK_EGO, &LONG_TRUCK),
    ] {
        let r = score_pair(&ctx, ego, partner);
        assert_same(
            &format!("{what}: DRL"),
            r.drl_score,
            r.drl_in_domain,
            host(drl, ego, partner),
        );
        assert_same(
            &format!("{what}: MSRA"),
            r.msra_score,
            r.msra_in_domain,
            host(msra, ego, partner),
        );
        assert_same(
            &format!("{what}: GSSM"),
            r.gssm_score,
            r.gssm_in_domain,
            host(gssm, ego, partner),
        );
    }
}

#[test]
fn every_outside_policy_scores_as_the_hosts_guard() {
    let drl = shipped("drl-default.rsk");
    let base = model::decode_blob(drl).expect("shipped DRL decodes");
    let domain = base
        .meta
        .training_domain
        .expect("the shipped DRL carries a training domain");
    let fallback = base
        .meta
        .kinematic_fallback
        .expect("the shipped DRL carries a kinematic fallback");
    let plain = unguarded(drl, &TRUCK_EGO, &LONG_TRUCK);
    let plain_inside = unguarded(drl, &EGO, &LEAD);
    for policy in OutsidePolicy::ALL {
        let blob = encoded(&ModelBlob {
            model: base.model.clone(),
            meta: ModelMeta {
                training_domain: Some(TrainingDomain::new(policy, domain.range_bytes)),
                kinematic_fallback: policy.uses_fallback().then_some(fallback),
                blend: (policy == OutsidePolicy::Blend).then_some(Blend {
                    network_weight: 0.7,
                }),
                ..base.meta
            },
        });
        let ctx = context_with(&[blob]);
        for (what, ego, partner) in [
            ("inside", &EGO, &LEAD),
            ("outside", &TRUCK_EGO, &LONG_TRUCK),
        ] {
            let r = score_pair(&ctx, ego, partner);
            let expected = host(blob, ego, partner);
            assert_same(
                &format!("{} {what}", policy.name()),
                r.drl_score,
                r.drl_in_domain,
                expected,
            );
            assert_eq!(
                (r.msra_in_domain, r.gssm_in_domain),
                (1, 1),
                "no model: inside"
            );
            assert!(r.msra_score.is_nan() && r.gssm_score.is_nan());
        }
        // Inside, only blend moves the network's score.
        let r = score_pair(&ctx, &EGO, &LEAD);
        assert_eq!(
            r.drl_score.to_bits() != plain_inside.to_bits(),
            policy == OutsidePolicy::Blend,
            "{}: inside score {:e}, unguarded {plain_inside:e}",
            policy.name(),
            r.drl_score
        );
        // Outside, only flag-only leaves the network's score alone.
        let r = score_pair(&ctx, &TRUCK_EGO, &LONG_TRUCK);
        assert_eq!(
            r.drl_score.to_bits() == plain.to_bits(),
            policy == OutsidePolicy::FlagOnly,
            "{}: outside score {:e}, unguarded {plain:e}",
            policy.name(),
            r.drl_score
        );
    }
}

#[test]
fn a_blob_without_records_scores_unguarded_and_inside() {
    let drl = shipped("drl-default.rsk");
    let stripped = encoded(&ModelBlob::from(
        model::decode(drl).expect("shipped DRL decodes"),
    ));
    assert_eq!(
        model::decode_blob(stripped)
            .expect("stripped blob decodes")
            .meta,
        ModelMeta::default()
    );
    let ctx = context_with(&[stripped]);
    for (ego, partner) in [(&EGO, &LEAD), (&TRUCK_EGO, &LONG_TRUCK)] {
        let r = score_pair(&ctx, ego, partner);
        assert_eq!(r.drl_in_domain, 1);
        assert_eq!(
            r.drl_score.to_bits(),
            unguarded(drl, ego, partner).to_bits()
        );
    }
}

/// `model::decode` keeps the model alone (its rustdoc): for the shipped DRL, whose `blend` mixes
/// in the kinematic fallback inside the domain too, `Model::score` of it is not the deployed score
/// the C ABI gives, even for an everyday pair inside the domain; `decode_blob` + `score_guarded` is.
#[test]
fn decode_alone_is_not_the_deployed_score_of_the_shipped_drl() {
    let drl = shipped("drl-default.rsk");
    let r = score_pair(&context_with(&[drl]), &EGO, &LEAD);
    assert_eq!(r.drl_in_domain, 1);
    assert_same(
        "inside: DRL",
        r.drl_score,
        r.drl_in_domain,
        host(drl, &EGO, &LEAD),
    );
    let alone = model::decode(drl).expect("blob decodes");
    let (ego, lead) = (core_state(&EGO), core_state(&LEAD));
    assert_eq!(
        alone.score(&ego, &lead).to_bits(),
        unguarded(drl, &EGO, &LEAD).to_bits()
    );
    assert_ne!(
        alone.score(&ego, &lead).to_bits(),
        r.drl_score.to_bits(),
        "decode + Model::score gave the deployed score: the rustdoc of decode says it does not"
    );
}

/// Inside every trained range but in a geometry cell the shipped DRL's training never reached (an
/// oncoming car in the ego's lane 10 m ahead): `drl_in_domain` is 0 (its header comment), and
/// `blend` scores the fallback there, as the host's guard does.
#[test]
fn a_pair_outside_only_by_its_geometry_cell_is_flagged_outside() {
    let drl = shipped("drl-default.rsk");
    let oncoming = RiskscoreVehicleState {
        y: 10.0,
        vy: -15.0,
        hy: -1.0,
        ..EGO
    };
    let ego = RiskscoreVehicleState { vy: 0.0, ..EGO };
    let on_host = host(drl, &ego, &oncoming);
    assert_eq!(on_host.first_outside, Some(model::GEOMETRY_INPUT));
    let r = score_pair(&context_with(&[drl]), &ego, &oncoming);
    assert_eq!(r.drl_in_domain, 0);
    assert_same("cell only: DRL", r.drl_score, r.drl_in_domain, on_host);
}

/// An SSRA blob is a GSSM (its header comment): loaded after the GSSM it takes the GSSM slot, and
/// `gssm_score` is then the SSRA's.
#[test]
fn an_ssra_blob_replaces_the_gssm() {
    let (gssm, ssra) = (shipped("gssm-default.rsk"), shipped("ssra-default.rsk"));
    let mut ctx = context_with(&[gssm]);
    let mut info = std::mem::MaybeUninit::<RiskscoreLoadInfo>::uninit();
    // SAFETY: an initialised context, a leaked blob, a writable info.
    let status =
        unsafe { riskscore_load_model(&mut *ctx, ssra.as_ptr(), ssra.len(), info.as_mut_ptr()) };
    assert_eq!(status, RiskscoreStatus::Ok);
    // SAFETY: written by the call.
    assert_eq!(unsafe { info.assume_init() }.kind, RiskscoreModelKind::Gssm);
    let r = score_pair(&ctx, &EGO, &LEAD);
    assert_same(
        "SSRA in the GSSM slot",
        r.gssm_score,
        r.gssm_in_domain,
        host(ssra, &EGO, &LEAD),
    );
    assert_ne!(
        r.gssm_score.to_bits(),
        host(gssm, &EGO, &LEAD).score.to_bits()
    );
}
