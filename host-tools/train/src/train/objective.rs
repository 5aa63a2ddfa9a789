//! The training objective on candle tensors:
//!
//! `L = L_pair + lambda_impact * L_impact + lambda_upper * L_upper`, with
//! - `L_pair = mean_i beta_{s(i)} a_i * -log sigmoid(R(o_w,i) - R(o_l,i))` (source-weighted
//!   Bradley-Terry; `-log sigmoid(d)` is evaluated as `relu(-d) + log(1 + exp(-|d|))`, exact and
//!   overflow-free),
//! - `L_impact = mean_j (R(o_j) - r*)^2` over impact-window states,
//! - `L_upper = mean_j relu(R(o_j) - u)^2` over earlier conflict states.
//!
//! An empty term contributes 0.
use candle_core::{Result, Tensor};

use super::config::ObjectiveConfig;

/// Value of each term (for logs and reports).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LossParts {
    pub pair: f64,
    pub impact: f64,
    pub upper: f64,
    pub total: f64,
}

/// `-log sigmoid(d)`, element-wise and numerically stable.
pub fn neg_log_sigmoid(d: &Tensor) -> Result<Tensor> {
    let pos = d.neg()?.relu()?;
    let soft = (d.abs()?.neg()?.exp()? + 1.0)?.log()?;
    pos + soft
}

/// The objective from the scores of one batch.
///
/// `winners`, `losers`, `pair_weights` have one entry per pair (`pair_weights = beta_s * a_i`);
/// `impact` and `upper` hold the scores of the anchor states (possibly empty).
pub fn objective(
    winners: &Tensor,
    losers: &Tensor,
    pair_weights: &Tensor,
    impact: &Tensor,
    upper: &Tensor,
    config: &ObjectiveConfig,
) -> Result<(Tensor, LossParts)> {
    let device = winners.device().clone();
    let zero = || Tensor::new(0f32, &device);
    let pair = if winners.elem_count() > 0 {
        let d = (winners - losers)?;
        (neg_log_sigmoid(&d)? * pair_weights)?.mean_all()?
    } else {
        zero()?
    };
    let l_impact = if impact.elem_count() > 0 && config.lambda_impact > 0.0 {
        (impact - config.r_star as f64)?.sqr()?.mean_all()?
    } else {
        zero()?
    };
    let l_upper = if upper.elem_count() > 0 && config.lambda_upper > 0.0 {
        (upper - config.u as f64)?.relu()?.sqr()?.mean_all()?
    } else {
        zero()?
    };
    let total = ((&pair + (&l_impact * config.lambda_impact as f64)?)?
        + (&l_upper * config.lambda_upper as f64)?)?;
    let parts = LossParts {
        pair: pair.to_scalar::<f32>()? as f64,
        impact: l_impact.to_scalar::<f32>()? as f64,
        upper: l_upper.to_scalar::<f32>()? as f64,
        total: total.to_scalar::<f32>()? as f64,
    };
    Ok((total, parts))
}
