//! Test-side model builders: random f32 networks, a reference int8 quantiser built only from
//! `scorer_core::quant`, and blob wrapping. Shared by the integration tests of the inference layer.
#![allow(
    dead_code,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use scorer_core::mlp::{FloatLayer, FloatMlp, QuantLayer, QuantMlp};
use scorer_core::model::{BoundedVec, FEATURE_SCHEMA, MODEL_ONLY_VERSION};
use scorer_core::{quant, Features, FEATURE_COUNT};

/// Deterministic generator (SplitMix64).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * u
    }
}

pub fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}
pub fn i32_bytes(v: &[i32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Plausible feature ranges (means, stds) for random observations.
pub const FEATURE_MEAN: [f32; FEATURE_COUNT] = [
    4.5, 4.5, 3.6, 0.0, 8.0, 0.0, 150.0, 150.0, 40.0, 3.0, 0.0, 0.0, 20.0,
];
pub const FEATURE_STD: [f32; FEATURE_COUNT] = [
    0.8, 1.5, 0.5, 0.5, 6.0, 2.0, 120.0, 120.0, 60.0, 4.0, 1.5, 1.5, 15.0,
];

pub fn random_features(rng: &mut Rng) -> Features {
    let mut f = [0.0; FEATURE_COUNT];
    for i in 0..FEATURE_COUNT {
        f[i] = FEATURE_MEAN[i] + FEATURE_STD[i] * rng.uniform(-2.0, 2.0);
    }
    f[FEATURE_COUNT - 1] = f[FEATURE_COUNT - 1].abs() + 0.1; // spacing s > 0
    f
}

/// An owned f32 network whose byte buffers a `FloatMlp` can borrow.
#[derive(Clone, Debug)]
pub struct FloatNet {
    pub inputs: Vec<u8>,
    pub scale: Vec<f32>,
    pub offset: Vec<f32>,
    /// Per layer: (out_dim, relu, weights [out][in], bias).
    pub layers: Vec<(usize, bool, Vec<f32>, Vec<f32>)>,
    pub w_bytes: Vec<Vec<u8>>,
    pub b_bytes: Vec<Vec<u8>>,
}

impl FloatNet {
    /// Random He-initialised network over `inputs`, hidden widths `hidden` (ReLU), `outputs` outputs.
    pub fn random(seed: u64, inputs: &[u8], hidden: &[usize], outputs: usize) -> Self {
        let mut rng = Rng(seed);
        let scale = inputs
            .iter()
            .map(|&i| 1.0 / FEATURE_STD[i as usize])
            .collect::<Vec<_>>();
        let offset = inputs
            .iter()
            .map(|&i| -FEATURE_MEAN[i as usize] / FEATURE_STD[i as usize])
            .collect::<Vec<_>>();
        let mut layers = Vec::new();
        let mut in_dim = inputs.len();
        for (l, &out) in hidden.iter().chain(core::iter::once(&outputs)).enumerate() {
            let bound = (6.0 / in_dim as f32).sqrt();
            let w = (0..out * in_dim)
                .map(|_| rng.uniform(-bound, bound))
                .collect::<Vec<_>>();
            let b = (0..out).map(|_| rng.uniform(-0.1, 0.1)).collect::<Vec<_>>();
            layers.push((out, l < hidden.len(), w, b));
            in_dim = out;
        }
        let w_bytes = layers.iter().map(|l| f32_bytes(&l.2)).collect();
        let b_bytes = layers.iter().map(|l| f32_bytes(&l.3)).collect();
        Self {
            inputs: inputs.to_vec(),
            scale,
            offset,
            layers,
            w_bytes,
            b_bytes,
        }
    }

    pub fn mlp(&self) -> FloatMlp<'_> {
        let mut layers = BoundedVec::new();
        for (i, l) in self.layers.iter().enumerate() {
            layers
                .push(FloatLayer {
                    out_dim: l.0 as u16,
                    relu: l.1,
                    weights: &self.w_bytes[i],
                    bias: &self.b_bytes[i],
                })
                .unwrap();
        }
        FloatMlp {
            inputs: BoundedVec::from_slice(&self.inputs).unwrap(),
            input_scale: BoundedVec::from_slice(&self.scale).unwrap(),
            input_offset: BoundedVec::from_slice(&self.offset).unwrap(),
            layers,
        }
    }

    /// Per-layer activations (after ReLU) of the float network, in f64, for calibration.
    pub fn activations(&self, x: &Features) -> Vec<Vec<f64>> {
        let mut a: Vec<f64> = self
            .inputs
            .iter()
            .enumerate()
            .map(|(k, &i)| f64::from(x[i as usize] * self.scale[k] + self.offset[k]))
            .collect();
        let mut all = vec![a.clone()];
        for (out, relu, w, b) in &self.layers {
            let n_in = a.len();
            let mut next = vec![0.0; *out];
            for j in 0..*out {
                let mut s = f64::from(b[j]);
                for i in 0..n_in {
                    s += f64::from(w[j * n_in + i]) * a[i];
                }
                next[j] = if *relu { s.max(0.0) } else { s };
            }
            all.push(next.clone());
            a = next;
        }
        all
    }
}

/// An owned int8 network quantised from a `FloatNet` with the core's quantisation functions.
#[derive(Clone, Debug)]
pub struct QuantNet {
    pub inputs: Vec<u8>,
    pub input_mul: Vec<f32>,
    pub input_add: Vec<f32>,
    pub input_zero_point: i8,
    /// Per layer: (out_dim, relu, output_zero_point).
    pub meta: Vec<(usize, bool, i8)>,
    pub w: Vec<Vec<u8>>,
    pub b: Vec<Vec<u8>>,
    pub m: Vec<Vec<u8>>,
    pub s: Vec<Vec<u8>>,
    pub output_scales: Vec<f32>,
}

impl QuantNet {
    /// Post-training quantisation calibrated on `calibration` (min/max per tensor).
    pub fn quantize(net: &FloatNet, calibration: &[Features]) -> Self {
        let n_tensors = net.layers.len() + 1;
        let mut lo = vec![f64::INFINITY; n_tensors];
        let mut hi = vec![f64::NEG_INFINITY; n_tensors];
        for x in calibration {
            for (t, act) in net.activations(x).iter().enumerate() {
                for &v in act {
                    lo[t] = lo[t].min(v);
                    hi[t] = hi[t].max(v);
                }
            }
        }
        let params: Vec<(f32, i8)> = (0..n_tensors)
            .map(|t| quant::asymmetric_params(lo[t] as f32, hi[t] as f32))
            .collect();
        let (s_in, zp_in) = params[0];
        let mut input_mul = Vec::new();
        let mut input_add = Vec::new();
        for k in 0..net.inputs.len() {
            let std = 1.0 / net.scale[k];
            let mean = -net.offset[k] * std;
            let (mul, add) = quant::fold_standardisation(mean, std, s_in, zp_in);
            input_mul.push(mul);
            input_add.push(add);
        }
        let mut q = QuantNet {
            inputs: net.inputs.clone(),
            input_mul,
            input_add,
            input_zero_point: zp_in,
            meta: Vec::new(),
            w: Vec::new(),
            b: Vec::new(),
            m: Vec::new(),
            s: Vec::new(),
            output_scales: Vec::new(),
        };
        let mut in_dim = net.inputs.len();
        let n_layers = net.layers.len();
        for (l, (out, relu, w, b)) in net.layers.iter().enumerate() {
            let s_act_in = params[l].0;
            let last = l + 1 == n_layers;
            let (s_out, zp_out) = params[l + 1];
            let mut wq = Vec::new();
            let mut bq = Vec::new();
            let mut mq = Vec::new();
            let mut sq = Vec::new();
            for j in 0..*out {
                let row = &w[j * in_dim..(j + 1) * in_dim];
                let max_abs = row.iter().fold(0.0f32, |m, v| m.max(v.abs()));
                let s_w = quant::symmetric_scale(max_abs);
                wq.extend(row.iter().map(|&v| quant::quantize_weight(v, s_w) as u8));
                let acc_scale = s_act_in * s_w;
                bq.push(quant::quantize_bias(b[j], acc_scale));
                if last {
                    q.output_scales.push(acc_scale);
                } else {
                    let (m, s) = quant::quantize_multiplier(acc_scale / s_out);
                    mq.push(m);
                    sq.push(s as u8);
                }
            }
            q.meta.push((*out, *relu, if last { 0 } else { zp_out }));
            q.w.push(wq);
            q.b.push(i32_bytes(&bq));
            q.m.push(i32_bytes(&mq));
            q.s.push(sq);
            in_dim = *out;
        }
        q
    }

    pub fn mlp(&self) -> QuantMlp<'_> {
        let mut layers = BoundedVec::new();
        for (i, &(out, relu, zp)) in self.meta.iter().enumerate() {
            layers
                .push(QuantLayer {
                    out_dim: out as u16,
                    relu,
                    weights: &self.w[i],
                    bias: &self.b[i],
                    multipliers: &self.m[i],
                    shifts: &self.s[i],
                    output_zero_point: zp,
                })
                .unwrap();
        }
        QuantMlp {
            inputs: BoundedVec::from_slice(&self.inputs).unwrap(),
            input_mul: BoundedVec::from_slice(&self.input_mul).unwrap(),
            input_add: BoundedVec::from_slice(&self.input_add).unwrap(),
            input_zero_point: self.input_zero_point,
            layers,
            output_scales: BoundedVec::from_slice(&self.output_scales).unwrap(),
        }
    }
}

/// All 13 features, and the 12 GSSM context features (all but s).
pub const ALL_FEATURES: [u8; 13] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12];
pub const CONTEXT_FEATURES: [u8; 12] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11];

/// A blob with a valid header around an arbitrary payload (correct length and CRC).
pub fn wrap(kind: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(b"RSKM");
    out.extend_from_slice(&MODEL_ONLY_VERSION.to_le_bytes());
    out.push(kind);
    out.push(0);
    let schema = scorer_core::ModelKind::from_u8(kind).map_or(FEATURE_SCHEMA, |k| k.input_schema());
    out.extend_from_slice(&schema.to_le_bytes());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(&scorer_core::crc::crc32(payload).to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// Postcard encoding of any serde value (test side, into a large buffer).
pub fn postcard_bytes<T: serde::Serialize>(value: &T) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 20];
    let n = postcard::to_slice(value, &mut buf).unwrap().len();
    buf.truncate(n);
    buf
}
