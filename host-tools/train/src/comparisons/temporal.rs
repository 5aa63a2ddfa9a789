//! Temporal comparisons: inside a conflict sequence, a later state is riskier than an earlier one.
//!
//! A pair is `(o_t2 over o_t1)` with `t1 < t2 <= t_impact` and `dmin <= t2 - t1 <= dmax`. Sequences
//! are drawn uniformly, then `t2` uniformly among the frames that have at least one valid `t1`, then
//! `t1` uniformly among the valid ones. The weight `a_i` is the time-to-impact difference
//! `(t_impact - t1) - (t_impact - t2) = t2 - t1`, normalised by its mean over the source.
use rand::Rng;

use super::config::TemporalConfig;
use super::draw::{normalise_mean_one, Draw};
use riskscore_data::events::{Sequence, TIME_TOLERANCE_S};

use super::types::{Pair, SourceStats};

/// `(j, lo, hi)`: frame `j` and the range `lo..hi` of its valid earlier frames.
type FrameRange = (usize, usize, usize);

/// For each usable frame `j` (at or before the endpoint), the range `lo..hi` of frames `i` with
/// `dmin <= t_j - t_i <= dmax`.
fn valid_ranges(s: &Sequence, dmin: f64, dmax: f64) -> Vec<FrameRange> {
    let n = s.alert_frames().len();
    let mut out = Vec::new();
    for j in 0..n {
        let tj = s.frames[j].time;
        // times are increasing: frames with t_i <= tj - dmin and t_i >= tj - dmax.
        let hi = s.frames[..j].partition_point(|f| f.time <= tj - dmin + TIME_TOLERANCE_S);
        let lo = s.frames[..j].partition_point(|f| f.time < tj - dmax - TIME_TOLERANCE_S);
        if lo < hi {
            out.push((j, lo, hi));
        }
    }
    out
}

pub(crate) fn build(draw: Draw<'_>, config: &TemporalConfig) -> (Vec<Pair>, SourceStats) {
    draw.run(|d, stats| {
        let candidates: Vec<(usize, Vec<FrameRange>)> = d
            .seqs
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_conflict())
            .map(|(i, s)| (i, valid_ranges(s, config.dmin, config.dmax)))
            .filter(|(_, r)| !r.is_empty())
            .collect();
        stats.rejected = d
            .seqs
            .iter()
            .filter(|s| s.is_conflict())
            .count()
            .saturating_sub(candidates.len());
        if candidates.is_empty() {
            return Vec::new();
        }
        let mut pairs = Vec::with_capacity(d.target);
        let mut weights = Vec::with_capacity(d.target);
        for _ in 0..d.target {
            let (si, ranges) = &candidates[d.rng.random_range(0..candidates.len())];
            let (j, lo, hi) = ranges[d.rng.random_range(0..ranges.len())];
            let i = d.rng.random_range(lo..hi);
            let s = &d.seqs[*si];
            let dt = (s.frames[j].time - s.frames[i].time) as f32;
            let winner = d.tb.frame(d.origin, d.seqs, *si, j);
            let loser = d.tb.frame(d.origin, d.seqs, *si, i);
            pairs.push(Pair {
                winner,
                loser,
                source: d.tag,
                weight: 0.0,
            });
            weights.push(dt);
        }
        normalise_mean_one(&mut weights);
        for (p, w) in pairs.iter_mut().zip(weights) {
            p.weight = w;
        }
        pairs
    })
}
