//! The observation table: every state a pair or anchor refers to, computed once by scorer-core.
use scorer_core::{DrlInputs, Features, Observation, Surrogates, VehicleState};

/// Where a row of the observation table comes from (for audits and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowOrigin {
    /// Frame `frame` of sequence `sequence` of the training (or, with `augmentation`, the
    /// augmentation) sequences passed to [`build`].
    Frame {
        augmentation: bool,
        sequence: u32,
        frame: u32,
    },
    /// A physics counterfactual of the row `of`.
    Counterfactual { of: u32 },
    /// Added directly (tests, external tables).
    External,
}

/// Every observation used by pairs or anchors, computed by scorer-core once per row
/// ([`Observation::of`]) and stored by column (features, surrogates, DRL inputs), so each model
/// reads the part it needs as a slice.
#[derive(Clone, Debug, Default)]
pub struct ObservationTable {
    pub features: Vec<Features>,
    pub surrogates: Vec<Surrogates>,
    pub drl_inputs: Vec<DrlInputs>,
    pub origins: Vec<RowOrigin>,
}

impl ObservationTable {
    pub fn len(&self) -> usize {
        self.features.len()
    }

    pub fn is_empty(&self) -> bool {
        self.features.is_empty()
    }

    /// Compute and append one observation; returns its row.
    pub fn push(&mut self, ego: &VehicleState, partner: &VehicleState, origin: RowOrigin) -> u32 {
        self.push_computed(Observation::of(ego, partner), origin)
    }

    /// Append an observation that is already computed.
    pub fn push_computed(&mut self, observation: Observation, origin: RowOrigin) -> u32 {
        self.features.push(observation.features);
        self.surrogates.push(observation.surrogates);
        self.drl_inputs.push(observation.drl_inputs);
        self.origins.push(origin);
        (self.features.len() - 1) as u32
    }
}
