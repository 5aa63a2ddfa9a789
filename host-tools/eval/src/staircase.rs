//! One method's alert profiles of a whole folder, packed: the running-maximum records of every
//! sequence in two flat arrays (12 bytes a record, 40 a sequence) instead of one [`AlertProfile`]
//! each (16 bytes a record in its own heap block, plus an 80-byte header).
//!
//! Why not less: the metrics sum lead-time steps in one fixed order (all records sorted by level,
//! [`warning_curve`]), and floating-point sums depend on that order; every record's level and
//! exact frame time must be at hand when the curve is swept, or the report would differ in its
//! last bits. So the records are kept, only without per-sequence overhead, and turned back into
//! [`AlertProfile`]s one method at a time for the sweep.
use super::metrics::{warning_curve, WarningCurve};
use super::protocol::{AlertProfile, EventKind, RunningMaxRecord};

/// One sequence in a [`Staircases`] block.
#[derive(Clone, Copy, Debug)]
struct Entry {
    /// Position of the event in `events.csv`.
    position: usize,
    endpoint: Option<f64>,
    /// Its records start here in `times` and `levels` and end where the next entry's start.
    start: usize,
    kind: EventKind,
}

/// The profiles of one method gathered by one worker, packed (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct Staircases {
    entries: Vec<Entry>,
    times: Vec<f64>,
    levels: Vec<f32>,
}

impl Staircases {
    /// Packs `profile`, the sequence of the event at `position` in `events.csv` (its id is not
    /// kept: the metrics never read it).
    pub fn push(&mut self, position: usize, profile: &AlertProfile) {
        self.entries.push(Entry {
            position,
            endpoint: profile.endpoint,
            start: self.times.len(),
            kind: profile.kind,
        });
        for r in &profile.records {
            self.times.push(r.time);
            self.levels.push(r.level);
        }
    }

    /// Entry `i`'s profile (without its id).
    fn profile(&self, i: usize) -> Option<AlertProfile> {
        let e = self.entries.get(i)?;
        let end = self
            .entries
            .get(i + 1)
            .map_or(self.times.len(), |next| next.start);
        let records = self
            .times
            .get(e.start..end)?
            .iter()
            .zip(self.levels.get(e.start..end)?)
            .map(|(&time, &level)| RunningMaxRecord { time, level })
            .collect();
        Some(AlertProfile {
            event_id: String::new(),
            kind: e.kind,
            endpoint: e.endpoint,
            records,
        })
    }

    /// Sequences held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Records held (12 bytes each).
    pub fn records(&self) -> usize {
        self.times.len()
    }
}

/// Sequence classes of `blocks` in `events.csv` order.
pub fn classes_in_order(blocks: &[Staircases]) -> Vec<EventKind> {
    let mut classes: Vec<(usize, EventKind)> = blocks
        .iter()
        .flat_map(|b| b.entries.iter().map(|e| (e.position, e.kind)))
        .collect();
    classes.sort_by_key(|(position, _)| *position);
    classes.into_iter().map(|(_, c)| c).collect()
}

/// The operating points of one method from its blocks (gathered by any number of workers):
/// the profiles are unpacked in `events.csv` order and swept by [`warning_curve`], so the curve is
/// bit for bit the one of the profiles themselves. Consumes the blocks, so only this method's
/// profiles are ever unpacked at once.
pub fn warning_curve_of(blocks: Vec<Staircases>) -> WarningCurve {
    let mut order: Vec<(usize, usize, usize)> = blocks
        .iter()
        .enumerate()
        .flat_map(|(b, block)| {
            block
                .entries
                .iter()
                .enumerate()
                .map(move |(i, e)| (e.position, b, i))
        })
        .collect();
    order.sort_unstable_by_key(|(position, _, _)| *position);
    let profiles: Vec<AlertProfile> = order
        .into_iter()
        .filter_map(|(_, b, i)| blocks.get(b)?.profile(i))
        .collect();
    drop(blocks);
    warning_curve(&profiles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::AlertProfileBuilder;

    /// The profile of a sequence with these `(time, score)` frames.
    fn profile(kind: EventKind, endpoint: Option<f64>, frames: &[(f64, f32)]) -> AlertProfile {
        let mut builder = AlertProfileBuilder::new("x", kind, endpoint).unwrap();
        for &(time, score) in frames {
            builder.push(time, score).unwrap();
        }
        builder.finish()
    }

    #[test]
    fn packed_blocks_give_the_curve_of_the_profiles_in_position_order() {
        let p = [
            profile(
                EventKind::Crash,
                Some(3.0),
                &[(0.1, 0.2), (0.4, 0.1), (0.7, 0.5), (2.9, 0.9)],
            ),
            profile(EventKind::Safe, None, &[(4.0, 0.6)]),
            profile(EventKind::NearCrash, Some(1.0), &[(0.3, 0.5), (0.9, 0.95)]),
            profile(EventKind::Safe, None, &[]),
            profile(EventKind::Crash, Some(2.0), &[(1.3, 0.1), (1.4, 0.4)]),
        ];
        let expected = warning_curve(&p);
        // Two workers, each with the events it happened to get.
        let mut a = Staircases::default();
        let mut b = Staircases::default();
        for &i in &[4, 1] {
            a.push(i, &p[i]);
        }
        for &i in &[2, 0, 3] {
            b.push(i, &p[i]);
        }
        assert_eq!((a.len(), a.records()), (2, 3));
        let blocks = vec![a, b];
        assert_eq!(
            classes_in_order(&blocks),
            p.iter().map(|p| p.kind).collect::<Vec<_>>()
        );
        assert_eq!(warning_curve_of(blocks), expected);
    }
}
