//! The training-domain record of a model, measured on the sequences its training data holds: per
//! input the model reads, the range its frames cover (less a small tail of outliers) widened to
//! every value a share of the sequences reached.
//!
//! A DRL model's domain also records the geometry cells (`scorer_core::geometry_cell`) that at
//! least a few sequences reached: inside every range, a partner crossing 60 m ahead is still a
//! combination the network never saw.
//!
//! The inputs are computed by scorer-core (`Observation::of`, `Model::domain_inputs`), so the
//! ranges are of exactly the numbers the ECU checks. Which inputs are bounded: every input the
//! model's network reads (DRL: its selected DRL inputs; GSSM/SSRA: its context features), and for
//! MSRA all 13 features (its terms were fitted over that speed and geometry; the features feed
//! its embedded GSSM, if any). Why this and not min/max: `docs/domain-guard.md`.
use scorer_core::geometry_cell::{geometry_cell, GEOMETRY_CELLS};
use scorer_core::model::geometry_coverage::COVERAGE_BYTES;
use scorer_core::model::{
    GeometryCoverage, InputRange, Model, ModelError, OutsidePolicy, TrainingDomain,
};
use scorer_core::{Observation, VehicleState, FEATURE_COUNT};

/// How much of the training data a range may leave outside at each end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tails {
    /// Share of the frames left outside at each end (0 = min/max): real tracks carry one-frame
    /// glitches that must not stretch a range.
    pub frames: f64,
    /// Every value at least this share of the sequences reached is inside, whatever the frame
    /// share says: one frame of each crash is its impact (touching boxes), far fewer than 0.1 %
    /// of the frames, yet the state the model was trained on hardest.
    pub sequences: f64,
    /// A geometry cell (DRL models) is covered when at least this many sequences reached it (at
    /// least one): a count, not a share, because a network learns a geometry from examples.
    pub cell_sequences: usize,
}

/// 0.1 % of the frames, inside whatever at least 1 % of the sequences reached, and the geometry
/// cells at least 5 sequences reached (measured: docs/domain-guard.md, "The geometry cells").
pub const DEFAULT_TAILS: Tails = Tails {
    frames: 0.001,
    sequences: 0.01,
    cell_sequences: 5,
};

/// Measuring a training domain failed.
#[derive(Debug, thiserror::Error)]
pub enum DomainRangesError {
    #[error("no observations to measure the training domain on")]
    NoObservations,
    #[error("frame tail share {0}: must be in [0, 0.5)")]
    BadTail(f64),
    #[error("sequence share {0}: must be in [0, 1]")]
    BadSequenceShare(f64),
    #[error("the measured training domain is not a valid record: {0}")]
    Record(ModelError),
}

/// A measured training domain, owning its ranges' wire bytes and its covered geometry cells.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredDomain {
    pub policy: OutsidePolicy,
    pub range_bytes: Vec<u8>,
    /// The cell bit set (DRL models), `None` for the kinds whose inputs have no geometry cell.
    pub coverage: Option<[u8; COVERAGE_BYTES]>,
}

impl MeasuredDomain {
    /// The records to store in a blob (tag 2, and tag 4 for a DRL model).
    pub fn domain(&self) -> TrainingDomain<'_> {
        TrainingDomain::new(self.policy, &self.range_bytes)
            .with_coverage(self.coverage.as_ref().map(|c| GeometryCoverage::new(c)))
    }
}

/// The inputs (indices into the kind's input vector) the domain of `model` bounds.
pub fn bounded_inputs(model: &Model<'_>) -> Vec<u8> {
    let all = || (0..FEATURE_COUNT as u8).collect();
    let mut inputs: Vec<u8> = match model {
        Model::DrlInt8(m) => m.inputs.to_vec(),
        Model::DrlF32(m) => m.inputs.to_vec(),
        Model::Gssm(m) => m.net.inputs.to_vec(),
        Model::Msra(_) => all(),
    };
    inputs.sort_unstable();
    inputs.dedup();
    inputs
}

/// The domain of `model` over `sequences`, each the observations (ego, partner) of one training
/// sequence: for each bounded input, `lo` the lower of the `tails.frames` quantile of all frames
/// and the `tails.sequences` quantile of the sequences' minima (nearest rank), `hi` likewise at
/// the top; ranges in input order, under `policy`. For a DRL model, the geometry cells that at
/// least `tails.cell_sequences` sequences reached are covered.
pub fn measure<'p, S>(
    model: &Model<'_>,
    sequences: impl IntoIterator<Item = S>,
    tails: Tails,
    policy: OutsidePolicy,
) -> Result<MeasuredDomain, DomainRangesError>
where
    S: IntoIterator<Item = (&'p VehicleState, &'p VehicleState)>,
{
    if !(0.0..0.5).contains(&tails.frames) {
        return Err(DomainRangesError::BadTail(tails.frames));
    }
    if !(0.0..=1.0).contains(&tails.sequences) {
        return Err(DomainRangesError::BadSequenceShare(tails.sequences));
    }
    let inputs = bounded_inputs(model);
    let mut columns: Vec<Vec<f32>> = vec![Vec::new(); inputs.len()];
    let mut minima: Vec<Vec<f32>> = vec![Vec::new(); inputs.len()];
    let mut maxima: Vec<Vec<f32>> = vec![Vec::new(); inputs.len()];
    let has_cells = model.runs_a_network();
    let mut cell_sequences = [0usize; GEOMETRY_CELLS];
    for sequence in sequences {
        let starts: Vec<usize> = columns.iter().map(Vec::len).collect();
        let mut reached = [false; GEOMETRY_CELLS];
        for (ego, partner) in sequence {
            let observation = Observation::of(ego, partner);
            let values = model.domain_inputs(&observation);
            if has_cells {
                reached[usize::from(geometry_cell(&observation.drl_inputs))] = true;
            }
            for (column, &input) in columns.iter_mut().zip(&inputs) {
                // The core's inputs are finite by construction; a NaN would have no rank.
                if let Some(&x) = values.get(usize::from(input)).filter(|x| !x.is_nan()) {
                    column.push(x);
                }
            }
        }
        for (count, hit) in cell_sequences.iter_mut().zip(reached) {
            *count += usize::from(hit);
        }
        for (k, column) in columns.iter().enumerate() {
            let frames = column.get(starts[k]..).unwrap_or_default();
            if let Some(min) = frames.iter().copied().reduce(f32::min) {
                minima[k].push(min);
                maxima[k].push(frames.iter().copied().fold(min, f32::max));
            }
        }
    }
    let mut range_bytes = Vec::with_capacity(inputs.len() * 9);
    for (k, &input) in inputs.iter().enumerate() {
        let frames = sorted(&mut columns[k]);
        let frame_lo =
            at_quantile(frames, tails.frames).ok_or(DomainRangesError::NoObservations)?;
        let frame_hi =
            at_quantile(frames, 1.0 - tails.frames).ok_or(DomainRangesError::NoObservations)?;
        let sequence_lo = at_quantile(sorted(&mut minima[k]), tails.sequences)
            .ok_or(DomainRangesError::NoObservations)?;
        let sequence_hi = at_quantile(sorted(&mut maxima[k]), 1.0 - tails.sequences)
            .ok_or(DomainRangesError::NoObservations)?;
        let (lo, hi) = (frame_lo.min(sequence_lo), frame_hi.max(sequence_hi));
        range_bytes.extend(InputRange { input, lo, hi }.to_bytes());
    }

    let coverage = has_cells.then(|| {
        let mut cells = [0u8; COVERAGE_BYTES];
        for (cell, &count) in cell_sequences.iter().enumerate() {
            if count >= tails.cell_sequences.max(1) {
                cells[cell / 8] |= 1 << (cell % 8);
            }
        }
        cells
    });
    let measured = MeasuredDomain {
        policy,
        range_bytes,
        coverage,
    };
    measured
        .domain()
        .validate()
        .map_err(DomainRangesError::Record)?;
    Ok(measured)
}

/// `values` in ascending order (sorted in place), for [`at_quantile`].
fn sorted(values: &mut [f32]) -> &[f32] {
    values.sort_unstable_by(f32::total_cmp);
    values
}

/// The `q` nearest-rank quantile of ascending `sorted`; `None` when empty.
fn at_quantile(sorted: &[f32], q: f64) -> Option<f32> {
    let last = sorted.len().checked_sub(1)?;
    let rank = ((q * last as f64).round() as usize).min(last);
    sorted.get(rank).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_nearest_rank() {
        let mut v: Vec<f32> = (0..=1000).rev().map(|i| i as f32).collect();
        let v = sorted(&mut v);
        assert_eq!(at_quantile(v, 0.0), Some(0.0));
        assert_eq!(at_quantile(v, 1.0), Some(1000.0));
        assert_eq!(at_quantile(v, 0.001), Some(1.0));
        assert_eq!(at_quantile(v, 0.9), Some(900.0));
        assert_eq!(at_quantile(&[], 0.1), None);
        assert_eq!(at_quantile(&[3.0], 0.1), Some(3.0));
    }

    /// Ego speed `v` (the DRL input `v_ego`), partner 30 m ahead in the same lane.
    fn pair(v: f32) -> (VehicleState, VehicleState) {
        let car = |x: f32, vx: f32| VehicleState {
            x,
            y: 0.0,
            vx,
            vy: 0.0,
            hx: 1.0,
            hy: 0.0,
            acc: 0.0,
            length: 4.5,
            width: 1.8,
        };
        (car(0.0, v), car(30.0, 15.0))
    }

    /// The `v_ego` range measured on 200 sequences of 100 frames at 10-20 m/s, of which three
    /// (1.5 %) end in one frame at 30 m/s and one (0.5 %) carries a one-frame glitch at 60 m/s.
    fn v_ego_range(tails: Tails) -> (f32, f32) {
        let sequences: Vec<Vec<(VehicleState, VehicleState)>> = (0..200)
            .map(|s| {
                (0..100)
                    .map(|f| {
                        let v = match (s, f) {
                            (0..=2, 99) => 30.0,
                            (7, 50) => 60.0,
                            _ => 10.0 + ((s * 100 + f) % 101) as f32 / 10.0,
                        };
                        pair(v)
                    })
                    .collect()
            })
            .collect();
        let blob =
            scorer_core::model::decode_blob(include_bytes!("../../../models/drl-default.rsk"))
                .unwrap();
        let per_sequence = sequences.iter().map(|s| s.iter().map(|(e, p)| (e, p)));
        let measured = measure(&blob.model, per_sequence, tails, OutsidePolicy::FlagOnly).unwrap();
        let v_ego = scorer_core::encoding::DRL_INPUT_NAMES
            .iter()
            .position(|&n| n == "v_ego")
            .unwrap();
        let range = measured
            .domain()
            .ranges()
            .find(|r| usize::from(r.input) == v_ego)
            .unwrap();
        (range.lo, range.hi)
    }

    #[test]
    fn a_value_a_share_of_the_sequences_reached_is_inside_and_a_glitch_is_not() {
        assert_eq!(v_ego_range(DEFAULT_TAILS), (10.0, 30.0));
        // The frame quantiles alone leave the three sequences' last frames outside.
        let frames_only = Tails {
            sequences: 1.0,
            ..DEFAULT_TAILS
        };
        assert_eq!(v_ego_range(frames_only), (10.0, 20.0));
        // Min/max takes the glitch in.
        let min_max = Tails {
            frames: 0.0,
            sequences: 1.0,
            ..DEFAULT_TAILS
        };
        assert_eq!(v_ego_range(min_max), (10.0, 60.0));
    }

    #[test]
    fn shares_out_of_range_are_refused() {
        let blob =
            scorer_core::model::decode_blob(include_bytes!("../../../models/drl-default.rsk"))
                .unwrap();
        let none = std::iter::empty::<std::iter::Empty<(&VehicleState, &VehicleState)>>;
        let bad = |frames, sequences| {
            measure(
                &blob.model,
                none(),
                Tails {
                    frames,
                    sequences,
                    ..DEFAULT_TAILS
                },
                OutsidePolicy::FlagOnly,
            )
            .unwrap_err()
        };
        assert!(matches!(bad(0.5, 0.01), DomainRangesError::BadTail(_)));
        assert!(matches!(
            bad(0.001, 1.5),
            DomainRangesError::BadSequenceShare(_)
        ));
        assert!(matches!(
            bad(0.001, 0.01),
            DomainRangesError::NoObservations
        ));
    }

    #[test]
    fn a_geometry_cell_is_covered_once_enough_sequences_reached_it() {
        let blob =
            scorer_core::model::decode_blob(include_bytes!("../../../models/drl-default.rsk"))
                .unwrap();
        // 100 following sequences; `crossing` of them also pass a partner crossing 20 m to the
        // right of a straight lane.
        let crossing_pair = {
            let (ego, mut partner) = pair(10.0);
            (partner.x, partner.y, partner.vx, partner.hx, partner.hy) =
                (0.0, -20.0, 0.0, 0.0, 1.0);
            partner.vy = 8.0;
            (ego, partner)
        };
        let cell_of = |(e, p): &(VehicleState, VehicleState)| {
            scorer_core::geometry_cell::geometry_cell(&scorer_core::drl_inputs(e, p))
        };
        let (following, crossing) = (cell_of(&pair(10.0)), cell_of(&crossing_pair));
        assert_ne!(following, crossing);
        let covered = |crossing_sequences: usize, cell_sequences: usize| {
            let sequences: Vec<Vec<(VehicleState, VehicleState)>> = (0..100)
                .map(|s| {
                    let mut frames = vec![pair(10.0); 10];
                    if s < crossing_sequences {
                        frames.push(crossing_pair);
                    }
                    frames
                })
                .collect();
            let per_sequence = sequences.iter().map(|s| s.iter().map(|(e, p)| (e, p)));
            let tails = Tails {
                cell_sequences,
                ..DEFAULT_TAILS
            };
            let measured =
                measure(&blob.model, per_sequence, tails, OutsidePolicy::FlagOnly).unwrap();
            let domain = measured.domain();
            let coverage = domain.coverage.unwrap();
            assert!(coverage.covers(following));
            (coverage.covers(crossing), coverage.covered())
        };
        assert_eq!(covered(4, 5), (false, 1));
        assert_eq!(covered(5, 5), (true, 2));
        assert_eq!(covered(1, 1), (true, 2));
        assert_eq!(covered(0, 1), (false, 1));
        // MSRA reads the features: no cells.
        let msra =
            scorer_core::model::decode_blob(include_bytes!("../../../models/msra-default.rsk"))
                .unwrap();
        let frames = [pair(10.0)];
        let one = std::iter::once(frames.iter().map(|(e, p)| (e, p)));
        let measured = measure(&msra.model, one, DEFAULT_TAILS, OutsidePolicy::FlagOnly).unwrap();
        assert_eq!(measured.coverage, None);
    }
}
