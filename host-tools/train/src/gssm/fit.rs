//! Fitting the GSSM by the lognormal negative log-likelihood of the spacings of safe driving.
//!
//! Per observation, with `(mu, v = sigma^2)` the clamped heads at its context `x`:
//! `nll = 1/2 ln(2 pi) + 1/2 ln v + (ln s - mu)^2 / (2 v)` (the Gaussian NLL of `ln s`; the
//! lognormal one adds `ln s`, a constant of the data). The optional smoothness regulariser of the
//! original GSSM adds `lambda * KL(N(mu, v) || N(mu', v'))`, where `(mu', v')` are the heads at
//! `x + eps`, `eps ~ N(0, noise^2)` per standardised feature: nearby contexts should predict
//! nearby distributions.
//!
//! Data: the frames of the SAFE sequences of the training events with a finite positive spacing.
//! The training events are split by event (the same [`crate::train::split_validation`] as the
//! comparison trainer, so the held-out events are the same) and the held-out safe frames decide
//! early stopping; the best parameters are restored.
use std::time::Instant;

use candle_core::{Device, Tensor};
use candle_nn::Optimizer;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use scorer_core::gssm::S_INDEX;
use scorer_core::{Features, FEATURE_COUNT};
use serde::Serialize;

use super::config::FitConfig;
use super::net::{GssmNet, GssmParams, CONTEXT_WIDTH, ROW_WIDTH};
use super::GssmError;
use crate::nn::trainer::{adamw, EarlyStopping, EpochOutcome, Progress};
use crate::train::drl::FeatureScaler;
use riskscore_data::events::Sequence;

/// What a GSSM fit did.
#[derive(Clone, Debug, Serialize)]
pub struct FitReport {
    pub epochs: usize,
    pub best_epoch: usize,
    pub stopped_early: bool,
    pub seconds: f64,
    pub observations: usize,
    pub validation_observations: usize,
    /// Mean Gaussian NLL of `ln s` (nats) on the fit observations at the kept parameters.
    pub train_nll: f64,
    /// Same on the validation observations (when there are any).
    pub validation_nll: Option<f64>,
    /// Per epoch: mean training objective (NLL + smoothness) and validation NLL.
    pub history: Vec<(usize, f64, Option<f64>)>,
}

/// A fitted GSSM.
#[derive(Clone, Debug)]
pub struct TrainedGssm {
    pub params: GssmParams,
    pub report: FitReport,
}

/// Features of every frame of the safe sequences whose spacing is finite and positive.
pub fn safe_observations(seqs: &[Sequence]) -> Vec<Features> {
    seqs.iter()
        .filter(|s| !s.is_conflict())
        .flat_map(|s| {
            s.frames
                .iter()
                .map(|f| scorer_core::features(&f.ego, &f.partner))
        })
        .filter(|f| f[S_INDEX].is_finite() && f[S_INDEX] > 0.0)
        .collect()
}

/// Mean and standard deviation of every feature over `obs` (degenerate features get `std = 1`), in
/// the [`FeatureScaler`] the core's standardisation reads.
pub fn scaler_of(obs: &[Features]) -> FeatureScaler {
    let mut mean = vec![0f32; FEATURE_COUNT];
    let mut std = vec![1f32; FEATURE_COUNT];
    for k in 0..FEATURE_COUNT {
        let v: Vec<f64> = obs
            .iter()
            .map(|f| f64::from(f[k]))
            .filter(|x| x.is_finite())
            .collect();
        if v.is_empty() {
            continue;
        }
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        mean[k] = m as f32;
        std[k] = if sd > 1e-6 { sd as f32 } else { 1.0 };
    }
    FeatureScaler { mean, std }
}

/// Fit a GSSM on the safe frames of the training sequences (validation split by event as the
/// comparison trainer does with `validation_fraction` and `seed`).
pub fn fit_gssm(
    train: &[Sequence],
    validation_fraction: f64,
    seed: u64,
    config: &FitConfig,
    progress: Progress,
) -> Result<TrainedGssm, GssmError> {
    let (fit, val) = crate::train::split_validation(train, validation_fraction, seed);
    let fit_obs = safe_observations(&fit);
    let val_obs = safe_observations(&val);
    fit_gssm_on_observations(&fit_obs, &val_obs, config, seed, progress)
}

/// Gaussian NLL of `ln s` per row and, with `smooth`, the KL smoothness term, for encoded rows.
fn objective(
    net: &GssmNet,
    rows: &Tensor,
    smooth: Option<(f32, &Tensor)>,
) -> candle_core::Result<(Tensor, Tensor)> {
    let ctx = rows.narrow(1, 0, CONTEXT_WIDTH)?;
    let ln_s = rows.narrow(1, CONTEXT_WIDTH, 1)?.squeeze(1)?;
    let (mu, lv) = net.heads(&ctx)?;
    let resid = (ln_s - &mu)?;
    let nll = ((&lv * 0.5)? + (resid.sqr()? * (lv.neg()?.exp()? * 0.5)?)?)?
        .affine(1.0, 0.5 * (2.0 * std::f64::consts::PI).ln())?
        .mean_all()?;
    let total = match smooth {
        Some((lambda, noise)) if lambda > 0.0 => {
            let (mu2, lv2) = net.heads(&(&ctx + noise)?)?;
            // KL(N(mu, e^lv) || N(mu2, e^lv2)) = 1/2 (lv2 - lv + (e^lv + (mu - mu2)^2) / e^lv2 - 1)
            let num = (lv.exp()? + (&mu - &mu2)?.sqr()?)?;
            let kl = ((&lv2 - &lv)? + (num * lv2.neg()?.exp()?)?)?
                .affine(0.5, -0.5)?
                .mean_all()?;
            (&nll + (kl * f64::from(lambda))?)?
        }
        _ => nll.clone(),
    };
    Ok((total, nll))
}

/// Fit a GSSM on given observations (all must have a finite positive spacing). The feature
/// standardisation and the head initialisation (marginal lognormal) are measured on `obs`;
/// `validation` (possibly empty) decides early stopping.
pub fn fit_gssm_on_observations(
    obs: &[Features],
    validation: &[Features],
    config: &FitConfig,
    seed: u64,
    progress: Progress,
) -> Result<TrainedGssm, GssmError> {
    let usable = |f: &&Features| f[S_INDEX].is_finite() && f[S_INDEX] > 0.0;
    let obs: Vec<Features> = obs.iter().filter(usable).copied().collect();
    let validation: Vec<Features> = validation.iter().filter(usable).copied().collect();
    if obs.len() < 2 {
        return Err(GssmError::NoSafeObservations);
    }
    let started = Instant::now();
    let ln_s: Vec<f64> = obs.iter().map(|f| f64::from(f[S_INDEX]).ln()).collect();
    let m = ln_s.iter().sum::<f64>() / ln_s.len() as f64;
    let var = ln_s.iter().map(|x| (x - m).powi(2)).sum::<f64>() / ln_s.len() as f64;
    let net = GssmNet::new(
        scaler_of(&obs),
        &config.hidden,
        seed,
        m as f32,
        var.max(1e-6).ln() as f32,
    )?;
    let rows = net.rows_tensor(&obs)?;
    let val_rows = if validation.is_empty() {
        None
    } else {
        Some(net.rows_tensor(&validation)?)
    };
    let vars = net.vars();
    let mut opt = adamw(vars.clone(), config.learning_rate, config.weight_decay)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0655_DF17);
    let noise_dist =
        Normal::new(0.0f32, config.smoothness_noise).map_err(GssmError::SmoothnessNoise)?;
    let n = obs.len();
    let batches = n.div_ceil(config.batch).max(1);
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut history = Vec::new();
    let rule = EarlyStopping {
        max_epochs: config.max_epochs,
        patience: config.patience,
        min_delta: config.min_delta,
    };
    let stop = rule.run(&vars, "GSSM", progress, |epoch| {
        order.shuffle(&mut rng);
        let mut sum = 0.0f64;
        for b in 0..batches {
            let sel = &order[b * n / batches..(b + 1) * n / batches];
            let idx = Tensor::from_slice(sel, sel.len(), &Device::Cpu)?;
            let batch = rows.index_select(&idx, 0)?;
            let noise = if config.smoothness > 0.0 {
                let v: Vec<f32> = (0..sel.len() * CONTEXT_WIDTH)
                    .map(|_| noise_dist.sample(&mut rng))
                    .collect();
                Some(Tensor::from_vec(
                    v,
                    (sel.len(), CONTEXT_WIDTH),
                    &Device::Cpu,
                )?)
            } else {
                None
            };
            let (loss, _) =
                objective(&net, &batch, noise.as_ref().map(|t| (config.smoothness, t)))?;
            let value = f64::from(loss.to_scalar::<f32>()?);
            if !value.is_finite() {
                return Err(GssmError::Diverged { epoch });
            }
            opt.backward_step(&loss)?;
            sum += value;
        }
        let train_loss = sum / batches as f64;
        let val_nll = match &val_rows {
            Some(v) => Some(f64::from(objective(&net, v, None)?.1.to_scalar::<f32>()?)),
            None => None,
        };
        history.push((epoch, train_loss, val_nll));
        Ok(EpochOutcome {
            criterion: val_nll.unwrap_or(train_loss),
            message: match val_nll {
                Some(v) => format!("loss {train_loss:.4} val nll {v:.4}"),
                None => format!("loss {train_loss:.4}"),
            },
        })
    })?;
    let train_nll = f64::from(objective(&net, &rows, None)?.1.to_scalar::<f32>()?);
    let validation_nll = match &val_rows {
        Some(v) => Some(f64::from(objective(&net, v, None)?.1.to_scalar::<f32>()?)),
        None => None,
    };
    debug_assert_eq!(rows.dims2()?.1, ROW_WIDTH);
    Ok(TrainedGssm {
        params: net.params()?,
        report: FitReport {
            epochs: stop.epochs,
            best_epoch: stop.best_epoch,
            stopped_early: stop.stopped_early,
            seconds: started.elapsed().as_secs_f64(),
            observations: n,
            validation_observations: validation.len(),
            train_nll,
            validation_nll,
            history,
        },
    })
}

/// Ego-speed bands of the operating domain (m/s, `[lo, hi)`, docs/domain.md); the last one also
/// holds anything faster.
pub const SPEED_BANDS: [(f32, f32); 5] = [
    (0.0, 5.0),
    (5.0, 15.0),
    (15.0, 25.0),
    (25.0, 35.0),
    (35.0, 50.0),
];

/// Index of the ego speed among the features (`vy_ego`, the ego's speed along its heading).
const EGO_SPEED_INDEX: usize = 3;

/// How well a GSSM models one speed band of some normal driving.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BandNll {
    /// `[lo, hi)` ego speed (m/s).
    pub band: (f32, f32),
    pub observations: usize,
    /// Mean Gaussian NLL of `ln s` (nats); `None` without observations.
    pub nll: Option<f64>,
}

/// The GSSM's mean NLL on the safe observations of `seqs`, per ego-speed band ([`SPEED_BANDS`]):
/// where a model of normal driving fits the driving it has not seen, and where it does not.
pub fn nll_by_speed_band(
    params: &GssmParams,
    seqs: &[Sequence],
) -> Result<Vec<BandNll>, GssmError> {
    let obs = safe_observations(seqs);
    let last = SPEED_BANDS.len() - 1;
    let mut bands: Vec<Vec<Features>> = vec![Vec::new(); SPEED_BANDS.len()];
    for f in obs {
        let speed = f[EGO_SPEED_INDEX];
        let k = SPEED_BANDS
            .iter()
            .position(|&(lo, hi)| speed >= lo && speed < hi)
            .unwrap_or(last);
        bands[k].push(f);
    }
    SPEED_BANDS
        .iter()
        .zip(bands)
        .map(|(&band, obs)| {
            Ok(BandNll {
                band,
                observations: obs.len(),
                nll: if obs.is_empty() {
                    None
                } else {
                    Some(nll(params, &obs)?)
                },
            })
        })
        .collect()
}

/// Mean Gaussian NLL of `ln s` of the given parameters on observations (finite positive spacing).
pub fn nll(params: &GssmParams, obs: &[Features]) -> Result<f64, GssmError> {
    let obs: Vec<Features> = obs
        .iter()
        .filter(|f| f[S_INDEX].is_finite() && f[S_INDEX] > 0.0)
        .copied()
        .collect();
    if obs.is_empty() {
        return Err(GssmError::NoSafeObservations);
    }
    let net = GssmNet::from_params(params)?;
    let rows = net.rows_tensor(&obs)?;
    Ok(f64::from(
        objective(&net, &rows, None)?.1.to_scalar::<f32>()?,
    ))
}
