//! Physics counterfactuals: a recorded state is less risky than the same state made physically
//! worse, and riskier than the same state with the partner a lane further aside.
//!
//! Each candidate takes one frame (sequences drawn uniformly, then frames uniformly; conflict frames
//! at or before the endpoint) and perturbs ONE physical variable of the underlying vehicle states:
//! - [`Perturbation::Gap`]: the partner moves towards the ego along the centre-to-centre line of
//!   sight by a fraction of the current box distance;
//! - [`Perturbation::ClosingSpeed`]: the partner's velocity gains a component towards the ego along the
//!   line of sight (heading unchanged: a small side slip, as trackers report);
//! - [`Perturbation::LateralClearance`]: the partner moves towards the ego's longitudinal axis, in the
//!   ego frame, by a fraction of its lateral offset;
//! - [`Perturbation::Size`]: the partner's length and width grow by a factor (centre unchanged);
//! - [`Perturbation::LaneShift`] (opt-in, `lane_shift`): the partner moves AWAY from the ego's
//!   longitudinal axis, in the ego frame, by about a lane width. This one counterfactual is the
//!   safer state, so its pair is (recorded over counterfactual). The other four only ever bring a
//!   partner closer; this one shows the network the next-lane pass an in-lane approach becomes, at
//!   the same gap and speeds.
//!
//! The counterfactual observation is recomputed through `scorer_core::{features, surrogates}` and kept
//! only if the pair's order is verified by the core: the counterfactual's boxes must not overlap;
//! the box distance must shrink (gap, size), not grow (lateral clearance), not shrink (lane shift),
//! or the box distance after a constant-velocity horizon must shrink (closing speed); and, unless
//! disabled, no surrogate may call the winner safer than the loser (TTC2D and TAdv not larger, EI
//! not smaller). Rejections are counted.
//!
//! `a_i` is the perturbation magnitude (m, m/s, m, growth factor) normalised by its mean over the
//! source's pairs of the same kind, so the kinds are commensurable and average 1.
use rand::Rng;
use scorer_core::{box_distance, Surrogates, VehicleState};

use super::config::PhysicsConfig;
use super::draw::{normalise_mean_one, Draw};
use super::types::{Pair, SourceStats};

/// The physical variable a counterfactual changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Perturbation {
    Gap,
    ClosingSpeed,
    LateralClearance,
    Size,
    LaneShift,
}

impl Perturbation {
    pub const ALL: [Perturbation; 5] = [
        Perturbation::Gap,
        Perturbation::ClosingSpeed,
        Perturbation::LateralClearance,
        Perturbation::Size,
        Perturbation::LaneShift,
    ];

    /// The kinds a configuration draws, in turn: the four, and the lane shift when configured.
    pub fn enabled(config: &PhysicsConfig) -> &'static [Perturbation] {
        if config.lane_shift.is_some() {
            &Self::ALL
        } else {
            &Self::ALL[..4]
        }
    }

    /// Whether this kind's counterfactual is the safer state of its pair (the recorded frame wins).
    pub fn counterfactual_is_safer(self) -> bool {
        self == Perturbation::LaneShift
    }
}

/// Smallest box distance (m) a frame needs for a gap/size counterfactual to stay contact-free.
const MIN_GAP: f32 = 0.05;
/// Smallest lateral offset (m) worth reducing.
const MIN_LATERAL: f32 = 0.2;
/// Relative tolerance when comparing surrogates (float32 noise in the core's iterative parts).
const SURROGATE_TOL: f32 = 1e-4;

/// A counterfactual partner state and the magnitude of its perturbation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Counterfactual {
    pub kind: Perturbation,
    pub partner: VehicleState,
    pub magnitude: f32,
}

fn lerp_at(range: [f32; 2], u: f32) -> f32 {
    range[0] + (range[1] - range[0]) * u
}

fn advance(s: &VehicleState, horizon: f32) -> VehicleState {
    VehicleState {
        x: s.x + s.vx * horizon,
        y: s.y + s.vy * horizon,
        ..*s
    }
}

/// Apply perturbation `kind` with a uniform draw `u` in [0, 1) over its configured range. Returns
/// `None` when the state does not admit this perturbation (coincident centres, too small a gap or
/// lateral offset) or the kind is not configured (a lane shift without `lane_shift`).
// `!(x > y)` on purpose: NaN must fail every check.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn perturb(
    ego: &VehicleState,
    partner: &VehicleState,
    kind: Perturbation,
    u: f32,
    config: &PhysicsConfig,
) -> Option<Counterfactual> {
    let lerp = |r: [f32; 2]| lerp_at(r, u);
    let (dx, dy) = (partner.x - ego.x, partner.y - ego.y);
    let dist = dx.hypot(dy);
    if !(dist > 1e-3) {
        return None;
    }
    // Unit line of sight from partner towards ego.
    let (lx, ly) = (-dx / dist, -dy / dist);
    let mut p = *partner;
    let magnitude = match kind {
        Perturbation::Gap => {
            let gap = box_distance(ego, partner);
            if !(gap > MIN_GAP) {
                return None;
            }
            let delta = lerp(config.gap_fraction) * gap;
            p.x += lx * delta;
            p.y += ly * delta;
            delta
        }
        Perturbation::ClosingSpeed => {
            let dv = lerp(config.closing_speed);
            p.vx += lx * dv;
            p.vy += ly * dv;
            dv
        }
        Perturbation::LateralClearance => {
            // Lateral axis of the ego (left-hand normal of its heading).
            let (nx, ny) = (-ego.hy, ego.hx);
            let lateral = dx * nx + dy * ny;
            if !(lateral.abs() > MIN_LATERAL) {
                return None;
            }
            let delta = lerp(config.lateral_fraction) * lateral.abs();
            let sign = lateral.signum();
            p.x -= sign * nx * delta;
            p.y -= sign * ny * delta;
            delta
        }
        Perturbation::LaneShift => {
            // Away from the ego's axis on the partner's side; a partner on the axis goes left for
            // the first half of the draw, right for the second, each half spanning the range.
            let (nx, ny) = (-ego.hy, ego.hx);
            let lateral = dx * nx + dy * ny;
            let side = if lateral.abs() > MIN_LATERAL {
                lateral.signum()
            } else if u < 0.5 {
                1.0
            } else {
                -1.0
            };
            let delta = lerp_at(config.lane_shift?, (2.0 * u).fract());
            p.x += side * nx * delta;
            p.y += side * ny * delta;
            delta
        }
        Perturbation::Size => {
            if !(box_distance(ego, partner) > MIN_GAP) {
                return None;
            }
            let g = lerp(config.size_growth);
            p.length *= 1.0 + g;
            p.width *= 1.0 + g;
            g
        }
    };
    Some(Counterfactual {
        kind,
        partner: p,
        magnitude,
    })
}

fn not_larger(new: f32, old: f32) -> bool {
    new <= old || (old.is_finite() && new <= old + SURROGATE_TOL * (1.0 + old.abs()))
}

/// Whether the pair this counterfactual makes is ordered as its kind says, measured by scorer-core:
/// the counterfactual riskier than the original, or (lane shift) safer.
// `!(x > y)` on purpose: NaN must fail every check.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn order_holds(
    ego: &VehicleState,
    original: &VehicleState,
    cf: &Counterfactual,
    original_surrogates: &Surrogates,
    cf_surrogates: &Surrogates,
    config: &PhysicsConfig,
) -> bool {
    let d_old = original_surrogates.box_distance;
    let d_new = cf_surrogates.box_distance;
    if !(d_new > 0.0) {
        return false; // contact is not a counterfactual of a contact-free state
    }
    let physical = match cf.kind {
        Perturbation::Gap | Perturbation::Size => d_new < d_old,
        Perturbation::LateralClearance => d_new <= d_old,
        Perturbation::LaneShift => d_new >= d_old,
        Perturbation::ClosingSpeed => {
            let h = config.closing_horizon;
            let e = advance(ego, h);
            box_distance(&e, &advance(&cf.partner, h)) < box_distance(&e, &advance(original, h))
        }
    };
    if !physical {
        return false;
    }
    if config.require_surrogate_agreement {
        let (riskier, safer) = if cf.kind.counterfactual_is_safer() {
            (original_surrogates, cf_surrogates)
        } else {
            (cf_surrogates, original_surrogates)
        };
        not_larger(riskier.ttc2d, safer.ttc2d)
            && not_larger(riskier.tadv, safer.tadv)
            && not_larger(-riskier.ei, -safer.ei)
    } else {
        true
    }
}

pub(crate) fn build(draw: Draw<'_>, config: &PhysicsConfig) -> (Vec<Pair>, SourceStats) {
    draw.run(|d, stats| {
        let usable: Vec<(usize, usize)> = d
            .seqs
            .iter()
            .enumerate()
            .map(|(i, s)| (i, s.alert_frames().len()))
            .filter(|&(_, n)| n > 0)
            .collect();
        if usable.is_empty() {
            stats.rejected = d.target;
            return Vec::new();
        }
        let enabled = Perturbation::enabled(config);
        let mut pairs = Vec::with_capacity(d.target);
        let mut kinds = Vec::with_capacity(d.target);
        let mut magnitudes = Vec::with_capacity(d.target);
        let max_attempts = d.target.saturating_mul(20);
        let mut attempts = 0usize;
        while pairs.len() < d.target && attempts < max_attempts {
            attempts += 1;
            let kind = enabled[pairs.len() % enabled.len()];
            let (si, n) = usable[d.rng.random_range(0..usable.len())];
            let fi = d.rng.random_range(0..n);
            let u: f32 = d.rng.random();
            let s = &d.seqs[si];
            let (ego, partner) = (&s.frames[fi].ego, &s.frames[fi].partner);
            let Some(cf) = perturb(ego, partner, kind, u, config) else {
                stats.rejected += 1;
                continue;
            };
            let original_surr = scorer_core::surrogates(ego, partner);
            let cf_surr = scorer_core::surrogates(ego, &cf.partner);
            if !order_holds(ego, partner, &cf, &original_surr, &cf_surr, config) {
                stats.rejected += 1;
                continue;
            }
            let recorded = d.tb.frame(d.origin, d.seqs, si, fi);
            let counterfactual = d.tb.counterfactual(ego, &cf.partner, recorded);
            let (winner, loser) = if kind.counterfactual_is_safer() {
                (recorded, counterfactual)
            } else {
                (counterfactual, recorded)
            };
            pairs.push(Pair {
                winner,
                loser,
                source: d.tag,
                weight: 0.0,
            });
            kinds.push(kind);
            magnitudes.push(cf.magnitude);
        }
        for kind in Perturbation::ALL {
            let idx: Vec<usize> = (0..kinds.len()).filter(|&i| kinds[i] == kind).collect();
            let mut w: Vec<f32> = idx.iter().map(|&i| magnitudes[i]).collect();
            normalise_mean_one(&mut w);
            for (&i, w) in idx.iter().zip(w) {
                pairs[i].weight = w;
            }
        }
        pairs
    })
}
