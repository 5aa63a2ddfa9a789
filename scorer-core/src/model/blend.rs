//! The blend record (tag 5 of a version-2 blob): how much of the model's own score a blob under
//! [`OutsidePolicy::Blend`](super::OutsidePolicy::Blend) keeps inside its training domain.
//!
//! Inside the domain such a blob scores `w * model + (1 - w) * fallback`, the fallback being the
//! kinematic one of record tag 3 ([`KinematicFallback`](super::KinematicFallback)) on the model's
//! own scale; outside it scores the fallback alone, as under the fallback policy. A network
//! trained without a geometry or a speed band still ranks inside its ranges and cells, where it
//! extrapolates between what it saw; the kinematic share keeps an ordering there that needs no
//! examples (`docs/domain-guard.md`, "Blend").
//!
//! Body (postcard): `network_weight: f32` little-endian, `0 < w < 1`. A build that does not know
//! tag 5 refuses the blob through its policy byte (3) before it could read the record wrongly.
use serde::{Deserialize, Serialize};

use super::ModelError;
use crate::wire_reader::WireReader;

/// Record tag of the [`Blend`].
pub const BLEND_TAG: u8 = 5;

/// The model's share `w` of the score inside the domain; the kinematic fallback has `1 - w`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Blend {
    /// Strictly between 0 and 1 (0 would be the fallback everywhere, 1 the fallback policy).
    pub network_weight: f32,
}

impl Blend {
    /// The record body's fields, in postcard order.
    pub(super) fn read(r: &mut WireReader<'_>) -> Result<Self, postcard::Error> {
        Ok(Self {
            network_weight: r.f32()?,
        })
    }

    /// `w * model + (1 - w) * fallback`.
    pub fn mix(&self, model: f32, fallback: f32) -> f32 {
        self.network_weight * model + (1.0 - self.network_weight) * fallback
    }

    /// `0 < network_weight < 1` (false for NaN).
    pub fn validate(&self) -> Result<(), ModelError> {
        let w = self.network_weight;
        if w > 0.0 && w < 1.0 {
            Ok(())
        } else {
            Err(ModelError::BadRecord {
                field: "blend.network_weight",
                reason: "must lie strictly between 0 and 1",
            })
        }
    }
}
