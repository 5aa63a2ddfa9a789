//! PLACEHOLDER: owned by the ECU helper.
