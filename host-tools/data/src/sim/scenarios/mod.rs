//! Scenario families and their parameter distributions (documented in `docs/simulator.md`).
//!
//! A family builds the two vehicles (paths, initial states, drivers, scripted behaviour) from
//! randomly drawn parameters. `hazardous` selects the parameter regime: hazardous draws (short
//! headways, distraction, late or misjudged decisions, hard braking) and benign draws (ample
//! gaps, attentive drivers, gentle manoeuvres, but still close interactions). The regime only
//! shapes the draw: what actually happened is decided afterwards from the trajectories.
mod crossing;
mod following;
mod junction;
mod motorway;
mod parts;
mod queue;
mod roadside;

use rand_chacha::ChaCha8Rng;

use super::world::Agent;
use crossing::{crossing, left_turn_across, opposite_drift, turn_into_path};
use following::{cut_in, lane_change, lead_braking, merge, stopped_ahead};
use junction::{signal_crossing, signal_left_turn, signal_right_turn};
use motorway::{motorway_approach, motorway_cut_in};
pub(crate) use parts::u as uniform;
use parts::vehicle;
pub use parts::{Vehicle, VehicleClass};
use queue::signal_queue;
use roadside::roadside_object;

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
    MotorwayApproach,
    MotorwayCutIn,
    SignalQueue,
    SignalCrossing,
    SignalLeftTurn,
    SignalRightTurn,
    RoadsideObject,
}

impl Family {
    pub const ALL: [Family; 16] = [
        Family::LeadBraking,
        Family::StoppedAhead,
        Family::CutIn,
        Family::LaneChange,
        Family::Merge,
        Family::Crossing,
        Family::LeftTurnAcross,
        Family::TurnIntoPath,
        Family::OppositeDrift,
        Family::MotorwayApproach,
        Family::MotorwayCutIn,
        Family::SignalQueue,
        Family::SignalCrossing,
        Family::SignalLeftTurn,
        Family::SignalRightTurn,
        Family::RoadsideObject,
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
            Family::MotorwayApproach => "motorway_approach",
            Family::MotorwayCutIn => "motorway_cut_in",
            Family::SignalQueue => "signal_queue",
            Family::SignalCrossing => "signal_crossing",
            Family::SignalLeftTurn => "signal_left_turn",
            Family::SignalRightTurn => "signal_right_turn",
            Family::RoadsideObject => "roadside_object",
        }
    }
    /// The family called `name` (as written in `scenarios.csv`).
    pub fn from_name(name: &str) -> Option<Family> {
        Family::ALL.into_iter().find(|f| f.name() == name)
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

/// Builds a scenario of `family`.
pub(crate) fn build(family: Family, rng: &mut ChaCha8Rng, hz: bool) -> Scenario {
    let ego = vehicle(rng, true);
    let partner = vehicle(rng, false);
    let mut classes = [ego.class, partner.class];
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
        Family::MotorwayApproach => motorway_approach(rng, hz, &ego, &partner),
        Family::MotorwayCutIn => motorway_cut_in(rng, hz, &ego, &partner),
        Family::SignalQueue => signal_queue(rng, hz, &ego, &partner),
        Family::SignalCrossing => signal_crossing(rng, hz, &ego, &partner),
        Family::SignalLeftTurn => signal_left_turn(rng, hz, &ego, &partner),
        Family::SignalRightTurn => signal_right_turn(rng, hz, &ego, &partner),
        Family::RoadsideObject => {
            let (built, object) = roadside_object(rng, hz, &ego, &partner);
            classes[1] = object;
            built
        }
    };
    // Role assignment was drawn inside: `a` is the ego when the flag says so.
    let agents = if p_ego_first { [a, b] } else { [b, a] };
    Scenario {
        family,
        agents,
        classes,
        horizon,
    }
}
