//! Training-only data scoped to DRL (`cv::ExtraTrain::drl_only`, what `riskctl demo
//! --extra-drl-only` feeds): every DRL fold model trains on it, MSRA's never does, and no fold
//! tests on it.
use riskscore_data::events::Sequence;
use riskscore_train::train::cv::{self, CvOptions, ExtraTrain, FoldOutcome};
use riskscore_train::train::{GuardPolicy, Progress, TrainConfig};

mod common;
use common::{following, in_town, quick_config};

/// Calm following 25 m/s faster than anything in town: speeds only a model that trained on
/// these sequences has in its domain record.
fn fast_following(n: usize) -> Vec<Sequence> {
    (0..n)
        .map(|i| {
            let mut s = following(i, 12.0 + i as f32 % 7.0, 40.0, 0.0);
            s.event_id = format!("drl-only-{}", s.event_id);
            for f in &mut s.frames {
                f.ego.vx += 25.0;
                f.partner.vx += 25.0;
            }
            s
        })
        .collect()
}

fn cross_validate(drl_only: &[Sequence]) -> Vec<FoldOutcome> {
    cross_validate_with(drl_only, |c| c.guard.policy = GuardPolicy::FlagOnly)
}

fn cross_validate_with(
    drl_only: &[Sequence],
    adjust: impl FnOnce(&mut TrainConfig),
) -> Vec<FoldOutcome> {
    let mut config = quick_config();
    adjust(&mut config);
    let options = CvOptions {
        folds: 2,
        progress: Progress::Hidden,
        ..CvOptions::default()
    };
    let extra = ExtraTrain {
        all_models: &[],
        drl_only,
    };
    cv::cross_validate_with_extra(&in_town(16), &extra, None, &config, &options).unwrap()
}

fn blob<'a>(outcome: &'a FoldOutcome, name: &str) -> &'a [u8] {
    &outcome.blobs.iter().find(|(n, _)| n == name).unwrap().1
}

#[test]
fn drl_only_data_trains_drl_alone_and_is_never_tested() {
    let fast = fast_following(6);
    let without = cross_validate(&[]);
    let with = cross_validate(&fast);
    let fast_observation =
        scorer_core::Observation::of(&fast[0].frames[0].ego, &fast[0].frames[0].partner);
    for (a, b) in without.iter().zip(&with) {
        // MSRA is trained exactly as without the data (same comparisons, same blob) ...
        assert!(
            blob(a, "MSRA") == blob(b, "MSRA"),
            "fold {}: MSRA saw the DRL-only data",
            b.fold
        );
        // ... DRL is not, and its domain record covers the DRL-only speeds, MSRA's does not.
        assert!(
            blob(a, "DRL") != blob(b, "DRL"),
            "fold {}: DRL did not train on it",
            b.fold
        );
        let in_domain = |name| {
            scorer_core::model::decode_blob(blob(b, name))
                .unwrap()
                .score_guarded(&fast_observation)
                .in_domain
        };
        assert!(in_domain("DRL") && in_domain("DRL-f32"), "fold {}", b.fold);
        assert!(!in_domain("MSRA"), "fold {}", b.fold);
        // No fold scores a DRL-only sequence.
        for run in &b.runs {
            assert!(
                run.scored
                    .iter()
                    .all(|s| !s.event_id.starts_with("drl-only-")),
                "fold {}: {} scored a DRL-only sequence",
                b.fold,
                run.name
            );
        }
    }
}

/// The fallback terms a fold's DRL carries.
fn fallback_terms(outcome: &FoldOutcome) -> Vec<scorer_core::msra::MsraTerm> {
    scorer_core::model::decode_blob(blob(outcome, "DRL"))
        .unwrap()
        .meta
        .kinematic_fallback
        .expect("a fallback record")
        .terms()
        .collect()
}

#[test]
fn the_drl_s_own_fallback_msra_trains_on_the_drl_only_data_too() {
    // `[guard] fallback_weight_decay`: the DRL's fallback is an MSRA of its own, trained on what
    // the DRL trained on; the MSRA that ships never sees the DRL-only data.
    let own_fallback = |c: &mut TrainConfig| {
        c.guard.policy = GuardPolicy::Blend;
        c.guard.fallback_weight_decay = Some(0.5);
    };
    let fast = fast_following(6);
    let without = cross_validate_with(&[], own_fallback);
    let with = cross_validate_with(&fast, own_fallback);
    for (a, b) in without.iter().zip(&with) {
        assert!(blob(a, "MSRA") == blob(b, "MSRA"), "fold {}", b.fold);
        assert_ne!(fallback_terms(a), fallback_terms(b), "fold {}", b.fold);
    }
}
