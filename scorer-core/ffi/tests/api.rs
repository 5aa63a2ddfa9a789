//! Rust-side checks of the C ABI contract that the C test (tests/c/ffi_test.c) cannot see easily.
use scorer_ffi::*;

mod common;
use common::{config, context, core_state, EGO, LEAD};

#[path = "../../../tests/firmware/test_models.rs"]
#[allow(dead_code)]
mod test_models;

/// A context initialised with `config()` and the test DRL loaded; the blob outlives it.
fn context_with_drl() -> (Box<RiskscoreContext>, &'static [u8]) {
    let blob: &'static [u8] = Box::leak(test_models::drl_int8().into_boxed_slice());
    let mut ctx = context();
    let raw: *mut RiskscoreContext = &mut *ctx;
    unsafe {
        assert_eq!(
            riskscore_init(raw, RISKSCORE_CONTEXT_SIZE, &config()),
            RiskscoreStatus::Ok
        );
        assert_eq!(
            riskscore_load_model(raw, blob.as_ptr(), blob.len(), std::ptr::null_mut()),
            RiskscoreStatus::Ok
        );
    }
    (ctx, blob)
}

#[test]
fn every_status_code_round_trips_and_is_described() {
    let unknown = unsafe { std::ffi::CStr::from_ptr(riskscore_status_str(-1)) };
    let mut seen = std::collections::HashSet::new();
    for code in 0..=22 {
        let status = RiskscoreStatus::from_code(code).expect("codes 0..=22 are all defined");
        assert_eq!(status as i32, code);
        let text = unsafe { std::ffi::CStr::from_ptr(riskscore_status_str(code)) };
        assert_ne!(text, unknown, "code {code} has no description");
        assert!(
            seen.insert(text.to_owned()),
            "code {code} shares its description"
        );
    }
    assert_eq!(RiskscoreStatus::from_code(23), None);
}

/// Configurations that would silently disable the warnings are refused by `riskscore_init` with
/// `RISKSCORE_STATUS_INVALID_CONFIG`, like the NaN threshold, and leave the context uninitialised:
/// `stale_after_us == 0` (every track is stale as soon as the clock moves on: no warning
/// persists, no partner is followed) and an infinite threshold (`+inf`: no finite score ever
/// warns; `-inf`: every partner warns). The smallest window, 1 us, and "never"
/// (`RISKSCORE_NONE_U64`) are accepted.
#[test]
fn configs_that_disable_the_warnings_are_refused() {
    let refused = [
        (
            "stale_after_us = 0",
            RiskscoreWarningConfig {
                stale_after_us: 0,
                ..config()
            },
        ),
        (
            "latched, stale_after_us = 0",
            RiskscoreWarningConfig {
                stale_after_us: 0,
                latch: 1,
                ..config()
            },
        ),
        (
            "threshold = +inf",
            RiskscoreWarningConfig {
                threshold: f32::INFINITY,
                ..config()
            },
        ),
        (
            "threshold = -inf",
            RiskscoreWarningConfig {
                threshold: f32::NEG_INFINITY,
                ..config()
            },
        ),
        // Refused before this check too: the same status.
        (
            "threshold = NaN",
            RiskscoreWarningConfig {
                threshold: f32::NAN,
                ..config()
            },
        ),
        (
            "hysteresis = -0.1",
            RiskscoreWarningConfig {
                hysteresis: -0.1,
                ..config()
            },
        ),
        (
            "hysteresis = inf",
            RiskscoreWarningConfig {
                hysteresis: f32::INFINITY,
                ..config()
            },
        ),
        (
            "latch = 2",
            RiskscoreWarningConfig {
                latch: 2,
                ..config()
            },
        ),
        (
            "evict_when_full = 2",
            RiskscoreWarningConfig {
                evict_when_full: 2,
                ..config()
            },
        ),
    ];
    for (what, cfg) in refused {
        let mut ctx = context();
        let raw: *mut RiskscoreContext = &mut *ctx;
        let mut warnings = 7u32;
        let mut tracks = 7u32;
        unsafe {
            assert_eq!(
                riskscore_init(raw, RISKSCORE_CONTEXT_SIZE, &cfg),
                RiskscoreStatus::InvalidConfig,
                "{what}"
            );
            // Nothing was written: the context is still not initialised.
            assert_eq!(
                riskscore_any_warning(raw, 0, &mut warnings, &mut tracks),
                RiskscoreStatus::ContextNotInitialized,
                "{what}"
            );
        }
        assert_eq!((warnings, tracks), (7, 7), "{what}: outputs written");
    }

    // The smallest window and "never stale" are valid: a warning then persists between updates.
    for stale_after_us in [1, 100_000, RISKSCORE_NONE_U64] {
        let cfg = RiskscoreWarningConfig {
            stale_after_us,
            ..config()
        };
        let mut ctx = context();
        let raw: *mut RiskscoreContext = &mut *ctx;
        let (mut warnings, mut tracks) = (0u32, 0u32);
        unsafe {
            assert_eq!(
                riskscore_init(raw, RISKSCORE_CONTEXT_SIZE, &cfg),
                RiskscoreStatus::Ok,
                "stale_after_us = {stale_after_us}"
            );
            assert_eq!(
                riskscore_track_update(raw, 1, 1_000, 0.9, std::ptr::null_mut()),
                RiskscoreStatus::Ok
            );
            assert_eq!(
                riskscore_any_warning(raw, 1_001, &mut warnings, &mut tracks),
                RiskscoreStatus::Ok
            );
        }
        assert_eq!(
            (warnings, tracks),
            (1, 1),
            "stale_after_us = {stale_after_us}"
        );
    }
}

#[test]
fn states_without_heading_or_with_a_negative_size_and_the_reserved_id_are_refused() {
    let (mut ctx, blob) = context_with_drl();
    let ctx: *mut RiskscoreContext = &mut *ctx;
    let mut r = std::mem::MaybeUninit::<RiskscorePairResult>::uninit();
    let mut info = std::mem::MaybeUninit::<RiskscoreLoadInfo>::uninit();
    unsafe {
        let bad = [
            RiskscoreVehicleState { hy: 0.0, ..LEAD },
            RiskscoreVehicleState {
                length: -0.5,
                ..LEAD
            },
            RiskscoreVehicleState {
                width: -1.0,
                ..LEAD
            },
        ];
        for s in &bad {
            assert_eq!(
                riskscore_score_pair(ctx, &EGO, s, r.as_mut_ptr()),
                RiskscoreStatus::InvalidInput
            );
            assert_eq!(
                riskscore_score_pair(ctx, s, &EGO, r.as_mut_ptr()),
                RiskscoreStatus::InvalidInput
            );
        }
        // A size of 0 is a point, as `riskctl ssm` scores it: scored.
        let point = RiskscoreVehicleState {
            length: 0.0,
            width: 0.0,
            ..LEAD
        };
        assert_eq!(
            riskscore_score_pair(ctx, &EGO, &point, r.as_mut_ptr()),
            RiskscoreStatus::Ok
        );
        assert_eq!(
            riskscore_track_update(ctx, RISKSCORE_NONE_U32, 1, 0.1, std::ptr::null_mut()),
            RiskscoreStatus::InvalidInput
        );
        // Header errors after the kind byte still report the kind.
        let mut reserved = blob.to_vec();
        reserved[7] = 1;
        assert_eq!(
            riskscore_load_model(ctx, reserved.as_ptr(), reserved.len(), info.as_mut_ptr()),
            RiskscoreStatus::ModelReservedNotZero
        );
        assert_eq!(info.assume_init().kind, RiskscoreModelKind::DrlInt8);
        let mut schema = blob.to_vec();
        schema[8] = 200;
        assert_eq!(
            riskscore_load_model(ctx, schema.as_ptr(), schema.len(), info.as_mut_ptr()),
            RiskscoreStatus::ModelUnsupportedFeatureSchema
        );
        assert_eq!(info.assume_init().kind, RiskscoreModelKind::DrlInt8);
    }
}

#[test]
fn failed_load_keeps_the_previous_model_and_scores_match_the_core() {
    let (mut ctx, blob) = context_with_drl();
    let ctx: *mut RiskscoreContext = &mut *ctx;
    let mut r = std::mem::MaybeUninit::<RiskscorePairResult>::uninit();
    unsafe {
        assert_eq!(
            riskscore_score_pair(ctx, &EGO, &LEAD, r.as_mut_ptr()),
            RiskscoreStatus::Ok
        );
    }
    let before = unsafe { r.assume_init() };

    let mut corrupt = blob.to_vec();
    let last = corrupt.len() - 1;
    corrupt[last] ^= 1;
    let mut info = std::mem::MaybeUninit::<RiskscoreLoadInfo>::uninit();
    unsafe {
        assert_eq!(
            riskscore_load_model(ctx, corrupt.as_ptr(), corrupt.len(), info.as_mut_ptr()),
            RiskscoreStatus::ModelCrcMismatch
        );
        assert_eq!(info.assume_init().kind, RiskscoreModelKind::DrlInt8);
        assert_eq!(
            riskscore_score_pair(ctx, &EGO, &LEAD, r.as_mut_ptr()),
            RiskscoreStatus::Ok
        );
    }
    let after = unsafe { r.assume_init() };
    assert_eq!(before.drl_score.to_bits(), after.drl_score.to_bits());

    // Same numbers as the core called directly.
    let model = scorer_core::model::decode(blob).expect("decode");
    let (ego, lead) = (core_state(&EGO), core_state(&LEAD));
    assert_eq!(
        after.drl_score.to_bits(),
        model.score(&ego, &lead).to_bits()
    );
    assert_eq!(after.features, scorer_core::features(&ego, &lead));
}

#[test]
fn truncated_blob_reports_needed_and_available_bytes() {
    // Three bytes: not even a header, so the kind is unknown too.
    let blob = test_models::drl_int8();
    let (status, info) = load_into_fresh_context(&blob[..3]);
    assert_eq!(status, RiskscoreStatus::ModelTruncated);
    assert_eq!((info.expected, info.found), (20, 3));
    assert_eq!(info.kind, RiskscoreModelKind::None);
}

/// Loads `blob` into a freshly initialised context: the status and the load details.
fn load_into_fresh_context(blob: &[u8]) -> (RiskscoreStatus, RiskscoreLoadInfo) {
    let mut ctx = context();
    let ctx: *mut RiskscoreContext = &mut *ctx;
    let mut info = std::mem::MaybeUninit::<RiskscoreLoadInfo>::uninit();
    // SAFETY: a fresh context, a live blob, a writable info (written on every status).
    unsafe {
        assert_eq!(
            riskscore_init(ctx, RISKSCORE_CONTEXT_SIZE, &config()),
            RiskscoreStatus::Ok
        );
        let status = riskscore_load_model(ctx, blob.as_ptr(), blob.len(), info.as_mut_ptr());
        (status, info.assume_init())
    }
}

#[test]
fn default_threshold_is_the_blobs_own_or_the_kinds_rule() {
    use scorer_core::model::{self, DefaultThreshold, ModelBlob, ModelMeta, ThresholdRule};
    let plain = test_models::drl_int8();
    let mut t = f32::NAN;
    // SAFETY: valid pointers and lengths.
    let status = unsafe { riskscore_model_default_threshold(plain.as_ptr(), plain.len(), &mut t) };
    assert_eq!(status, RiskscoreStatus::Ok);
    assert_eq!(t, 2.0);
    let calibrated = ModelBlob {
        model: model::decode(&plain).unwrap(),
        meta: ModelMeta {
            training_domain: None,
            kinematic_fallback: None,
            blend: None,
            default_threshold: Some(DefaultThreshold {
                threshold: 2.75,
                rule: ThresholdRule::KindDefault,
                data: "",
            }),
        },
    };
    let mut blob = vec![0u8; model::encoded_blob_len(&calibrated).unwrap()];
    model::encode_blob(&calibrated, &mut blob).unwrap();
    // SAFETY: as above.
    let status = unsafe { riskscore_model_default_threshold(blob.as_ptr(), blob.len(), &mut t) };
    assert_eq!(status, RiskscoreStatus::Ok);
    assert_eq!(t, 2.75);
    // A corrupt blob leaves the output alone.
    blob[30] ^= 1;
    // SAFETY: as above.
    let status = unsafe { riskscore_model_default_threshold(blob.as_ptr(), blob.len(), &mut t) };
    assert_eq!(status, RiskscoreStatus::ModelCrcMismatch);
    assert_eq!(t, 2.75);
}

/// A version-2 DRL-f32 blob around `payload` (the header of docs/model-format.md's examples).
fn v2_blob(payload: &[u8]) -> Vec<u8> {
    let mut blob = b"RSKM\x02\x00\x02\x00\x03\x00\x00\x00".to_vec();
    blob.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    blob.extend_from_slice(&scorer_core::crc::crc32(payload).to_le_bytes());
    blob.extend_from_slice(payload);
    blob
}

#[test]
fn every_record_error_names_its_field() {
    // docs/model-format.md's worked example, then its training-domain record (policy `p`, input 3
    // in [0, 40] and `second` in [-0.75, 5]) and, under policy 2, its kinematic fallback over one
    // term of surrogate kind `kind`.
    let payload = |p: u8, second: u8, kind: Option<u8>| {
        let mut v = vec![
            0x01, 0x08, 0x01, 0xcd, 0xcc, 0xcc, 0x3d, 0x01, 0x00, 0x00, 0x80, 0xbf, 0x01, 0x01,
            0x00, 0x04, 0x00, 0x00, 0x80, 0xbf, 0x04, 0x00, 0x00, 0x00, 0x3f,
        ];
        v.extend_from_slice(&[
            0x02, 0x14, p, 0x12, 0x03, 0, 0, 0, 0, 0, 0, 0x20, 0x42, second,
        ]);
        v.extend_from_slice(&[0x00, 0x00, 0x40, 0xbf, 0x00, 0x00, 0xa0, 0x40]);
        if let Some(kind) = kind {
            v.extend_from_slice(&[0x03, 0x1e, 0, 0, 0, 0x40, 0, 0, 0, 0xbf, 0x15, kind]);
            v.extend_from_slice(&[0, 0, 0x80, 0x3f, 0, 0, 0x80, 0xbf, 0, 0, 0, 0x40]);
            v.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0x20, 0x41]);
        }
        v2_blob(&v)
    };
    let load = |blob: &[u8]| {
        let (status, info) = load_into_fresh_context(blob);
        // SAFETY: the field is NUL-terminated (the C ABI leaves its last byte 0).
        let field = unsafe { std::ffi::CStr::from_ptr(info.field.as_ptr()) };
        (
            status,
            field.to_str().unwrap().to_owned(),
            info.index,
            info.found,
        )
    };
    // A record declaring 22 body bytes where 20 are left: truncated, counted in the record.
    let mut overrun = payload(1, 8, None);
    let at = overrun.len() - 21;
    assert_eq!(overrun[at], 0x14, "tag 2's length byte");
    overrun[at] = 0x16;
    let overrun = v2_blob(&overrun[20..]);
    let (status, info) = load_into_fresh_context(&overrun);
    assert_eq!(status, RiskscoreStatus::ModelTruncated);
    assert_eq!((info.expected, info.found), (22, 20));
    // The blobs as documented load.
    assert_eq!(load(&payload(1, 8, None)).0, RiskscoreStatus::Ok);
    assert_eq!(load(&payload(2, 8, Some(1))).0, RiskscoreStatus::Ok);
    let invalid = RiskscoreStatus::ModelInvalid;
    let none = RISKSCORE_NONE_U32;
    // An outside policy this build does not know (a newer exporter's).
    assert_eq!(
        load(&payload(9, 8, None)),
        (invalid, "training_domain.policy".into(), none, 9)
    );
    // Range 1 names input 3 again.
    assert_eq!(
        load(&payload(1, 3, None)),
        (invalid, "training_domain.ranges".into(), 1, 3)
    );
    // A fallback term over GSSM (kind 3), which is refused.
    assert_eq!(
        load(&payload(2, 8, Some(3))),
        (invalid, "kinematic_fallback.terms".into(), 0, none)
    );
}

/// A `len` no buffer can have (above `PTRDIFF_MAX`, e.g. a failed read's `-1` cast to `size_t`)
/// is refused before the blob is touched, as more bytes than a blob has: it reported
/// `RISKSCORE_STATUS_MODEL_TRUNCATED` ("model blob truncated"), the opposite of what was wrong,
/// while any other too-long `len` gives `RISKSCORE_STATUS_MODEL_TRAILING_BYTES`. Nothing is
/// known about the extra bytes, so `found` is `RISKSCORE_NONE_U32`; the context is unchanged.
#[test]
fn impossible_blob_length_is_trailing_bytes_not_truncated() {
    let blob = test_models::drl_int8();
    // The length one past the real blob: trailing bytes, counted.
    let mut longer = blob.clone();
    longer.push(0);
    let (status, info) = load_into_fresh_context(&longer);
    assert_eq!(
        (status, info.found),
        (RiskscoreStatus::ModelTrailingBytes, 1)
    );
    let (mut ctx, loaded) = context_with_drl();
    let ctx: *mut RiskscoreContext = &mut *ctx;
    for len in [isize::MAX as usize + 1, usize::MAX] {
        let mut info = std::mem::MaybeUninit::<RiskscoreLoadInfo>::uninit();
        let mut t = 7.0f32;
        // SAFETY: the library refuses such a length before reading any byte of the blob.
        unsafe {
            assert_eq!(
                riskscore_load_model(ctx, loaded.as_ptr(), len, info.as_mut_ptr()),
                RiskscoreStatus::ModelTrailingBytes,
                "len {len}"
            );
            let info = info.assume_init();
            assert_eq!(
                (info.kind, info.expected, info.found),
                (
                    RiskscoreModelKind::None,
                    RISKSCORE_NONE_U32,
                    RISKSCORE_NONE_U32
                )
            );
            assert_eq!(
                riskscore_model_default_threshold(loaded.as_ptr(), len, &mut t),
                RiskscoreStatus::ModelTrailingBytes
            );
        }
        assert_eq!(t, 7.0, "threshold written on error");
    }
    // The DRL loaded before is still there.
    let mut r = std::mem::MaybeUninit::<RiskscorePairResult>::uninit();
    // SAFETY: an initialised context and valid states and output.
    unsafe {
        assert_eq!(
            riskscore_score_pair(ctx, &EGO, &LEAD, r.as_mut_ptr()),
            RiskscoreStatus::Ok
        );
        assert_eq!(r.assume_init().has_drl, 1);
    }
}

/// A version-2 record may declare a body longer than the whole blob (its length is any `u32`
/// varint): `RISKSCORE_STATUS_MODEL_TRUNCATED` with `expected` the declared body length, which
/// is then larger than the blob, and `found` the payload bytes left after the length varint.
#[test]
fn record_longer_than_the_blob_is_truncated_with_its_declared_length() {
    // The worked example of docs/model-format.md (DRL-f32, 25 payload bytes), then an unknown
    // record (tag 99) declaring 1000 body bytes (varint e8 07) with none left.
    let mut payload = vec![
        0x01, 0x08, 0x01, 0xcd, 0xcc, 0xcc, 0x3d, 0x01, 0x00, 0x00, 0x80, 0xbf, 0x01, 0x01, 0x00,
        0x04, 0x00, 0x00, 0x80, 0xbf, 0x04, 0x00, 0x00, 0x00, 0x3f,
    ];
    payload.extend_from_slice(&[99, 0xe8, 0x07]);
    let blob = v2_blob(&payload);
    let (status, info) = load_into_fresh_context(&blob);
    assert_eq!(status, RiskscoreStatus::ModelTruncated);
    assert_eq!(info.kind, RiskscoreModelKind::DrlF32);
    assert_eq!((info.expected, info.found), (1000, 0));
    assert!(info.expected as usize > blob.len());
}

/// A warning can end without a `RISKSCORE_WARNING_EVENT_RELEASE`: when its track goes stale
/// (reads as not warning, then dropped by the next update) or is restarted after a reset time
/// base, and in latched mode too. An integration that switched its warning output off only on
/// RELEASE kept it on; the header says to follow `warning` / `riskscore_any_warning` instead.
/// A stale track read with `riskscore_track_get` keeps the `on_since_us` of its warning while its
/// `warning` reads 0, as the header says.
#[test]
fn a_warning_ends_without_release_when_its_track_is_dropped_or_restarted() {
    for latch in [0, 1] {
        let mut ctx = context();
        let ctx: *mut RiskscoreContext = &mut *ctx;
        let cfg = RiskscoreWarningConfig { latch, ..config() };
        let mut ts = std::mem::MaybeUninit::<RiskscoreTrackStatus>::uninit();
        let mut tr = std::mem::MaybeUninit::<RiskscoreTrack>::uninit();
        let (mut warnings, mut held) = (9u32, 9u32);
        // SAFETY: a fresh context and writable outputs.
        unsafe {
            assert_eq!(
                riskscore_init(ctx, RISKSCORE_CONTEXT_SIZE, &cfg),
                RiskscoreStatus::Ok
            );
            // Partner 1 warns at t = 0 and is not seen again for 1.5 s (stale after 1 s).
            assert_eq!(
                riskscore_track_update(ctx, 1, 0, 0.9, ts.as_mut_ptr()),
                RiskscoreStatus::Ok
            );
            let onset = ts.assume_init();
            assert_eq!(
                (onset.warning, onset.event),
                (1, RiskscoreWarningEvent::Onset)
            );
            assert_eq!(
                riskscore_track_get(ctx, 1, 1_500_000, tr.as_mut_ptr()),
                RiskscoreStatus::Ok
            );
            let stale = tr.assume_init();
            assert_eq!((stale.stale, stale.warning, stale.on_since_us), (1, 0, 0));
            assert_eq!(
                riskscore_any_warning(ctx, 1_500_000, &mut warnings, &mut held),
                RiskscoreStatus::Ok
            );
            assert_eq!((warnings, held), (0, 1));
            // Another partner's update drops it: no event for partner 1 at all.
            assert_eq!(
                riskscore_track_update(ctx, 2, 1_500_000, 0.1, std::ptr::null_mut()),
                RiskscoreStatus::Ok
            );
            assert_eq!(
                riskscore_track_get(ctx, 1, 1_500_000, tr.as_mut_ptr()),
                RiskscoreStatus::UnknownTrack
            );
            // Partner 1 seen again, harmless: a new track, warning off, event NONE (not RELEASE).
            assert_eq!(
                riskscore_track_update(ctx, 1, 1_600_000, 0.1, ts.as_mut_ptr()),
                RiskscoreStatus::Ok
            );
            let back = ts.assume_init();
            assert_eq!(
                (back.warning, back.event, back.new_track),
                (0, RiskscoreWarningEvent::None, 1)
            );
            // A reset time base: partner 2 warns at 5 000 s, then the clock restarts at 1 ms.
            assert_eq!(
                riskscore_track_update(ctx, 2, 5_000_000_000, 0.9, std::ptr::null_mut()),
                RiskscoreStatus::Ok
            );
            assert_eq!(
                riskscore_track_update(ctx, 2, 1_000, 0.1, ts.as_mut_ptr()),
                RiskscoreStatus::Ok
            );
            let restarted = ts.assume_init();
            assert_eq!(
                (restarted.warning, restarted.event, restarted.new_track),
                (0, RiskscoreWarningEvent::None, 1)
            );
        }
    }
}

/// TTC2D is +INFINITY ("no conflict") for boxes that already overlap whenever neither of its
/// branches sees a positive gap, as in the reference implementation: the header says so, so an
/// integration does not read an infinite `ttc2d` as "no risk". Here a partner overlapping the
/// ego's front half, closing.
#[test]
fn overlapping_boxes_can_have_an_infinite_ttc2d() {
    let (mut ctx, _blob) = context_with_drl();
    let ctx: *mut RiskscoreContext = &mut *ctx;
    let overlapping = RiskscoreVehicleState {
        y: 2.0,
        vy: 10.0,
        ..EGO
    };
    let mut r = std::mem::MaybeUninit::<RiskscorePairResult>::uninit();
    // SAFETY: an initialised context, valid states and output.
    let r = unsafe {
        assert_eq!(
            riskscore_score_pair(ctx, &EGO, &overlapping, r.as_mut_ptr()),
            RiskscoreStatus::Ok
        );
        r.assume_init()
    };
    assert_eq!(r.box_distance, 0.0);
    assert_eq!(r.ttc2d, f32::INFINITY);
}
