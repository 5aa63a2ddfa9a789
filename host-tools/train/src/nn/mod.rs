//! The candle training kernel every learned model shares: the dense network ([`mlp`]) and the
//! early-stopping trainer ([`trainer`]).
//!
//! DRL and the GSSM both train an [`mlp::Mlp`]; DRL, MSRA, SSRA, MSRA-over-GSSM (through
//! [`crate::train::train_with`]) and the GSSM likelihood fit ([`crate::gssm::fit`]) all run their
//! epochs through [`trainer::EarlyStopping`].
pub mod mlp;
pub mod trainer;

pub use mlp::{DenseLayer, Mlp};
pub use trainer::{EarlyStopping, EpochOutcome, Progress, StopReport};
