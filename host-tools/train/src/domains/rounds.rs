//! The leave-one-out rounds: which slice each holds out, and how a round splits the data.
//!
//! A round trains without its slice and tests on it. Per seed and fold (the real scenario files
//! dealt into groups as in the transfer benchmark):
//! - train = the training simulation outside the slice + the real sequences outside the slice
//!   whose scenario file is not in the fold's group;
//! - test = the test simulation inside the slice + the real sequences inside the slice whose
//!   scenario file no training sequence came from (so a recording never sits on both sides).
//!
//! A real-city slice has no conflicts of its own (the real recordings are normal driving). Its
//! conflicts are the test simulation's conflicts in the cells (geometry x speed band) that the
//! slice's real sequences occupy: the hazardous versions of the situations the city shows.
use std::collections::BTreeSet;
use std::fmt;

use scorer_core::interaction::Geometry;
use serde::Serialize;

use super::slice::{domain_of, Domain, SpeedBand};
use super::source::Source;
use crate::transfer::scenario_of;
use riskscore_data::events::Sequence;

/// The cities a city round can hold out (each while training on the other).
pub const CITIES: [&str; 2] = ["Lankershim", "Peachtree"];
/// The `--rounds` value that runs every round ([`Round::all`]).
pub const ALL: &str = "all";

/// What to do with a round whose slice is empty in the data given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmptyRound {
    /// Refuse the run (the round was asked for by name).
    Fail,
    /// Report it as "no data" and run the others (the default rounds, some of whose data, e.g. a
    /// city, may not be there).
    ReportNoData,
}

/// What a round holds out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HeldOut {
    Band(SpeedBand),
    Geometry(Geometry),
    /// The real traffic of one city (by [`Source::RealCity`] name).
    City(String),
}

/// One leave-one-out round.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Round {
    /// Command-line name: `speed-35-50`, `geometry-crossing`, `city-lankershim`.
    pub name: String,
    pub held_out: HeldOut,
}

impl Round {
    fn band(b: SpeedBand) -> Round {
        Round {
            name: format!("speed-{}", b.label()),
            held_out: HeldOut::Band(b),
        }
    }

    fn geometry(g: Geometry) -> Round {
        Round {
            name: format!("geometry-{}", g.as_str()),
            held_out: HeldOut::Geometry(g),
        }
    }

    fn city(c: &str) -> Round {
        Round {
            name: format!("city-{}", c.to_lowercase()),
            held_out: HeldOut::City(c.to_owned()),
        }
    }

    /// Every round the benchmark knows: each speed band, each geometry, each city.
    pub fn all() -> Vec<Round> {
        SpeedBand::ALL
            .into_iter()
            .map(Round::band)
            .chain(Geometry::ALL.into_iter().map(Round::geometry))
            .chain(CITIES.iter().map(|c| Round::city(c)))
            .collect()
    }

    /// The rounds run when none are named: the 35-50 m/s band, each city held out while
    /// training on the other, crossing and oncoming geometry.
    pub fn defaults() -> Vec<Round> {
        let mut rounds = vec![Round::band(SpeedBand::Motorway)];
        rounds.extend(CITIES.iter().map(|c| Round::city(c)));
        rounds.push(Round::geometry(Geometry::Crossing));
        rounds.push(Round::geometry(Geometry::Oncoming));
        rounds
    }

    /// The rounds a run asks for, and what an empty one means: none named runs the defaults,
    /// `all` every round, both reporting an empty slice as "no data" (a city's folder may be
    /// missing); a list of names fails on an empty one, since it was asked for by name.
    pub fn selection(list: Option<&str>) -> Result<(Vec<Round>, EmptyRound), String> {
        match list.map(str::trim) {
            None => Ok((Round::defaults(), EmptyRound::ReportNoData)),
            Some(ALL) => Ok((Round::all(), EmptyRound::ReportNoData)),
            Some(list) => Ok((Round::parse_list(list)?, EmptyRound::Fail)),
        }
    }

    /// The rounds of a comma-separated list of names (as [`Round::all`] spells them).
    pub fn parse_list(list: &str) -> Result<Vec<Round>, String> {
        let all = Round::all();
        let mut rounds: Vec<Round> = Vec::new();
        for name in list.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            if name == ALL {
                return Err(format!(
                    "`{ALL}` runs every round and stands alone, not in a list"
                ));
            }
            let round = all.iter().find(|r| r.name == name).ok_or_else(|| {
                let known: Vec<&str> = all.iter().map(|r| r.name.as_str()).collect();
                format!("unknown round `{name}` (known: {})", known.join(", "))
            })?;
            if !rounds.contains(round) {
                rounds.push(round.clone());
            }
        }
        if rounds.is_empty() {
            return Err("no round named".into());
        }
        Ok(rounds)
    }

    /// True when a sequence of this domain belongs to the held-out slice.
    pub fn contains(&self, domain: &Domain) -> bool {
        match &self.held_out {
            HeldOut::Band(b) => domain.band == Some(*b),
            HeldOut::Geometry(g) => domain.geometry == Some(*g),
            HeldOut::City(c) => matches!(&domain.source, Source::RealCity(x) if x == c),
        }
    }

    /// True when the slice is defined by a real source (so its conflicts come from the test
    /// simulation's matching cells).
    pub fn is_real_source(&self) -> bool {
        matches!(self.held_out, HeldOut::City(_))
    }
}

impl fmt::Display for Round {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.held_out {
            HeldOut::Band(b) => write!(f, "ego speed {b}"),
            HeldOut::Geometry(g) => write!(f, "{} geometry", g.as_str()),
            HeldOut::City(c) => write!(f, "real city traffic of {c}"),
        }
    }
}

/// A sequence with its place in the domain.
#[derive(Clone, Debug, PartialEq)]
pub struct Labelled {
    pub sequence: Sequence,
    pub domain: Domain,
}

/// Everything the benchmark draws from, sliced.
#[derive(Clone, Debug, Default)]
pub struct DomainData {
    pub train_sim: Vec<Labelled>,
    pub test_sim: Vec<Labelled>,
    /// Real normal driving, freeway and city.
    pub real: Vec<Labelled>,
}

fn label(sequences: Vec<Sequence>, source: impl Fn(&Sequence) -> Source) -> Vec<Labelled> {
    sequences
        .into_iter()
        .map(|s| {
            let domain = domain_of(&s, source(&s));
            Labelled {
                sequence: s,
                domain,
            }
        })
        .collect()
}

impl DomainData {
    /// Slices the folders by their roles: city sequences get their city from the event id.
    pub fn new(
        train_sim: Vec<Sequence>,
        test_sim: Vec<Sequence>,
        real_freeway: Vec<Sequence>,
        real_city: Vec<Sequence>,
    ) -> DomainData {
        let mut real = label(real_freeway, |_| Source::RealFreeway);
        real.extend(label(real_city, |s| Source::city_of_event(&s.event_id)));
        DomainData {
            train_sim: label(train_sim, |_| Source::Sim),
            test_sim: label(test_sim, |_| Source::Sim),
            real,
        }
    }

    /// The `(geometry, band)` cells the real sequences of `round`'s slice occupy.
    fn real_cells(&self, round: &Round) -> BTreeSet<(Geometry, SpeedBand)> {
        self.real
            .iter()
            .filter(|l| round.contains(&l.domain))
            .filter_map(|l| Some((l.domain.geometry?, l.domain.band?)))
            .collect()
    }

    /// The test simulation's part of `round`'s test set (the same in every fold): its sequences
    /// in the slice or, for a real-source slice, its conflicts in the slice's real cells.
    pub fn test_sim_part(&self, round: &Round) -> Vec<&Labelled> {
        if round.is_real_source() {
            let cells = self.real_cells(round);
            self.test_sim
                .iter()
                .filter(|l| l.sequence.is_conflict())
                .filter(|l| match (l.domain.geometry, l.domain.band) {
                    (Some(g), Some(b)) => cells.contains(&(g, b)),
                    _ => false,
                })
                .collect()
        } else {
            self.test_sim
                .iter()
                .filter(|l| round.contains(&l.domain))
                .collect()
        }
    }
}

/// Conflict and safe sequences of a set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct KindCounts {
    pub conflicts: usize,
    pub safe: usize,
}

/// Counts of several sets added up (e.g. a slice over several simulator draws).
impl std::ops::AddAssign for KindCounts {
    fn add_assign(&mut self, other: KindCounts) {
        self.conflicts += other.conflicts;
        self.safe += other.safe;
    }
}

impl KindCounts {
    pub fn of<'a>(sequences: impl IntoIterator<Item = &'a Sequence>) -> KindCounts {
        let mut c = KindCounts::default();
        for s in sequences {
            if s.kind.is_conflict() {
                c.conflicts += 1;
            } else {
                c.safe += 1;
            }
        }
        c
    }
}

/// How much a round has to train and test on, over all folds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SliceCounts {
    /// The slice's test sequences (test simulation part + every real sequence of the slice).
    pub test: KindCounts,
    /// The real safe sequences among them.
    pub real_safe: usize,
    /// Everything outside the slice (training simulation + real).
    pub train: KindCounts,
}

/// Fewer conflicts or safe sequences than this in a slice, and its figures are flagged.
pub const SMALL_SLICE: usize = 30;

/// Counts of several simulator draws added up ([`super::draws::sum_counts`]).
impl std::ops::AddAssign for SliceCounts {
    fn add_assign(&mut self, other: SliceCounts) {
        self.test += other.test;
        self.real_safe += other.real_safe;
        self.train += other.train;
    }
}

impl SliceCounts {
    /// True when the slice has fewer than [`SMALL_SLICE`] conflicts or safe sequences.
    pub fn is_small(&self) -> bool {
        self.test.conflicts < SMALL_SLICE || self.test.safe < SMALL_SLICE
    }

    /// True when the round can be trained and scored at all.
    pub fn is_runnable(&self) -> bool {
        self.test.conflicts > 0
            && self.test.safe > 0
            && self.train.conflicts > 0
            && self.train.safe > 0
    }
}

/// The counts of `round` on `data`.
pub fn slice_counts(round: &Round, data: &DomainData) -> SliceCounts {
    let real_in: Vec<&Sequence> = data
        .real
        .iter()
        .filter(|l| round.contains(&l.domain))
        .map(|l| &l.sequence)
        .collect();
    let sim_in = data.test_sim_part(round);
    let train = data
        .train_sim
        .iter()
        .chain(&data.real)
        .filter(|l| !round.contains(&l.domain))
        .map(|l| &l.sequence);
    SliceCounts {
        test: KindCounts::of(
            sim_in
                .iter()
                .map(|l| &l.sequence)
                .chain(real_in.iter().copied()),
        ),
        real_safe: real_in.iter().filter(|s| !s.kind.is_conflict()).count(),
        train: KindCounts::of(train),
    }
}

/// One fold of one round.
#[derive(Clone, Debug, PartialEq)]
pub struct RoundSplit {
    pub train: Vec<Sequence>,
    /// Test sequences: the simulated part first, then the real ones from `real_from` on.
    pub test: Vec<Sequence>,
    /// The place in the domain of each test sequence (same order as `test`).
    pub test_domains: Vec<Domain>,
    pub real_from: usize,
}

/// Split the data for `round` with the real scenario files `held_scenarios` kept out of training.
pub fn split_round(round: &Round, data: &DomainData, held_scenarios: &[String]) -> RoundSplit {
    let held = |l: &Labelled| {
        held_scenarios
            .iter()
            .any(|n| n == scenario_of(&l.sequence.event_id))
    };
    let real_train = || {
        data.real
            .iter()
            .filter(|l| !round.contains(&l.domain) && !held(l))
            .map(|l| &l.sequence)
    };
    let training_scenarios: BTreeSet<&str> =
        real_train().map(|s| scenario_of(&s.event_id)).collect();
    let mut train: Vec<Sequence> = data
        .train_sim
        .iter()
        .filter(|l| !round.contains(&l.domain))
        .map(|l| l.sequence.clone())
        .collect();
    train.extend(real_train().cloned());
    let mut tested: Vec<&Labelled> = data.test_sim_part(round);
    let real_from = tested.len();
    tested.extend(
        data.real
            .iter()
            .filter(|l| round.contains(&l.domain))
            .filter(|l| !training_scenarios.contains(scenario_of(&l.sequence.event_id))),
    );
    RoundSplit {
        train,
        test: tested.iter().map(|l| l.sequence.clone()).collect(),
        test_domains: tested.iter().map(|l| l.domain.clone()).collect(),
        real_from,
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use riskscore_data::events::{EventKind, Frame};
    use scorer_core::VehicleState;

    /// A one-frame sequence: the ego at `speed` along +x, the partner 20 m ahead travelling along
    /// `(hx, hy)` (a crossing or oncoming partner when its heading says so).
    fn seq(id: &str, kind: EventKind, speed: f32, hx: f32, hy: f32) -> Sequence {
        let state = |x: f32, v: f32, hx: f32, hy: f32| VehicleState {
            x,
            y: 0.0,
            vx: v * hx,
            vy: v * hy,
            hx,
            hy,
            acc: 0.0,
            length: 4.5,
            width: 1.8,
        };
        let endpoint = kind.is_conflict().then_some(0.0);
        let mut s = Sequence::new(id, kind, endpoint);
        s.frames.push(Frame {
            time: 0.0,
            ego: state(0.0, speed, 1.0, 0.0),
            partner: state(20.0, 10.0, hx, hy),
        });
        s
    }

    /// Every slice kind in a few one-frame sequences (also the other domain modules' test data).
    pub(in crate::domains) fn data() -> DomainData {
        use EventKind::{Crash, Safe};
        let sim = |tag: &str| {
            vec![
                seq(&format!("{tag}1"), Crash, 40.0, 1.0, 0.0),
                seq(&format!("{tag}2"), Crash, 10.0, 0.0, 1.0),
                seq(&format!("{tag}3"), Safe, 40.0, 1.0, 0.0),
                seq(&format!("{tag}4"), Safe, 20.0, -1.0, 0.0),
                seq(&format!("{tag}5"), Crash, 3.0, 1.0, 0.0),
            ]
        };
        DomainData::new(
            sim("a"),
            sim("b"),
            vec![
                seq("USA_US101-1/1", Safe, 40.0, 1.0, 0.0),
                seq("USA_US101-1/2", Safe, 12.0, 1.0, 0.0),
                seq("USA_US101-2/1", Safe, 36.0, 1.0, 0.0),
            ],
            vec![
                seq("USA_Lanker-1_1_T-1/1", Safe, 3.0, 1.0, 0.0),
                seq("USA_Lanker-1_1_T-1/2", Safe, 9.0, 0.0, 1.0),
                seq("USA_Peach-1_1_T-1/1", Safe, 8.0, 1.0, 0.0),
            ],
        )
    }

    fn ids(seqs: &[Sequence]) -> Vec<&str> {
        seqs.iter().map(|s| s.event_id.as_str()).collect()
    }

    #[test]
    fn a_band_round_trains_without_its_band_and_tests_only_on_it() {
        let round = Round::parse_list("speed-35-50").unwrap().remove(0);
        let data = data();
        let split = split_round(&round, &data, &["USA_US101-2".to_string()]);
        assert_eq!(
            ids(&split.train),
            [
                "a2",
                "a4",
                "a5",
                "USA_US101-1/2",
                "USA_Lanker-1_1_T-1/1",
                "USA_Lanker-1_1_T-1/2",
                "USA_Peach-1_1_T-1/1"
            ]
        );
        // US101-1 trained (its 12 m/s sequence), so its 40 m/s sequence is not tested in this
        // fold; US101-2 is held out: its 36 m/s sequence is.
        assert_eq!(ids(&split.test), ["b1", "b3", "USA_US101-2/1"]);
        assert_eq!(split.real_from, 2);
        let sources: Vec<&Source> = split.test_domains.iter().map(|d| &d.source).collect();
        assert_eq!(sources, [&Source::Sim, &Source::Sim, &Source::RealFreeway]);
        assert!(split
            .test_domains
            .iter()
            .all(|d| d.band == Some(SpeedBand::Motorway)));
        let counts = slice_counts(&round, &data);
        assert_eq!(
            counts.test,
            KindCounts {
                conflicts: 1,
                safe: 3
            }
        );
        assert_eq!(counts.real_safe, 2);
        assert_eq!(
            counts.train,
            KindCounts {
                conflicts: 2,
                safe: 5
            }
        );
        assert!(counts.is_small() && counts.is_runnable());
    }

    #[test]
    fn geometry_rounds_hold_out_crossing_and_oncoming() {
        let data = data();
        let crossing = Round::parse_list("geometry-crossing").unwrap().remove(0);
        // Its recording also trained (its following sequence): not tested in this fold.
        let split = split_round(&crossing, &data, &[]);
        assert_eq!(ids(&split.test), ["b2"]);
        let split = split_round(&crossing, &data, &["USA_Lanker-1_1_T-1".to_string()]);
        assert_eq!(ids(&split.test), ["b2", "USA_Lanker-1_1_T-1/2"]);
        assert!(!ids(&split.train).contains(&"a2"));
        assert!(!ids(&split.train).contains(&"USA_Lanker-1_1_T-1/2"));
        let oncoming = Round::parse_list("geometry-oncoming").unwrap().remove(0);
        let split = split_round(&oncoming, &data, &[]);
        assert_eq!(ids(&split.test), ["b4"]);
        let counts = slice_counts(&oncoming, &data);
        assert!(!counts.is_runnable(), "no oncoming conflict: {counts:?}");
    }

    #[test]
    fn a_city_round_trains_on_the_other_city_and_takes_matching_sim_conflicts() {
        let round = Round::parse_list("city-lankershim").unwrap().remove(0);
        assert_eq!(round.held_out, HeldOut::City("Lankershim".into()));
        let data = data();
        let split = split_round(&round, &data, &["USA_US101-1".to_string()]);
        // Lankershim occupies (following, 0-5) and (crossing, 5-15): the test simulation's
        // conflicts there are b5 and b2; its safe sequences and other conflicts stay out.
        assert_eq!(
            ids(&split.test),
            ["b2", "b5", "USA_Lanker-1_1_T-1/1", "USA_Lanker-1_1_T-1/2"]
        );
        let lankershim = Source::RealCity("Lankershim".into());
        let sources: Vec<&Source> = split.test_domains.iter().map(|d| &d.source).collect();
        assert_eq!(
            sources,
            [&Source::Sim, &Source::Sim, &lankershim, &lankershim]
        );
        let train = ids(&split.train);
        assert!(train.contains(&"USA_Peach-1_1_T-1/1"));
        assert!(train.contains(&"a2") && train.contains(&"a5"));
        assert!(!train.iter().any(|id| id.starts_with("USA_Lanker")));
        assert!(!train.contains(&"USA_US101-1/1"), "held scenario trained");
    }

    #[test]
    fn round_names_parse_and_unknown_ones_are_refused() {
        let names: Vec<String> = Round::defaults().into_iter().map(|r| r.name).collect();
        assert_eq!(
            names,
            [
                "speed-35-50",
                "city-lankershim",
                "city-peachtree",
                "geometry-crossing",
                "geometry-oncoming"
            ]
        );
        assert_eq!(Round::all().len(), 11);
        let err = Round::parse_list("speed-35-50,speed-90-99").unwrap_err();
        assert!(
            err.contains("`speed-90-99`") && err.contains("geometry-oncoming"),
            "{err}"
        );
        assert_eq!(Round::parse_list("speed-0-5,speed-0-5").unwrap().len(), 1);
    }

    #[test]
    fn all_runs_every_round_and_reports_empty_ones_like_the_defaults() {
        assert_eq!(
            Round::selection(None).unwrap(),
            (Round::defaults(), EmptyRound::ReportNoData)
        );
        assert_eq!(
            Round::selection(Some(" all ")).unwrap(),
            (Round::all(), EmptyRound::ReportNoData)
        );
        assert_eq!(
            Round::selection(Some("speed-0-5")).unwrap(),
            (Round::parse_list("speed-0-5").unwrap(), EmptyRound::Fail)
        );
        // `all` names the whole set, not a round to mix with others.
        let err = Round::selection(Some("all,speed-0-5")).unwrap_err();
        assert!(
            err.contains("`all` runs every round and stands alone"),
            "{err}"
        );
    }
}
