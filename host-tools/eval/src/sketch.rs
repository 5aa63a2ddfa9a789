//! A bounded-memory, mergeable summary of a method's scores that answers "how many scores are
//! below `r`" with a deterministic, stated error, and exactly while it is small.
//!
//! The trajectory plot places each frame of a few events at its percentile among *all* alert-window
//! scores of the method (see [`plots`](super::plots)). Keeping every score costs 4 bytes a frame and
//! method; this summary keeps at most `capacity` scores per level instead.
//!
//! How: scores go into level 0 (weight 1). When a level holds `capacity` scores it is sorted and
//! every other score (alternately the even and the odd ones) moves up one level with twice the
//! weight; an odd one out stays. The total weight stays the number of scores pushed. Each such
//! compaction of weight-`w` scores moves any rank query by at most `w` (the kept half of a sorted
//! prefix counts its length rounded to even), so [`ScoreSketch::rank_error`], the sum of those
//! weights, bounds the error of every count. Level `h` is compacted at most `n / (capacity 2^h)`
//! times, so the bound is at most `levels * n / capacity`: with the default capacity (65,536) and
//! 10 M scores that is 8 levels, a rank error of at most 0.012 % of `n`. Until `capacity` scores
//! are reached nothing is compacted and every count is exact ([`ScoreSketch::is_exact`]).
//!
//! Memory: below `capacity` scores per level, `4 * capacity * levels` bytes (2.3 MB for 10 M
//! scores). Merging is level by level, with the same compaction rule, so the bound holds for
//! summaries built on several threads and merged. Which scores survive a compaction depends on the
//! order they arrived in: with several threads, runs may differ within the bound.
//!
//! NaN scores are not counted (they have no rank).

/// Scores kept per level before the level is halved (see the module docs).
pub const DEFAULT_CAPACITY: usize = 1 << 16;

/// A summary of one method's scores (see the module docs).
#[derive(Clone, Debug)]
pub struct ScoreSketch {
    capacity: usize,
    /// Level `h` holds scores of weight `2^h`; unsorted until [`Self::ranks`] is first needed.
    levels: Vec<Vec<f32>>,
    /// Per level: whether the next compaction keeps the odd positions.
    odd: Vec<bool>,
    count: u64,
    rank_error: u64,
    sorted: bool,
}

impl ScoreSketch {
    /// A summary that compacts a level once it holds `capacity` (at least 2) scores.
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.max(2),
            levels: vec![Vec::new()],
            odd: vec![false],
            count: 0,
            rank_error: 0,
            sorted: true,
        }
    }

    /// A summary that never compacts: exact, with memory growing with the scores.
    pub fn exact() -> Self {
        Self::new(usize::MAX)
    }

    /// Counts `score` (NaN is ignored).
    pub fn push(&mut self, score: f32) {
        if score.is_nan() {
            return;
        }
        self.count += 1;
        self.sorted = false;
        if let Some(level) = self.levels.first_mut() {
            level.push(score);
        }
        self.compact_from(0);
    }

    /// Adds everything `other` has counted.
    pub fn merge(&mut self, other: ScoreSketch) {
        self.count += other.count;
        self.rank_error += other.rank_error;
        self.sorted = false;
        for (h, level) in other.levels.into_iter().enumerate() {
            self.level_mut(h).extend(level);
        }
        self.compact_from(0);
    }

    /// Scores counted (NaN excluded).
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The largest error of any count [`Self::ranks`] returns (0: exact).
    pub fn rank_error(&self) -> u64 {
        self.rank_error
    }

    pub fn is_exact(&self) -> bool {
        self.rank_error == 0
    }

    /// Scores held (memory is 4 bytes each).
    pub fn held(&self) -> usize {
        self.levels.iter().map(Vec::len).sum()
    }

    /// `(scores < r, scores <= r)`, each within [`Self::rank_error`] of the true count.
    pub fn ranks(&mut self, r: f32) -> (u64, u64) {
        if !self.sorted {
            for level in &mut self.levels {
                level.sort_unstable_by(f32::total_cmp);
            }
            self.sorted = true;
        }
        let (mut below, mut at_or_below) = (0u64, 0u64);
        for (h, level) in self.levels.iter().enumerate() {
            let weight = 1u64 << h;
            below += weight * level.partition_point(|x| *x < r) as u64;
            at_or_below += weight * level.partition_point(|x| *x <= r) as u64;
        }
        (below, at_or_below)
    }

    fn level_mut(&mut self, h: usize) -> &mut Vec<f32> {
        while self.levels.len() <= h {
            self.levels.push(Vec::new());
            self.odd.push(false);
        }
        &mut self.levels[h]
    }

    /// Halves every level, from `h` up, that holds `capacity` scores or more.
    fn compact_from(&mut self, mut h: usize) {
        while h < self.levels.len() {
            if self.levels[h].len() >= self.capacity {
                let mut level = std::mem::take(&mut self.levels[h]);
                level.sort_unstable_by(f32::total_cmp);
                // An odd one out (the largest) stays at this level with its weight.
                let rest = if level.len() % 2 == 1 {
                    level.pop()
                } else {
                    None
                };
                let offset = usize::from(self.odd[h]);
                self.odd[h] = !self.odd[h];
                let promoted: Vec<f32> = level.iter().skip(offset).step_by(2).copied().collect();
                self.rank_error += 1u64 << h;
                level.clear();
                level.extend(rest);
                self.levels[h] = level;
                self.level_mut(h + 1).extend(promoted);
            }
            h += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact_ranks(values: &[f32], r: f32) -> (u64, u64) {
        let below = values.iter().filter(|x| **x < r).count() as u64;
        let at = values.iter().filter(|x| **x <= r).count() as u64;
        (below, at)
    }

    /// Deterministic pseudo-random scores with many ties (a method's scores often repeat).
    fn scores(n: usize, seed: u64) -> Vec<f32> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 40) % 5000) as f32 / 100.0
            })
            .collect()
    }

    #[test]
    fn exact_below_capacity() {
        let values = scores(999, 1);
        let mut sketch = ScoreSketch::new(1000);
        values.iter().for_each(|v| sketch.push(*v));
        sketch.push(f32::NAN);
        assert!(sketch.is_exact());
        assert_eq!(sketch.count(), 999);
        for r in [-1.0, 0.0, 3.5, 12.34, 49.99, 60.0] {
            assert_eq!(sketch.ranks(r), exact_ranks(&values, r), "{r}");
        }
    }

    #[test]
    fn merged_summaries_stay_within_the_stated_error() {
        let values = scores(200_000, 7);
        // Four "threads", each with its own summary, then merged.
        let mut parts: Vec<ScoreSketch> = (0..4).map(|_| ScoreSketch::new(512)).collect();
        for (i, v) in values.iter().enumerate() {
            parts[i % 4].push(*v);
        }
        let mut sketch = ScoreSketch::new(512);
        for p in parts {
            sketch.merge(p);
        }
        assert_eq!(sketch.count(), values.len() as u64);
        assert!(!sketch.is_exact());
        assert!(sketch.held() < 512 * 12, "{}", sketch.held());
        // The module's bound: at most levels * n / capacity.
        let levels = sketch.levels.len() as u64;
        assert!(sketch.rank_error() <= levels * values.len() as u64 / 512 + levels);
        let mut worst = 0u64;
        for r in scores(300, 3).into_iter().chain([0.0, 49.99, 100.0]) {
            let (b, a) = sketch.ranks(r);
            let (eb, ea) = exact_ranks(&values, r);
            worst = worst.max(b.abs_diff(eb)).max(a.abs_diff(ea));
        }
        assert!(
            worst <= sketch.rank_error(),
            "{worst} > {}",
            sketch.rank_error()
        );
        assert!(worst > 0, "the test must exercise compaction");
    }
}
