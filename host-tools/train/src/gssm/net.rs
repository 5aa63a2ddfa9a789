//! The GSSM network in candle: a context MLP over the 12 standardised features other than the
//! spacing `s`, whose last layer has the two heads `(mu, log sigma^2)` of `ln s`, and the survival
//! function `F_S` in the training graph.
//!
//! It has exactly the structure the core's `FloatMlp` runs (feature selection, per-input
//! standardisation, dense layers with ReLU on the hidden ones, a linear 2-output last layer), so
//! [`GssmParams::gssm_blob`] is a lossless export, and the same clamps as `scorer_core::gssm`
//! (`mu` to `+-MU_LIMIT`, `log sigma^2` to `[LOG_VAR_MIN, LOG_VAR_MAX]`).
//!
//! `F_S = 1/2 (1 - erf((ln s - mu) / sqrt(2 sigma^2)))` is evaluated in f64 inside the graph
//! (candle's `erf`, which is `libm::erf`, with its exact derivative `2/sqrt(pi) exp(-z^2)` in
//! backprop), so `1 - erf` keeps its precision down to the `1e-6` clip of the logit; the result is
//! cast back to f32. The guards of the core are reproduced without branching: an observation row
//! carries a guard code (`0` spacing usable, `1` contact `s <= 0` -> `F_S = 1`, `-1` no spacing
//! `s` infinite/NaN -> `F_S = 0`).
use candle_core::{DType, Device, Tensor, Var};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use scorer_core::gssm::{
    GssmModel, GssmScore, CDF_CLIP, LOG_VAR_MAX, LOG_VAR_MIN, MU_LIMIT, S_INDEX,
};
use scorer_core::{Features, Model, FEATURE_COUNT};
use serde::{Deserialize, Serialize};

use super::config::SsraScore;
use super::GssmError;
use crate::nn::mlp::{init_layers, Init, Mlp};
use crate::quantize::FloatBuffers;
use crate::train::drl::{DenseLayer, FeatureScaler};

/// Number of context features (all features except `s`).
pub const CONTEXT_WIDTH: usize = FEATURE_COUNT - 1;
/// Width of one encoded observation row: the standardised context, `ln s`, the guard code.
pub const ROW_WIDTH: usize = CONTEXT_WIDTH + 2;

/// Feature indices of the context, in network-input order (every feature but `s`).
pub fn context_indices() -> [u8; CONTEXT_WIDTH] {
    let mut out = [0u8; CONTEXT_WIDTH];
    let mut k = 0;
    for i in 0..FEATURE_COUNT {
        if i != S_INDEX {
            out[k] = i as u8;
            k += 1;
        }
    }
    out
}

/// Float GSSM parameters: the feature standardisation (only the context entries are used) and the
/// dense layers (hidden ReLU, last linear with the 2 heads `mu`, `log sigma^2`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GssmParams {
    pub scaler: FeatureScaler,
    pub layers: Vec<DenseLayer>,
}

impl GssmParams {
    /// The core's f32 network buffers (context selection, standardisation, layers).
    pub fn float_buffers(&self) -> FloatBuffers {
        FloatBuffers::new(&context_indices(), &self.scaler, &self.layers)
    }

    /// The GSSM-kind model blob with the given score mode (`Intensity` = the GSSM baseline,
    /// `Logit`/`Cdf` = SSRA).
    pub fn gssm_blob(&self, score: GssmScore) -> Result<Vec<u8>, GssmError> {
        let fb = self.float_buffers();
        let net = fb.as_core().map_err(|e| GssmError::Export(e.into()))?;
        let blob = super::encode_blob(&Model::Gssm(GssmModel { net, score }))?;
        Ok(blob)
    }

    /// Number of float parameters of the network.
    pub fn parameter_count(&self) -> usize {
        self.layers
            .iter()
            .map(|l| l.weight.len() + l.bias.len())
            .sum::<usize>()
            + 2 * CONTEXT_WIDTH
    }

    /// Network shape, e.g. `12-32-32-2`.
    pub fn shape(&self) -> String {
        let mut dims = vec![CONTEXT_WIDTH.to_string()];
        dims.extend(self.layers.iter().map(|l| l.outputs.to_string()));
        dims.join("-")
    }

    /// The parameters of a GSSM-kind blob's network (the inverse of [`GssmParams::gssm_blob`] up to
    /// the `1/std` round trip), so a shipped GSSM can be aligned or embedded without its checkpoint.
    pub fn from_blob(blob: &[u8]) -> Result<(GssmParams, GssmScore), GssmError> {
        let model = scorer_core::model::decode(blob)?;
        let g = match model {
            Model::Gssm(g) => g,
            Model::Msra(m) => m
                .gssm
                .ok_or_else(|| GssmError::Config("the MSRA blob embeds no GSSM network".into()))?,
            other => {
                return Err(GssmError::Config(format!(
                    "expected a GSSM model blob, found kind {}",
                    other.kind().name()
                )))
            }
        };
        if g.net.inputs.as_slice() != context_indices() {
            return Err(GssmError::Config(
                "the GSSM network does not read the 12 context features in schema order".into(),
            ));
        }
        let mut mean = vec![0f32; FEATURE_COUNT];
        let mut std = vec![1f32; FEATURE_COUNT];
        for ((&k, &scale), &offset) in g
            .net
            .inputs
            .iter()
            .zip(g.net.input_scale.iter())
            .zip(g.net.input_offset.iter())
        {
            std[k as usize] = 1.0 / scale;
            mean[k as usize] = -offset / scale;
        }
        let n = g.net.layers.len();
        let mut inputs = CONTEXT_WIDTH;
        let mut layers = Vec::with_capacity(n);
        for (i, l) in g.net.layers.iter().enumerate() {
            if l.relu != (i + 1 < n) {
                return Err(GssmError::Config(format!(
                    "layer {i}: expected ReLU on hidden layers only"
                )));
            }
            let f = |b: &[u8]| -> Vec<f32> {
                b.chunks_exact(4)
                    .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                    .collect()
            };
            let outputs = usize::from(l.out_dim);
            layers.push(DenseLayer {
                inputs,
                outputs,
                weight: f(l.weights),
                bias: f(l.bias),
            });
            inputs = outputs;
        }
        Ok((
            GssmParams {
                scaler: FeatureScaler { mean, std },
                layers,
            },
            g.score,
        ))
    }
}

/// Guard code of a spacing, as the core's `survival` treats it.
fn guard(s: f32) -> (f32, f32) {
    if s.is_nan() || s == f32::INFINITY {
        (0.0, -1.0)
    } else if s <= 0.0 {
        (0.0, 1.0)
    } else {
        (s.ln(), 0.0)
    }
}

/// The trainable GSSM network.
pub struct GssmNet {
    scaler: FeatureScaler,
    mlp: Mlp,
}

impl GssmNet {
    /// A fresh network: He-uniform hidden layers, small head weights and head biases
    /// `(mu0, log_var0)` (the marginal lognormal of the training spacings), seeded by `seed`.
    pub fn new(
        scaler: FeatureScaler,
        hidden: &[usize],
        seed: u64,
        mu0: f32,
        log_var0: f32,
    ) -> candle_core::Result<GssmNet> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x655D_0000);
        let mut sizes = vec![CONTEXT_WIDTH];
        sizes.extend_from_slice(hidden);
        sizes.push(2);
        let heads = [mu0, log_var0];
        let init = Init {
            last_weight_scale: 0.1,
            last_bias: Some(&heads),
        };
        let layers = init_layers(&sizes, &mut rng, init);
        GssmNet::from_params(&GssmParams { scaler, layers })
    }

    /// A network holding the given parameters.
    pub fn from_params(p: &GssmParams) -> candle_core::Result<GssmNet> {
        Ok(GssmNet {
            scaler: p.scaler.clone(),
            mlp: Mlp::from_layers(&p.layers)?,
        })
    }

    pub fn params(&self) -> candle_core::Result<GssmParams> {
        Ok(GssmParams {
            scaler: self.scaler.clone(),
            layers: self.mlp.layers()?,
        })
    }

    pub fn vars(&self) -> Vec<Var> {
        self.mlp.vars()
    }

    /// Encoded rows ([`ROW_WIDTH`] each): the context standardised through the core's
    /// `standardise`, `ln s`, and the guard code.
    pub fn encode_rows<'a>(&self, features: impl IntoIterator<Item = &'a Features>) -> Vec<f32> {
        let ctx = context_indices();
        let mut rows = Vec::new();
        for f in features {
            let z = self.scaler.apply(f);
            rows.extend(ctx.iter().map(|&k| z[k as usize]));
            let (ln_s, code) = guard(f[S_INDEX]);
            rows.push(ln_s);
            rows.push(code);
        }
        rows
    }

    /// Encoded rows as a `[n, ROW_WIDTH]` tensor.
    pub fn rows_tensor(&self, features: &[Features]) -> candle_core::Result<Tensor> {
        Tensor::from_vec(
            self.encode_rows(features),
            (features.len(), ROW_WIDTH),
            &Device::Cpu,
        )
    }

    /// Unclamped network outputs `[n, 2]` for a batch of standardised contexts `[n, 12]`.
    pub fn context_forward(&self, context: &Tensor) -> candle_core::Result<Tensor> {
        self.mlp.forward(context)
    }

    /// Clamped `(mu, log sigma^2)`, each `[n]`, from a batch of standardised contexts.
    pub fn heads(&self, context: &Tensor) -> candle_core::Result<(Tensor, Tensor)> {
        let out = self.context_forward(context)?;
        let mu = out
            .narrow(1, 0, 1)?
            .squeeze(1)?
            .clamp(-MU_LIMIT, MU_LIMIT)?;
        let lv = out
            .narrow(1, 1, 1)?
            .squeeze(1)?
            .clamp(LOG_VAR_MIN, LOG_VAR_MAX)?;
        Ok((mu, lv))
    }

    /// `F_S` `[n]` (f64) of encoded rows `[n, ROW_WIDTH]`.
    fn survival_f64(&self, rows: &Tensor) -> candle_core::Result<Tensor> {
        let z = self.z(rows)?;
        let code = self.code(rows)?;
        let f = z.erf()?.affine(-0.5, 0.5)?.clamp(0.0, 1.0)?;
        // Guards: usable rows keep F, contact rows get 1, no-spacing rows 0.
        let usable = code.abs()?.affine(-1.0, 1.0)?;
        (f * usable)? + code.relu()?
    }

    /// `F_S` `[n]` (f32) of encoded rows.
    pub fn survival(&self, rows: &Tensor) -> candle_core::Result<Tensor> {
        self.survival_f64(rows)?.to_dtype(DType::F32)
    }

    /// SSRA's training score `[n]` (f32) of encoded rows.
    ///
    /// - `Cdf`: `F_S`.
    /// - `Logit`: the exact, unclipped `l = logit(F_S) = ln erfc(z) - ln erfc(-z)` ([`ln_erfc`]),
    ///   log-compressed: `R = c (ln(1 + relu(l)/c) - ln(1 + relu(-l)/c))`, `c =`
    ///   [`TRAIN_LOGIT_SCALE`]. The deployed score clips `F_S` to `[1e-6, 1 - 1e-6]`, which would
    ///   cut the gradient of every saturated observation (for a GSSM fitted on safe driving,
    ///   typically every late conflict frame: `l ~ z^2` with `|z|` of 10 or more); the compression
    ///   keeps `dR/dz` of order 1 there while staying strictly monotone in `F_S`, so it orders
    ///   observations exactly like the deployed logit wherever the latter is not clipped.
    ///   Guard rows get the compressed `+-logit(1 - 1e-6)`.
    pub fn score(&self, rows: &Tensor, mode: SsraScore) -> candle_core::Result<Tensor> {
        match mode {
            SsraScore::Cdf => self.survival(rows),
            SsraScore::Logit => {
                let z = self.z(rows)?;
                let logit = (ln_erfc(&z)? - ln_erfc(&z.neg()?)?)?;
                let compressed = compress_logit(&logit)?;
                let code = self.code(rows)?;
                let usable = code.abs()?.affine(-1.0, 1.0)?;
                let limit = compress_scalar(f64::from(scorer_core::gssm::logit(1.0)));
                ((compressed * usable)? + (code * limit)?)?.to_dtype(DType::F32)
            }
        }
    }

    /// The deployed score `[n]` (f32) of encoded rows exactly as `scorer_core::gssm` defines it
    /// (`F_S`, its logit clipped at `1e-6`, or the intensity), for parity checks and diagnostics.
    pub fn deployed_score(&self, rows: &Tensor, mode: GssmScore) -> candle_core::Result<Tensor> {
        let f = self.survival_f64(rows)?;
        let c = f64::from(CDF_CLIP);
        let out = match mode {
            GssmScore::Cdf => f,
            GssmScore::Logit => {
                let f = f.clamp(c, 1.0 - c)?;
                (f.log()? - f.affine(-1.0, 1.0)?.log()?)?
            }
            GssmScore::Intensity => {
                let n = f
                    .clamp(c, 1.0 - c)?
                    .log()?
                    .recip()?
                    .affine(-std::f64::consts::LN_2, 0.0)?;
                n.maximum(1.0)?
                    .log()?
                    .affine(std::f64::consts::LOG10_E, 0.0)?
            }
        };
        out.to_dtype(DType::F32)
    }

    /// Guard codes `[n]` (f64) of encoded rows.
    fn code(&self, rows: &Tensor) -> candle_core::Result<Tensor> {
        rows.narrow(1, CONTEXT_WIDTH + 1, 1)?
            .squeeze(1)?
            .to_dtype(DType::F64)
    }

    /// `z = (ln s - mu) / sqrt(2 sigma^2)` `[n]` (f64) of encoded rows (guard rows: `ln s = 0`).
    fn z(&self, rows: &Tensor) -> candle_core::Result<Tensor> {
        let (mu, lv) = self.heads(&rows.narrow(1, 0, CONTEXT_WIDTH)?)?;
        let ln_s = rows
            .narrow(1, CONTEXT_WIDTH, 1)?
            .squeeze(1)?
            .to_dtype(DType::F64)?;
        let inv_sigma = (lv.to_dtype(DType::F64)? * -0.5)?.exp()?;
        ((ln_s - mu.to_dtype(DType::F64)?)? * inv_sigma)?
            .affine(std::f64::consts::FRAC_1_SQRT_2, 0.0)
    }
}

/// Scale `c` of the log-compressed training logit (see [`GssmNet::score`]).
pub const TRAIN_LOGIT_SCALE: f64 = 10.0;

/// `c (ln(1 + relu(l)/c) - ln(1 + relu(-l)/c))`: identity near 0, logarithmic in `|l|`.
pub fn compress_logit(l: &Tensor) -> candle_core::Result<Tensor> {
    let c = TRAIN_LOGIT_SCALE;
    let up = l.relu()?.affine(1.0 / c, 1.0)?.log()?;
    let down = l.neg()?.relu()?.affine(1.0 / c, 1.0)?.log()?;
    (up - down)?.affine(c, 0.0)
}

/// [`compress_logit`] of one number.
pub fn compress_scalar(l: f64) -> f64 {
    let c = TRAIN_LOGIT_SCALE;
    l.signum() * c * (1.0 + l.abs() / c).ln()
}

/// `ln erfc(x)` (f64) without underflow: `ln(1 - erf(x))` for `x < 4`, and for `x >= 4` the
/// asymptotic series `-x^2 - ln(x sqrt(pi)) + ln(1 - 1/(2x^2) + 3/(4x^4) - 15/(8x^6) + 105/(16x^8))`,
/// whose truncation error there is below `3e-5` (relative, in `erfc`). Each branch only sees
/// arguments on its side of the switch, so neither produces NaN values or gradients.
pub fn ln_erfc(x: &Tensor) -> candle_core::Result<Tensor> {
    const SWITCH: f64 = 4.0;
    let direct = x.minimum(SWITCH)?.erf()?.affine(-1.0, 1.0)?.log()?;
    let big = x.maximum(SWITCH)?;
    let u = big.sqr()?.recip()?;
    let series = ((((u.affine(105.0 / 16.0, -15.0 / 8.0)? * &u)?.affine(1.0, 0.75)? * &u)?
        .affine(1.0, -0.5)?
        * &u)?
        .affine(1.0, 1.0))?;
    let half_ln_pi = 0.5 * std::f64::consts::PI.ln();
    let asym = ((big.sqr()?.neg()? - big.log()?)?.affine(1.0, -half_ln_pi)? + series.log()?)?;
    x.ge(SWITCH)?.where_cond(&asym, &direct)
}

/// The core's score mode for an SSRA score.
pub fn core_score(mode: SsraScore) -> GssmScore {
    match mode {
        SsraScore::Logit => GssmScore::Logit,
        SsraScore::Cdf => GssmScore::Cdf,
    }
}
