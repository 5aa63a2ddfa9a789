//! Scoring prepared sequences with the methods under evaluation, through scorer-core only: model
//! blobs via [`Model::score_observation`] (the deployed path: int8 for DRL), baselines via the
//! core's surrogates in their risk direction ([`Baseline`]).
//!
//! Each frame's [`Observation`] (features, surrogates, DRL inputs) is computed once ([`observe`])
//! and shared by every method.
use scorer_core::gssm::GssmScore;
use scorer_core::model::{Model, ModelBlob, ModelKind};
use scorer_core::Guarded;
use scorer_core::{Observation, SurrogateKind};

use super::metrics::{warning_curve, WarningCurve};
use super::protocol::{
    alert_profiles, AlertProfile, Baseline, ProtocolError, ScoredFrame, ScoredSequence,
};
use super::report::{EvaluationReport, EventCounts, MethodResult};
use riskscore_data::events::{EventKind, Frame, Sequence};

/// One frame's inputs to every method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObservedFrame {
    pub time: f64,
    pub observation: Observation,
}

/// A prepared sequence with its observations computed.
#[derive(Clone, Debug, PartialEq)]
pub struct ObservedSequence {
    pub event_id: String,
    pub kind: EventKind,
    pub endpoint: Option<f64>,
    pub frames: Vec<ObservedFrame>,
}

impl ObservedSequence {
    /// Scores every frame with `score`.
    pub fn score(&self, score: impl Fn(&ObservedFrame) -> f32) -> ScoredSequence {
        ScoredSequence {
            event_id: self.event_id.clone(),
            kind: self.kind,
            endpoint: self.endpoint,
            frames: self
                .frames
                .iter()
                .map(|f| ScoredFrame {
                    time: f.time,
                    score: score(f),
                })
                .collect(),
        }
    }
}

/// Computes the observation ([`Observation::of`], scorer-core) of every frame of every sequence.
pub fn observe(sequences: &[Sequence]) -> Vec<ObservedSequence> {
    sequences
        .iter()
        .map(|s| ObservedSequence {
            event_id: s.event_id.clone(),
            kind: s.kind,
            endpoint: s.endpoint,
            frames: observe_frames(&s.frames),
        })
        .collect()
}

/// The observation of each frame (features, surrogates, DRL inputs: scorer-core's
/// [`Observation::of`]), in order.
pub fn observe_frames(frames: &[Frame]) -> Vec<ObservedFrame> {
    frames
        .iter()
        .map(|f| ObservedFrame {
            time: f.time,
            observation: Observation::of(&f.ego, &f.partner),
        })
        .collect()
}

/// Something that turns an observation into a risk score.
// A handful exist per evaluation and each scores every frame: keep the model inline, unboxed.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Scorer<'a> {
    /// A decoded model blob, scored exactly as on the ECU.
    Model(Model<'a>),
    /// A model blob with a training-domain record, scored through its guard exactly as on the
    /// ECU ([`ModelBlob::score_guarded`]: the blob's policy decides the score outside).
    Guarded(ModelBlob<'a>),
    /// A surrogate baseline in its risk direction.
    Baseline(Baseline),
}

impl<'a> Scorer<'a> {
    /// How a model file is scored: through its guard when it carries a training domain, as the
    /// ECU scores it; as the bare model otherwise.
    pub fn of_blob(blob: ModelBlob<'a>) -> Self {
        if blob.meta.training_domain.is_some() {
            Scorer::Guarded(blob)
        } else {
            Scorer::Model(blob.model)
        }
    }
}

impl Scorer<'_> {
    pub fn score(&self, observation: &Observation) -> f32 {
        match self {
            Scorer::Model(m) => m.score_observation(observation),
            Scorer::Guarded(blob) => blob.score_guarded(observation).score,
            Scorer::Baseline(b) => b.risk(&observation.surrogates),
        }
    }

    /// The guarded score, for a scorer with a training domain (`None`: nothing to guard).
    pub fn score_guarded(&self, observation: &Observation) -> Option<Guarded> {
        match self {
            Scorer::Guarded(blob) => Some(blob.score_guarded(observation)),
            Scorer::Model(_) | Scorer::Baseline(_) => None,
        }
    }

    /// True for a model with a training-domain record.
    pub fn has_domain(&self) -> bool {
        matches!(self, Scorer::Guarded(_))
    }

    /// The surrogates the scorer reads: an MSRA's terms, a blob's kinematic-fallback terms, a
    /// baseline's own (in that order, repeats kept).
    pub fn surrogates_read(&self) -> Vec<SurrogateKind> {
        let terms = |m: &Model<'_>| match m {
            Model::Msra(msra) => msra.terms.iter().map(|t| t.kind).collect(),
            _ => Vec::new(),
        };
        match self {
            Scorer::Model(m) => terms(m),
            Scorer::Guarded(blob) => {
                let mut kinds = terms(&blob.model);
                if let Some(fallback) = &blob.meta.kinematic_fallback {
                    kinds.extend(fallback.terms().map(|t| t.kind));
                }
                kinds
            }
            Scorer::Baseline(b) => vec![b.surrogate()],
        }
    }

    /// The model kind, for a model scorer.
    pub fn model_kind(&self) -> Option<ModelKind> {
        match self {
            Scorer::Model(m) => Some(m.kind()),
            Scorer::Guarded(blob) => Some(blob.model.kind()),
            Scorer::Baseline(_) => None,
        }
    }
}

/// A named row of the results table.
#[derive(Clone, Debug)]
pub struct Method<'a> {
    pub name: String,
    pub scorer: Scorer<'a>,
}

impl<'a> Method<'a> {
    pub fn baseline(b: Baseline) -> Self {
        Method {
            name: b.name().to_owned(),
            scorer: Scorer::Baseline(b),
        }
    }

    /// The three surrogate baselines, in table order (TTC2D, TAdv, EI).
    pub fn baselines() -> Vec<Method<'static>> {
        Baseline::ALL.into_iter().map(Method::baseline).collect()
    }

    /// The baselines to report next to `models`: [`Method::baselines`], then one for every other
    /// kinematic surrogate the models read ([`Scorer::surrogates_read`], e.g. TAdv-corridor), so
    /// that each model is compared with its own inputs.
    pub fn baselines_for(models: &[Method<'_>]) -> Vec<Method<'static>> {
        Baseline::read_by(models.iter().flat_map(|m| m.scorer.surrogates_read()))
            .into_iter()
            .map(Method::baseline)
            .collect()
    }
}

/// Row name of a model kind: `DRL` (int8, the deployed network), `DRL-f32`, `MSRA`, `GSSM`.
/// [`model_row_name`] also tells SSRA from GSSM, which share a kind.
pub fn kind_row_name(kind: ModelKind) -> &'static str {
    match kind {
        ModelKind::DrlInt8 => "DRL",
        ModelKind::DrlF32 => "DRL-f32",
        ModelKind::Msra => "MSRA",
        ModelKind::Gssm => "GSSM",
    }
}

/// Row name of a decoded model: [`kind_row_name`], except that a GSSM blob scoring the spacing CDF
/// (`GssmScore::Cdf` / `Logit`, the fine-tuned SSRA risk) is `SSRA` (the GSSM baseline reports its
/// intensity, `GssmScore::Intensity`), and an MSRA with an embedded GSSM term is `MSRA-GSSM`: each
/// method of the paper has its own name, so its own colour in every figure.
pub fn model_row_name(model: &Model<'_>) -> &'static str {
    match model {
        Model::Gssm(g) if g.score != GssmScore::Intensity => "SSRA",
        Model::Msra(m) if m.gssm.is_some() => "MSRA-GSSM",
        m => kind_row_name(m.kind()),
    }
}

/// Row names for models loaded from files, from `(explicit name, default name, file stem)`: the
/// explicit name when given, else the default ([`model_row_name`]); when two or more rows would
/// share a default name, each of them takes its file stem instead (and names that still collide
/// get `#position`, 1-based).
pub fn row_names(models: &[(Option<String>, &str, String)]) -> Vec<String> {
    let base: Vec<String> = models
        .iter()
        .map(|(explicit, default, _)| explicit.clone().unwrap_or_else(|| (*default).to_owned()))
        .collect();
    let mut names: Vec<String> = base
        .iter()
        .zip(models)
        .map(|(b, (explicit, _, stem))| {
            let shared = base.iter().filter(|x| *x == b).count() > 1;
            if shared && explicit.is_none() {
                stem.clone()
            } else {
                b.clone()
            }
        })
        .collect();
    let snapshot = names.clone();
    for (i, n) in names.iter_mut().enumerate() {
        if snapshot.iter().filter(|x| *x == n).count() > 1 {
            *n = format!("{n}#{}", i + 1);
        }
    }
    names
}

/// The columns of the `riskctl score` table that are not model columns: the frame's identity and
/// the surrogates (model columns and their `<model>_in_domain` flags go between and after).
pub const FIXED_SCORE_COLUMNS: [&str; 7] = [
    "event_id",
    "time",
    "class",
    "ttc2d",
    "tadv",
    "ei",
    "tadv_corridor",
];

/// Suffix of a guarded model's flag column in the score table.
const IN_DOMAIN_SUFFIX: &str = "_in_domain";

/// Why a model may not take the row (and column) name `name`, if it may not: it equals,
/// case-insensitively, a baseline row (TTC2D, TAdv, EI, TAdv-corridor, which the evaluation reports
/// next to the models) or a fixed column of the score table ([`FIXED_SCORE_COLUMNS`]), or it ends in
/// `_in_domain` (a guarded model's flag column). Otherwise the report would hold two rows, or the
/// table two columns, of one name.
pub fn reserved_name_clash(name: &str) -> Option<String> {
    if let Some(b) = Baseline::EVERY
        .into_iter()
        .find(|b| b.name().eq_ignore_ascii_case(name))
    {
        return Some(format!("the baseline row {}", b.name()));
    }
    if let Some(c) = FIXED_SCORE_COLUMNS
        .iter()
        .find(|c| c.eq_ignore_ascii_case(name))
    {
        return Some(format!("the score table's column `{c}`"));
    }
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(IN_DOMAIN_SUFFIX) {
        return Some(format!(
            "the score table's `<model>{IN_DOMAIN_SUFFIX}` flag columns"
        ));
    }
    None
}

/// One method's scored sequences and curve.
#[derive(Clone, Debug)]
pub struct MethodRun {
    pub name: String,
    pub scored: Vec<ScoredSequence>,
    pub curve: WarningCurve,
}

/// Scores every sequence with every method and evaluates each ([`evaluate_scored`]).
pub fn evaluate_methods(
    observed: &[ObservedSequence],
    methods: &[Method<'_>],
) -> Result<(EvaluationReport, Vec<MethodRun>), ProtocolError> {
    let scored = methods
        .iter()
        .map(|m| {
            let seqs = observed
                .iter()
                .map(|s| s.score(|f| m.scorer.score(&f.observation)))
                .collect();
            (m.name.clone(), seqs)
        })
        .collect();
    evaluate_scored(scored)
}

/// Evaluates methods from their per-frame scores: the entry point for scores computed elsewhere
/// (training folds, the CAN bridge). Returns the report (table/JSON/CSV) and each method's scored
/// sequences and curve (for plots). Event counts are those of the first method's sequences (every
/// method is expected to score the same sequences).
pub fn evaluate_scored(
    methods: Vec<(String, Vec<ScoredSequence>)>,
) -> Result<(EvaluationReport, Vec<MethodRun>), ProtocolError> {
    let events = methods
        .first()
        .map(|(_, seqs)| EventCounts::from_classes(seqs.iter().map(|s| s.kind)))
        .unwrap_or_default();
    let mut runs = Vec::with_capacity(methods.len());
    for (name, scored) in methods {
        let curve = warning_curve(&alert_profiles(&scored)?);
        runs.push(MethodRun {
            name,
            scored,
            curve,
        });
    }
    let report = report_of(events, runs.iter().map(|r| (&r.name, &r.curve)));
    Ok((report, runs))
}

/// The report of named warning curves: each method's metrics, read off its curve.
pub(crate) fn report_of<'c>(
    events: EventCounts,
    curves: impl Iterator<Item = (&'c String, &'c WarningCurve)>,
) -> EvaluationReport {
    EvaluationReport {
        events,
        methods: curves
            .map(|(name, curve)| MethodResult {
                name: name.clone(),
                metrics: curve.metrics(),
            })
            .collect(),
    }
}

/// The report from per-sequence alert data built elsewhere, e.g. the CAN bridge streaming its own
/// per-frame scores through [`AlertProfileBuilder`](super::protocol::AlertProfileBuilder). Same
/// numbers as [`evaluate_scored`] on the frames the profiles were built from.
pub fn report_from_profiles(methods: &[(String, Vec<AlertProfile>)]) -> EvaluationReport {
    let events = methods
        .first()
        .map(|(_, p)| EventCounts::from_classes(p.iter().map(|p| p.kind)))
        .unwrap_or_default();
    let curves: Vec<WarningCurve> = methods.iter().map(|(_, p)| warning_curve(p)).collect();
    report_of(events, methods.iter().map(|(name, _)| name).zip(&curves))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(v: &[(Option<&str>, &'static str, &str)]) -> Vec<String> {
        let owned: Vec<(Option<String>, &str, String)> = v
            .iter()
            .map(|(e, d, s)| (e.map(str::to_owned), *d, (*s).to_owned()))
            .collect();
        row_names(&owned)
    }

    #[test]
    fn baseline_and_fixed_column_names_are_reserved() {
        for name in [
            "TTC2D", "ttc2d", "TAdv", "tadv", "EI", "event_id", "Time", "CLASS",
        ] {
            assert!(reserved_name_clash(name).is_some(), "{name}");
        }
        assert!(reserved_name_clash("DRL_in_domain").is_some());
        for name in ["DRL", "MSRA", "mine", "ttc", "events"] {
            assert_eq!(reserved_name_clash(name), None, "{name}");
        }
    }

    #[test]
    fn row_names_fall_back_to_stems_only_when_shared() {
        assert_eq!(
            rows(&[(None, "DRL", "drl-default"), (None, "MSRA", "msra-default")]),
            ["DRL", "MSRA"]
        );
        assert_eq!(
            rows(&[
                (None, "MSRA", "msra-default"),
                (None, "MSRA", "msra-gssm"),
                (None, "DRL", "drl")
            ]),
            ["msra-default", "msra-gssm", "DRL"]
        );
        // Explicit names win; identical stems from different folders are told apart by position.
        assert_eq!(
            rows(&[
                (Some("SSRA"), "GSSM", "x"),
                (None, "DRL", "m"),
                (None, "DRL", "m")
            ]),
            ["SSRA", "m#2", "m#3"]
        );
    }

    #[test]
    fn baselines_score_in_their_risk_direction() {
        let frame = |ttc: f32, ei: f32| Observation {
            features: [0.0; scorer_core::FEATURE_COUNT],
            surrogates: scorer_core::Surrogates {
                box_distance: 5.0,
                ttc2d: ttc,
                tadv: f32::INFINITY,
                tadv_corridor: f32::INFINITY,
                ei,
            },
            drl_inputs: [0.0; scorer_core::DRL_INPUT_COUNT],
        };
        let ttc = Scorer::Baseline(Baseline::Ttc2d);
        assert!(ttc.score(&frame(1.0, 0.0)) > ttc.score(&frame(3.0, 0.0)));
        let ei = Scorer::Baseline(Baseline::Ei);
        assert!(ei.score(&frame(1.0, 4.0)) > ei.score(&frame(1.0, 2.0)));
        let tadv = Scorer::Baseline(Baseline::Tadv);
        assert_eq!(
            tadv.score(&frame(1.0, 0.0)),
            super::super::protocol::NO_CONFLICT_RISK
        );
    }
}

#[cfg(test)]
mod baseline_rows {
    use super::*;
    use scorer_core::msra::{MsraModel, MsraTerm};

    fn msra_over(kinds: &[SurrogateKind]) -> Method<'static> {
        let terms: Vec<MsraTerm> = kinds
            .iter()
            .map(|&kind| MsraTerm {
                kind,
                weight: 1.0,
                a: -1.0,
                b: 0.0,
                lo: 0.0,
                hi: 5.0,
            })
            .collect();
        Method {
            name: "MSRA".into(),
            scorer: Scorer::Model(Model::Msra(MsraModel {
                terms: scorer_core::bounded::BoundedVec::from_slice(&terms).unwrap(),
                gssm: None,
            })),
        }
    }

    fn names(methods: &[Method<'_>]) -> Vec<String> {
        methods.iter().map(|m| m.name.clone()).collect()
    }

    #[test]
    fn a_model_is_reported_beside_each_of_its_inputs_once() {
        // The published three always; TAdv-corridor where a model reads it, once.
        assert_eq!(names(&Method::baselines_for(&[])), ["TTC2D", "TAdv", "EI"]);
        let reference = msra_over(&[SurrogateKind::Tadv, SurrogateKind::Ei]);
        assert_eq!(
            names(&Method::baselines_for(std::slice::from_ref(&reference))),
            ["TTC2D", "TAdv", "EI"]
        );
        let corridor = msra_over(&[SurrogateKind::TadvCorridor, SurrogateKind::Ei]);
        let both = [corridor.clone(), corridor, reference];
        assert_eq!(
            names(&Method::baselines_for(&both)),
            ["TTC2D", "TAdv", "EI", "TAdv-corridor"]
        );
        // GSSM is a model, not a baseline.
        assert_eq!(
            Baseline::read_by([SurrogateKind::Gssm, SurrogateKind::TadvCorridor]),
            [
                Baseline::Ttc2d,
                Baseline::Tadv,
                Baseline::Ei,
                Baseline::TadvCorridor
            ]
        );
        // The row scores TAdv-corridor's own value, not the reference's.
        let o = scorer_core::Observation::of(
            &scorer_core::VehicleState {
                vx: 15.0,
                hx: 1.0,
                length: 4.5,
                width: 1.8,
                ..Default::default()
            },
            &scorer_core::VehicleState {
                x: 20.0,
                y: 4.0,
                hx: 1.0,
                length: 4.5,
                width: 1.8,
                ..Default::default()
            },
        );
        assert_eq!(
            Baseline::TadvCorridor.risk(&o.surrogates),
            crate::protocol::NO_CONFLICT_RISK
        );
        assert!(Baseline::Tadv.risk(&o.surrogates) > -2.0);
    }
}
