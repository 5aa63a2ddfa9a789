//! The deployed Rust path as a firmware user calls it, under hostile inputs:
//! - every shipped blob (`models/*.rsk`, each with its training-domain record and policy) scores
//!   any pair, NaN/inf/huge states included, through [`ModelBlob::score_pair_guarded`] to a finite
//!   score, the same bits as [`ModelBlob::score_guarded`] of [`Observation::of`], with a flag that
//!   agrees with the first input outside;
//! - every shipped blob re-encodes to its own bytes;
//! - truncated and byte-flipped shipped blobs never panic [`decode_blob`], and whatever still
//!   decodes scores finitely;
//! - random operation sequences on a [`TrackTable`] (any times, scores and configs that
//!   validate) never panic and keep the table's documented invariants.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common_hostile;

use common_hostile::{nasty_f32_weighted, nasty_state_of};
use proptest::prelude::*;
use scorer_core::model::{
    decode_blob, encode_blob, encoded_blob_len, ModelBlob, OutsidePolicy, TrainingDomain,
    HEADER_LEN,
};
use scorer_core::warning::{FullPolicy, TrackTable, WarningConfig, WarningError, WarningEvent};
use scorer_core::{Observation, VehicleState};

const SHIPPED: [(&str, &[u8]); 5] = [
    (
        "drl-default",
        include_bytes!("../../models/drl-default.rsk"),
    ),
    (
        "gssm-default",
        include_bytes!("../../models/gssm-default.rsk"),
    ),
    (
        "msra-default",
        include_bytes!("../../models/msra-default.rsk"),
    ),
    ("msra-gssm", include_bytes!("../../models/msra-gssm.rsk")),
    (
        "ssra-default",
        include_bytes!("../../models/ssra-default.rsk"),
    ),
];

fn shipped() -> Vec<(&'static str, ModelBlob<'static>)> {
    SHIPPED
        .iter()
        .map(|(name, bytes)| (*name, decode_blob(bytes).unwrap()))
        .collect()
}

fn nasty_f32() -> impl Strategy<Value = f32> {
    nasty_f32_weighted(4)
}

fn nasty_state() -> impl Strategy<Value = VehicleState> {
    nasty_state_of(nasty_f32())
}

/// A plausible road user: what reaches both sides of every shipped domain.
fn road_user() -> impl Strategy<Value = VehicleState> {
    (
        -80.0f32..80.0,
        -20.0f32..20.0,
        0.0f32..45.0,
        -1.0f32..1.0,
        -3.0f32..3.0,
        3.0f32..18.0,
        1.5f32..2.6,
    )
        .prop_map(|(x, y, speed, angle, acc, length, width)| {
            let (hy, hx) = libm::sincosf(angle);
            VehicleState {
                x,
                y,
                vx: speed * hx,
                vy: speed * hy,
                hx,
                hy,
                acc,
                length,
                width,
            }
        })
}

#[test]
fn shipped_blobs_re_encode_byte_for_byte() {
    for (name, bytes) in SHIPPED {
        let blob = decode_blob(bytes).unwrap();
        let mut out = vec![0u8; encoded_blob_len(&blob).unwrap()];
        let n = encode_blob(&blob, &mut out).unwrap();
        assert_eq!(&out[..n], bytes, "{name}");
        assert!(blob.default_threshold().is_finite(), "{name}");
        assert!(
            blob.meta.training_domain.is_some(),
            "{name}: every shipped blob is guarded"
        );
    }
}

/// The shipped blobs, and each blob with a domain under every outside policy (in memory: a policy
/// whose records the blob lacks scores as flag-only, as `score_guarded` documents).
fn variants() -> Vec<(String, ModelBlob<'static>)> {
    let mut out = Vec::new();
    for (name, blob) in shipped() {
        if let Some(domain) = blob.meta.training_domain {
            for policy in OutsidePolicy::ALL {
                let mut v = blob.clone();
                v.meta.training_domain = Some(TrainingDomain { policy, ..domain });
                out.push((format!("{name} under {}", policy.name()), v));
            }
        }
        out.push((name.to_string(), blob));
    }
    out
}

fn check_pair(ego: &VehicleState, partner: &VehicleState) -> Result<(), TestCaseError> {
    for (name, blob) in variants() {
        let pair = blob.score_pair_guarded(ego, partner);
        let observed = blob.score_guarded(&Observation::of(ego, partner));
        prop_assert!(pair.score.is_finite(), "{}: {:?}", name, pair);
        prop_assert_eq!(pair.score.to_bits(), observed.score.to_bits(), "{}", name);
        prop_assert_eq!(pair.in_domain, observed.in_domain, "{}", name);
        prop_assert_eq!(pair.first_outside, observed.first_outside, "{}", name);
        prop_assert_eq!(pair.in_domain, pair.first_outside.is_none(), "{}", name);
        prop_assert!(
            pair.first_outside.is_none_or(|i| i <= 13),
            "{}: {:?}",
            name,
            pair
        );
        // Without a record the guard is the model's own score.
        let unguarded = ModelBlob::from(blob.model.clone()).score_pair_guarded(ego, partner);
        prop_assert_eq!(
            unguarded.score.to_bits(),
            blob.model.score(ego, partner).to_bits(),
            "{}",
            name
        );
        prop_assert!(unguarded.in_domain);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn shipped_blobs_score_any_pair_finitely_and_alike(ego in nasty_state(), partner in nasty_state()) {
        check_pair(&ego, &partner)?;
    }

    #[test]
    fn shipped_blobs_score_plausible_pairs_finitely_and_alike(ego in road_user(), partner in road_user()) {
        check_pair(&ego, &partner)?;
    }

    #[test]
    fn mutated_shipped_blobs_never_panic(
        which in 0usize..SHIPPED.len(),
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..6),
        cut in any::<prop::sample::Index>(),
        fix_crc in any::<bool>(),
        ego in road_user(),
        partner in nasty_state(),
    ) {
        let mut bytes = SHIPPED[which].1.to_vec();
        for (i, v) in edits {
            let i = i.index(bytes.len());
            bytes[i] = v;
        }
        bytes.truncate(cut.index(bytes.len() + 1).max(bytes.len() * 3 / 4));
        if fix_crc && bytes.len() >= HEADER_LEN {
            // Past the CRC, so the payload and record readers and validation see the damage.
            let payload_len = (bytes.len() - HEADER_LEN) as u32;
            let crc = scorer_core::crc::crc32(&bytes[HEADER_LEN..]);
            bytes[12..16].copy_from_slice(&payload_len.to_le_bytes());
            bytes[16..20].copy_from_slice(&crc.to_le_bytes());
        }
        if let Ok(blob) = decode_blob(&bytes) {
            prop_assert!(blob.score_pair_guarded(&ego, &partner).score.is_finite());
            prop_assert!(blob.score_pair_guarded(&partner, &ego).score.is_finite());
            prop_assert!(blob.default_threshold().is_finite());
        };
    }
}

#[derive(Clone, Debug)]
enum Op {
    Update { id: u32, now: u64, r: f32 },
    Expire(u64),
    Remove(u32),
    Query(u64),
}

fn nasty_time() -> impl Strategy<Value = u64> {
    prop_oneof![
        4 => 0u64..5_000_000,
        1 => Just(0u64),
        1 => Just(u64::MAX),
        1 => Just(u64::MAX - 1),
        1 => any::<u64>(),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        6 => (0u32..12, nasty_time(), nasty_f32()).prop_map(|(id, now, r)| Op::Update { id, now, r }),
        1 => nasty_time().prop_map(Op::Expire),
        1 => (0u32..12).prop_map(Op::Remove),
        1 => nasty_time().prop_map(Op::Query),
    ]
}

fn config() -> impl Strategy<Value = WarningConfig> {
    (
        nasty_f32(),
        any::<bool>(),
        prop_oneof![Just(0.0f32), 0.0f32..10.0, Just(f32::MAX)],
        nasty_time(),
        nasty_time(),
        any::<bool>(),
    )
        .prop_map(
            |(threshold, latch, hysteresis, min_on_us, stale_after_us, reject)| WarningConfig {
                threshold,
                latch,
                hysteresis,
                min_on_us,
                stale_after_us,
                when_full: if reject {
                    FullPolicy::Reject
                } else {
                    FullPolicy::EvictLeastRecent
                },
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn track_table_survives_any_sequence(cfg in config(), ops in proptest::collection::vec(op(), 0..60)) {
        let Ok(mut table) = TrackTable::<4>::new(cfg) else {
            prop_assert!(
                !cfg.threshold.is_finite()
                    || cfg.stale_after_us == 0
                    // hysteresis f32::MAX under a threshold near f32::MIN: release level -inf
                    || !(cfg.threshold - cfg.hysteresis).is_finite()
            );
            return Ok(());
        };
        for op in ops {
            match op {
                Op::Update { id, now, r } => {
                    let before = table.clone();
                    match table.update(id, now, r) {
                        Ok(status) => {
                            let t = table.get(id).unwrap();
                            prop_assert_eq!(t.warning, status.warning);
                            prop_assert_eq!(t.last_update_us, now);
                            prop_assert_eq!(t.last_score.to_bits(), r.to_bits());
                            if status.event == WarningEvent::Onset {
                                prop_assert!(r >= cfg.threshold);
                            }
                            if status.event == WarningEvent::Release {
                                prop_assert!(!cfg.latch);
                            }
                            if let Some(v) = status.evicted {
                                prop_assert!(table.get(v).is_none());
                            }
                        }
                        Err(WarningError::NonFiniteScore { .. }) => {
                            prop_assert!(r.is_nan());
                            prop_assert_eq!(table.len(), before.len());
                        }
                        Err(WarningError::OutOfOrder { last_us, now_us, .. }) => {
                            prop_assert!(now_us < last_us);
                        }
                        Err(WarningError::TableFull { .. }) => {
                            prop_assert_eq!(table.len(), table.capacity());
                        }
                        Err(e) => prop_assert!(false, "unexpected {e}"),
                    }
                }
                Op::Expire(now) => {
                    let before = table.len();
                    let dropped = table.expire(now);
                    prop_assert_eq!(before - dropped, table.len());
                }
                Op::Remove(id) => {
                    table.remove(id);
                    prop_assert!(table.get(id).is_none());
                }
                Op::Query(now) => {
                    let n = table.warnings(now).count();
                    prop_assert_eq!(n > 0, table.any_warning(now));
                    for t in table.warnings(now) {
                        prop_assert!(t.warning && table.is_warning(t.id, now));
                        prop_assert!(t.on_since_us().is_some() && t.first_warning_us().is_some());
                    }
                }
            }
            prop_assert!(table.len() <= table.capacity());
        }
    }
}
