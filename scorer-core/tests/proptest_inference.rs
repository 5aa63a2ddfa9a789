//! Inference robustness and parity:
//! - the int8 network, quantised in the test with the core's own `quant` functions, tracks the f32
//!   network it came from;
//! - NaN, +-inf, huge, tiny and zero inputs into the MLPs, MSRA, GSSM and whole models give finite
//!   results (or the documented bound);
//! - arbitrary bytes and mutated blobs into `decode` never panic.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

mod common_hostile;
mod common_models;

use common_hostile::{nasty_f32_weighted, nasty_state_of};
use common_models::*;
use proptest::prelude::*;
use scorer_core::gssm::{self, GssmModel, GssmScore};
use scorer_core::model::{self, BoundedVec, Model, ModelKind};
use scorer_core::msra::{self, MsraModel, MsraTerm};
use scorer_core::{Features, SurrogateKind, Surrogates, VehicleState, FEATURE_COUNT};

fn nasty_f32() -> impl Strategy<Value = f32> {
    nasty_f32_weighted(3)
}

fn nasty_features() -> impl Strategy<Value = Features> {
    proptest::array::uniform13(nasty_f32())
}

fn nasty_surrogates() -> impl Strategy<Value = Surrogates> {
    (
        nasty_f32(),
        nasty_f32(),
        nasty_f32(),
        nasty_f32(),
        nasty_f32(),
    )
        .prop_map(|(a, b, c, d, e)| Surrogates {
            box_distance: a,
            ttc2d: b,
            tadv: c,
            tadv_corridor: e,
            ei: d,
        })
}

fn nasty_state() -> impl Strategy<Value = VehicleState> {
    nasty_state_of(nasty_f32())
}

struct Nets {
    drl: FloatNet,
    drl_q: QuantNet,
    gssm: FloatNet,
}

fn nets() -> &'static Nets {
    use std::sync::OnceLock;
    static NETS: OnceLock<Nets> = OnceLock::new();
    NETS.get_or_init(|| {
        let drl = FloatNet::random(3, &ALL_FEATURES, &[32, 16], 1);
        let mut rng = Rng(17);
        let calib: Vec<Features> = (0..1000).map(|_| random_features(&mut rng)).collect();
        let drl_q = QuantNet::quantize(&drl, &calib);
        let gssm = FloatNet::random(4, &CONTEXT_FEATURES, &[16, 16], 2);
        Nets { drl, drl_q, gssm }
    })
}

fn msra_terms() -> [MsraTerm; 3] {
    [
        MsraTerm {
            kind: SurrogateKind::Tadv,
            weight: 0.6,
            a: -1.2,
            b: 2.0,
            lo: 0.0,
            hi: 10.0,
        },
        MsraTerm {
            kind: SurrogateKind::Ei,
            weight: -0.3,
            a: 0.9,
            b: -0.4,
            lo: -5.0,
            hi: 5.0,
        },
        MsraTerm {
            kind: SurrogateKind::Gssm,
            weight: 0.4,
            a: 1.5,
            b: -3.0,
            lo: 0.0,
            hi: 6.0,
        },
    ]
}

/// Int8 vs f32 on a random network: the error must be a small fraction of the output spread, and
/// the int8 network must rank pairs of observations like the f32 one almost always.
#[test]
fn int8_tracks_float_network() {
    for (seed, hidden) in [
        (3u64, vec![32usize, 16]),
        (8, vec![64, 64, 64]),
        (9, vec![8]),
    ] {
        let float = FloatNet::random(seed, &ALL_FEATURES, &hidden, 1);
        let mut rng = Rng(seed + 100);
        let calib: Vec<Features> = (0..2000).map(|_| random_features(&mut rng)).collect();
        let q = QuantNet::quantize(&float, &calib);
        let (fm, qm) = (float.mlp(), q.mlp());
        fm.validate().unwrap();
        qm.validate().unwrap();
        let mut ys = Vec::new();
        let mut max_err = 0.0f32;
        let mut sum_err = 0.0f32;
        for _ in 0..2000 {
            let x = random_features(&mut rng);
            let (yf, yq) = (fm.forward(&x)[0], qm.forward(&x)[0]);
            // The reference f64 forward agrees with the core's f32 path.
            let y64 = *float.activations(&x).last().unwrap().first().unwrap();
            assert!(
                (f64::from(yf) - y64).abs() <= 1e-4 * (1.0 + y64.abs()),
                "{yf} vs {y64}"
            );
            max_err = max_err.max((yf - yq).abs());
            sum_err += (yf - yq).abs();
            ys.push((yf, yq));
        }
        let lo = ys.iter().map(|p| p.0).fold(f32::INFINITY, f32::min);
        let hi = ys.iter().map(|p| p.0).fold(f32::NEG_INFINITY, f32::max);
        let spread = hi - lo;
        let mean_err = sum_err / ys.len() as f32;
        let mut concordant = 0;
        let mut pairs = 0;
        for w in ys.windows(2) {
            let (a, b) = (w[0], w[1]);
            if (a.0 - b.0).abs() > 0.05 * spread {
                pairs += 1;
                if (a.0 > b.0) == (a.1 > b.1) {
                    concordant += 1;
                }
            }
        }
        println!(
            "hidden {hidden:?}: spread {spread:.3}, mean |err| {mean_err:.4}, max |err| {max_err:.4}, rank agreement {concordant}/{pairs}"
        );
        assert!(
            mean_err <= 0.005 * spread,
            "mean error {mean_err} vs spread {spread}"
        );
        assert!(
            max_err <= 0.025 * spread,
            "max error {max_err} vs spread {spread}"
        );
        assert!(concordant as f32 >= 0.98 * pairs as f32);
    }
}

#[test]
fn int8_arithmetic_matches_an_independent_integer_reference() {
    // Recompute the int8 forward pass with i64 arithmetic and the documented formulas.
    let n = nets();
    let q = &n.drl_q;
    let qm = q.mlp();
    let mut rng = Rng(77);
    for _ in 0..500 {
        let x = random_features(&mut rng);
        let mut act: Vec<i64> = (0..q.inputs.len())
            .map(|k| {
                let v = x[q.inputs[k] as usize] * q.input_mul[k] + q.input_add[k];
                i64::from(libm::roundf(v).clamp(-128.0, 127.0) as i8)
            })
            .collect();
        let mut zp = i64::from(q.input_zero_point);
        let mut y = 0.0f32;
        for (l, &(out, relu, zp_out)) in q.meta.iter().enumerate() {
            let in_dim = act.len();
            let mut next = Vec::new();
            for j in 0..out {
                let mut acc = i64::from(i32::from_le_bytes(
                    q.b[l][4 * j..4 * j + 4].try_into().unwrap(),
                ));
                for (i, a) in act.iter().enumerate() {
                    acc += i64::from(q.w[l][j * in_dim + i] as i8) * (a - zp);
                }
                if l + 1 == q.meta.len() {
                    y = acc as f32 * q.output_scales[j];
                } else {
                    let m = i64::from(i32::from_le_bytes(
                        q.m[l][4 * j..4 * j + 4].try_into().unwrap(),
                    ));
                    let total = 31 + i64::from(q.s[l][j] as i8);
                    let p = i128::from(acc) * i128::from(m);
                    let d = 1i128 << total;
                    let r = (2 * p.abs() + d) / (2 * d) * p.signum();
                    let mut v = (r as i64 + i64::from(zp_out)).clamp(-128, 127);
                    if relu {
                        v = v.max(i64::from(zp_out));
                    }
                    next.push(v);
                }
            }
            act = next;
            zp = i64::from(zp_out);
        }
        assert_eq!(qm.forward(&x)[0].to_bits(), y.to_bits());
    }
}

#[test]
fn feature_selection_ignores_unselected_features() {
    let n = nets();
    let g = n.gssm.mlp();
    let mut rng = Rng(5);
    let mut x = random_features(&mut rng);
    let before = g.forward(&x);
    x[12] = f32::NAN; // s is not a GSSM context input
    assert_eq!(g.forward(&x), before);
    x[0] += 1.0;
    assert_ne!(g.forward(&x), before);
}

proptest! {
    // Failures print their minimal input; no regression files are written next to the tests.
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mlps_are_finite_for_any_features(x in nasty_features()) {
        let n = nets();
        for y in n.drl.mlp().forward(&x) {
            prop_assert!(y.is_finite());
        }
        for y in n.drl_q.mlp().forward(&x) {
            prop_assert!(y.is_finite());
        }
        for y in n.gssm.mlp().forward(&x) {
            prop_assert!(y.is_finite());
        }
    }

    #[test]
    fn gssm_outputs_are_bounded(x in nasty_features()) {
        let n = nets();
        for score in [GssmScore::Intensity, GssmScore::Cdf, GssmScore::Logit] {
            let g = GssmModel { net: n.gssm.mlp(), score };
            let f = g.survival(&x);
            prop_assert!((0.0..=1.0).contains(&f));
            let r = g.score(&x);
            prop_assert!(r.is_finite());
            match score {
                GssmScore::Intensity => prop_assert!((0.0..=5.85).contains(&r)),
                GssmScore::Cdf => prop_assert_eq!(r, f),
                GssmScore::Logit => prop_assert!(r.abs() <= 13.82),
            }
        }
    }

    #[test]
    fn gssm_formulas_are_total(s in nasty_f32(), mu in nasty_f32(), lv in nasty_f32()) {
        let f = gssm::survival(s, mu, lv);
        prop_assert!((0.0..=1.0).contains(&f), "{}", f);
        prop_assert!(gssm::intensity(f).is_finite());
        prop_assert!(gssm::logit(f).is_finite());
        if s <= 0.0 { prop_assert_eq!(f, 1.0); }
        if s.is_nan() || s == f32::INFINITY { prop_assert_eq!(f, 0.0); }
    }

    #[test]
    fn msra_is_finite_and_bounded(x in nasty_features(), s in nasty_surrogates()) {
        let n = nets();
        let terms = msra_terms();
        let m = MsraModel {
            terms: BoundedVec::from_slice(&terms).unwrap(),
            gssm: Some(GssmModel { net: n.gssm.mlp(), score: GssmScore::Intensity }),
        };
        m.validate().unwrap();
        let r = m.score(&x, &s);
        let bound: f32 = terms.iter().map(|t| t.weight.abs()).sum();
        prop_assert!(r.is_finite() && r.abs() <= bound + 1e-6, "{}", r);
    }

    #[test]
    fn transform_stays_in_range(raw in nasty_f32(), lo in -1.0e6f32..1.0e6, width in 1.0e-3f32..1.0e6) {
        let hi = lo + width;
        for kind in [SurrogateKind::Ttc2d, SurrogateKind::Tadv, SurrogateKind::Ei, SurrogateKind::Gssm] {
            let g = msra::transform(kind, raw, lo, hi);
            prop_assert!(g >= lo && g <= hi);
        }
    }

    #[test]
    fn models_score_finite_for_any_pair(ego in nasty_state(), partner in nasty_state()) {
        let n = nets();
        let terms = msra_terms();
        let models = [
            Model::DrlF32(n.drl.mlp()),
            Model::DrlInt8(n.drl_q.mlp()),
            Model::Gssm(GssmModel { net: n.gssm.mlp(), score: GssmScore::Logit }),
            Model::Msra(MsraModel {
                terms: BoundedVec::from_slice(&terms).unwrap(),
                gssm: Some(GssmModel { net: n.gssm.mlp(), score: GssmScore::Intensity }),
            }),
        ];
        for m in &models {
            let r = m.score(&ego, &partner);
            prop_assert!(r.is_finite(), "{:?}: {}", m.kind(), r);
        }
    }

    #[test]
    fn decode_never_panics_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = model::decode(&bytes);
        let _ = model::decode_header(&bytes);
        // Also behind a valid header, so the payload decoder and validation see the bytes.
        for kind in 1..=4u8 {
            let blob = wrap(kind, &bytes);
            if let Ok(m) = model::decode(&blob) {
                let x: Features = [1.0; FEATURE_COUNT];
                let sur = scorer_core::Surrogates { box_distance: 1.0, ttc2d: 1.0, tadv: 1.0, tadv_corridor: 1.0, ei: 1.0 };
                let o = scorer_core::Observation { features: x, surrogates: sur, drl_inputs: x };
                prop_assert!(m.score_observation(&o).is_finite());
            };
        }
    }

    #[test]
    fn decode_never_panics_on_mutated_payloads(
        which in 0usize..4,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in any::<prop::sample::Index>(),
    ) {
        let n = nets();
        let terms = msra_terms();
        let m = match which {
            0 => Model::DrlF32(n.drl.mlp()),
            1 => Model::DrlInt8(n.drl_q.mlp()),
            2 => Model::Gssm(GssmModel { net: n.gssm.mlp(), score: GssmScore::Cdf }),
            _ => Model::Msra(MsraModel {
                terms: BoundedVec::from_slice(&terms).unwrap(),
                gssm: Some(GssmModel { net: n.gssm.mlp(), score: GssmScore::Intensity }),
            }),
        };
        let mut buf = vec![0u8; model::encoded_len(&m).unwrap()];
        model::encode(&m, &mut buf).unwrap();
        let mut payload = buf[model::HEADER_LEN..].to_vec();
        for (i, v) in edits {
            let i = i.index(payload.len());
            payload[i] = v;
        }
        let keep = cut.index(payload.len() + 1);
        payload.truncate(keep.max(payload.len() / 2));
        let kind = m.kind() as u8;
        if let Ok(back) = model::decode(&wrap(kind, &payload)) {
            prop_assert_eq!(back.kind() as u8, kind);
            let x: Features = [f32::NAN; FEATURE_COUNT];
            let s = Surrogates { box_distance: 1.0, ttc2d: 2.0, tadv: f32::INFINITY, tadv_corridor: f32::INFINITY, ei: f32::NEG_INFINITY };
            let o = scorer_core::Observation { features: x, surrogates: s, drl_inputs: x };
            prop_assert!(back.score_observation(&o).is_finite());
        }
        let _ = ModelKind::from_u8(kind);
    }
}
