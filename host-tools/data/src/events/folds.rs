//! Event-level k-fold splits: seeded, stratified by kind, and never splitting one event's frames
//! (items that share an event id always land in the same fold).
use std::collections::HashMap;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{Event, EventKind, Sequence};

/// Anything that belongs to one event and has a kind: [`Event`], [`Sequence`].
pub trait Labelled {
    fn event_id(&self) -> &str;
    fn kind(&self) -> EventKind;
}

impl Labelled for Event {
    fn event_id(&self) -> &str {
        &self.id
    }
    fn kind(&self) -> EventKind {
        self.kind
    }
}

impl Labelled for Sequence {
    fn event_id(&self) -> &str {
        &self.event_id
    }
    fn kind(&self) -> EventKind {
        self.kind
    }
}

/// A fold assignment for a list of items.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Folds {
    k: usize,
    fold_of: Vec<usize>,
}

impl Folds {
    /// Number of folds.
    pub fn k(&self) -> usize {
        self.k
    }
    /// The fold of item `i`.
    pub fn fold_of(&self, i: usize) -> usize {
        self.fold_of[i]
    }
    /// Indices of the items in fold `fold` (the test part of round `fold`), ascending.
    pub fn test(&self, fold: usize) -> Vec<usize> {
        (0..self.fold_of.len())
            .filter(|&i| self.fold_of[i] == fold)
            .collect()
    }
    /// Indices of the items outside fold `fold` (the training part of round `fold`), ascending.
    pub fn train(&self, fold: usize) -> Vec<usize> {
        (0..self.fold_of.len())
            .filter(|&i| self.fold_of[i] != fold)
            .collect()
    }
}

/// The recording an event id belongs to: the part before the first `/` (`riskctl import` writes
/// `{scenario}/{ego}-{partner}@{step}#{n}`). `None` for ids without one (simulated events, most
/// user data): each such event is its own recording.
pub fn recording_of_event_id(event_id: &str) -> Option<&str> {
    event_id
        .split_once('/')
        .map(|(s, _)| s)
        .filter(|s| !s.is_empty())
}

/// The unit that must never be split across folds: the recording of [`recording_of_event_id`],
/// else the event itself.
pub fn fold_group(event_id: &str) -> &str {
    recording_of_event_id(event_id).unwrap_or(event_id)
}

/// Splits `items` into `k` folds by event, stratified by kind, deterministic for `seed`.
///
/// Events of one recording (ids `recording/...`, see [`fold_group`]) always share a fold: the two
/// ego views of one real interaction, or consecutive pieces of it, are near-duplicates and would
/// leak between training and test otherwise.
///
/// Distinct groups of each kind are shuffled (ChaCha8 seeded with `seed`) and dealt round-robin;
/// each kind starts dealing where the previous kind stopped, so fold sizes differ by at most one
/// event overall. An id that appears with several kinds is stratified by its first item's kind.
/// `k` is clamped to at least 1.
pub fn kfold_by_event<T: Labelled>(items: &[T], k: usize, seed: u64) -> Folds {
    let k = k.max(1);
    let mut first_kind: HashMap<&str, EventKind> = HashMap::new();
    let mut ids: [Vec<&str>; 3] = Default::default();
    for it in items {
        let group = fold_group(it.event_id());
        if let std::collections::hash_map::Entry::Vacant(e) = first_kind.entry(group) {
            e.insert(it.kind());
            ids[kind_index(it.kind())].push(group);
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut fold_of_id: HashMap<&str, usize> = HashMap::new();
    let mut next = 0;
    for group in &mut ids {
        group.shuffle(&mut rng);
        for id in group.iter() {
            fold_of_id.insert(id, next);
            next = (next + 1) % k;
        }
    }
    Folds {
        k,
        fold_of: items
            .iter()
            .map(|it| fold_of_id[fold_group(it.event_id())])
            .collect(),
    }
}

fn kind_index(k: EventKind) -> usize {
    match k {
        EventKind::Crash => 0,
        EventKind::NearCrash => 1,
        EventKind::Safe => 2,
    }
}
