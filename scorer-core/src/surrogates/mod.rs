//! Surrogate safety measures of an ego/partner pair, reproducing the published reference
//! implementations (see `tests/data/golden_README.md` for the conventions and the parity data).
//!
//! - [`ttc2d`]: two-dimensional time-to-collision (s). `f32::INFINITY` = no conflict.
//! - [`tadv`]: time advantage (s). `f32::INFINITY` = no conflict.
//! - [`tadv_corridor`]: TAdv under the corridor rule (s): not a reference measure; standing road
//!   users beside the mover's path are no conflict. `f32::INFINITY` = no conflict.
//! - [`ei`]: emergency index (m/s). `f32::NEG_INFINITY` = no conflict.
//! - [`box_distance`](crate::geometry::box_distance): exact gap between the boxes (m).
//!
//! Every function is total: NaN or infinite inputs, zero headings and overflowing intermediate
//! values give the "no conflict" sentinel (or a finite value), never NaN and never a panic.
//! TTC2D and TAdv move the vehicles with `(vx, vy)` and use the heading only for the box; EI, like
//! its reference, moves each vehicle with its speed `|(vx, vy)|` along its heading.
use crate::features::{features_from, Features, PSI_SUR};
use crate::geometry::{centre_distance, unit_heading, BoxPair, OrientedBox, Speeds, Vec2};
use crate::state::VehicleState;

mod angle;
mod ei;
mod guard;
mod tadv;
mod tadv_corridor;
mod ttc2d;

pub use ei::ei;
pub use tadv::tadv;
pub use tadv_corridor::{tadv_corridor, STANDING_SPEED};
pub use ttc2d::ttc2d;

/// Which surrogate an MSRA term (or a baseline) reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[repr(u8)]
pub enum SurrogateKind {
    /// Two-dimensional time-to-collision ([`ttc2d`], s; smaller is riskier, `+inf` = no
    /// conflict). Wire index 0.
    Ttc2d = 0,
    /// Time advantage ([`tadv`], s; smaller is riskier, `+inf` = no conflict). Wire index 1.
    Tadv = 1,
    /// Emergency index ([`ei`], m/s; larger is riskier, `-inf` = no conflict). Wire index 2.
    Ei = 2,
    /// The score of the GSSM network embedded in an MSRA model ([`crate::gssm`]; larger is
    /// riskier; dimensionless, in the range of its [`GssmScore`](crate::gssm::GssmScore) mode); not a kinematic measure, so not in [`Surrogates`].
    /// Wire index 3.
    Gssm = 3,
    /// TAdv under the corridor rule ([`tadv_corridor`], s; smaller is riskier, `+inf` = no
    /// conflict): a standing road user beside the mover's path is no conflict. Wire index 4.
    TadvCorridor = 4,
}

impl SurrogateKind {
    /// Every kind, in wire order.
    pub const ALL: [SurrogateKind; 5] = [
        SurrogateKind::Ttc2d,
        SurrogateKind::Tadv,
        SurrogateKind::Ei,
        SurrogateKind::Gssm,
        SurrogateKind::TadvCorridor,
    ];

    /// The name reports and tables print (`TTC2D`, `TAdv`, `EI`, `GSSM`, `TAdv-corridor`).
    pub const fn name(self) -> &'static str {
        match self {
            SurrogateKind::Ttc2d => "TTC2D",
            SurrogateKind::Tadv => "TAdv",
            SurrogateKind::Ei => "EI",
            SurrogateKind::Gssm => "GSSM",
            SurrogateKind::TadvCorridor => "TAdv-corridor",
        }
    }

    /// The key configuration and model files use (`ttc2d`, `tadv`, `ei`, `gssm`, `tadv_corridor`).
    pub const fn key(self) -> &'static str {
        match self {
            SurrogateKind::Ttc2d => "ttc2d",
            SurrogateKind::Tadv => "tadv",
            SurrogateKind::Ei => "ei",
            SurrogateKind::Gssm => "gssm",
            SurrogateKind::TadvCorridor => "tadv_corridor",
        }
    }

    /// Reads a key or a name, case-insensitively and ignoring surrounding white space; `ttc` is
    /// accepted for TTC2D. `None` for anything else.
    pub fn parse(text: &str) -> Option<SurrogateKind> {
        let text = text.trim();
        if text.eq_ignore_ascii_case("ttc") {
            return Some(SurrogateKind::Ttc2d);
        }
        SurrogateKind::ALL.into_iter().find(|kind| {
            text.eq_ignore_ascii_case(kind.key()) || text.eq_ignore_ascii_case(kind.name())
        })
    }

    /// True where a larger value means more risk (EI, GSSM); TTC2D and TAdv are riskier when
    /// smaller.
    pub const fn larger_is_riskier(self) -> bool {
        matches!(self, SurrogateKind::Ei | SurrogateKind::Gssm)
    }

    /// The value of this surrogate in `surrogates`; NaN for GSSM, which is a learned model, not a
    /// geometric measure (its value comes from [`crate::gssm`]).
    pub const fn value_in(self, surrogates: &Surrogates) -> f32 {
        match self {
            SurrogateKind::Ttc2d => surrogates.ttc2d,
            SurrogateKind::Tadv => surrogates.tadv,
            SurrogateKind::Ei => surrogates.ei,
            SurrogateKind::Gssm => f32::NAN,
            SurrogateKind::TadvCorridor => surrogates.tadv_corridor,
        }
    }
}

/// All surrogates of one pair, computed once and shared by MSRA and baselines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surrogates {
    /// Exact box-to-box distance (m), 0 when touching or overlapping.
    pub box_distance: f32,
    /// Two-dimensional time-to-collision (s), `f32::INFINITY` = no conflict by the measure's
    /// rules, which boxes that already touch or overlap (`box_distance` 0) often get too, as in
    /// the reference implementation (all 50 `overlapping` rows of
    /// `tests/data/golden_surrogates.csv`): infinity alone does not mean "no risk".
    pub ttc2d: f32,
    /// Time advantage (s), `f32::INFINITY` = no conflict.
    pub tadv: f32,
    /// Time advantage under the corridor rule (s, [`tadv_corridor`]), `f32::INFINITY` = no
    /// conflict.
    pub tadv_corridor: f32,
    /// Emergency index (m/s), `f32::NEG_INFINITY` = no conflict.
    pub ei: f32,
}

impl Surrogates {
    /// The value of a kinematic surrogate (TTC2D, TAdv, EI, TAdv-corridor); `None` for GSSM, which is a model's
    /// score and not computed here.
    pub fn kinematic(&self, kind: SurrogateKind) -> Option<f32> {
        match kind {
            SurrogateKind::Ttc2d => Some(self.ttc2d),
            SurrogateKind::Tadv => Some(self.tadv),
            SurrogateKind::Ei => Some(self.ei),
            SurrogateKind::Gssm => None,
            SurrogateKind::TadvCorridor => Some(self.tadv_corridor),
        }
    }
}

/// Compute every surrogate of the pair (`ego`, `partner`).
pub fn surrogates(ego: &VehicleState, partner: &VehicleState) -> Surrogates {
    surrogates_from(
        ego,
        unit_heading(ego),
        partner,
        unit_heading(partner),
        Speeds::of(ego, partner),
        centre_distance(ego, partner),
        None,
    )
}

/// Every surrogate and the 13 features of the pair, bit for bit [`surrogates`] and
/// [`features`](crate::features::features), with what they share done once: each heading is
/// normalised, each box built and the boxes' relative geometry taken once (not once per measure);
/// the two speeds and the centre distance are one square root each; TAdv's near-parallel
/// fallback reuses the box distance and EI's heading test the feature `psi_sur`.
pub fn surrogates_and_features(
    ego: &VehicleState,
    partner: &VehicleState,
) -> (Surrogates, Features) {
    surrogates_and_features_with_headings(ego, unit_heading(ego), partner, unit_heading(partner))
}

/// [`surrogates_and_features`] with the [`unit_heading`] of each state already computed.
pub(crate) fn surrogates_and_features_with_headings(
    ego: &VehicleState,
    heading_ego: Option<Vec2>,
    partner: &VehicleState,
    heading_partner: Option<Vec2>,
) -> (Surrogates, Features) {
    let speeds = Speeds::of(ego, partner);
    let distance = centre_distance(ego, partner);
    let features = features_from(
        ego,
        heading_ego,
        partner,
        heading_partner,
        speeds.ego,
        distance,
    );
    // With both boxes (the only case EI asks), `psi_sur` is `atan2` of the unit headings' cross
    // and dot products, finite and so not clamped: the boxes' `atan2(sin, cos)`.
    let heading_angle = features.get(PSI_SUR).copied();
    let surrogates = surrogates_from(
        ego,
        heading_ego,
        partner,
        heading_partner,
        speeds,
        distance,
        heading_angle,
    );
    (surrogates, features)
}

/// [`surrogates`] with the [`unit_heading`] of each state, the pair's speeds and centre distance
/// already computed, and the angle from the ego's heading to the partner's when the caller has it
/// (else EI computes it if it needs it).
fn surrogates_from(
    ego: &VehicleState,
    heading_ego: Option<Vec2>,
    partner: &VehicleState,
    heading_partner: Option<Vec2>,
    speeds: Speeds,
    distance: f32,
    heading_angle: Option<f32>,
) -> Surrogates {
    let boxes = (
        OrientedBox::with_axis(ego, heading_ego),
        OrientedBox::with_axis(partner, heading_partner),
    );
    let (Some(bi), Some(bj)) = boxes else {
        // What each measure reports without a box.
        return Surrogates {
            box_distance: f32::INFINITY,
            ttc2d: f32::INFINITY,
            tadv: f32::INFINITY,
            tadv_corridor: f32::INFINITY,
            ei: f32::NEG_INFINITY,
        };
    };
    let boxes = BoxPair::new(&bi, &bj);
    let box_distance = boxes.gap();
    let tadv = tadv::tadv_of_pair(&boxes, ego, partner, speeds, || box_distance);
    Surrogates {
        box_distance,
        ttc2d: ttc2d::ttc2d_of_boxes(&boxes.a, &boxes.b, boxes.b_in_a.0 < 0.0, ego, partner),
        tadv,
        tadv_corridor: tadv_corridor::tadv_corridor_of_pair(&boxes, speeds, tadv),
        ei: ei::ei_of_pair(&boxes, ego, partner, speeds, distance, || {
            heading_angle.unwrap_or_else(|| libm::atan2f(boxes.sin, boxes.cos))
        }),
    }
}

/// A 4 m x 2 m test vehicle at `(x, y)` with velocity `(vx, vy)` and heading `(hx, hy)`.
#[cfg(test)]
pub(crate) fn test_car(x: f32, y: f32, vx: f32, vy: f32, hx: f32, hy: f32) -> VehicleState {
    VehicleState {
        x,
        y,
        vx,
        vy,
        hx,
        hy,
        acc: 0.0,
        length: 4.0,
        width: 2.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_parses_from_its_key_and_name() {
        for kind in SurrogateKind::ALL {
            assert_eq!(SurrogateKind::parse(kind.key()), Some(kind));
            assert_eq!(SurrogateKind::parse(kind.name()), Some(kind));
            assert_eq!(
                SurrogateKind::ALL[kind as usize],
                kind,
                "ALL is in wire order"
            );
        }
        assert_eq!(SurrogateKind::parse(" TTC "), Some(SurrogateKind::Ttc2d));
        assert_eq!(SurrogateKind::parse("ttc3d"), None);
        assert_eq!(SurrogateKind::parse(""), None);
    }

    #[test]
    fn risk_direction_matches_the_no_conflict_sentinels() {
        // "No conflict" is the least risky value: +inf for the times, -inf for EI.
        let far = surrogates(
            &test_car(0.0, 0.0, -10.0, 0.0, -1.0, 0.0),
            &test_car(0.0, 50.0, 0.0, 10.0, 0.0, 1.0),
        );
        for kind in [
            SurrogateKind::Ttc2d,
            SurrogateKind::Tadv,
            SurrogateKind::Ei,
            SurrogateKind::TadvCorridor,
        ] {
            let v = kind.value_in(&far);
            assert!(v.is_infinite(), "{kind:?}: {v}");
            assert_eq!(kind.larger_is_riskier(), v < 0.0, "{kind:?}");
        }
        assert!(SurrogateKind::Gssm.value_in(&far).is_nan());
    }
}
