//! The final models' fallback (`final_models::train_and_export`, what `riskctl train` and the
//! demo write): the DRL falls back on the kinematic terms of the MSRA written beside it, or, under
//! `[guard] fallback_weight_decay` or `fallback_surrogates` (by default the reference TAdv and EI
//! while MSRA reads TAdv-corridor), of an MSRA trained for it alone; `msra.rsk` is the same either
//! way.
use riskscore_data::events::Sequence;
use riskscore_train::final_models::train_and_export;
use riskscore_train::train::Progress;
use scorer_core::model::{decode_blob, Model};
use scorer_core::msra::MsraTerm;

mod common;
use common::{following, in_town, quick_config};

/// The kinematic terms of `drl.rsk`'s fallback and of `msra.rsk`, and `msra.rsk`'s bytes.
/// `fallback_surrogates` `None`: those of the shipped MSRA.
fn trained(
    fallback_weight_decay: Option<f64>,
    fallback_surrogates: Option<&[&str]>,
    drl_only: &[Sequence],
) -> (Vec<MsraTerm>, Vec<MsraTerm>, Vec<u8>) {
    let mut config = quick_config();
    config.guard.fallback_weight_decay = fallback_weight_decay;
    config.guard.fallback_surrogates =
        fallback_surrogates.map(|s| s.iter().map(|k| k.to_string()).collect());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("models");
    let data = in_town(24);
    train_and_export(
        &data,
        drl_only,
        None,
        &config,
        &out,
        serde_json::json!({}),
        Progress::Hidden,
    )
    .unwrap();
    let drl = std::fs::read(out.join("drl.rsk")).unwrap();
    let msra = std::fs::read(out.join("msra.rsk")).unwrap();
    let fallback = decode_blob(&drl)
        .unwrap()
        .meta
        .kinematic_fallback
        .expect("a fallback record")
        .terms()
        .collect();
    let terms = match decode_blob(&msra).unwrap().model {
        Model::Msra(m) => m.terms.to_vec(),
        _ => panic!("msra.rsk is not an MSRA"),
    };
    (fallback, terms, msra)
}

#[test]
fn a_fallback_weight_decay_gives_the_final_drl_a_fallback_of_its_own() {
    let (shared, msra_terms, msra) = trained(None, None, &[]);
    assert_eq!(shared, msra_terms);
    let (own, own_msra_terms, own_msra) = trained(Some(0.5), None, &[]);
    assert_ne!(own, own_msra_terms);
    assert_eq!(own_msra, msra, "msra.rsk changed");
    // The fallback MSRA trains on what the DRL trains on, DRL-only sequences included; the
    // MSRA that ships does not see them.
    let drl_only: Vec<Sequence> = (0..6)
        .map(|i| {
            let mut s = following(i, 8.0 + i as f32, 30.0, 0.0);
            s.event_id = format!("drl-only-{}", s.event_id);
            s
        })
        .collect();
    let (own_with, _, msra_with) = trained(Some(0.5), None, &drl_only);
    assert_ne!(own_with, own);
    assert_eq!(msra_with, msra, "msra.rsk saw the DRL-only data");
}

#[test]
fn the_default_fallback_reads_the_reference_tadv_while_msra_reads_tadv_corridor() {
    use scorer_core::SurrogateKind::{Ei, Tadv, TadvCorridor};
    let kinds = |terms: &[MsraTerm]| terms.iter().map(|t| t.kind).collect::<Vec<_>>();
    let (shared, msra_terms, msra) = trained(None, None, &[]);
    assert_eq!(kinds(&msra_terms), [TadvCorridor, Ei]);
    assert_eq!(kinds(&shared), [TadvCorridor, Ei]);
    // The default's list (quick_config clears it to share the MSRA's terms).
    assert_eq!(
        riskscore_train::train::GuardConfig::default().fallback_surrogates,
        Some(vec!["tadv".to_string(), "ei".to_string()])
    );
    let (own, own_msra_terms, own_msra) = trained(None, Some(&["tadv", "ei"]), &[]);
    assert_eq!(kinds(&own), [Tadv, Ei]);
    assert_eq!(own_msra_terms, msra_terms);
    assert_eq!(own_msra, msra, "msra.rsk changed");
}
