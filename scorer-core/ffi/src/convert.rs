//! Conversions between the C types and the core's: vehicle states, the warning configuration,
//! model kinds and errors, warning events, and results into status codes.
use crate::types::{
    RiskscoreLoadInfo, RiskscoreModelKind, RiskscoreStatus, RiskscoreVehicleState,
    RiskscoreWarningConfig, RiskscoreWarningEvent,
};
use crate::{RISKSCORE_FIELD_NAME_LEN, RISKSCORE_NONE_U64};
use core::ffi::c_char;
use scorer_core::geometry::unit_heading;
use scorer_core::model::{ModelError, ModelKind};
use scorer_core::warning::{FullPolicy, WarningConfig, WarningError, WarningEvent};
use scorer_core::VehicleState;

pub(crate) fn vehicle(s: &RiskscoreVehicleState) -> Result<VehicleState, RiskscoreStatus> {
    let v = VehicleState {
        x: s.x,
        y: s.y,
        vx: s.vx,
        vy: s.vy,
        hx: s.hx,
        hy: s.hy,
        acc: s.acc,
        length: s.length,
        width: s.width,
    };
    if !v.is_finite() {
        return Err(RiskscoreStatus::NonFiniteState);
    }
    // `riskctl ssm`'s row rules: a heading the core can normalise, a size >= 0 (0 is a point).
    if unit_heading(&v).is_none() || v.length < 0.0 || v.width < 0.0 {
        return Err(RiskscoreStatus::InvalidInput);
    }
    Ok(v)
}

pub(crate) fn flag(v: u8) -> Result<bool, RiskscoreStatus> {
    match v {
        0 => Ok(false),
        1 => Ok(true),
        _ => Err(RiskscoreStatus::InvalidConfig),
    }
}

/// The C configuration as the core's; `RISKSCORE_STATUS_INVALID_CONFIG` for a flag other than 0/1
/// and for what [`WarningConfig::validate`] refuses: a threshold that is not finite (NaN; `+inf`:
/// no finite score ever warns; `-inf`: every partner warns), a negative or non-finite hysteresis,
/// a hysteresis whose release level `threshold - hysteresis` overflows to `-inf`,
/// `stale_after_us == 0` (every track is stale as soon as the clock moves on: no warning persists,
/// no partner is followed). The zero and finite tests are also written out here, ahead of
/// `validate`'s, which the optimiser then drops: that form is the cheapest found for the 32 KiB
/// flash budget (`footprint_c` 32 660 B; relying on `validate` alone cost 36 B, an equivalent `if`
/// at the top of the function 32 B).
pub(crate) fn warning_config(c: &RiskscoreWarningConfig) -> Result<WarningConfig, RiskscoreStatus> {
    let config = WarningConfig {
        threshold: c.threshold,
        latch: flag(c.latch)?,
        hysteresis: c.hysteresis,
        min_on_us: c.min_on_us,
        // 0 refused; RISKSCORE_NONE_U64 is "never stale".
        stale_after_us: core::num::NonZeroU64::new(c.stale_after_us)
            .ok_or(RiskscoreStatus::InvalidConfig)?
            .get(),
        when_full: if flag(c.evict_when_full)? {
            FullPolicy::EvictLeastRecent
        } else {
            FullPolicy::Reject
        },
    };
    if !c.threshold.is_finite() {
        return Err(RiskscoreStatus::InvalidConfig);
    }
    config
        .validate()
        .map_err(|_| RiskscoreStatus::InvalidConfig)?;
    Ok(config)
}

pub(crate) fn kind_code(kind: ModelKind) -> RiskscoreModelKind {
    match kind {
        ModelKind::DrlInt8 => RiskscoreModelKind::DrlInt8,
        ModelKind::DrlF32 => RiskscoreModelKind::DrlF32,
        ModelKind::Msra => RiskscoreModelKind::Msra,
        ModelKind::Gssm => RiskscoreModelKind::Gssm,
    }
}

pub(crate) fn sat_u32(v: usize) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX - 1)
}

/// Copies `name` into `field`, truncated to leave its terminating NUL. Not inlined: one copy
/// serves every error arm of [`model_error`] (flash).
#[inline(never)]
fn copy_field(field: &mut [c_char; RISKSCORE_FIELD_NAME_LEN], name: &str) {
    let room = RISKSCORE_FIELD_NAME_LEN - 1;
    for (dst, &b) in field.iter_mut().take(room).zip(name.as_bytes()) {
        *dst = b as c_char;
    }
}

/// Status code and load details for a model error.
pub(crate) fn model_error(e: &ModelError, info: &mut RiskscoreLoadInfo) -> RiskscoreStatus {
    let mut field = |name: &str| copy_field(&mut info.field, name);
    match e {
        ModelError::Truncated { needed, available } => {
            info.expected = sat_u32(*needed);
            info.found = sat_u32(*available);
            RiskscoreStatus::ModelTruncated
        }
        ModelError::BadMagic(_) => RiskscoreStatus::ModelBadMagic,
        ModelError::UnsupportedVersion(v) => {
            info.found = u32::from(*v);
            RiskscoreStatus::ModelUnsupportedVersion
        }
        ModelError::UnknownKind(k) => {
            info.found = u32::from(*k);
            RiskscoreStatus::ModelUnknownKind
        }
        ModelError::ReservedNotZero { offset } => {
            info.index = sat_u32(*offset);
            RiskscoreStatus::ModelReservedNotZero
        }
        ModelError::UnsupportedFeatureSchema(s) => {
            info.found = u32::from(*s);
            RiskscoreStatus::ModelUnsupportedFeatureSchema
        }
        ModelError::WrongInputSchema {
            found, expected, ..
        } => {
            field("input_schema");
            info.found = u32::from(*found);
            info.expected = u32::from(*expected);
            RiskscoreStatus::ModelUnsupportedFeatureSchema
        }
        ModelError::TrailingBytes { extra } => {
            info.found = sat_u32(*extra);
            RiskscoreStatus::ModelTrailingBytes
        }
        ModelError::CrcMismatch { stored, computed } => {
            info.expected = *stored;
            info.found = *computed;
            RiskscoreStatus::ModelCrcMismatch
        }
        ModelError::Payload(_) => RiskscoreStatus::ModelMalformedPayload,
        ModelError::CapacityExceeded { field: f, len, max } => {
            field(f);
            info.expected = sat_u32(*max);
            info.found = sat_u32(*len);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::Empty { field: f } => {
            field(f);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::DimensionMismatch {
            field: f,
            index,
            expected,
            found,
        } => {
            field(f);
            info.index = sat_u32(*index);
            info.expected = sat_u32(*expected);
            info.found = sat_u32(*found);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::NonFinite { field: f, index }
        | ModelError::NonPositiveScale { field: f, index } => {
            field(f);
            info.index = sat_u32(*index);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadFeatureIndex { index, feature } => {
            field("inputs");
            info.index = sat_u32(*index);
            info.found = u32::from(*feature);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadMultiplier { layer, channel, .. } => {
            field("layers.multipliers");
            info.index = sat_u32(*layer);
            info.found = sat_u32(*channel);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadClipRange { term } | ModelError::MissingGssm { term } => {
            field("terms");
            info.index = sat_u32(*term);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::DuplicateRecord { tag } => {
            field("metadata");
            info.found = u32::from(*tag);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadRecord { field: name, .. } => {
            field(name);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadDomainEntry { entry, input, .. } => {
            field("training_domain.ranges");
            info.index = sat_u32(*entry);
            info.found = u32::from(*input);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::UnknownOutsidePolicy(policy) => {
            field("training_domain.policy");
            info.found = u32::from(*policy);
            RiskscoreStatus::ModelInvalid
        }
        ModelError::BadFallbackTerm { term, .. } => {
            field("kinematic_fallback.terms");
            info.index = sat_u32(*term);
            RiskscoreStatus::ModelInvalid
        }
        // Encoding-only errors and variants added to the core later.
        _ => RiskscoreStatus::ModelInvalid,
    }
}

pub(crate) fn warning_error(e: WarningError) -> RiskscoreStatus {
    match e {
        WarningError::NonFiniteScore { .. } => RiskscoreStatus::NanScore,
        WarningError::OutOfOrder { .. } => RiskscoreStatus::OutOfOrder,
        WarningError::TableFull { .. } => RiskscoreStatus::TableFull,
        WarningError::InvalidConfig(_) => RiskscoreStatus::InvalidConfig,
    }
}

pub(crate) fn event_code(e: WarningEvent) -> RiskscoreWarningEvent {
    match e {
        WarningEvent::None => RiskscoreWarningEvent::None,
        WarningEvent::Onset => RiskscoreWarningEvent::Onset,
        WarningEvent::Release => RiskscoreWarningEvent::Release,
    }
}

pub(crate) fn opt_us(v: Option<u64>) -> u64 {
    v.unwrap_or(RISKSCORE_NONE_U64)
}

pub(crate) fn status(r: Result<(), RiskscoreStatus>) -> RiskscoreStatus {
    match r {
        Ok(()) => RiskscoreStatus::Ok,
        Err(e) => e,
    }
}
