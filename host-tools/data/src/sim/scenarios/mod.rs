//! Scenario families and their parameter distributions (documented in `docs/simulator.md`).
//!
//! A family builds the two vehicles (paths, initial states, drivers, scripted behaviour) from
//! randomly drawn parameters. `hazardous` selects the parameter regime: hazardous draws (short
//! headways, distraction, late or misjudged decisions, hard braking) and benign draws (ample
//! gaps, attentive drivers, gentle manoeuvres, but still close interactions). The regime only
//! shapes the draw: what actually happened is decided afterwards from the trajectories.
mod crossing;
mod following;
mod parts;

use rand_chacha::ChaCha8Rng;

use super::world::Agent;
use crossing::{crossing, left_turn_across, opposite_drift, turn_into_path};
use following::{cut_in, lane_change, lead_braking, merge, stopped_ahead};
use parts::{u, vehicle};
pub use parts::{Vehicle, VehicleClass};

/// The scenario families.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    LeadBraking,
    StoppedAhead,
    CutIn,
    LaneChange,
    Merge,
    Crossing,
    LeftTurnAcross,
    TurnIntoPath,
    OppositeDrift,
}

impl Family {
    pub const ALL: [Family; 9] = [
        Family::LeadBraking,
        Family::StoppedAhead,
        Family::CutIn,
        Family::LaneChange,
        Family::Merge,
        Family::Crossing,
        Family::LeftTurnAcross,
        Family::TurnIntoPath,
        Family::OppositeDrift,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Family::LeadBraking => "lead_braking",
            Family::StoppedAhead => "stopped_ahead",
            Family::CutIn => "cut_in",
            Family::LaneChange => "lane_change",
            Family::Merge => "merge",
            Family::Crossing => "crossing",
            Family::LeftTurnAcross => "left_turn_across",
            Family::TurnIntoPath => "turn_into_path",
            Family::OppositeDrift => "opposite_drift",
        }
    }
    /// Relative frequency of the family in draws.
    fn weight(self) -> f64 {
        match self {
            Family::LeadBraking => 0.20,
            Family::StoppedAhead => 0.10,
            Family::CutIn => 0.13,
            Family::LaneChange => 0.11,
            Family::Merge => 0.08,
            Family::Crossing => 0.13,
            Family::LeftTurnAcross => 0.09,
            Family::TurnIntoPath => 0.06,
            Family::OppositeDrift => 0.10,
        }
    }
}

/// A built scenario: ego is agent 0, its partner (the other road user) agent 1.
pub(crate) struct Scenario {
    pub family: Family,
    pub agents: [Agent; 2],
    pub classes: [VehicleClass; 2],
    /// Simulated duration (s).
    pub horizon: f64,
}

/// Draws one scenario of a random family.
pub(crate) fn draw(rng: &mut ChaCha8Rng, hazardous: bool) -> Scenario {
    let total: f64 = Family::ALL.iter().map(|f| f.weight()).sum();
    let mut r = u(rng, 0.0, total);
    let mut family = Family::LeadBraking;
    for f in Family::ALL {
        if r < f.weight() {
            family = f;
            break;
        }
        r -= f.weight();
    }
    build(family, rng, hazardous)
}

/// Builds a scenario of `family`.
pub(crate) fn build(family: Family, rng: &mut ChaCha8Rng, hz: bool) -> Scenario {
    let ego = vehicle(rng, true);
    let partner = vehicle(rng, false);
    // `first` is the role the family calls A; the ego takes it with probability `p_ego_first`.
    let (a, b, horizon, p_ego_first) = match family {
        Family::LeadBraking => lead_braking(rng, hz, &ego, &partner),
        Family::StoppedAhead => stopped_ahead(rng, hz, &ego, &partner),
        Family::CutIn => cut_in(rng, hz, &ego, &partner),
        Family::LaneChange => lane_change(rng, hz, &ego, &partner),
        Family::Merge => merge(rng, hz, &ego, &partner),
        Family::Crossing => crossing(rng, hz, &ego, &partner),
        Family::LeftTurnAcross => left_turn_across(rng, hz, &ego, &partner),
        Family::TurnIntoPath => turn_into_path(rng, hz, &ego, &partner),
        Family::OppositeDrift => opposite_drift(rng, hz, &ego, &partner),
    };
    // Role assignment was drawn inside: `a` is the ego when the flag says so.
    let (agents, classes) = if p_ego_first {
        ([a, b], [ego.class, partner.class])
    } else {
        ([b, a], [ego.class, partner.class])
    };
    Scenario {
        family,
        agents,
        classes,
        horizon,
    }
}
