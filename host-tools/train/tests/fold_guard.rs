//! The fold models of cross-validation (and so of `benchmark transfer` / `benchmark domains`)
//! carry the training-domain record of `[guard] policy`, measured on the fold's training data, and
//! are scored through it: `none` and `flag-only` score alike, `clamp` moves held-out scores,
//! `fallback` and `blend` hand held-out frames to the kinematic terms of the fold's MSRA.
use riskscore_data::events::Sequence;
use riskscore_train::train::cv::{self, CvOptions, FoldOutcome, Models};
use riskscore_train::train::{GuardConfig, GuardPolicy, Progress, TrainConfig};
use scorer_core::model::OutsidePolicy;

mod common;
use common::{in_town, quick_config};

/// The same situations 25 m/s faster: the ego's and the partner's speeds lie far outside
/// what the training data covered, the relative kinematics inside.
fn on_the_autobahn(n: usize) -> Vec<Sequence> {
    let mut seqs = in_town(n);
    for s in &mut seqs {
        s.event_id = format!("fast-{}", s.event_id);
        for f in &mut s.frames {
            f.ego.vx += 25.0;
            f.partner.vx += 25.0;
        }
    }
    seqs
}

fn fold(policy: GuardPolicy) -> FoldOutcome {
    fold_of(policy, Models::default())
}

fn fold_of(policy: GuardPolicy, models: Models) -> FoldOutcome {
    fold_with(policy, models, |_| ())
}

/// A fold under `policy` with `adjust` applied to the small test configuration.
fn fold_with(
    policy: GuardPolicy,
    models: Models,
    adjust: impl FnOnce(&mut TrainConfig),
) -> FoldOutcome {
    let mut config = quick_config();
    config.optimiser.max_epochs = 8;
    config.guard.policy = policy;
    adjust(&mut config);
    let options = CvOptions {
        progress: Progress::Hidden,
        models,
        ..CvOptions::default()
    };
    cv::run_fold(
        0,
        &in_town(24),
        &[],
        &on_the_autobahn(8),
        None,
        &config,
        &options,
    )
    .unwrap()
}

fn policies(outcome: &FoldOutcome) -> Vec<(String, Option<OutsidePolicy>)> {
    outcome
        .blobs
        .iter()
        .map(|(name, blob)| {
            let blob = scorer_core::model::decode_blob(blob).unwrap();
            (name.clone(), blob.meta.training_domain.map(|d| d.policy))
        })
        .collect()
}

/// The fold's blob of `method`, decoded.
fn blob_of<'a>(outcome: &'a FoldOutcome, method: &str) -> scorer_core::model::ModelBlob<'a> {
    let bytes = &outcome.blobs.iter().find(|(n, _)| n == method).unwrap().1;
    scorer_core::model::decode_blob(bytes).unwrap()
}

fn scores(outcome: &FoldOutcome, method: &str) -> Vec<u32> {
    let run = outcome.runs.iter().find(|r| r.name == method).unwrap();
    run.scored
        .iter()
        .flat_map(|s| s.frames.iter().map(|f| f.score.to_bits()))
        .collect()
}

#[test]
fn fold_models_carry_the_configured_record_and_are_scored_through_it() {
    let none = fold(GuardPolicy::None);
    let flag = fold(GuardPolicy::FlagOnly);
    let clamp = fold(GuardPolicy::Clamp);
    let models = ["DRL", "DRL-f32", "MSRA"];
    let with = |p| {
        models
            .iter()
            .map(|m| (m.to_string(), p))
            .collect::<Vec<_>>()
    };
    assert_eq!(policies(&none), with(None));
    assert_eq!(policies(&flag), with(Some(OutsidePolicy::FlagOnly)));
    assert_eq!(policies(&clamp), with(Some(OutsidePolicy::Clamp)));
    // The record is measured on the fold's training data: the held-out speeds are outside.
    let blob = scorer_core::model::decode_blob(&flag.blobs[0].1).unwrap();
    let held_out = on_the_autobahn(1);
    let observation =
        scorer_core::Observation::of(&held_out[0].frames[0].ego, &held_out[0].frames[0].partner);
    assert!(!blob.score_guarded(&observation).in_domain);
    // Every held-out frame is 25 m/s beyond the training speeds: outside for every model.
    assert!(none.domain_shares.is_empty());
    for outcome in [&flag, &clamp] {
        let shares: Vec<_> = outcome
            .domain_shares
            .iter()
            .map(|d| (d.name.as_str(), d.outside_percent()))
            .collect();
        assert_eq!(shares, models.map(|m| (m, Some(100.0))));
    }
    for m in models {
        // flag-only scores exactly as no record: the default leaves every number unchanged.
        assert!(
            scores(&none, m) == scores(&flag, m),
            "{m}: flag-only moved a score"
        );
    }
    for m in ["DRL", "DRL-f32"] {
        // clamp moves the network's scores of the held-out frames (it sees its trained edge).
        assert!(
            scores(&none, m) != scores(&clamp, m),
            "{m}: clamp moved no score"
        );
    }
    // MSRA scores from relative-kinematic surrogates (TAdv, EI) that a shift of both speeds
    // leaves alone: clamping its features changes nothing here.
    assert!(scores(&none, "MSRA") == scores(&clamp, "MSRA"));
    assert_eq!(none.result.methods.len(), flag.result.methods.len());
}

#[test]
fn under_fallback_the_drl_hands_over_to_the_kinematic_terms_of_its_msra() {
    let flag = fold(GuardPolicy::FlagOnly);
    let fallback = fold(GuardPolicy::Fallback);
    // DRL blobs fall back; the MSRA is itself the kinematic score and only flags.
    assert_eq!(
        policies(&fallback),
        vec![
            ("DRL".to_string(), Some(OutsidePolicy::Fallback)),
            ("DRL-f32".to_string(), Some(OutsidePolicy::Fallback)),
            ("MSRA".to_string(), Some(OutsidePolicy::FlagOnly)),
        ]
    );
    // Every fallback was fitted, so the fold has nothing to warn about.
    assert!(fallback.warnings.is_empty(), "{:?}", fallback.warnings);
    let msra_blob = scorer_core::model::decode_blob(&fallback.blobs[2].1).unwrap();
    let scorer_core::model::Model::Msra(msra) = &msra_blob.model else {
        panic!("not MSRA")
    };
    let held_out = on_the_autobahn(8);
    for m in ["DRL", "DRL-f32"] {
        let blob = blob_of(&fallback, m);
        let record = blob.meta.kinematic_fallback.expect("a fallback record");
        // The fallback is the fold MSRA's (kinematic) terms, on a positive scale.
        assert_eq!(record.terms().collect::<Vec<_>>(), msra.terms.to_vec());
        assert!(record.scale > 0.0);
        // Every held-out frame is outside: the fold scored each one with the fallback.
        let expected: Vec<u32> = held_out
            .iter()
            .flat_map(|s| s.frames.iter())
            .map(|f| {
                let o = scorer_core::Observation::of(&f.ego, &f.partner);
                record.score(&o.surrogates).to_bits()
            })
            .collect();
        assert_eq!(scores(&fallback, m), expected, "{m}");
        assert!(scores(&flag, m) != expected, "{m}");
    }
    // The MSRA scores as under flag-only, and the fold trains the MSRA for the fallback even
    // when it is not asked to report it.
    assert!(scores(&flag, "MSRA") == scores(&fallback, "MSRA"));
    let drl_only = fold_of(
        GuardPolicy::Fallback,
        Models {
            msra: false,
            ..Models::default()
        },
    );
    assert_eq!(drl_only.blobs.len(), 2);
    assert!(drl_only.msra_params.is_none());
    assert!(scores(&drl_only, "DRL") == scores(&fallback, "DRL"));
}

#[test]
fn a_drl_whose_fallback_cannot_be_fitted_gets_a_flag_only_record_and_the_reason() {
    use riskscore_train::export::with_measured_domain;
    use riskscore_train::fallback::FallbackError;
    use scorer_core::model::{decode_blob, Model};
    let drl = include_bytes!("../../../models/drl-default.rsk");
    let msra = include_bytes!("../../../models/msra-default.rsk");
    let Model::Msra(m) = decode_blob(msra).unwrap().model else {
        panic!("msra-default.rsk is not an MSRA");
    };
    let terms = m.terms.to_vec();
    // Too few frames to align the fallback with: flag-only, and the caller learns why.
    let mut short = in_town(1);
    short.truncate(1);
    short[0].frames.truncate(10);
    let fallback = GuardConfig {
        policy: GuardPolicy::Fallback,
        ..GuardConfig::default()
    };
    let guarded = with_measured_domain(drl, &short, &fallback, Some(&terms)).unwrap();
    assert!(
        matches!(
            guarded.fallback_refused,
            Some(FallbackError::TooFewFrames { .. })
        ),
        "{:?}",
        guarded.fallback_refused
    );
    // The warning a caller prints (training and the benchmarks return it, never print it).
    let warning = guarded.warning("fold 3: DRL").expect("a warning");
    assert!(
        warning.starts_with("fold 3: DRL: no kinematic fallback (")
            && warning.contains("training frames inside the domain")
            && warning.ends_with("its guard is flag-only"),
        "{warning}"
    );
    let blob = decode_blob(&guarded.bytes).unwrap();
    let domain = blob.meta.training_domain.expect("a record");
    assert_eq!(domain.policy, OutsidePolicy::FlagOnly);
    assert!(blob.meta.kinematic_fallback.is_none());
    // Enough frames: the fallback is fitted.
    let guarded = with_measured_domain(drl, &in_town(24), &fallback, Some(&terms)).unwrap();
    assert!(
        guarded.fallback_refused.is_none(),
        "{:?}",
        guarded.fallback_refused
    );
    assert_eq!(guarded.warning("DRL"), None);
    let blob = decode_blob(&guarded.bytes).unwrap();
    assert_eq!(
        blob.meta.training_domain.unwrap().policy,
        OutsidePolicy::Fallback
    );
    assert!(blob.meta.kinematic_fallback.is_some());
    assert!(blob.meta.blend.is_none());
    // Under blend the same refusal leaves no blend record either.
    let blend = GuardConfig::default();
    assert_eq!(blend.policy, GuardPolicy::Blend);
    let refused = with_measured_domain(drl, &short, &blend, Some(&terms)).unwrap();
    assert!(refused.fallback_refused.is_some());
    let refused = decode_blob(&refused.bytes).unwrap();
    assert_eq!(
        refused.meta.training_domain.unwrap().policy,
        OutsidePolicy::FlagOnly
    );
    assert!(refused.meta.kinematic_fallback.is_none() && refused.meta.blend.is_none());
}

#[test]
fn under_blend_the_drl_mixes_in_the_fallback_inside_and_hands_over_outside() {
    let fallback = fold(GuardPolicy::Fallback);
    let blend = fold(GuardPolicy::Blend);
    assert_eq!(
        policies(&blend),
        vec![
            ("DRL".to_string(), Some(OutsidePolicy::Blend)),
            ("DRL-f32".to_string(), Some(OutsidePolicy::Blend)),
            ("MSRA".to_string(), Some(OutsidePolicy::FlagOnly)),
        ]
    );
    assert!(blend.warnings.is_empty(), "{:?}", blend.warnings);
    let inside = in_town(24);
    for m in ["DRL", "DRL-f32"] {
        // The same network and fallback; every held-out frame is outside, where both policies
        // score the fallback.
        assert!(scores(&blend, m) == scores(&fallback, m), "{m}");
        let (mixed, handed) = (blob_of(&blend, m), blob_of(&fallback, m));
        assert_eq!(mixed.model, handed.model, "{m}: one network");
        let weight = mixed.meta.blend.expect("a blend record").network_weight;
        assert_eq!(weight, riskscore_train::train::DEFAULT_BLEND_WEIGHT);
        let record = mixed.meta.kinematic_fallback.expect("a fallback record");
        // Inside the domain: the network's share plus the rest of the fallback, bit for bit.
        let mut checked = 0;
        for f in inside.iter().flat_map(|s| s.frames.iter()) {
            let o = scorer_core::Observation::of(&f.ego, &f.partner);
            let guarded = mixed.score_guarded(&o);
            if !guarded.in_domain {
                continue;
            }
            let network = mixed.model.score_observation(&o);
            let expected = weight * network + (1.0 - weight) * record.score(&o.surrogates);
            assert_eq!(guarded.score.to_bits(), expected.to_bits(), "{m}");
            assert_eq!(handed.score_guarded(&o).score.to_bits(), network.to_bits());
            checked += 1;
        }
        assert!(checked > 100, "{m}: only {checked} frames inside");
    }
}

/// The kinematic terms of a fold's blob: an MSRA's own, a DRL's fallback record's.
fn kinematic_terms(outcome: &FoldOutcome, method: &str) -> Vec<scorer_core::msra::MsraTerm> {
    let blob = blob_of(outcome, method);
    match (&blob.model, blob.meta.kinematic_fallback) {
        (scorer_core::model::Model::Msra(m), _) => m.terms.to_vec(),
        (_, Some(record)) => record.terms().collect(),
        _ => panic!("{method}: neither an MSRA nor a fallback record"),
    }
}

#[test]
fn a_fallback_weight_decay_gives_the_drl_an_msra_of_its_own_and_leaves_the_shipped_one() {
    let decayed = 0.5;
    let shared = fold(GuardPolicy::Blend);
    let own = fold_with(GuardPolicy::Blend, Models::default(), |c| {
        c.guard.fallback_weight_decay = Some(decayed)
    });
    // The same MSRA ships, and the same network; only the DRL's fallback changed.
    assert_eq!(
        kinematic_terms(&own, "MSRA"),
        kinematic_terms(&shared, "MSRA")
    );
    assert!(scores(&own, "MSRA") == scores(&shared, "MSRA"));
    assert_eq!(blob_of(&own, "DRL").model, blob_of(&shared, "DRL").model);
    assert_eq!(
        kinematic_terms(&shared, "DRL"),
        kinematic_terms(&shared, "MSRA")
    );
    assert_ne!(kinematic_terms(&own, "DRL"), kinematic_terms(&own, "MSRA"));
    // The fallback is the MSRA that this decay trains.
    let msra_decayed = fold_with(GuardPolicy::Blend, Models::default(), |c| {
        c.msra.weight_decay = Some(decayed)
    });
    assert_eq!(
        kinematic_terms(&own, "DRL"),
        kinematic_terms(&msra_decayed, "MSRA")
    );
    assert_eq!(
        kinematic_terms(&msra_decayed, "DRL"),
        kinematic_terms(&msra_decayed, "MSRA")
    );
    // Without the MSRA in the report the DRL still gets the decayed fallback.
    let drl_only = fold_with(
        GuardPolicy::Blend,
        Models {
            msra: false,
            ..Models::default()
        },
        |c| c.guard.fallback_weight_decay = Some(decayed),
    );
    assert!(drl_only.msra_params.is_none());
    assert_eq!(
        kinematic_terms(&drl_only, "DRL"),
        kinematic_terms(&own, "DRL")
    );
}
