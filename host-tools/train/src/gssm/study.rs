//! Studies: event-level cross-validation of GSSM, SSRA and the MSRA-with-GSSM configurations
//! against the surrogate baselines, and the simulation-augmentation study.
//!
//! Every trained model is exported to its blob and scored on the test fold through
//! `scorer_core::model::decode` + `Model::score_observation` (the deployed path), then evaluated by
//! [`riskscore_eval`]; folds come from [`riskscore_data::events::kfold_by_event`], comparisons from
//! [`crate::train::prepare_comparisons`] on the training part only.
use serde::Serialize;

use super::config::GssmConfig;
use super::fit::{fit_gssm, FitReport};
use super::guard::guard_blobs;
use super::msra::{align_msra_gssm, row_name as msra_row_name, TermWeight};
use super::ssra::align_ssra;
use super::GssmError;
use crate::train::{self, Progress, TrainConfig};
use riskscore_data::events::{kfold_by_event, Sequence};
use riskscore_eval::report::{aggregate, CvReport, EventCounts, FoldResult};
use riskscore_eval::scoring::{
    evaluate_methods, observe, Method, MethodRun, ObservedSequence, Scorer,
};
use scorer_core::gssm::GssmScore;
use scorer_core::msra::MsraTerm;
use scorer_core::SurrogateKind;

/// Options of [`cross_validate`].
#[derive(Clone, Debug)]
pub struct CvOptions {
    pub folds: usize,
    /// One CV run per seed (fold assignment, comparisons, initialisation).
    pub seeds: Vec<u64>,
    /// MSRA configurations to train (each reads the fold's GSSM).
    pub configurations: Vec<Vec<SurrogateKind>>,
    /// Include the TTC2D, TAdv, EI baseline rows.
    pub baselines: bool,
    /// The kinematic terms of the MSRA trained beside the fold's models (the benchmarks pass the
    /// fold's): with them every blob carries the training domain of its GSSM's fit data under
    /// the training configuration's `[guard] policy` ([`guard_blobs`]) and is scored through it,
    /// as the shipped ones are; without, the blobs are unguarded.
    pub fallback_terms: Option<Vec<MsraTerm>>,
}

/// What one fold trained.
#[derive(Clone, Debug, Serialize)]
pub struct FoldDetail {
    pub seed: u64,
    pub fold: usize,
    pub gssm: FitReport,
    pub ssra_epochs: usize,
    pub ssra_best_epoch: usize,
    pub ssra_kept_initial: bool,
    pub ssra_validation_before: Option<f64>,
    pub ssra_validation_after: Option<f64>,
    /// Per MSRA configuration: its row name and learned weights.
    pub msra: Vec<(String, Vec<TermWeight>)>,
}

/// The result of [`cross_validate`].
#[derive(Clone, Debug, Serialize)]
pub struct GssmCvResult {
    pub report: CvReport,
    pub folds: Vec<FoldResult>,
    pub details: Vec<FoldDetail>,
    /// Per fold, the models whose kinematic fallback could not be fitted (guard `flag-only`).
    pub warnings: Vec<String>,
}

fn counts(seqs: &[Sequence]) -> EventCounts {
    EventCounts::from_classes(seqs.iter().map(|s| s.kind))
}

fn pick(seqs: &[Sequence], idx: &[usize]) -> Vec<Sequence> {
    idx.iter().map(|&i| seqs[i].clone()).collect()
}

/// Evaluate named blobs (plus the baselines) on observed test sequences.
fn evaluate_blobs(
    observed: &[ObservedSequence],
    blobs: &[(String, Vec<u8>)],
    baselines: bool,
) -> Result<(Vec<riskscore_eval::report::MethodResult>, Vec<MethodRun>), GssmError> {
    let mut models = Vec::new();
    for (name, blob) in blobs {
        // Scored as the ECU and `riskctl evaluate` score the exported file.
        models.push(Method {
            name: name.clone(),
            scorer: Scorer::of_blob(scorer_core::model::decode_blob(blob)?),
        });
    }
    // The baselines first (this study's table order), each model's inputs among them.
    let mut methods = if baselines {
        Method::baselines_for(&models)
    } else {
        Vec::new()
    };
    methods.extend(models);
    let (report, runs) = evaluate_methods(observed, &methods)?;
    Ok((report.methods, runs))
}

/// What [`train_fold`] trained and how its models scored the test sequences.
pub struct GssmFold {
    pub methods: Vec<riskscore_eval::report::MethodResult>,
    /// Every method's scored test sequences (e.g. to read a threshold off its curve).
    pub runs: Vec<MethodRun>,
    pub detail: FoldDetail,
    /// Models whose kinematic fallback could not be fitted (their guard became `flag-only`).
    pub warnings: Vec<String>,
    /// The fold's model blobs by row name (GSSM, SSRA, the MSRA configurations), as scored:
    /// with their training-domain record when guarded.
    pub blobs: Vec<(String, Vec<u8>)>,
}

/// One fold: fit the GSSM on the safe sequences of `normal` (the normal driving it models: the
/// benchmarks pass every safe training sequence, simulated and real, as the shipped GSSM is
/// fitted; the training sequences themselves when `None`), align it to SSRA with the
/// comparisons of `train`, train the MSRA configurations over it, and score `test` through the
/// deployed path, through the guard of `options.fallback_terms`. `cfg.seed` seeds everything.
pub fn train_fold(
    train: &[Sequence],
    normal: Option<&[Sequence]>,
    test: &[ObservedSequence],
    cfg: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &CvOptions,
    progress: Progress,
) -> Result<GssmFold, GssmError> {
    let prepared = train::prepare_comparisons(train, None, cfg);
    let gssm = fit_gssm(
        normal.unwrap_or(train),
        cfg.optimiser.validation_fraction,
        cfg.seed,
        &gssm_config.fit,
        progress,
    )?;
    let ssra = align_ssra(&gssm.params, &prepared, cfg, &gssm_config.ssra, progress)?;
    let mut blobs = vec![
        (
            "GSSM".to_string(),
            gssm.params.gssm_blob(GssmScore::Intensity)?,
        ),
        ("SSRA".to_string(), ssra.blob()?),
    ];
    let mut msra_weights = Vec::new();
    for kinds in &options.configurations {
        let m = align_msra_gssm(
            kinds,
            &gssm.params,
            train,
            &prepared,
            cfg,
            gssm_config.msra.learning_rate,
            progress,
        )?;
        let name = msra_row_name(kinds);
        msra_weights.push((name.clone(), m.params.weights()));
        blobs.push((name, m.params.blob()?));
    }
    let warnings = match &options.fallback_terms {
        Some(terms) => guard_blobs(
            &mut blobs,
            normal.unwrap_or(train),
            cfg.guard.policy,
            Some(terms),
        )?,
        None => Vec::new(),
    };
    let (methods, runs) = evaluate_blobs(test, &blobs, options.baselines)?;
    Ok(GssmFold {
        methods,
        runs,
        warnings,
        blobs,
        detail: FoldDetail {
            seed: cfg.seed,
            fold: 0,
            gssm: gssm.report,
            ssra_epochs: ssra.report.epochs,
            ssra_best_epoch: ssra.report.best_epoch,
            ssra_kept_initial: ssra.kept_initial,
            ssra_validation_before: ssra.initial_validation.map(|p| p.total),
            ssra_validation_after: ssra.final_validation.map(|p| p.total),
            msra: msra_weights,
        },
    })
}

/// K-fold event-level CV of GSSM (intensity), SSRA and the MSRA configurations, per seed. With
/// `normal`, every fold's GSSM is fitted on those (real, normal-driving) sequences instead of the
/// fold's own safe sequences.
pub fn cross_validate(
    seqs: &[Sequence],
    normal: Option<&[Sequence]>,
    train_config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &CvOptions,
    progress: Progress,
) -> Result<GssmCvResult, GssmError> {
    let mut folds_out = Vec::new();
    let mut details = Vec::new();
    let mut warnings = Vec::new();
    for &seed in &options.seeds {
        let folds = kfold_by_event(seqs, options.folds, seed);
        for fold in 0..folds.k() {
            let train_seqs = pick(seqs, &folds.train(fold));
            let test = observe(&pick(seqs, &folds.test(fold)));
            let mut cfg = train_config.clone();
            cfg.seed = seed.wrapping_mul(1000).wrapping_add(fold as u64);
            let out = train_fold(
                &train_seqs,
                normal,
                &test,
                &cfg,
                gssm_config,
                options,
                progress,
            )?;
            folds_out.push(FoldResult {
                seed,
                fold,
                methods: out.methods,
            });
            details.push(FoldDetail {
                seed,
                fold,
                ..out.detail
            });
            warnings.extend(
                out.warnings
                    .into_iter()
                    .map(|w| format!("seed {seed} fold {fold}: {w}")),
            );
        }
    }
    Ok(GssmCvResult {
        report: aggregate(counts(seqs), &folds_out),
        folds: folds_out,
        details,
        warnings,
    })
}

/// Mean (over folds and seeds) of each configuration's learned weights, in term order.
pub fn mean_weights(details: &[FoldDetail]) -> Vec<(String, Vec<TermWeight>)> {
    let mut out: Vec<(String, Vec<TermWeight>, usize)> = Vec::new();
    for d in details {
        for (name, ws) in &d.msra {
            match out.iter_mut().find(|(n, _, _)| n == name) {
                Some((_, acc, count)) => {
                    for (a, w) in acc.iter_mut().zip(ws) {
                        a.w += w.w;
                        a.a += w.a;
                        a.b += w.b;
                        a.span += w.span;
                        a.share += w.share;
                        a.risk_consistent &= w.risk_consistent;
                    }
                    *count += 1;
                }
                None => out.push((name.clone(), ws.clone(), 1)),
            }
        }
    }
    out.into_iter()
        .map(|(name, mut ws, count)| {
            let c = count as f32;
            for w in &mut ws {
                w.w /= c;
                w.a /= c;
                w.b /= c;
                w.span /= c;
                w.share /= c;
            }
            (name, ws)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Simulation augmentation.

/// The parameterisation trained in the augmentation study.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum StudyModel {
    /// GSSM fitted on the arm's primary data, then aligned (SSRA).
    Ssra,
    /// The DRL network, evaluated through its int8 export.
    Drl,
}

impl StudyModel {
    pub fn parse(s: &str) -> Option<StudyModel> {
        match s.trim().to_ascii_lowercase().as_str() {
            "ssra" => Some(StudyModel::Ssra),
            "drl" => Some(StudyModel::Drl),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            StudyModel::Ssra => "SSRA",
            StudyModel::Drl => "DRL",
        }
    }
}

/// Options of [`augmentation_study`].
#[derive(Clone, Debug)]
pub struct AugmentationOptions {
    pub folds: usize,
    pub seed: u64,
    /// Real budgets: fractions of each fold's real training events (e.g. `[0.2, 1.0]`).
    pub budgets: Vec<f64>,
    /// Simulated pairs as multiples of the real pair target (e.g. `[0.5, 1, 2]`).
    pub sim_ratios: Vec<f64>,
    pub model: StudyModel,
}

/// One budget's results: rows `sim only`, `real only`, `real + sim xR`.
#[derive(Clone, Debug, Serialize)]
pub struct BudgetResult {
    pub budget: f64,
    pub report: CvReport,
}

/// The result of [`augmentation_study`].
#[derive(Clone, Debug, Serialize)]
pub struct AugmentationReport {
    pub model: StudyModel,
    pub real_events: EventCounts,
    pub sim_events: EventCounts,
    pub budgets: Vec<BudgetResult>,
}

impl AugmentationReport {
    pub fn to_markdown(&self) -> String {
        let mut out = format!(
            "Simulation-augmentation study ({}): test folds are always real events.\n\n",
            self.model.name()
        );
        for b in &self.budgets {
            out.push_str(&format!(
                "### Real budget {:.0} % of each fold's training events\n\n{}\n",
                b.budget * 100.0,
                b.report.to_markdown()
            ));
        }
        out
    }
}

/// Train the study's model on prepared comparisons and return its blob.
fn train_blob(
    model: StudyModel,
    primary: &[Sequence],
    prepared: &train::PreparedComparisons,
    cfg: &TrainConfig,
    gssm_config: &GssmConfig,
    progress: Progress,
) -> Result<Vec<u8>, GssmError> {
    match model {
        StudyModel::Ssra => {
            let gssm = fit_gssm(
                primary,
                cfg.optimiser.validation_fraction,
                cfg.seed,
                &gssm_config.fit,
                progress,
            )?;
            align_ssra(&gssm.params, prepared, cfg, &gssm_config.ssra, progress)?.blob()
        }
        StudyModel::Drl => {
            let drl = train::train_drl(primary, prepared, cfg, progress)?;
            let q = crate::quantize::quantize(&drl.params, &drl.calibration)
                .map_err(|e| GssmError::Export(e.into()))?;
            Ok(crate::export::drl_int8_blob(&q)?)
        }
    }
}

/// Arm label of a simulated-pair ratio.
pub fn arm_label(ratio: Option<f64>) -> String {
    match ratio {
        None => "real only".to_string(),
        Some(r) => format!("real + sim x{r}"),
    }
}

/// Sim-only, real-only and real + increasing simulated comparisons, at each real budget, under
/// K-fold CV on the REAL events (tests are real folds). "Sim only" trains on every simulated event
/// with the ordinary constructions (no real event at all); the augmented arms add the simulated
/// constructions as the `simulation` source (its own `beta`) with `ratio x` the real pair target.
pub fn augmentation_study(
    real: &[Sequence],
    sim: &[Sequence],
    train_config: &TrainConfig,
    gssm_config: &GssmConfig,
    options: &AugmentationOptions,
    progress: Progress,
) -> Result<AugmentationReport, GssmError> {
    let sim_ts = sim.to_vec();
    let folds = kfold_by_event(real, options.folds, options.seed);
    let mut per_budget: Vec<Vec<FoldResult>> = vec![Vec::new(); options.budgets.len()];
    let real_target = {
        let c = &train_config.comparisons;
        c.temporal.pairs + c.cross_sequence.pairs + c.physics.pairs
    };
    for fold in 0..folds.k() {
        let train_all = pick(real, &folds.train(fold));
        let test = observe(&pick(real, &folds.test(fold)));
        let mut cfg = train_config.clone();
        cfg.seed = options.seed.wrapping_mul(1000).wrapping_add(fold as u64);
        // Sim only: independent of the real budget.
        let sim_prepared = train::prepare_comparisons(&sim_ts, None, &cfg);
        let sim_blob = train_blob(
            options.model,
            &sim_ts,
            &sim_prepared,
            &cfg,
            gssm_config,
            progress,
        )?;
        for (bi, &budget) in options.budgets.iter().enumerate() {
            let subset = if budget >= 1.0 {
                train_all.clone()
            } else {
                train::split_validation(&train_all, 1.0 - budget, cfg.seed ^ 0xB0D6E7).0
            };
            let mut blobs = vec![("sim only".to_string(), sim_blob.clone())];
            let prepared = train::prepare_comparisons(&subset, None, &cfg);
            blobs.push((
                arm_label(None),
                train_blob(
                    options.model,
                    &subset,
                    &prepared,
                    &cfg,
                    gssm_config,
                    progress,
                )?,
            ));
            for &ratio in &options.sim_ratios {
                let mut c = cfg.clone();
                c.comparisons.simulation.pairs = (real_target as f64 * ratio).round() as usize;
                let prepared = train::prepare_comparisons(&subset, Some(&sim_ts), &c);
                blobs.push((
                    arm_label(Some(ratio)),
                    train_blob(options.model, &subset, &prepared, &c, gssm_config, progress)?,
                ));
            }
            let (methods, _) = evaluate_blobs(&test, &blobs, false)?;
            per_budget[bi].push(FoldResult {
                seed: options.seed,
                fold,
                methods,
            });
        }
    }
    Ok(AugmentationReport {
        model: options.model,
        real_events: counts(real),
        sim_events: counts(sim),
        budgets: options
            .budgets
            .iter()
            .zip(per_budget)
            .map(|(&budget, folds)| BudgetResult {
                budget,
                report: aggregate(counts(real), &folds),
            })
            .collect(),
    })
}
