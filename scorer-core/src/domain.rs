//! The guard at the edge of the operating domain: whether an observation lies inside the range the
//! model's training data covered, and the guarded score ([`ModelBlob::score_guarded`]).
//!
//! The domain ([`TrainingDomain`], record tag 2 of the blob) bounds the vector the model kind reads:
//! the DRL inputs (schema 3) for DRL, the 13 features for MSRA and GSSM. An observation is inside
//! when every bounded input `x` satisfies `lo <= x <= hi`; a NaN input is outside (it compares
//! false). The first range, in record order, that an input leaves is reported for diagnostics. The
//! domain of a network (DRL, GSSM: [`Model::runs_a_network`]) may also carry the geometry cells
//! its training data reached (record tag 4, [`crate::geometry_cell`], read off the DRL inputs
//! whatever the kind reads): an observation inside every range whose cell is not covered is
//! outside, reported as input [`GEOMETRY_INPUT`] (13). A blob without the record is inside
//! everywhere and scores exactly as [`Model::score`].
//!
//! Under the fallback policy an observation outside scores the blob's kinematic fallback (record
//! tag 3, [`KinematicFallback`](crate::model::KinematicFallback)) from the pair's surrogates; the
//! model itself is not run then. The blend policy does the same outside and, inside, mixes the
//! model's score with that fallback by the blob's [`Blend`](crate::model::Blend) record (tag 5).
//!
//! No allocation, no panic: a fixed 13-element copy of the inputs is clamped when the policy asks.
use crate::encoding::drl_inputs;
use crate::features::{features, Features};
use crate::geometry_cell::geometry_cell;
use crate::model::geometry_coverage::GEOMETRY_INPUT;
use crate::model::training_domain::{InputRange, OutsidePolicy, TrainingDomain};
use crate::model::{Model, ModelBlob};
use crate::observation::Observation;
use crate::state::VehicleState;
use crate::surrogates::{surrogates, surrogates_and_features, Surrogates};

/// Every model kind reads 13 numbers (DRL inputs or features): the vector a domain bounds.
pub type DomainInputs = Features;

/// A score with what the guard says about the observation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guarded {
    /// The score under the blob's policy (inside the domain the model's own, or its blend).
    pub score: f32,
    /// True when every bounded input is inside its trained range and, when the blob carries a
    /// geometry-coverage record, the observation's geometry cell is covered (always for an
    /// unguarded blob).
    pub in_domain: bool,
    /// The input index of the first range (record order) the observation is outside of, else
    /// [`GEOMETRY_INPUT`] (13) when it is inside every range but its geometry cell is not covered.
    /// The index is into the vector the model kind reads ([`Model::domain_inputs`]): name it with
    /// [`crate::DRL_INPUT_NAMES`] when [`Model::reads_drl_inputs`], else [`crate::FEATURE_NAMES`],
    /// and 13 with [`GEOMETRY_INPUT_NAME`](crate::model::geometry_coverage::GEOMETRY_INPUT_NAME).
    pub first_outside: Option<u8>,
}

impl InputRange {
    /// `lo <= x <= hi`; false for NaN.
    pub fn contains(&self, x: f32) -> bool {
        x >= self.lo && x <= self.hi
    }

    /// `x` moved into `[lo, hi]`; NaN to the midpoint (it has no nearer end).
    pub fn clamp(&self, x: f32) -> f32 {
        if x < self.lo {
            self.lo
        } else if x > self.hi {
            self.hi
        } else if x.is_nan() {
            // Halves first: `hi - lo` may overflow for ranges near f32::MAX.
            self.lo * 0.5 + self.hi * 0.5
        } else {
            x
        }
    }

    fn value(&self, inputs: &DomainInputs) -> f32 {
        // An index past the vector cannot pass validation; read it as inside rather than panic.
        inputs
            .get(usize::from(self.input))
            .copied()
            .unwrap_or(self.lo)
    }
}

impl TrainingDomain<'_> {
    /// The input index of the first range `inputs` leaves; inside every range,
    /// [`GEOMETRY_INPUT`] when the observation's geometry cell (`cell`, asked only when the domain
    /// has cells: [`geometry_cell`] of its DRL inputs) is not covered; `None` when inside.
    pub fn first_outside(&self, inputs: &DomainInputs, cell: impl FnOnce() -> u8) -> Option<u8> {
        self.ranges()
            .find(|r| !r.contains(r.value(inputs)))
            .map(|r| r.input)
            .or_else(|| {
                let covered = self.coverage?.covers(cell());
                (!covered).then_some(GEOMETRY_INPUT)
            })
    }

    /// [`TrainingDomain::first_outside`] of an observation computed once, as `model` reads it.
    pub fn first_outside_of(&self, model: &Model<'_>, observation: &Observation) -> Option<u8> {
        self.first_outside(model.domain_inputs(observation), || {
            geometry_cell(&observation.drl_inputs)
        })
    }

    /// Moves every bounded input into its range (see [`InputRange::clamp`]). Clamping cannot move
    /// an observation into a covered geometry cell: there the model scores as under flag-only.
    pub fn clamp(&self, inputs: &mut DomainInputs) {
        for r in self.ranges() {
            if let Some(x) = inputs.get_mut(usize::from(r.input)) {
                *x = r.clamp(*x);
            }
        }
    }
}

impl Model<'_> {
    /// The vector of `observation` that this kind reads and a training domain bounds.
    pub fn domain_inputs<'o>(&self, observation: &'o Observation) -> &'o DomainInputs {
        match self {
            Self::DrlInt8(_) | Self::DrlF32(_) => &observation.drl_inputs,
            Self::Msra(_) | Self::Gssm(_) => &observation.features,
        }
    }
}

impl ModelBlob<'_> {
    /// The guarded score of an observation computed once ([`Observation::of`]). Inside the
    /// domain (or without a record) the score is [`Model::score_observation`] bit for bit, except
    /// under the blend policy (its mix with the fallback).
    pub fn score_guarded(&self, observation: &Observation) -> Guarded {
        let inputs = *self.model.domain_inputs(observation);
        self.guard(
            inputs,
            || geometry_cell(&observation.drl_inputs),
            |x| {
                let mut o = *observation;
                match self.model {
                    Model::DrlInt8(_) | Model::DrlF32(_) => o.drl_inputs = *x,
                    Model::Msra(_) | Model::Gssm(_) => o.features = *x,
                }
                self.model.score_observation(&o)
            },
            || observation.surrogates,
        )
    }

    /// The guarded score of one pair, computing only what the model reads (the ECU's path); the
    /// same bits as [`ModelBlob::score_guarded`] of [`Observation::of`] the pair. The score is
    /// finite for every pair of a decoded blob; it is a risk only for states the C ABI would accept
    /// (see "Check states before scoring" on [`VehicleState`]).
    pub fn score_pair_guarded(&self, ego: &VehicleState, partner: &VehicleState) -> Guarded {
        // The surrogates only when the fallback needs them (DRL, GSSM) or the model reads them;
        // a GSSM's geometry cell only when its domain has cells.
        let fallback = || surrogates(ego, partner);
        match &self.model {
            Model::DrlInt8(m) => {
                let x = drl_inputs(ego, partner);
                self.guard(x, || geometry_cell(&x), |x| m.forward(x)[0], fallback)
            }
            Model::DrlF32(m) => {
                let x = drl_inputs(ego, partner);
                self.guard(x, || geometry_cell(&x), |x| m.forward(x)[0], fallback)
            }
            Model::Msra(m) => {
                let (s, f) = surrogates_and_features(ego, partner);
                let cell = || geometry_cell(&drl_inputs(ego, partner));
                self.guard(f, cell, |f| m.score(f, &s), || s)
            }
            Model::Gssm(m) => {
                let cell = || geometry_cell(&drl_inputs(ego, partner));
                self.guard(features(ego, partner), cell, |f| m.score(f), fallback)
            }
        }
    }

    fn guard(
        &self,
        mut inputs: DomainInputs,
        cell: impl FnOnce() -> u8,
        score: impl Fn(&DomainInputs) -> f32,
        surrogates: impl Fn() -> Surrogates,
    ) -> Guarded {
        let Some(domain) = &self.meta.training_domain else {
            return Guarded {
                score: score(&inputs),
                in_domain: true,
                first_outside: None,
            };
        };
        let first_outside = domain.first_outside(&inputs, cell);
        let fallback = self.meta.kinematic_fallback.as_ref();
        let score = match (first_outside, domain.policy, fallback, &self.meta.blend) {
            (None, OutsidePolicy::Blend, Some(fallback), Some(blend)) => {
                blend.mix(score(&inputs), fallback.score(&surrogates()))
            }
            (None, ..) | (Some(_), OutsidePolicy::FlagOnly, ..) => score(&inputs),
            (Some(_), OutsidePolicy::Clamp, ..) => {
                domain.clamp(&mut inputs);
                score(&inputs)
            }
            (Some(_), OutsidePolicy::Fallback | OutsidePolicy::Blend, Some(fallback), _) => {
                fallback.score(&surrogates())
            }
            // A decoded blob never has these policies without their records
            // (`ModelMeta::validate`); an unvalidated one in memory scores as flag-only rather
            // than panic.
            (Some(_), OutsidePolicy::Fallback | OutsidePolicy::Blend, None, _) => score(&inputs),
        };
        Guarded {
            score,
            in_domain: first_outside.is_none(),
            first_outside,
        }
    }
}
