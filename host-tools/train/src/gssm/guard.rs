//! The training domain of the GSSM family's blobs: where the normal driving its GSSM was fitted
//! on reached (`docs/domain-guard.md`, "The GSSM family").
//!
//! A GSSM is a model of normal driving: outside the contexts of that driving (a speed, a geometry
//! its fit data never had) its spacing distribution is an extrapolation, and SSRA, aligned from
//! it, inherits the same network. Both get the record measured on the safe sequences the GSSM was
//! fitted on ([`crate::export::domain_sequences`]) under the training configuration's `[guard]
//! policy`; under `fallback` they hand over to the kinematic terms of the MSRA trained beside
//! them, aligned to their own score scale on all the fit sequences' frames inside, conflicts
//! included, as a DRL's is. `blend` (a DRL's default) is written as `fallback` for them, and an
//! MSRA over the GSSM gets a `flag-only` record ([`crate::export::with_measured_domain`]).
use riskscore_data::events::Sequence;
use scorer_core::msra::MsraTerm;

use super::GssmError;
use crate::export::with_measured_domain;
use crate::train::{GuardConfig, GuardPolicy};

/// Replaces every blob of `blobs` (row name, bytes) by the blob with its record measured on
/// `fit_sequences` under `policy` (`blend` as `fallback`), `fallback_terms` its kinematic fallback
/// (without them a `fallback` policy is written as `flag-only`); returns the warnings of the blobs
/// whose fallback could not be fitted (their guard became `flag-only` too).
pub fn guard_blobs(
    blobs: &mut [(String, Vec<u8>)],
    fit_sequences: &[Sequence],
    policy: GuardPolicy,
    fallback_terms: Option<&[MsraTerm]>,
) -> Result<Vec<String>, GssmError> {
    let policy = match (policy, fallback_terms) {
        (GuardPolicy::Fallback | GuardPolicy::Blend, None) => GuardPolicy::FlagOnly,
        (policy, _) => policy,
    };
    let guard = GuardConfig {
        policy,
        ..GuardConfig::default()
    };
    let mut warnings = Vec::new();
    for (name, blob) in blobs {
        let guarded = with_measured_domain(blob, fit_sequences, &guard, fallback_terms)?;
        warnings.extend(guarded.warning(name));
        *blob = guarded.bytes;
    }
    Ok(warnings)
}
