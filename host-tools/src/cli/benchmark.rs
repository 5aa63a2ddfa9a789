//! `riskctl benchmark`: benchmarks that train and test on different data (today: `transfer`).
use std::path::{Path, PathBuf};

use anyhow::Context;
use host_tools::demo::{
    acceptance_claims, default_real_data, msra_input_names, print_claims, write_transfer_report,
    REAL_DATA,
};
use riskscore_data::events::Sequence;
use riskscore_data::sim::{simulate_to_dir, Mix, SimConfig};
use riskscore_train::gssm::GssmConfig;
use riskscore_train::train::{Progress, TrainConfig};
use riskscore_train::transfer::{self, TransferData, TransferOptions};

/// Benchmarks whose test data differs from the training data.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Train on one simulator seed + part of the real recordings; test on another simulator seed
    /// and event mix + the real recordings held out by scenario file.
    ///
    /// Per seed and fold, the real scenario files (the event-id prefix before `/`, as written by
    /// `riskctl import commonroad`) are dealt into --folds groups; one group is held out. DRL and
    /// MSRA train as in the demo's cross-validation, the GSSM is fitted on the training part's real
    /// sequences (normal driving) and aligned to SSRA. Every model is scored through its exported
    /// blob, and the table (and --json) has the schema of `riskctl evaluate`.
    Transfer(TransferArgs),
}

#[derive(clap::Args, Debug)]
pub struct TransferArgs {
    /// Real normal-driving event folder, split by scenario file (default: the committed extract
    /// data/ngsim-us101-safe).
    #[arg(long, value_name = "DIR")]
    pub real: Option<PathBuf>,
    /// Training event folder; default: simulate --train-seed / --train-mix / --events.
    #[arg(long, value_name = "DIR")]
    pub train_events: Option<PathBuf>,
    /// Test event folder; default: simulate --test-seed / --test-mix / --events.
    #[arg(long, value_name = "DIR")]
    pub test_events: Option<PathBuf>,
    /// Simulator seed of the training folder.
    #[arg(long, default_value_t = 1)]
    pub train_seed: u64,
    /// Event mix crash,near_crash,safe of the training folder.
    #[arg(long, value_name = "C,N,S", default_value = "70,110,130")]
    pub train_mix: Mix,
    /// Simulator seed of the test folder.
    #[arg(long, default_value_t = 2)]
    pub test_seed: u64,
    /// Event mix crash,near_crash,safe of the test folder.
    #[arg(long, value_name = "C,N,S", default_value = "100,60,150")]
    pub test_mix: Mix,
    /// Events per simulated folder.
    #[arg(long, default_value_t = 310)]
    pub events: usize,
    /// Groups of real scenario files (one held out per fold).
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Repetitions with seeds seed, seed+1, ...
    #[arg(long, default_value_t = 3)]
    pub seeds: usize,
    /// Training configuration TOML (default: built-in = configs/train.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// GSSM configuration TOML (default: built-in, docs/gssm.md).
    #[arg(long = "gssm-config", value_name = "FILE")]
    pub gssm_config: Option<PathBuf>,
    /// Output folder: simulated data (train-data/, test-data/) and the report (report/).
    #[arg(long, default_value = "out/transfer")]
    pub out: PathBuf,
    /// Print the report as JSON (the schema of `riskctl evaluate --json`) instead of Markdown.
    #[arg(long)]
    pub json: bool,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Transfer(a) => run_transfer(a),
    }
}

fn folder_or_simulate(
    given: Option<&Path>,
    out: &Path,
    seed: u64,
    mix: Mix,
    events: usize,
) -> anyhow::Result<Vec<Sequence>> {
    let dir = match given {
        Some(d) => d.to_path_buf(),
        None => {
            let cfg = SimConfig {
                seed,
                events,
                mix,
                ..SimConfig::default()
            };
            simulate_to_dir(out, &cfg).with_context(|| format!("simulating {}", out.display()))?;
            out.to_path_buf()
        }
    };
    Ok(super::load_prepared(&dir)?.sequences)
}

fn run_transfer(a: TransferArgs) -> anyhow::Result<()> {
    super::output::refuse_inputs_of(
        &[
            ("--real", a.real.as_deref()),
            ("--train-events", a.train_events.as_deref()),
            ("--test-events", a.test_events.as_deref()),
        ],
        &[
            ("--config", a.config.as_deref()),
            ("--gssm-config", a.gssm_config.as_deref()),
        ],
        &[("--out", &a.out)],
    )?;
    let config = TrainConfig::load_or_default(a.config.as_deref(), None)?;
    let gssm_config = GssmConfig::load_or_default(a.gssm_config.as_deref())?;
    let real_dir = match a.real.clone().or_else(default_real_data) {
        Some(d) => d,
        None => anyhow::bail!(
            "no real recordings: pass --real DIR (the default {REAL_DATA} was not found)"
        ),
    };
    let data = TransferData {
        train_sim: folder_or_simulate(
            a.train_events.as_deref(),
            &a.out.join("train-data"),
            a.train_seed,
            a.train_mix,
            a.events,
        )?,
        test_sim: folder_or_simulate(
            a.test_events.as_deref(),
            &a.out.join("test-data"),
            a.test_seed,
            a.test_mix,
            a.events,
        )?,
        real: super::load_prepared(&real_dir)?.sequences,
    };
    eprintln!(
        "riskctl: real recordings from {} ({} sequences, split into folds by scenario file)",
        real_dir.display(),
        data.real.len()
    );
    let options = TransferOptions {
        folds: a.folds,
        seeds: a.seeds,
        progress: if a.quiet {
            Progress::Hidden
        } else {
            Progress::Bar
        },
    };
    let result = transfer::run(&data, &config, &gssm_config, &options)?;
    write_transfer_report(&a.out.join("report"), &result)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&result.report.to_json())?
        );
        return Ok(());
    }
    print!("{}", result.report.to_markdown());
    println!();
    print_claims(
        "Claims (fold means, strictly better unless marked >=):",
        &acceptance_claims(&result.report, &msra_input_names(&config)),
    );
    eprintln!("riskctl: report in {}", a.out.join("report").display());
    Ok(())
}
