//! Cross-sequence comparisons: a state of a conflict sequence is riskier than a state of a safe one.
//!
//! Draws a conflict sequence and a safe sequence uniformly over events, then a frame of each
//! uniformly over time (conflict frames at or before the endpoint, i.e. inside the alert window).
//! With probability `closest_fraction` the safe frame is instead taken near the safe sequence's
//! closest approach (smallest box gap, by scorer-core): uniformly from the `closest_window` seconds
//! that end at it (just the closest frame when the window is 0). That stretch is the safe
//! interaction's counterpart of a conflict's alert window: it looks most like danger, and it holds
//! the maximum that sets the warning threshold (a sequence warns on its maximum). Uniform safe
//! frames alone are mostly easy negatives. Every pair has weight `a_i = 1`.
use rand::Rng;

use super::config::CrossSequenceConfig;
use super::draw::Draw;
use riskscore_data::events::{Sequence, TIME_TOLERANCE_S};

use super::types::{Pair, SourceStats};

pub(crate) fn build(draw: Draw<'_>, config: &CrossSequenceConfig) -> (Vec<Pair>, SourceStats) {
    draw.run(|d, stats| {
        let conflicts: Vec<(usize, usize)> = d
            .seqs
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_conflict())
            .map(|(i, s)| (i, s.alert_frames().len()))
            .filter(|&(_, n)| n > 0)
            .collect();
        let safes: Vec<(usize, usize, (usize, usize))> = d
            .seqs
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.is_conflict() && !s.is_empty())
            .map(|(i, s)| (i, s.len(), approach_window(s, config.closest_window)))
            .collect();
        if conflicts.is_empty() || safes.is_empty() {
            stats.rejected = d.target;
            return Vec::new();
        }
        let mut pairs = Vec::with_capacity(d.target);
        for _ in 0..d.target {
            let (ci, cn) = conflicts[d.rng.random_range(0..conflicts.len())];
            let (si, sn, (first, closest)) = safes[d.rng.random_range(0..safes.len())];
            let cf = d.rng.random_range(0..cn);
            let sf = if d.rng.random_bool(config.closest_fraction.clamp(0.0, 1.0)) {
                if first == closest {
                    closest
                } else {
                    d.rng.random_range(first..=closest)
                }
            } else {
                d.rng.random_range(0..sn)
            };
            let winner = d.tb.frame(d.origin, d.seqs, ci, cf);
            let loser = d.tb.frame(d.origin, d.seqs, si, sf);
            pairs.push(Pair {
                winner,
                loser,
                source: d.tag,
                weight: 1.0,
            });
        }
        pairs
    })
}

/// Frame indices `(first, closest)`: `closest` has the smallest box gap, `first` is the earliest
/// frame at most `window` seconds before it.
fn approach_window(s: &Sequence, window: f64) -> (usize, usize) {
    let closest = closest_approach(s);
    let t_closest = s.frames[closest].time;
    let first = s.frames[..closest]
        .iter()
        .position(|f| f.time >= t_closest - window - TIME_TOLERANCE_S)
        .unwrap_or(closest);
    (first, closest)
}

/// Index of the frame with the smallest box gap (the first on ties; 0 for an empty sequence).
fn closest_approach(s: &Sequence) -> usize {
    s.frames
        .iter()
        .map(|f| scorer_core::box_distance(&f.ego, &f.partner))
        .enumerate()
        .fold(
            (0, f32::INFINITY),
            |best, (i, d)| if d < best.1 { (i, d) } else { best },
        )
        .0
}
