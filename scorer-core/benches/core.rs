//! Per-observation cost of the core on the host: features, each surrogate, all of them at once (what
//! `riskctl ssm` computes per pair), the int8 and f32 DRL networks, MSRA, each pipeline unguarded
//! (`Model::score`) and as deployed (`ModelBlob::score_pair_guarded`), and a warning-table update.
//! Inputs are the golden configurations (a realistic mix of conflicts and non-conflicts). Models:
//! the shipped `models/*.rsk` when present, else a synthetic 13-32-16-1 network with the same
//! structure (printed at start).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use scorer_core::model::{decode, decode_blob, encode, Model};
use scorer_core::msra::{MsraModel, MsraTerm};
use scorer_core::warning::{TrackTable, WarningConfig};
use scorer_core::{ei, features, tadv, ttc2d, SurrogateKind, VehicleState};
use std::hint::black_box;
use std::path::Path;

fn golden_pairs() -> Vec<(VehicleState, VehicleState)> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/golden_surrogates.csv");
    let text = std::fs::read_to_string(path).expect("golden csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let fields = ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"];
    let ci: Vec<usize> = fields.iter().map(|f| col(&format!("{f}_i"))).collect();
    let cj: Vec<usize> = fields.iter().map(|f| col(&format!("{f}_j"))).collect();
    let state = |row: &[&str], c: &[usize]| {
        let v: Vec<f32> = c.iter().map(|&k| row[k].parse().unwrap()).collect();
        VehicleState {
            x: v[0],
            y: v[1],
            vx: v[2],
            vy: v[3],
            hx: v[4],
            hy: v[5],
            acc: v[6],
            length: v[7],
            width: v[8],
        }
    };
    lines
        .map(|l| {
            let row: Vec<&str> = l.split(',').collect();
            (state(&row, &ci), state(&row, &cj))
        })
        .collect()
}

/// Deterministic pseudo-random bytes (xorshift), so the synthetic model is the same on every run.
fn bytes(n: usize, seed: &mut u64) -> Vec<u8> {
    (0..n)
        .map(|_| {
            *seed ^= *seed << 13;
            *seed ^= *seed >> 7;
            *seed ^= *seed << 17;
            (*seed >> 24) as u8
        })
        .collect()
}

fn shipped_or_synthetic(name: &str, synthetic: impl FnOnce() -> Vec<u8>) -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../models")
        .join(name);
    match std::fs::read(&path) {
        Ok(blob) if decode(&blob).is_ok() => {
            eprintln!("bench: using shipped model {}", path.display());
            blob
        }
        _ => {
            eprintln!("bench: {name} not found, using a synthetic model of the same structure");
            synthetic()
        }
    }
}

fn synthetic_drl_int8() -> Vec<u8> {
    use scorer_core::mlp::{QuantLayer, QuantMlp};
    use scorer_core::model::BoundedVec;
    use scorer_core::quant::quantize_multiplier;
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let dims = [13usize, 32, 16, 1];
    // Per layer: weights, bias, multipliers, shifts (owned bytes the borrowed model points into).
    type LayerBytes = (Vec<u8>, Vec<u8>, Vec<u8>, Vec<u8>);
    let mut store: Vec<LayerBytes> = Vec::new();
    for w in dims.windows(2) {
        let (din, dout) = (w[0], w[1]);
        let weights = bytes(din * dout, &mut seed);
        let bias: Vec<u8> = (0..dout)
            .flat_map(|k| (k as i32 * 37 - 200).to_le_bytes())
            .collect();
        let last = dout == 1;
        let (mults, shifts) = if last {
            (Vec::new(), Vec::new())
        } else {
            let (m, s) = quantize_multiplier(0.0031);
            (
                (0..dout).flat_map(|_| m.to_le_bytes()).collect(),
                (0..dout).map(|_| s as u8).collect(),
            )
        };
        store.push((weights, bias, mults, shifts));
    }
    let mut layers = BoundedVec::new();
    for (k, (w, b, m, s)) in store.iter().enumerate() {
        let _ = layers.push(QuantLayer {
            out_dim: dims[k + 1] as u16,
            relu: k + 2 < dims.len(),
            weights: w,
            bias: b,
            multipliers: m,
            shifts: s,
            output_zero_point: -128,
        });
    }
    let inputs: Vec<u8> = (0..13).collect();
    let model = Model::DrlInt8(QuantMlp {
        inputs: BoundedVec::from_slice(&inputs).unwrap(),
        input_mul: BoundedVec::from_slice(&[0.5; 13]).unwrap(),
        input_add: BoundedVec::from_slice(&[-3.0; 13]).unwrap(),
        input_zero_point: 0,
        layers,
        output_scales: BoundedVec::from_slice(&[0.001]).unwrap(),
    });
    let mut out = vec![0u8; 1 << 16];
    let n = encode(&model, &mut out).expect("encode synthetic DRL");
    out.truncate(n);
    out
}

fn synthetic_msra() -> Vec<u8> {
    use scorer_core::model::BoundedVec;
    let term = |kind, a, lo, hi| MsraTerm {
        kind,
        weight: 1.0,
        a,
        b: 0.0,
        lo,
        hi,
    };
    let model = Model::Msra(MsraModel {
        terms: BoundedVec::from_slice(&[
            term(SurrogateKind::Ttc2d, -1.0, 0.0, 10.0),
            term(SurrogateKind::Tadv, -1.0, 0.0, 10.0),
            term(SurrogateKind::Ei, 0.5, -10.0, 20.0),
        ])
        .unwrap(),
        gssm: None,
    });
    let mut out = vec![0u8; 1 << 12];
    let n = encode(&model, &mut out).expect("encode synthetic MSRA");
    out.truncate(n);
    out
}

fn bench_core(c: &mut Criterion) {
    let pairs = golden_pairs();
    let n = pairs.len() as u64;
    let drl_blob = shipped_or_synthetic("drl-default.rsk", synthetic_drl_int8);
    let msra_blob = shipped_or_synthetic("msra-default.rsk", synthetic_msra);
    let drl = decode(&drl_blob).expect("drl model");
    let msra = decode(&msra_blob).expect("msra model");
    // As deployed: through each blob's training-domain guard (for the shipped DRL, the blend
    // with its kinematic fallback inside the domain).
    let drl_guarded = decode_blob(&drl_blob).expect("drl blob");
    let msra_guarded = decode_blob(&msra_blob).expect("msra blob");
    let observations: Vec<_> = pairs
        .iter()
        .map(|(e, p)| scorer_core::Observation::of(e, p))
        .collect();

    let mut g = c.benchmark_group("per_observation");
    g.throughput(Throughput::Elements(n));
    g.bench_function("features", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(features(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("box_distance", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(scorer_core::box_distance(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("ttc2d", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(ttc2d(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("tadv", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(tadv(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("ei", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(ei(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("surrogates_and_features", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(scorer_core::surrogates::surrogates_and_features(
                    black_box(e),
                    black_box(p),
                ));
            }
        })
    });
    g.bench_function("drl_inputs", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(scorer_core::drl_inputs(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("drl_int8_from_observation", |b| {
        b.iter(|| {
            for o in &observations {
                black_box(drl.score_observation(black_box(o)));
            }
        })
    });
    g.bench_function("msra_from_surrogates", |b| {
        b.iter(|| {
            for o in &observations {
                black_box(msra.score_observation(black_box(o)));
            }
        })
    });
    g.bench_function("drl_pipeline_pair", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(drl.score(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("msra_pipeline_pair", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(msra.score(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("drl_guarded_pair", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(drl_guarded.score_pair_guarded(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("msra_guarded_pair", |b| {
        b.iter(|| {
            for (e, p) in &pairs {
                black_box(msra_guarded.score_pair_guarded(black_box(e), black_box(p)));
            }
        })
    });
    g.bench_function("warning_update_32_tracks", |b| {
        let mut table: TrackTable<32> =
            TrackTable::new(WarningConfig::live(0.5, 0.05, 500_000, 1_000_000)).unwrap();
        let mut now = 0u64;
        b.iter(|| {
            for (k, o) in observations.iter().enumerate() {
                now += 100;
                let r = o.features[12] * 0.01;
                black_box(table.update((k % 32) as u32, now, black_box(r)).ok());
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bench_core);
criterion_main!(benches);
