//! `riskctl demo`: the end-to-end main job on the default simulated data set.
use std::path::PathBuf;

use anyhow::Context;
use host_tools::demo::{self, DemoOptions};
use host_tools::train::{Progress, TrainConfig};

/// Simulate the default data set, train DRL and MSRA under 5-fold event-level cross-validation,
/// print the results table against TTC2D, TAdv and EI, quantise and export the final models, and
/// write plots.
///
/// Everything goes under --out (default ./out): data/ (the simulated events), report/
/// (results.md/csv/json, folds.csv, curves.csv, training.json), models/ (drl.rsk, drl-f32.rsk,
/// msra.rsk and their JSON checkpoints), plots/ (ROC, PR, risk trajectories as SVG and PNG).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Training configuration (TOML); default: the built-in defaults (= configs/train.toml).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override the training seed of the configuration.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Simulator seed of the data set.
    #[arg(long, default_value_t = DemoOptions::default().sim_seed)]
    pub sim_seed: u64,
    /// Number of simulated events.
    #[arg(long, default_value_t = DemoOptions::default().events)]
    pub events: usize,
    /// Use this event folder instead of simulating one.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Number of cross-validation folds.
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Cross-validation repetitions with seeds seed, seed+1, ... (fold assignment and training).
    #[arg(long, default_value_t = 3)]
    pub seeds: usize,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = match &args.config {
        Some(p) => TrainConfig::load(p)?,
        None => TrainConfig::default(),
    };
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    let opts = DemoOptions {
        out: args.out,
        config,
        sim_seed: args.sim_seed,
        events: args.events,
        data: args.data,
        folds: args.folds,
        seeds: args.seeds,
        progress: if args.quiet {
            Progress::Hidden
        } else {
            Progress::Bar
        },
    };
    demo::run(&opts).context("demo failed")?;
    Ok(())
}
