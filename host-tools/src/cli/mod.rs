//! One module per `riskctl` subcommand: argument struct (clap) + `run`.
pub mod ablation;
pub mod benchmark;
pub mod demo;
pub mod evaluate;
pub mod events_to_candump;
pub mod export_model;
pub mod gssm;
pub mod import;
pub mod inspect_model;
pub mod output;
#[cfg(feature = "parquet")]
pub mod score;
pub mod simulate;
pub mod ssm;
pub mod train;
