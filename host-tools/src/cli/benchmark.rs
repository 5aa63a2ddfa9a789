//! `riskctl benchmark`: benchmarks that train and test on different data (`transfer`, `domains`).
use std::path::{Path, PathBuf};

use anyhow::Context;
use host_tools::demo::{
    commit_staged, default_real_city_data, default_real_data, load_training_only, print_claims,
    simulate_staged, transfer_report, DRL_ONLY_PREFIX, REAL_DATA, TRAIN_ONLY_PREFIX,
};
use riskscore_data::events::Sequence;
use riskscore_data::sim::{FamilyMix, Mix, SimConfig};
use riskscore_eval::claims::{acceptance_claims, Claim};
use riskscore_output::OutputDir;
use riskscore_train::domains::{
    self, DomainData, DomainsResult, Draw, Round, SequenceSink, SequencesCsv,
};
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
    /// MSRA train as in the demo's cross-validation, the GSSM is fitted on every safe training
    /// sequence, simulated and real (normal driving, as the shipped GSSM is), and aligned to SSRA.
    /// Every model is scored through its exported blob, and the table (and --json) has the schema
    /// of `riskctl evaluate`. The acceptance claims follow, on the fold means and with the number
    /// of runs (folds x seeds) in which each holds (also report/claims.csv).
    Transfer(TransferArgs),
    /// Hold one slice of the operating domain out per round: train without it, test on it.
    ///
    /// Every sequence is sliced by the ego's speed band (0-5, 5-15, 15-25, 25-35, 35-50 m/s) and
    /// the interaction geometry (following, adjacent, crossing, oncoming) at its endpoint (a
    /// conflict) or closest approach (a safe sequence), and by its source (simulation, --real
    /// freeway, --real-city by the city of its event id). Per round, seed and fold: train = the
    /// training simulation + real sequences outside the slice; test = the test simulation + real
    /// sequences inside it (a real-city slice's conflicts: the test simulation's conflicts in the
    /// geometry and speed cells the city's sequences occupy). Models train as in `benchmark
    /// transfer`; one `riskctl evaluate` table (and JSON row group) per round, plus per method the
    /// share of real safe sequences above its 90 %-recall threshold, and the acceptance claims on
    /// the fold means with the number of runs in which each holds (report/claims.csv). See
    /// docs/evaluation.md.
    Domains(DomainsArgs),
}

/// The training and test simulations (given as folders or simulated into --out).
#[derive(clap::Args, Debug)]
pub struct SimArgs {
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
    /// Scenario families of both simulated folders: `default`, `domain` or a list such as
    /// `motorway_approach,signal_queue:2` (see `riskctl simulate --help`). Default: `default` for
    /// `transfer`, `domain` for `domains` (the default set has nothing at 35-50 m/s).
    #[arg(long, value_name = "MIX")]
    pub families: Option<FamilyMix>,
    /// Simulator draws: run the benchmark on N (training, test) simulation pairs and pool the
    /// runs, so means and claims are judged over draws x seeds x folds, not on one test
    /// simulation.
    ///
    /// Draw k (from 0) simulates with --train-seed + 100k and --test-seed + 100k (mixes and
    /// families as given) into --out (draw 0: train-data/, test-data/; draw k: draw-<k+1>/...),
    /// and trains with the seeds after the previous draw's. The report gives the pooled figures
    /// and each claim's verdict on each draw (claims-per-draw.csv); `domains` also each draw's
    /// counts. Cannot be combined with --train-events / --test-events (a given folder is one
    /// draw).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub draws: u32,
}

impl SimArgs {
    /// Refuses `--draws N` (N > 1) with a given event folder: a given folder is one draw.
    fn check_draws(&self) -> anyhow::Result<()> {
        if self.draws > 1 {
            if let Some((flag, Some(dir))) =
                self.event_folders().into_iter().find(|(_, d)| d.is_some())
            {
                anyhow::bail!(
                    "--draws {}: each draw simulates its own training and test folders, but {flag} {} \
                     gives one; drop --draws, or drop {flag} to simulate every draw",
                    self.draws,
                    dir.display()
                );
            }
        }
        Ok(())
    }

    /// Every draw's label and (training, test) simulation, in draw order ([`SimArgs::load_draw`]).
    fn load_draws(&self, out: &Path, default_families: FamilyMix) -> anyhow::Result<Vec<SimDraw>> {
        (0..self.draws)
            .map(|k| self.load_draw(out, default_families.clone(), k))
            .collect()
    }

    fn event_folders(&self) -> [(&'static str, Option<&Path>); 2] {
        [
            ("--train-events", self.train_events.as_deref()),
            ("--test-events", self.test_events.as_deref()),
        ]
    }

    /// The (training, test) sequences of draw `k` of `--draws`: the folders given (draw 0 only,
    /// [`SimArgs::check_draws`]), or simulated with `--families`, else `default_families`. Draw 0
    /// simulates into `out`; draw k moves both seeds by `k` x [`DRAW_SEED_STEP`] and simulates
    /// into `draw-<k+1>/`. A simulated folder is staged ([`SimDraw::staged`]), not yet in place.
    fn load_draw(
        &self,
        out: &Path,
        default_families: FamilyMix,
        k: u32,
    ) -> anyhow::Result<SimDraw> {
        let step = u64::from(k) * DRAW_SEED_STEP;
        let (train_seed, test_seed) = (
            self.train_seed.wrapping_add(step),
            self.test_seed.wrapping_add(step),
        );
        let label = match (&self.train_events, &self.test_events) {
            (None, None) => format!("sim seeds {train_seed}/{test_seed}"),
            _ => "the given event folders".to_owned(),
        };
        let dir = if k == 0 {
            out.to_path_buf()
        } else {
            draw_folder(out, k)
        };
        let families = self.families.clone().unwrap_or(default_families);
        let sim = |given: Option<&Path>, folder: &str, seed: u64, mix: Mix| {
            let cfg = SimConfig {
                seed,
                events: self.events,
                mix,
                families: families.clone(),
                ..SimConfig::default()
            };
            folder_or_simulate(given, &dir.join(folder), &cfg)
        };
        let (train, train_staged) = sim(
            self.train_events.as_deref(),
            "train-data",
            train_seed,
            self.train_mix,
        )?;
        let (test, test_staged) = sim(
            self.test_events.as_deref(),
            "test-data",
            test_seed,
            self.test_mix,
        )?;
        Ok(SimDraw {
            label,
            train,
            test,
            staged: [train_staged, test_staged].into_iter().flatten().collect(),
        })
    }
}

/// The simulator-seed step between two draws of `--draws`.
const DRAW_SEED_STEP: u64 = 100;

/// One simulator draw of `--draws`: its label for the report and its two simulations.
struct SimDraw {
    label: String,
    train: Vec<Sequence>,
    test: Vec<Sequence>,
    /// The folders this draw simulated, complete beside their targets under --out but not yet
    /// in place: [`commit_staged`] swaps them in once the report is written, so a failed or
    /// interrupted run (Ctrl-C, SIGTERM) leaves an old --out as it was.
    staged: Vec<OutputDir>,
}

/// Where draw `k` (k >= 1) of `--draws` simulates its folders.
fn draw_folder(out: &Path, k: u32) -> PathBuf {
    out.join(format!("draw-{}", k + 1))
}

/// Folds, seeds and the training configurations.
#[derive(clap::Args, Debug)]
pub struct TrainingArgs {
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
}

impl TrainingArgs {
    fn files(&self) -> [(&'static str, Option<&Path>); 2] {
        [
            ("--config", self.config.as_deref()),
            ("--gssm-config", self.gssm_config.as_deref()),
        ]
    }

    fn configs(&self) -> anyhow::Result<(TrainConfig, GssmConfig)> {
        Ok((
            TrainConfig::load_or_default(self.config.as_deref(), None)?,
            GssmConfig::load_or_default(self.gssm_config.as_deref())?,
        ))
    }

    fn options(&self, quiet: bool) -> TransferOptions {
        TransferOptions {
            folds: self.folds,
            seeds: self.seeds,
            progress: if quiet {
                Progress::Hidden
            } else {
                Progress::Bar
            },
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct TransferArgs {
    /// Real normal-driving event folder, split by scenario file (default: the committed extract
    /// data/ngsim-us101-safe).
    #[arg(long, value_name = "DIR")]
    pub real: Option<PathBuf>,
    #[command(flatten)]
    pub sim: SimArgs,
    /// Training-only event folder (repeatable): joins the training side of every fold, for every
    /// model (the GSSM fit's normal driving too), never a test fold. Its event ids get the prefix
    /// `train-only/<k>/` so they cannot collide with the training folder's. `riskctl demo`'s
    /// transfer stage trains on its `extra-data/` and data/ngsim-urban-safe this way.
    #[arg(long = "train-only", value_name = "DIR")]
    pub train_only: Vec<PathBuf>,
    /// Training-only event folder for DRL alone (repeatable), as `riskctl demo --extra-drl-only`
    /// (scripts/ship-models.sh gives it the roadside passes); ids prefixed `drl-only/<k>/`.
    #[arg(long = "drl-only", value_name = "DIR")]
    pub drl_only: Vec<PathBuf>,
    #[command(flatten)]
    pub training: TrainingArgs,
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

#[derive(clap::Args, Debug)]
pub struct DomainsArgs {
    /// Real freeway normal-driving folder (default: the committed extract data/ngsim-us101-safe).
    #[arg(long, value_name = "DIR")]
    pub real: Option<PathBuf>,
    /// Real city normal-driving folder (repeatable; default: the committed extract
    /// data/ngsim-urban-safe); each sequence's city comes from its event id (`USA_Lanker-...`:
    /// Lankershim, `USA_Peach-...`: Peachtree).
    #[arg(long = "real-city", value_name = "DIR")]
    pub real_city: Vec<PathBuf>,
    #[command(flatten)]
    pub sim: SimArgs,
    #[command(flatten)]
    pub training: TrainingArgs,
    /// Rounds to run, comma-separated (see --list-rounds), or `all` for every one. A named round
    /// whose slice is empty is an error; under `all` and of the default rounds, such a round is
    /// reported as "no data".
    #[arg(long, value_name = "NAME,...")]
    pub rounds: Option<String>,
    /// List the rounds (name and held-out slice; `*` marks the defaults) and exit.
    #[arg(long)]
    pub list_rounds: bool,
    /// Output folder: simulated data (train-data/, test-data/) and the report (report/).
    #[arg(long, default_value = "out/domains")]
    pub out: PathBuf,
    /// Print the report as JSON (per round the schema of `riskctl evaluate --json`).
    #[arg(long)]
    pub json: bool,
    /// Also write every method's result on every test sequence to FILE (CSV only: a `.parquet`
    /// name is refused).
    ///
    /// One row per round, seed, fold, method and test sequence: round, seed, fold, method,
    /// event_id, class, source (sim, real-freeway, real-city:<city>), speed_band and geometry
    /// (the sequence's slice labels), max (the sequence maximum the metrics rank), peak_time (the
    /// first frame at that maximum), t90 (the method's 90 %-recall threshold in that run, as the
    /// real-safe share reads it; empty without one), above_t90 (1/0); then at the peak frame:
    /// in_domain (1/0 for a model with a training domain, else empty), network and fallback (a
    /// guarded model's own score and its kinematic fallback's; empty otherwise), ttc2d, tadv, ei
    /// and the speeds v_ego, v_partner (m/s). Over several --draws, each draw's runs have training
    /// seeds of their own, so (seed, fold) still names one run. Written under a temporary name
    /// and renamed into place when the run succeeds; the report is unchanged by it. See
    /// docs/evaluation.md.
    #[arg(long = "sequences-out", value_name = "FILE")]
    pub sequences_out: Option<PathBuf>,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Transfer(a) => run_transfer(a),
        Command::Domains(a) => run_domains(a),
    }
}

/// The sequences of the folder given, else of a simulation into `out`: staged in a temporary
/// folder beside it (an [`OutputDir`], removed on an error or a signal), which the caller swaps
/// in when the run succeeds.
fn folder_or_simulate(
    given: Option<&Path>,
    out: &Path,
    cfg: &SimConfig,
) -> anyhow::Result<(Vec<Sequence>, Option<OutputDir>)> {
    if let Some(dir) = given {
        return Ok((super::load_prepared(dir)?.sequences, None));
    }
    let staged =
        simulate_staged(out, cfg).with_context(|| format!("simulating {}", out.display()))?;
    let sequences = super::load_prepared(staged.path())?.sequences;
    Ok((sequences, Some(staged)))
}

/// The real freeway folder: the one given, else the committed extract.
fn real_freeway_dir(given: Option<&Path>) -> anyhow::Result<PathBuf> {
    match given.map(Path::to_path_buf).or_else(default_real_data) {
        Some(d) => Ok(d),
        None => anyhow::bail!(
            "no real recordings: pass --real DIR (the default {REAL_DATA} was not found)"
        ),
    }
}

fn run_transfer(a: TransferArgs) -> anyhow::Result<()> {
    let training_only: Vec<(&str, Option<&Path>)> =
        super::output::repeated("--train-only", &a.train_only)
            .chain(super::output::repeated("--drl-only", &a.drl_only))
            .collect();
    super::output::refuse_inputs_of(
        &[
            [("--real", a.real.as_deref())].as_slice(),
            &a.sim.event_folders(),
            &training_only,
        ]
        .concat(),
        &a.training.files(),
        &[("--out", &a.out)],
    )?;
    a.sim.check_draws()?;
    let (config, gssm_config) = a.training.configs()?;
    let real_dir = real_freeway_dir(a.real.as_deref())?;
    let real = super::load_prepared(&real_dir)?.sequences;
    eprintln!(
        "riskctl: real recordings from {} ({} sequences, split into folds by scenario file)",
        real_dir.display(),
        real.len()
    );
    let (train_only, _) = load_training_only(&a.train_only, TRAIN_ONLY_PREFIX, "training only")?;
    let (drl_only, _) =
        load_training_only(&a.drl_only, DRL_ONLY_PREFIX, "training only, DRL only")?;
    let options = a.training.options(a.quiet);
    let inputs = config.msra.input_names();
    // Each draw runs with the seeds after the previous draw's ([`transfer::draw_config`]).
    let mut results = Vec::new();
    let mut per_draw = Vec::new();
    let mut labels = Vec::new();
    let mut staged = Vec::new();
    for (k, draw) in a
        .sim
        .load_draws(&a.out, FamilyMix::default())?
        .into_iter()
        .enumerate()
    {
        staged.extend(draw.staged);
        let mut train_sim = draw.train;
        train_sim.extend(train_only.iter().cloned());
        let data = TransferData {
            train_sim,
            train_drl_only: drl_only.clone(),
            test_sim: draw.test,
            real: real.clone(),
        };
        let draw_config = transfer::draw_config(&config, k, &options);
        let result = transfer::run(&data, &draw_config, &gssm_config, &options)?;
        per_draw.push(acceptance_claims(&result.report, &result.folds, &inputs));
        results.push(result);
        labels.push(draw.label);
    }
    let result = transfer::pool_draws(results)
        .ok_or_else(|| anyhow::anyhow!("--draws: no simulator draw to run on"))?;
    host_tools::warnings::print(&result.warnings);
    let claims = acceptance_claims(&result.report, &result.folds, &inputs);
    let draw_claims: Vec<&[Claim]> = per_draw.iter().map(Vec::as_slice).collect();
    let labelled: Vec<(&str, &[Claim])> = labels
        .iter()
        .map(String::as_str)
        .zip(draw_claims.iter().copied())
        .collect();
    transfer_report(&result, &claims, &labelled)?.write_to(&a.out.join("report"))?;
    commit_staged(staged)?;
    if a.json {
        outln!(
            "{}",
            serde_json::to_string_pretty(&result.report.to_json())?
        );
        return Ok(());
    }
    out!("{}", result.report.to_markdown());
    outln!();
    print_claims(
        "Claims (fold means, strictly better unless marked >=; a run = one fold x seed, both methods on its test set):",
        &claims,
    );
    if draw_claims.len() > 1 {
        outln!();
        for (k, label) in labels.iter().enumerate() {
            outln!("Draw {}: {label}", k + 1);
        }
        outln!();
        out!(
            "{}",
            riskscore_eval::claims::per_draw_markdown(&claims, &draw_claims)
        );
    }
    eprintln!("riskctl: report in {}", a.out.join("report").display());
    Ok(())
}

fn run_domains(a: DomainsArgs) -> anyhow::Result<()> {
    if a.list_rounds {
        let defaults = Round::defaults();
        for round in Round::all() {
            let mark = if defaults.contains(&round) { "*" } else { " " };
            outln!("{mark} {:<20} {round}", round.name);
        }
        return Ok(());
    }
    let (rounds, empty) =
        Round::selection(a.rounds.as_deref()).map_err(|e| anyhow::anyhow!("--rounds: {e}"))?;
    a.sim.check_draws()?;
    let mut event_folders = vec![("--real", a.real.as_deref())];
    event_folders.extend(super::output::repeated("--real-city", &a.real_city));
    event_folders.extend(a.sim.event_folders());
    let mut outputs = vec![("--out", a.out.as_path())];
    if let Some(path) = &a.sequences_out {
        refuse_sequences_out(path, &a)?;
        outputs.push(("--sequences-out", path));
    }
    super::output::refuse_inputs_of(&event_folders, &a.training.files(), &outputs)?;
    let (config, gssm_config) = a.training.configs()?;
    let real_dir = real_freeway_dir(a.real.as_deref())?;
    let real_freeway = super::load_prepared(&real_dir)?.sequences;
    let city_dirs = if a.real_city.is_empty() {
        default_real_city_data().into_iter().collect()
    } else {
        a.real_city.clone()
    };
    let mut real_city = Vec::new();
    for dir in &city_dirs {
        real_city.extend(super::load_prepared(dir)?.sequences);
    }
    eprintln!(
        "riskctl: real freeway {} ({} sequences), real city {} sequences from {} folder(s)",
        real_dir.display(),
        real_freeway.len(),
        real_city.len(),
        city_dirs.len()
    );
    let mut staged = Vec::new();
    let draw_data: Vec<(String, DomainData)> = a
        .sim
        .load_draws(&a.out, FamilyMix::domain())?
        .into_iter()
        .map(|draw| {
            staged.extend(draw.staged);
            let data = DomainData::new(
                draw.train,
                draw.test,
                real_freeway.clone(),
                real_city.clone(),
            );
            (draw.label, data)
        })
        .collect();
    let draws: Vec<Draw> = draw_data
        .iter()
        .map(|(label, data)| Draw { label, data })
        .collect();
    let options = a.training.options(a.quiet);
    let run = |sequences: Option<&mut dyn SequenceSink>| {
        domains::run_draws(
            &rounds,
            &draws,
            &config,
            &gssm_config,
            &options,
            empty,
            sequences,
        )
    };
    let report_dir = a.out.join("report");
    // The report, then the simulated folders, then (on return) the --sequences-out file: every
    // output goes in place only once the whole run has succeeded.
    let finish = |result: &DomainsResult| -> anyhow::Result<()> {
        host_tools::warnings::print(result.warnings());
        result.bundle()?.write_to(&report_dir)?;
        Ok(commit_staged(staged)?)
    };
    let result = match &a.sequences_out {
        None => {
            let result = run(None)?;
            finish(&result)?;
            result
        }
        Some(path) => write_sequences(path, |sink| run(Some(sink)), finish)?,
    };
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&result.to_json())?);
    } else {
        // Each round's section ends with its claims table.
        out!("{}", result.to_markdown());
    }
    eprintln!("riskctl: report in {}", report_dir.display());
    Ok(())
}

/// The folders under `--out` that this run writes whole: the report and the simulated folders
/// (when simulated).
fn written_folders(a: &DomainsArgs) -> Vec<PathBuf> {
    let mut folders = vec![a.out.join("report")];
    for (given, name) in [
        (&a.sim.train_events, "train-data"),
        (&a.sim.test_events, "test-data"),
    ] {
        if given.is_none() {
            folders.push(a.out.join(name));
        }
    }
    for k in 1..a.sim.draws {
        folders.extend(["train-data", "test-data"].map(|name| draw_folder(&a.out, k).join(name)));
    }
    folders
}

/// `--sequences-out` must name a file of its own: not standard output (the report goes there),
/// not Parquet (CSV only), and not inside a folder the run replaces whole.
fn refuse_sequences_out(path: &Path, a: &DomainsArgs) -> anyhow::Result<()> {
    let shown = path.display();
    if super::output::is_dash(path) {
        anyhow::bail!("--sequences-out -: standard output carries the report; name a file");
    }
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
    {
        anyhow::bail!(
            "--sequences-out {shown}: the per-sequence table is written as CSV only; name it .csv ({})",
            super::output::left_alone(path)
        );
    }
    super::output::refuse_overwriting_a_model("--sequences-out", path, "a per-sequence table")?;
    for folder in written_folders(a) {
        if riskscore_output::lies_within(path, &folder) {
            anyhow::bail!(
                "--sequences-out {shown} lies inside {}, which this run writes whole: refusing to \
                 write into it ({}); put it beside, e.g. {}",
                folder.display(),
                super::output::left_alone(path),
                a.out.join("sequences.csv").display()
            );
        }
    }
    Ok(())
}

/// Runs `run` with a CSV sink on `path`, then `finish` on its result (the run's other outputs):
/// written under a temporary name, renamed into place when both succeed (a failed or interrupted
/// run leaves an old file as it was), its folder created if needed (and removed again, if still
/// empty, on failure).
fn write_sequences<T>(
    path: &Path,
    run: impl FnOnce(&mut dyn SequenceSink) -> Result<T, domains::DomainsError>,
    finish: impl FnOnce(&T) -> anyhow::Result<()>,
) -> anyhow::Result<T> {
    let folders = match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) => Some(riskscore_output::NewFolders::create(dir).with_context(|| {
            format!(
                "--sequences-out {}: cannot create {}",
                path.display(),
                dir.display()
            )
        })?),
        None => None,
    };
    let written = super::output::write_output(path, |out| {
        let mut csv = SequencesCsv::new(out)?;
        let result = run(&mut csv)?;
        let rows = csv.rows();
        csv.finish()?;
        finish(&result)?;
        Ok((result, rows))
    })?;
    let (result, rows) =
        written.ok_or_else(|| anyhow::anyhow!("--sequences-out {}: closed", path.display()))?;
    if let Some(folders) = folders {
        folders.keep();
    }
    eprintln!("riskctl: {rows} per-sequence rows in {}", path.display());
    Ok(result)
}
