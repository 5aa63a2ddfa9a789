//! MSRA configurations that read the GSSM: `R = sum_k w_k sigmoid(a_k g_k(f_k) + b_k)` where one
//! `f_k` is the GSSM intensity of a (frozen, previously fitted) GSSM network embedded in the model,
//! the others TTC2D, TAdv or EI. Configurations by name: `ei+gssm`, `tadv+ei+gssm`,
//! `ttc2d+gssm`, `ttc2d+ei+gssm`, ...
//!
//! Every raw surrogate comes from the core (`scorer_core::msra::MsraModel::raw`, which for GSSM runs
//! the embedded network's `GssmModel::score`), through the core's transform `g_k`; training works on
//! standardised `z_k = (g_k - m_k)/s_k` like [`crate::train::msra`] and converts back exactly. The
//! exported blob is an MSRA model with the GSSM network embedded (score mode `Intensity`), so the
//! ECU and the bridge run the whole combination.
//!
//! Learned weights are reported after sigmoid normalisation ([`TermWeight`]): a term's effective
//! contribution is `span_k = w_k (sigmoid(a_k g_risky + b_k) - sigmoid(a_k g_safe + b_k))`, the change
//! of its value from the safe to the risky end of its clip range; `share_k = span_k / sum_j
//! |span_j|` is signed (negative = the term lowers the risk towards its risky end, i.e. it works
//! against its surrogate's meaning).
use candle_core::{Tensor, Var};
use scorer_core::gssm::{GssmModel, GssmScore};
use scorer_core::model::BoundedVec;
use scorer_core::msra::{sigmoid, MsraModel, MsraTerm};
use scorer_core::{Features, Model, SurrogateKind, Surrogates};
use serde::{Deserialize, Serialize};

// The configuration grammar lives with the configuration that names it (no config <-> msra cycle).
pub use super::config::parse_configuration;
use super::net::GssmParams;
use super::GssmError;
use riskscore_data::events::Sequence;

use crate::comparisons::ObservationTable;
use crate::train::msra::{default_range, MsraTermParams, MsraTerms};
use crate::train::{
    self, PreparedComparisons, Progress, RiskModel, TrainConfig, TrainReport, TrainSettings,
};

/// Clip range of the GSSM term: the intensity lies in `[0, log10(ln 0.5 / ln(1 - 1e-6))] ~ [0, 5.84]`.
pub const GSSM_RANGE: (f32, f32) = (0.0, 5.85);

/// Clip range of a term's transform.
pub fn term_range(kind: SurrogateKind) -> (f32, f32) {
    match kind {
        SurrogateKind::Gssm => GSSM_RANGE,
        other => default_range(other),
    }
}

/// Display name of a configuration, e.g. `TAdv+EI+GSSM`.
pub fn configuration_name(kinds: &[SurrogateKind]) -> String {
    kinds
        .iter()
        .map(|&k| k.name())
        .collect::<Vec<_>>()
        .join("+")
}

/// The evaluation row name of a configuration: `MSRA(TAdv+EI+GSSM)`.
pub fn row_name(kinds: &[SurrogateKind]) -> String {
    format!("MSRA({})", configuration_name(kinds))
}

/// The raw surrogate values the terms read, from the core (GSSM through the embedded network).
fn raw_values(
    core: &MsraModel<'_>,
    kinds: &[SurrogateKind],
    f: &Features,
    s: &Surrogates,
) -> Vec<f32> {
    kinds.iter().map(|&k| core.raw(k, f, s)).collect()
}

/// A learned term, with its weight after sigmoid normalisation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TermWeight {
    /// `TTC2D`, `TAdv`, `EI`, `GSSM`.
    pub surrogate: String,
    pub w: f32,
    pub a: f32,
    pub b: f32,
    /// `w (sigmoid(a g_risky + b) - sigmoid(a g_safe + b))` over the clip range.
    pub span: f32,
    /// `span / sum |span|`, signed.
    pub share: f32,
    /// True when the term raises the risk towards the risky end of its surrogate (`span > 0`).
    pub risk_consistent: bool,
}

/// The learned weights of `name` as a Markdown table, one row per term.
pub fn weights_table(name: &str, weights: &[TermWeight]) -> String {
    let mut out = format!(
        "{name}: learned weights after sigmoid normalisation\n| term | w | a | b | span | share | risk-consistent |\n|---|---|---|---|---|---|---|\n"
    );
    for w in weights {
        out.push_str(&format!(
            "| {} | {:+.4} | {:+.4} | {:+.4} | {:+.4} | {:+.3} | {} |\n",
            w.surrogate, w.w, w.a, w.b, w.span, w.share, w.risk_consistent
        ));
    }
    out
}

/// Float parameters of an MSRA-with-GSSM model (the checkpoint content).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MsraGssmParams {
    /// Configuration key, e.g. `tadv+ei+gssm`.
    pub configuration: String,
    /// Deployed-form terms (`a`, `b` on the transformed surrogate; surrogate `gssm` for the GSSM).
    pub terms: Vec<MsraTermParams>,
    /// The embedded (frozen) GSSM network; exported with score mode `Intensity`.
    pub gssm: GssmParams,
}

impl MsraGssmParams {
    fn kinds(&self) -> Result<Vec<SurrogateKind>, GssmError> {
        self.terms
            .iter()
            .map(|t| {
                SurrogateKind::parse(&t.surrogate).ok_or_else(|| {
                    GssmError::Config(format!("unknown surrogate {:?}", t.surrogate))
                })
            })
            .collect()
    }

    /// The MSRA blob with the GSSM network embedded.
    pub fn blob(&self) -> Result<Vec<u8>, GssmError> {
        let kinds = self.kinds()?;
        let terms: Vec<MsraTerm> = self
            .terms
            .iter()
            .zip(kinds)
            .map(|(t, kind)| t.core_term(kind))
            .collect();
        let fb = self.gssm.float_buffers();
        let net = fb.as_core().map_err(|e| GssmError::Export(e.into()))?;
        let model = MsraModel {
            terms: BoundedVec::from_slice(&terms)?,
            gssm: Some(GssmModel {
                net,
                score: GssmScore::Intensity,
            }),
        };
        let blob = super::encode_blob(&Model::Msra(model))?;
        Ok(blob)
    }

    /// The learned weights after sigmoid normalisation, in term order.
    pub fn weights(&self) -> Vec<TermWeight> {
        let spans: Vec<f32> = self
            .terms
            .iter()
            .map(|t| {
                let larger = SurrogateKind::parse(&t.surrogate)
                    .is_some_and(SurrogateKind::larger_is_riskier);
                let (risky, safe) = if larger { (t.hi, t.lo) } else { (t.lo, t.hi) };
                t.w * (sigmoid(t.a * risky + t.b) - sigmoid(t.a * safe + t.b))
            })
            .collect();
        let total: f32 = spans.iter().map(|s| s.abs()).sum();
        self.terms
            .iter()
            .zip(&spans)
            .map(|(t, &span)| TermWeight {
                surrogate: SurrogateKind::parse(&t.surrogate)
                    .map_or_else(|| t.surrogate.clone(), |k| k.name().to_string()),
                w: t.w,
                a: t.a,
                b: t.b,
                span,
                share: if total > 0.0 { span / total } else { 0.0 },
                risk_consistent: span > 0.0,
            })
            .collect()
    }
}

/// The trainable MSRA-with-GSSM model: the shared [`MsraTerms`] with raw values read through the
/// core (the GSSM term by the embedded, frozen network).
pub struct MsraGssm {
    terms: MsraTerms,
    gssm: GssmParams,
    gssm_blob: Vec<u8>,
}

impl MsraGssm {
    /// A model over `kinds` reading the frozen `gssm`; the input normalisation is measured on the
    /// frames of `seqs` (features and surrogates through scorer-core).
    pub fn new(
        kinds: &[SurrogateKind],
        gssm: &GssmParams,
        seqs: &[Sequence],
    ) -> Result<MsraGssm, GssmError> {
        let gssm_blob = gssm.gssm_blob(GssmScore::Intensity)?;
        let terms: Vec<(SurrogateKind, (f32, f32))> =
            kinds.iter().map(|&k| (k, term_range(k))).collect();
        let terms = {
            let core = Self::core_reader(&gssm_blob)?;
            let raw_rows = seqs.iter().flat_map(|s| {
                s.frames.iter().map(|f| (&f.ego, &f.partner)).map(|(e, p)| {
                    let f = scorer_core::features(e, p);
                    let surr = scorer_core::surrogates(e, p);
                    raw_values(&core, kinds, &f, &surr)
                })
            });
            MsraTerms::fit(&terms, raw_rows)?
        };
        Ok(MsraGssm {
            terms,
            gssm: gssm.clone(),
            gssm_blob,
        })
    }

    /// An MSRA model without terms that only serves `raw` (decoded from the owned GSSM blob).
    fn core_reader(blob: &[u8]) -> Result<MsraModel<'_>, GssmError> {
        match scorer_core::model::decode(blob)? {
            Model::Gssm(g) => Ok(MsraModel {
                terms: BoundedVec::new(),
                gssm: Some(g),
            }),
            _ => Err(GssmError::Config(
                "GSSM export produced another kind".into(),
            )),
        }
    }

    pub fn kinds(&self) -> &[SurrogateKind] {
        self.terms.kinds()
    }

    /// Deployed-form parameters.
    pub fn params(&self) -> candle_core::Result<MsraGssmParams> {
        Ok(MsraGssmParams {
            configuration: self
                .kinds()
                .iter()
                .map(|&k| k.key())
                .collect::<Vec<_>>()
                .join("+"),
            terms: self.terms.params()?,
            gssm: self.gssm.clone(),
        })
    }
}

impl RiskModel for MsraGssm {
    fn name(&self) -> &str {
        "MSRA+GSSM"
    }

    fn input_width(&self) -> usize {
        self.kinds().len()
    }

    fn encode(&self, table: &ObservationTable) -> Vec<f32> {
        let kinds = self.kinds();
        let mut rows = Vec::with_capacity(table.len() * kinds.len());
        // The blob was produced by `gssm_blob` at construction and decodes; a failure here would be
        // a core bug, and yields the "no conflict" input (0 after standardisation) for every row.
        let core = Self::core_reader(&self.gssm_blob).ok();
        let mut raw = Vec::with_capacity(kinds.len());
        for (f, s) in table.features.iter().zip(&table.surrogates) {
            raw.clear();
            raw.extend(
                kinds
                    .iter()
                    .map(|&kind| core.as_ref().map_or(f32::NAN, |c| c.raw(kind, f, s))),
            );
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

/// A trained MSRA-with-GSSM model.
#[derive(Clone, Debug)]
pub struct TrainedMsraGssm {
    pub params: MsraGssmParams,
    pub report: TrainReport,
}

/// Train an MSRA configuration over a frozen GSSM on prepared comparisons (shared trainer and
/// objective; normalisation measured on `train`).
pub fn align_msra_gssm(
    kinds: &[SurrogateKind],
    gssm: &GssmParams,
    train: &[Sequence],
    prepared: &PreparedComparisons,
    config: &TrainConfig,
    learning_rate: f64,
    progress: Progress,
) -> Result<TrainedMsraGssm, GssmError> {
    let model = MsraGssm::new(kinds, gssm, train)?;
    let optimiser = config.msra_optimiser();
    let settings = TrainSettings {
        objective: &config.objective,
        optimiser: &optimiser,
        learning_rate,
        seed: config.seed,
        progress,
        beta: None,
    };
    let report = train::train_with(
        &model,
        &prepared.fit,
        (!prepared.validation.pairs.is_empty()).then_some(&prepared.validation),
        &settings,
    )?;
    Ok(TrainedMsraGssm {
        params: model.params()?,
        report,
    })
}
