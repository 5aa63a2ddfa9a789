//! Everything a model reads about one ego/partner pair, computed once by one function.
//!
//! [`Observation::of`] is how every host table (training, evaluation, the C ABI's pair result)
//! gets its numbers, and [`Model::score_observation`](crate::model::Model::score_observation)
//! scores it; [`Model::score`](crate::model::Model::score) computes only the part its model reads
//! and gives the same bits.
use crate::encoding::{encode, DrlInputs};
use crate::features::Features;
use crate::geometry::unit_heading;
use crate::state::VehicleState;
use crate::surrogates::{surrogates_and_features_with_headings, Surrogates};

/// One ego/partner pair as every model sees it: the 13 reference features (GSSM, MSRA), the
/// surrogates (MSRA, baselines) and the DRL input encoding (DRL).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// The 13 reference features ([`crate::features()`]; names, units and the ego-frame
    /// convention in [`crate::features`](mod@crate::features)): what GSSM and MSRA blobs read
    /// and their training domain bounds. Always finite (NaN becomes 0, infinities
    /// `+-f32::MAX`).
    pub features: Features,
    /// Box distance (m), TTC2D (s), TAdv (s) and EI (m/s) ([`crate::surrogates()`]): "no
    /// conflict" is `+inf` for TTC2D and TAdv, `-inf` for EI; without a box the box distance is
    /// `+inf` too. Never NaN.
    pub surrogates: Surrogates,
    /// The 13 DRL inputs of encoding 3 ([`crate::drl_inputs()`]; table in [`crate::encoding`]):
    /// what DRL blobs read and their training domain bounds. Always finite.
    pub drl_inputs: DrlInputs,
}

impl Observation {
    /// The observation of the pair (`ego`, `partner`): [`crate::features()`], [`crate::surrogates()`]
    /// and [`crate::drl_inputs()`] (which reuses the surrogates' box distance, the same number).
    pub fn of(ego: &VehicleState, partner: &VehicleState) -> Self {
        // Each heading is normalised once for all three parts.
        let (heading_ego, heading_partner) = (unit_heading(ego), unit_heading(partner));
        let (surrogates, features) =
            surrogates_and_features_with_headings(ego, heading_ego, partner, heading_partner);
        Self {
            features,
            surrogates,
            drl_inputs: encode(
                ego,
                heading_ego,
                partner,
                heading_partner,
                surrogates.box_distance,
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::features;
    use crate::surrogates::surrogates;

    #[test]
    fn observation_parts_are_the_standalone_functions_bit_for_bit() {
        let ego = VehicleState {
            vy: 20.0,
            hy: 1.0,
            length: 4.6,
            width: 1.9,
            ..Default::default()
        };
        let partner = VehicleState {
            x: 3.1,
            y: 12.0,
            vx: -1.0,
            vy: 14.0,
            hx: -0.1,
            hy: 1.0,
            length: 12.0,
            width: 2.5,
            ..Default::default()
        };
        let o = Observation::of(&ego, &partner);
        let bits = |v: &[f32]| {
            v.iter()
                .map(|x| x.to_bits())
                .collect::<heapless::Vec<u32, 16>>()
        };
        assert_eq!(bits(&o.features), bits(&features(&ego, &partner)));
        assert_eq!(o.surrogates, surrogates(&ego, &partner));
        assert_eq!(
            bits(&o.drl_inputs),
            bits(&crate::drl_inputs(&ego, &partner))
        );
    }
}
