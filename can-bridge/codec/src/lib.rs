//! PLACEHOLDER: owned by the CAN helper.
