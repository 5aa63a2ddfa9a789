//! PLACEHOLDER: the inference/model-format helper writes this module.
