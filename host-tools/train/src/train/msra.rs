//! MSRA: `R = sum_k w_k * sigmoid(a_k * g_k(f_k) + b_k)` over surrogates `f_k` (TTC2D, TAdv, EI,
//! TAdv-corridor),
//! where `g_k = scorer_core::msra::transform` is the core's finite transform with clip range
//! `[lo_k, hi_k]` (so `+inf` TTC and `-inf` EI never reach the arithmetic).
//!
//! The transformed surrogates are precomputed once per observation. For conditioning, training
//! works on `z_k = (g_k - m_k) / s_k` (mean and standard deviation of `g_k` on the training frames)
//! with parameters `a'_k, b'_k`; [`Msra::params`] converts back exactly:
//! `a_k = a'_k / s_k`, `b_k = b'_k - a'_k m_k / s_k`. Initialisation points every term in its risk
//! direction (smaller TTC/TAdv, larger EI is riskier), read off the transform itself.
use candle_core::{DType, Device, Tensor, Var};
use scorer_core::{SurrogateKind, Surrogates};
use serde::{Deserialize, Serialize};

use super::model::RiskModel;
use riskscore_data::events::Sequence;

use crate::comparisons::ObservationTable;

/// A geometric surrogate by name (`ttc2d`, `tadv`, `ei`, `tadv_corridor`; case-insensitive, see
/// [`SurrogateKind::parse`]). GSSM is not one: it is a learned model, trained by `gssm`.
pub fn parse_surrogate(name: &str) -> Option<SurrogateKind> {
    SurrogateKind::parse(name).filter(|&kind| kind != SurrogateKind::Gssm)
}

/// Clip range `[lo, hi]` of the transform of each surrogate (the times in s, EI in m/s).
pub fn default_range(kind: SurrogateKind) -> (f32, f32) {
    match kind {
        SurrogateKind::Ttc2d | SurrogateKind::Tadv | SurrogateKind::TadvCorridor => (0.0, 10.0),
        SurrogateKind::Ei => (0.0, 20.0),
        SurrogateKind::Gssm => (0.0, 1.0),
    }
}

/// The core transform `g_k` of one raw surrogate.
pub fn transformed(kind: SurrogateKind, raw: f32, lo: f32, hi: f32) -> f32 {
    scorer_core::msra::transform(kind, raw, lo, hi)
}

/// One MSRA term's float parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MsraTermParams {
    /// `ttc2d`, `tadv`, `ei` or `tadv_corridor`.
    pub surrogate: String,
    pub lo: f32,
    pub hi: f32,
    pub w: f32,
    pub a: f32,
    pub b: f32,
}

impl MsraTermParams {
    pub fn kind(&self) -> Option<SurrogateKind> {
        parse_surrogate(&self.surrogate)
    }

    /// The core's term of these parameters for surrogate `kind` (the caller decides which kinds,
    /// e.g. GSSM, it accepts).
    pub fn core_term(&self, kind: SurrogateKind) -> scorer_core::msra::MsraTerm {
        scorer_core::msra::MsraTerm {
            kind,
            weight: self.w,
            a: self.a,
            b: self.b,
            lo: self.lo,
            hi: self.hi,
        }
    }
}

/// Float MSRA parameters (the checkpoint content).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MsraParams {
    pub terms: Vec<MsraTermParams>,
}

/// The trainable terms every MSRA shares (with or without a GSSM term): per term its kind, clip
/// range, the standardisation `(m_k, s_k)` of `g_k` on the training frames, and `w_k, a'_k, b'_k`.
pub struct MsraTerms {
    kinds: Vec<SurrogateKind>,
    ranges: Vec<(f32, f32)>,
    centre: Vec<f32>,
    spread: Vec<f32>,
    w: Var,
    a: Var,
    b: Var,
}

/// Slope sign of `g_k` as a function of the raw surrogate (+1 increasing, -1 decreasing).
fn transform_slope_sign(kind: SurrogateKind, lo: f32, hi: f32) -> f32 {
    let (x0, x1) = (lo + 0.25 * (hi - lo), lo + 0.75 * (hi - lo));
    let (g0, g1) = (transformed(kind, x0, lo, hi), transformed(kind, x1, lo, hi));
    if g1 >= g0 {
        1.0
    } else {
        -1.0
    }
}

/// +1 when a larger raw value is riskier (EI, GSSM), -1 when smaller is riskier (TTC2D, TAdv).
fn risk_direction(kind: SurrogateKind) -> f32 {
    if kind.larger_is_riskier() {
        1.0
    } else {
        -1.0
    }
}

impl MsraTerms {
    /// Terms `(kind, clip range)` with their standardisation fitted on `raw_rows` (per frame the raw
    /// surrogate value of every term, in term order). Every term starts with `w = 1`, `b' = 0` and
    /// `a'` pointing in its risk direction.
    pub fn fit(
        terms: &[(SurrogateKind, (f32, f32))],
        raw_rows: impl Iterator<Item = Vec<f32>>,
    ) -> candle_core::Result<MsraTerms> {
        let k = terms.len();
        let (kinds, ranges): (Vec<SurrogateKind>, Vec<(f32, f32)>) = terms.iter().copied().unzip();
        let mut sum = vec![0f64; k];
        let mut sq = vec![0f64; k];
        let mut n = 0usize;
        for raw in raw_rows {
            n += 1;
            for (j, (&(kind, (lo, hi)), &r)) in terms.iter().zip(&raw).enumerate() {
                let g = f64::from(transformed(kind, r, lo, hi));
                sum[j] += g;
                sq[j] += g * g;
            }
        }
        let mut centre = vec![0f32; k];
        let mut spread = vec![1f32; k];
        for j in 0..k {
            if n > 0 {
                let m = sum[j] / n as f64;
                let sd = (sq[j] / n as f64 - m * m).max(0.0).sqrt();
                centre[j] = m as f32;
                spread[j] = if sd > 1e-6 { sd as f32 } else { 1.0 };
            }
        }
        let init_a: Vec<f32> = terms
            .iter()
            .map(|&(kind, (lo, hi))| risk_direction(kind) * transform_slope_sign(kind, lo, hi))
            .collect();
        Ok(MsraTerms {
            kinds,
            ranges,
            centre,
            spread,
            w: Var::from_vec(vec![1.0f32; k], k, &Device::Cpu)?,
            a: Var::from_vec(init_a, k, &Device::Cpu)?,
            b: Var::zeros(k, DType::F32, &Device::Cpu)?,
        })
    }

    pub fn kinds(&self) -> &[SurrogateKind] {
        &self.kinds
    }

    /// Appends the input row of one frame: the standardised `z_k` of its raw values (0 when not
    /// finite).
    pub fn encode_row(&self, raw: &[f32], rows: &mut Vec<f32>) {
        for (k, (&kind, &(lo, hi))) in self.kinds.iter().zip(&self.ranges).enumerate() {
            let g = transformed(kind, raw[k], lo, hi);
            let z = (g - self.centre[k]) / self.spread[k];
            rows.push(if z.is_finite() { z } else { 0.0 });
        }
    }

    /// The terms in the deployed form (`a_k`, `b_k` on the transformed surrogate itself).
    pub fn params(&self) -> candle_core::Result<Vec<MsraTermParams>> {
        let w = self.w.as_tensor().to_vec1::<f32>()?;
        let a = self.a.as_tensor().to_vec1::<f32>()?;
        let b = self.b.as_tensor().to_vec1::<f32>()?;
        Ok((0..self.kinds.len())
            .map(|k| {
                let (m, s) = (self.centre[k], self.spread[k]);
                MsraTermParams {
                    surrogate: self.kinds[k].key().to_string(),
                    lo: self.ranges[k].0,
                    hi: self.ranges[k].1,
                    w: w[k],
                    a: a[k] / s,
                    b: b[k] - a[k] * m / s,
                }
            })
            .collect())
    }

    /// The MSRA sum `R = sum_k w_k * sigmoid(a'_k * z_k + b'_k)` over a batch of rows
    /// (`[batch, terms]` -> `[batch]`).
    pub fn forward(&self, inputs: &Tensor) -> candle_core::Result<Tensor> {
        let z = inputs
            .broadcast_mul(self.a.as_tensor())?
            .broadcast_add(self.b.as_tensor())?;
        candle_nn::ops::sigmoid(&z)?
            .broadcast_mul(self.w.as_tensor())?
            .sum(1)
    }

    pub fn vars(&self) -> Vec<Var> {
        vec![self.w.clone(), self.a.clone(), self.b.clone()]
    }
}

/// The trainable MSRA model over geometric surrogates.
pub struct Msra {
    terms: MsraTerms,
}

impl Msra {
    /// A model over `terms` (each a surrogate with its clip range, e.g. [`default_range`]), its
    /// input normalisation fitted on the frames of `seqs` (surrogates computed by scorer-core).
    pub fn new(
        terms: &[(SurrogateKind, (f32, f32))],
        seqs: &[Sequence],
    ) -> candle_core::Result<Msra> {
        let surrogates = seqs.iter().flat_map(|s| {
            s.frames
                .iter()
                .map(|f| scorer_core::surrogates(&f.ego, &f.partner))
        });
        Self::fitted(terms, surrogates)
    }

    /// Same, with the normalisation fitted on the rows of an observation table.
    pub fn from_table(
        terms: &[(SurrogateKind, (f32, f32))],
        table: &ObservationTable,
    ) -> candle_core::Result<Msra> {
        Self::fitted(terms, table.surrogates.iter().copied())
    }

    fn fitted(
        terms: &[(SurrogateKind, (f32, f32))],
        surrogates: impl Iterator<Item = Surrogates>,
    ) -> candle_core::Result<Msra> {
        let raw_rows =
            surrogates.map(|s| terms.iter().map(|(kind, _)| kind.value_in(&s)).collect());
        Ok(Msra {
            terms: MsraTerms::fit(terms, raw_rows)?,
        })
    }

    pub fn kinds(&self) -> &[SurrogateKind] {
        self.terms.kinds()
    }

    /// The parameters in the deployed form (`a_k`, `b_k` on the transformed surrogate itself).
    pub fn params(&self) -> candle_core::Result<MsraParams> {
        Ok(MsraParams {
            terms: self.terms.params()?,
        })
    }
}

impl RiskModel for Msra {
    fn name(&self) -> &str {
        "MSRA"
    }

    fn input_width(&self) -> usize {
        self.terms.kinds().len()
    }

    fn encode(&self, table: &ObservationTable) -> Vec<f32> {
        let kinds = self.terms.kinds();
        let mut rows = Vec::with_capacity(table.len() * kinds.len());
        let mut raw = Vec::with_capacity(kinds.len());
        for s in &table.surrogates {
            raw.clear();
            raw.extend(kinds.iter().map(|kind| kind.value_in(s)));
            self.terms.encode_row(&raw, &mut rows);
        }
        rows
    }

    fn forward(&self, inputs: &Tensor) -> candle_core::Result<Tensor> {
        self.terms.forward(inputs)
    }

    fn vars(&self) -> Vec<Var> {
        self.terms.vars()
    }
}
