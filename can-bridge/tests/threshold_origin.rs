//! `engine_config` names where a non-finite warning threshold came from.
//!
//! Only the `--threshold` case can be tested end to end: a model file never yields a non-finite
//! default threshold. Its calibrated default record is refused at load when not finite (shown
//! below with a hand-patched blob), and the kind's rule is finite for every valid model (DRL 2.0,
//! GSSM a constant, MSRA half the sum of at most 4 weights of at most 1e9 each). The message for
//! the model's default is the same code path with the model file's path in it.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]
mod common;

use can_bridge::commands::{engine_config, ScoringArgs, SetupError};
use can_bridge::ModelFile;
use scorer_core::model::meta::{DefaultThreshold, ModelMeta, ThresholdRule};
use scorer_core::model::{encode_blob, BoundedVec, Model, ModelBlob, HEADER_LEN};
use scorer_core::msra::{MsraModel, MsraTerm};
use scorer_core::SurrogateKind;
use std::path::{Path, PathBuf};

fn args(threshold: Option<f32>) -> ScoringArgs {
    ScoringArgs {
        model: PathBuf::from("m.rsk"),
        dbc: Vec::new(),
        map: None,
        threshold,
        urgent: None,
        hysteresis: 0.0,
        min_on_ms: 500,
        stale_ms: 500,
        latch: false,
        max_problems: 20,
    }
}

#[test]
fn a_non_finite_flag_threshold_is_named_as_the_flag() {
    let model = ModelFile::from_bytes(Path::new("m.rsk"), common::msra_blob()).unwrap();
    for (bad, shown) in [
        (f32::NAN, "NaN"),
        (f32::INFINITY, "inf"),
        (f32::NEG_INFINITY, "-inf"),
    ] {
        let err = engine_config(&args(Some(bad)), &model).unwrap_err();
        assert!(matches!(err, SetupError::Threshold { .. }), "{err:?}");
        assert_eq!(
            err.to_string(),
            format!("--threshold must be finite, not {shown}")
        );
    }
    // The flag wins over the model's default.
    assert_eq!(
        engine_config(&args(Some(1.5)), &model).unwrap().threshold,
        1.5
    );
}

/// An MSRA blob with the given terms' weights and, if any, a calibrated default threshold.
fn msra_blob(weights: &[f32], default: Option<f32>) -> Vec<u8> {
    let terms: Vec<MsraTerm> = weights
        .iter()
        .map(|&weight| MsraTerm {
            kind: SurrogateKind::Ttc2d,
            weight,
            a: -1.5,
            b: 3.0,
            lo: 0.0,
            hi: 10.0,
        })
        .collect();
    let blob = ModelBlob {
        model: Model::Msra(MsraModel {
            terms: BoundedVec::from_slice(&terms).unwrap(),
            gssm: None,
        }),
        meta: ModelMeta {
            default_threshold: default.map(|threshold| DefaultThreshold {
                threshold,
                rule: ThresholdRule::KindDefault,
                data: "",
            }),
            ..ModelMeta::default()
        },
    };
    let mut buf = vec![0u8; 4096];
    let n = encode_blob(&blob, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

#[test]
fn a_model_file_cannot_give_a_non_finite_default_threshold() {
    // The kind's rule at its extreme (4 terms of the largest weight validation accepts): finite.
    let max = scorer_core::mlp::MAX_ABS_PARAM;
    let extreme = ModelFile::from_bytes(Path::new("x.rsk"), msra_blob(&[max; 4], None)).unwrap();
    let config = engine_config(&args(None), &extreme).unwrap();
    assert_eq!(config.threshold, 2.0 * max);

    // A calibrated default patched to NaN after encoding (the encoder refuses it): the CRC is
    // fixed up, so only the record's own check stands in the way, and it refuses the file.
    let mut blob = msra_blob(&[1.0], Some(1234.5));
    let at = blob
        .windows(4)
        .position(|w| w == 1234.5f32.to_le_bytes())
        .expect("the default threshold's bytes");
    blob[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let crc = scorer_core::crc::crc32(&blob[HEADER_LEN..]);
    blob[16..20].copy_from_slice(&crc.to_le_bytes());
    let refused = ModelFile::from_bytes(Path::new("nan.rsk"), blob).unwrap_err();
    assert!(
        refused.to_string().contains("nan.rsk")
            && refused.to_string().contains("default_threshold"),
        "{refused}"
    );
}
