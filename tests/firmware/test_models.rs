//! Deterministic stand-in models for the firmware, used only while `models/drl-default.rsk` /
//! `models/msra-default.rsk` are not shipped (build.rs prefers the shipped files).
//!
//! They are encoded by `scorer_core::model::encode`, so they pass the same validation as a trained
//! export. The DRL network has a realistic shape (13 -> 32 -> 32 -> 1, ReLU, per-channel
//! requantisation, 1 472 multiply-accumulates) and weights from a fixed pseudo-random sequence;
//! the standardisation uses plausible feature scales so activations spread over the int8 range
//! instead of saturating. The MSRA model has one term per surrogate.
use scorer_core::mlp::{QuantLayer, QuantMlp};
use scorer_core::model::{encode, encoded_len, BoundedVec, Model};
use scorer_core::msra::{MsraModel, MsraTerm};
use scorer_core::quant;
use scorer_core::SurrogateKind;

/// Hidden layer widths of the stand-in DRL network.
const HIDDEN: [usize; 2] = [32, 32];

/// (mean, std) per feature, in model-input order: plausible road-traffic scales.
const FEATURE_STATS: [(f32, f32); 13] = [
    (4.5, 0.6),     // l_ego
    (4.5, 1.0),     // l_sur
    (1.9, 0.2),     // w_comb
    (18.0, 10.0),   // vy_ego
    (0.0, 8.0),     // vx_sur
    (10.0, 15.0),   // vy_sur
    (420.0, 400.0), // v_ego2
    (420.0, 400.0), // v_sur2
    (150.0, 250.0), // delta_v2
    (0.0, 10.0),    // delta_v
    (0.0, 1.5),     // psi_sur
    (0.0, 1.8),     // rho
    (40.0, 30.0),   // s
];

/// xorshift32: a fixed, dependency-free pseudo-random sequence.
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }
    /// Uniform in [-1, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 8) as f32 / (1u32 << 23) as f32 - 1.0
    }
}

fn to_blob(model: &Model<'_>) -> Vec<u8> {
    let len = encoded_len(model).expect("test model: encoded_len");
    let mut blob = vec![0u8; len];
    let n = encode(model, &mut blob).expect("test model: encode");
    blob.truncate(n);
    blob
}

/// The stand-in int8 DRL model blob.
pub fn drl_int8() -> Vec<u8> {
    let mut rng = Rng(0x5eed_1234);
    // Inputs: standardised features cover about [-4, 4] -> asymmetric int8.
    let (in_scale, in_zp) = quant::asymmetric_params(-4.0, 4.0);
    let mut inputs = BoundedVec::new();
    let mut input_mul = BoundedVec::new();
    let mut input_add = BoundedVec::new();
    for (i, &(mean, std)) in FEATURE_STATS.iter().enumerate() {
        let (mul, add) = quant::fold_standardisation(mean, std, in_scale, in_zp);
        inputs.push(i as u8).expect("inputs capacity");
        input_mul.push(mul).expect("input_mul capacity");
        input_add.push(add).expect("input_add capacity");
    }

    // Byte storage for every layer (the model borrows it).
    struct Bytes {
        weights: Vec<u8>,
        bias: Vec<u8>,
        multipliers: Vec<u8>,
        shifts: Vec<u8>,
        out_dim: usize,
        zero_point: i8,
    }
    let mut dims: Vec<usize> = HIDDEN.to_vec();
    dims.push(1);
    let mut in_dim = FEATURE_STATS.len();
    let mut storage = Vec::new();
    for (l, &out_dim) in dims.iter().enumerate() {
        let last = l + 1 == dims.len();
        let mut weights = Vec::with_capacity(out_dim * in_dim);
        for _ in 0..out_dim * in_dim {
            weights.push(((rng.unit() * 127.0) as i8) as u8);
        }
        let mut bias = Vec::new();
        for _ in 0..out_dim {
            bias.extend_from_slice(&((rng.unit() * 2000.0) as i32).to_le_bytes());
        }
        let (mut multipliers, mut shifts) = (Vec::new(), Vec::new());
        if !last {
            // Typical |dot| ~ 64 * 40 * sqrt(in_dim); map it to ~40 output codes.
            let base = 40.0 / (64.0 * 40.0 * (in_dim as f32).sqrt());
            for _ in 0..out_dim {
                let (m, s) = quant::quantize_multiplier(base * (1.0 + 0.25 * rng.unit()));
                multipliers.extend_from_slice(&m.to_le_bytes());
                shifts.push(s as u8);
            }
        }
        storage.push(Bytes {
            weights,
            bias,
            multipliers,
            shifts,
            out_dim,
            zero_point: if last { 0 } else { -128 },
        });
        in_dim = out_dim;
    }
    let mut layers = BoundedVec::new();
    for (l, b) in storage.iter().enumerate() {
        let last = l + 1 == storage.len();
        let layer = QuantLayer {
            out_dim: b.out_dim as u16,
            relu: !last,
            weights: &b.weights,
            bias: &b.bias,
            multipliers: &b.multipliers,
            shifts: &b.shifts,
            output_zero_point: b.zero_point,
        };
        if layers.push(layer).is_err() {
            panic!("test model: too many layers");
        }
    }
    let mut output_scales = BoundedVec::new();
    output_scales.push(2.0e-4).expect("output_scales capacity");
    let model = Model::DrlInt8(QuantMlp {
        inputs,
        input_mul,
        input_add,
        input_zero_point: in_zp,
        layers,
        output_scales,
    });
    to_blob(&model)
}

/// The stand-in MSRA model blob: one term per surrogate (TTC2D, TAdv, EI).
pub fn msra() -> Vec<u8> {
    let term = |kind, weight, a, b, lo, hi| MsraTerm {
        kind,
        weight,
        a,
        b,
        lo,
        hi,
    };
    let mut terms = BoundedVec::new();
    for t in [
        term(SurrogateKind::Ttc2d, 1.0, -1.2, 3.0, 0.0, 10.0),
        term(SurrogateKind::Tadv, 0.8, -0.9, 2.0, 0.0, 10.0),
        term(SurrogateKind::Ei, 0.6, 0.4, -1.0, -10.0, 20.0),
    ] {
        terms.push(t).expect("terms capacity");
    }
    to_blob(&Model::Msra(MsraModel { terms, gssm: None }))
}
