//! `riskctl`: the command line over riskscore's library crates. Each subcommand lives in
//! `cli/<name>.rs`, which parses its arguments and calls the libraries.
use clap::{CommandFactory, Parser, Subcommand};

// The `out!`/`outln!` printing macros (a closed standard output ends the printing, not the run).
#[macro_use]
extern crate host_tools;

mod cli;

/// Learn, evaluate and export collision-risk scores for ego/partner interactions.
///
/// Typical flow: `simulate` an event folder (or convert your own data to the event format), `train`
/// DRL/MSRA models from pairwise comparisons, `evaluate` them against the TTC2D/TAdv/EI baselines,
/// `export-model` for the ECU. `demo` runs all of it on the embedded defaults.
#[derive(Parser, Debug)]
#[command(name = "riskctl", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Compute surrogates (box distance, TTC2D, TAdv, EI) and the 13 features for a CSV of pairs.
    Ssm(cli::ssm::Args),
    /// Simulate crash, near-crash and safe events and write an event folder.
    Simulate(cli::simulate::Args),
    /// Build comparisons and train DRL / MSRA models on an event folder.
    Train(cli::train::Args),
    /// Score an event folder with model files and the baselines; print the metrics table.
    Evaluate(cli::evaluate::Args),
    /// Per-frame risk scores of every event under each model, with the surrogates (CSV/Parquet).
    #[cfg(feature = "parquet")]
    Score(cli::score::Args),
    /// Train on each comparison source alone and in combination, over training fractions.
    Ablation(cli::ablation::Args),
    /// Quantise (DRL) and write a trained model as a model blob for the ECU.
    ExportModel(cli::export_model::Args),
    /// Print a model blob's header, sizes and parameter summary, and check its integrity.
    InspectModel(cli::inspect_model::Args),
    /// Store a model's default warning threshold, chosen on normal driving by a target
    /// false-alarm rate, in its blob.
    Calibrate(cli::calibrate::Args),
    /// Store a model's training domain (the input ranges of its training data) and the policy
    /// for observations outside it, in its blob.
    CalibrateDomain(cli::calibrate_domain::Args),
    /// Draw one event: both road users' paths and boxes, and every method's risk over time with
    /// its threshold and first warning (SVG or PNG).
    Plot(cli::plot::Args),
    /// Write the safe passes beside stationary roadside objects (DRL-only training data; a grid
    /// disjoint from the roadside test's).
    RoadsidePasses(cli::roadside_passes::Args),
    /// GSSM, SSRA and MSRA over GSSM: fit, align, msra, ship, cv, augmentation.
    Gssm(cli::gssm::Args),
    /// Import recorded data (CommonRoad scenarios) as an event folder of real safe interactions.
    Import(cli::import::Args),
    /// Encode an event folder as 10 Hz vehicle CAN traffic in candump -L format.
    EventsToCandump(cli::events_to_candump::Args),
    /// The main job: simulate, train under 5-fold CV, evaluate, quantise, export, plot.
    Demo(cli::demo::Args),
    /// Benchmarks on data the models were not trained on: `transfer` (another simulator seed and
    /// mix, real recordings held out by scenario file) and `domains` (a whole slice held out: a
    /// speed band, a geometry, a city).
    Benchmark(cli::benchmark::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell) to standard output.
    Completions(cli::completions::Args),
    /// Write man pages (riskctl.1 and one per subcommand) into a folder.
    Man(cli::completions::ManArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // Ctrl-C / SIGTERM: remove the output layer's temporaries, leave old outputs as they were.
    if let Err(e) = riskscore_output::remove_temporaries_on_signals() {
        eprintln!("riskctl: warning: cannot install the Ctrl-C handler: {e}");
    }
    let result = match cli.command {
        Command::Ssm(a) => cli::ssm::run(a),
        Command::Simulate(a) => cli::simulate::run(a),
        Command::RoadsidePasses(a) => cli::roadside_passes::run(a),
        Command::Train(a) => cli::train::run(a),
        Command::Evaluate(a) => cli::evaluate::run(a),
        #[cfg(feature = "parquet")]
        Command::Score(a) => cli::score::run(a),
        Command::Ablation(a) => cli::ablation::run(a),
        Command::Calibrate(a) => cli::calibrate::run(a),
        Command::CalibrateDomain(a) => cli::calibrate_domain::run(a),
        Command::ExportModel(a) => cli::export_model::run(a),
        Command::InspectModel(a) => cli::inspect_model::run(a),
        Command::Plot(a) => cli::plot::run(a),
        Command::Gssm(a) => cli::gssm::run(a),
        Command::Import(a) => cli::import::run(a),
        Command::EventsToCandump(a) => cli::events_to_candump::run(a),
        Command::Demo(a) => cli::demo::run(a),
        Command::Benchmark(a) => cli::benchmark::run(a),
        Command::Completions(a) => cli::completions::run(a, Cli::command()),
        Command::Man(a) => cli::completions::man(a, Cli::command()),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("riskctl: error: {}", error_text(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

fn error_text(e: &anyhow::Error) -> String {
    host_tools::error_text(e.chain())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cause_already_quoted_is_not_repeated() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory");
        #[derive(Debug)]
        struct Quoting(std::io::Error);
        impl std::fmt::Display for Quoting {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "x/events.csv: {}", self.0)
            }
        }
        impl std::error::Error for Quoting {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let e = anyhow::Error::new(Quoting(io)).context("event folder x");
        assert_eq!(
            error_text(&e),
            "event folder x: x/events.csv: No such file or directory"
        );
        let plain = anyhow::anyhow!("inner").context("outer");
        assert_eq!(error_text(&plain), "outer: inner");
    }
}
