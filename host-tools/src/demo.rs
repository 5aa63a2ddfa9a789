//! The main job (`riskctl demo`): simulate the default data set, add the real safe driving of the
//! committed NGSIM extract, build comparisons, train DRL and MSRA under 5-fold event-level CV (fold
//! models scored through the deployed int8/core path), print the table against the TTC2D/TAdv/EI
//! baselines, run the transfer benchmark ([`riskscore_train::transfer`]: another simulator seed and
//! mix plus real recordings held out by scenario file), quantise, export the final models (trained
//! on all events), write plots, and say where everything went, with stage times.
//!
//! Output layout under the out folder:
//! - `data/`: the simulated event folder (`events.csv`, `frames.csv`, ...);
//! - `transfer-data/`: the simulated test folder of the transfer benchmark;
//! - `extra-data/`: the training-only simulated folder of the recipe ([`ExtraTraining`]);
//! - `report/`: `results.{md,csv,json}` (mean ± std over folds), `folds.csv`, `curves.csv`
//!   (pooled out-of-fold operating points), `claims.{md,csv}` (the acceptance claims with their
//!   run tallies), `training.json` (comparisons, training, quantisation and stage statistics),
//!   `transfer/` (the transfer benchmark's `results.{md,csv,json}`, `folds.csv`, `splits.json`,
//!   `claims.{md,csv}`), `domains/` (the short domain benchmark's `domains.{md,json}`, per-round
//!   folds, the real-safe shares and `claims.csv`);
//! - `domains-data/`: the domain benchmark's two simulated folders (`train/`, `test/`);
//! - `models/`: `drl.rsk` (int8), `drl-f32.rsk`, `msra.rsk`, and their checkpoints `drl.json`,
//!   `msra.json`;
//! - `plots/`: `roc`, `pr`, `trajectories` and `event-1..3` (the trajectory events drawn as
//!   `riskctl plot` draws them), SVG and PNG.
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use serde_json::json;

use riskscore_data::events::{self, Sequence};
use riskscore_data::sim::{self, SimConfig};
use riskscore_eval::claims::{self, acceptance_claims, Claim};
use riskscore_eval::metrics::Metric;
use riskscore_eval::report::format_value;
use riskscore_eval::{self as eval, plots, CvReport, EventCounts, ScoredSequence};
use riskscore_output::OutputDir;
use riskscore_train::export;
use riskscore_train::final_models::{train_and_export, FinalModelsError};
use riskscore_train::gssm::GssmConfig;
use riskscore_train::quantize::Agreement;
use riskscore_train::train::cv::{self, CvOptions, FoldOutcome};
use riskscore_train::train::{Progress, TrainConfig};

/// What the demo runs on and where it writes.
#[derive(Clone, Debug)]
pub struct DemoOptions {
    pub out: PathBuf,
    pub config: TrainConfig,
    /// Simulator seed of the default data set.
    pub sim_seed: u64,
    /// Number of simulated events.
    pub events: usize,
    /// Use this event folder instead of simulating.
    pub data: Option<PathBuf>,
    pub folds: usize,
    /// Cross-validation repetitions (fold assignment and training seeds `seed + k`).
    pub seeds: usize,
    /// Real normal-driving event folder added to the training data (safe sequences) and used by
    /// the transfer benchmark (held out by scenario file). `None`: simulation only.
    pub real: Option<PathBuf>,
    /// The transfer benchmark's test simulation; `None` skips the benchmark.
    pub transfer: Option<TransferSettings>,
    /// GSSM / SSRA settings of the transfer benchmark.
    pub gssm: GssmConfig,
    /// The short domain benchmark (held-out speed band, city, geometry); `None` skips it.
    pub domains: Option<DomainSettings>,
    /// Training-only data: joins every training fold, the transfer benchmark's training side and
    /// the final models, never a test fold ([`ExtraTraining::none`]: the recipe before issue #18).
    pub extra: ExtraTraining,
    pub progress: Progress,
}

/// The part of the recipe that covers the operating domain beyond the sets the benchmarks test
/// on (docs/training.md "Training on the operating domain"): a simulated folder of other scenario
/// families and real normal driving from other places. Training-only, so the in-distribution CV
/// and the transfer benchmark still test on the simulated default set and the real freeway.
#[derive(Clone, Debug)]
pub struct ExtraTraining {
    /// A simulated folder (the default event mix); `None`: no extra simulation.
    pub sim: Option<ExtraSim>,
    /// Real normal-driving folders (safe sequences).
    pub real: Vec<PathBuf>,
    /// Event folders only DRL trains on (never MSRA, never a test fold): data that teaches the
    /// network a geometry MSRA's kinematic inputs cannot tell apart from a conflict, e.g. the
    /// roadside passes of `riskctl roadside-passes` (docs/training.md).
    pub drl_only: Vec<PathBuf>,
}

/// The extra simulated folder: its seed (distinct from the training set's and the test folders'
/// seeds), size and scenario families.
#[derive(Clone, Debug)]
pub struct ExtraSim {
    pub seed: u64,
    pub events: usize,
    pub families: sim::FamilyMix,
}

impl ExtraSim {
    /// Seed 3: not the training set's 1, the transfer test's 2 or the unseen folder's 5.
    pub const DEFAULT_SEED: u64 = 3;
}

impl Default for ExtraSim {
    fn default() -> Self {
        ExtraSim {
            seed: Self::DEFAULT_SEED,
            events: SimConfig::default().events,
            families: sim::FamilyMix::domain(),
        }
    }
}

impl ExtraTraining {
    /// No training-only data: CV, transfer and final models train on the tested sets alone.
    pub fn none() -> Self {
        ExtraTraining {
            sim: None,
            real: Vec::new(),
            drl_only: Vec::new(),
        }
    }

    pub fn is_none(&self) -> bool {
        self.sim.is_none() && self.real.is_empty() && self.drl_only.is_empty()
    }
}

impl Default for ExtraTraining {
    /// The operating-domain families (seed 3, 310 events) and the committed real city extract.
    fn default() -> Self {
        ExtraTraining {
            sim: Some(ExtraSim::default()),
            real: default_real_city_data().into_iter().collect(),
            drl_only: Vec::new(),
        }
    }
}

/// The demo's short domain benchmark (`riskctl benchmark domains`' default rounds on smaller
/// settings): two simulated folders of the operating-domain families, the real freeway data
/// and the real city extract.
#[derive(Clone, Debug)]
pub struct DomainSettings {
    /// Events per simulated folder (training: the demo's mix; test: the transfer's).
    pub events: usize,
    pub folds: usize,
    pub seeds: usize,
    /// Real city normal-driving folder; `None`: the city rounds report "no data".
    pub real_city: Option<PathBuf>,
}

impl Default for DomainSettings {
    fn default() -> Self {
        DomainSettings {
            events: 310,
            folds: 2,
            seeds: 1,
            real_city: default_real_city_data(),
        }
    }
}

/// The transfer benchmark's simulated test folder: another seed and another event mix.
#[derive(Clone, Debug)]
pub struct TransferSettings {
    pub test_seed: u64,
    pub test_mix: sim::Mix,
    pub test_events: usize,
}

impl Default for TransferSettings {
    fn default() -> Self {
        TransferSettings {
            test_seed: 2,
            test_mix: sim::Mix {
                crash: 100.0,
                near_crash: 60.0,
                safe: 150.0,
            },
            test_events: 310,
        }
    }
}

/// The committed real freeway extract, if it can be found: `data/ngsim-us101-safe` under the
/// current folder, else next to this crate's sources (a checkout run from elsewhere).
pub fn default_real_data() -> Option<PathBuf> {
    committed_extract(REAL_DATA)
}

/// The committed real city extract (NGSIM Lankershim and Peachtree), found like
/// [`default_real_data`].
pub fn default_real_city_data() -> Option<PathBuf> {
    committed_extract(REAL_CITY_DATA)
}

fn committed_extract(relative: &str) -> Option<PathBuf> {
    let candidates = [
        PathBuf::from(relative),
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join(relative),
    ];
    candidates
        .into_iter()
        .find(|p| p.join(events::EVENTS_FILE).is_file())
}

/// Where the committed NGSIM US-101 extract of real safe interactions lives in the repository.
pub const REAL_DATA: &str = "data/ngsim-us101-safe";

/// Where the committed NGSIM Lankershim + Peachtree extract of real safe city interactions lives.
pub const REAL_CITY_DATA: &str = "data/ngsim-urban-safe";

/// What the demo's figures plot (printed on each): one pooled curve per method, where the summary
/// table averages folds and seeds, so the legends' figures differ from the table's.
const POOLED_SCORES: &str =
    "scores: out-of-fold scores of the first seed, pooled over the 5 folds \
     (the summary table instead averages per-fold metrics over folds and seeds)";

impl Default for DemoOptions {
    fn default() -> Self {
        let sim = SimConfig::default();
        DemoOptions {
            out: PathBuf::from("out"),
            config: TrainConfig::default(),
            sim_seed: sim.seed,
            events: sim.events,
            data: None,
            folds: 5,
            seeds: 3,
            real: default_real_data(),
            transfer: Some(TransferSettings::default()),
            gssm: GssmConfig::default(),
            domains: Some(DomainSettings::default()),
            extra: ExtraTraining::default(),
            progress: Progress::Bar,
        }
    }
}

/// Demo failures (each names the stage and, where it applies, the file).
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    #[error("simulation: {0}")]
    Sim(#[from] sim::SimError),
    #[error("loading events: {0}")]
    Events(#[from] events::EventsError),
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    /// An error whose message named a staged folder's temporary, named by its target instead
    /// (`Staged::name_targets`).
    #[error("{0}")]
    Staged(String),
    /// A staged folder's own errors ([`OutputDir`]) already name the folder.
    #[error(transparent)]
    Output(std::io::Error),
    #[error("cross-validation: {0}")]
    Cv(#[from] cv::CvError),
    #[error(transparent)]
    Final(#[from] FinalModelsError),
    #[error("export: {0}")]
    Export(#[from] export::ExportError),
    #[error("evaluation: {0}")]
    Eval(#[from] eval::ProtocolError),
    #[error("plots: {0}")]
    Plot(#[from] plots::PlotError),
    #[error("event figures: {0}")]
    ModelFile(#[from] eval::model_files::ModelFileError),
    #[error("report: {0}")]
    Report(#[from] eval::bundle::BundleError),
    #[error("{0}")]
    Transfer(#[from] riskscore_train::transfer::TransferError),
    #[error("domain benchmark: {0}")]
    Domains(#[from] riskscore_train::domains::DomainsError),
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> DemoError + '_ {
    move |source| DemoError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Simulates `cfg` into a temporary folder beside `target` ([`OutputDir`]: removed on an error
/// or a Ctrl-C/SIGTERM), not yet in place: [`commit_staged`] swaps it in once the report that
/// uses it is written, so a failed or interrupted run leaves an old `target` as it was. For
/// `benchmark` and `ablation`; the demo stages its folders with all the others (`Staged`).
pub fn simulate_staged(target: &Path, cfg: &SimConfig) -> Result<OutputDir, DemoError> {
    let staged = OutputDir::create(target).map_err(DemoError::Output)?;
    sim::simulate_to_dir(staged.path(), cfg)?;
    Ok(staged)
}

/// Swaps every staged simulated folder ([`simulate_staged`]) in (one rename each). On an error
/// the folders not yet swapped are dropped newest first, as they were made: a folder's temporary
/// and lock go before its parent's (`domains-data/test` before `domains-data/train`, whose new
/// parent is then removed).
pub fn commit_staged(staged: impl IntoIterator<Item = OutputDir>) -> Result<(), DemoError> {
    let mut staged: Vec<OutputDir> = staged.into_iter().collect();
    // What a swap would refuse, before the first: not some folders new and the rest old.
    for dir in &staged {
        dir.check_commit().map_err(DemoError::Output)?;
    }
    staged.reverse();
    while let Some(dir) = staged.pop() {
        // On an error `staged` (the rest, newest first) drops in order.
        dir.commit().map_err(DemoError::Output)?;
    }
    Ok(())
}

/// The demo's folders under `--out`, each built complete beside its target ([`OutputDir`]) and
/// swapped in together once the whole run has succeeded ([`Staged::commit`]): a failed or
/// interrupted run leaves every old folder as it was, not the early stages' new ones beside the
/// late stages' old ones.
#[derive(Default)]
struct Staged {
    dirs: Vec<OutputDir>,
    /// Subfolders written fresh inside a staged folder (`report/transfer/`): (written, final).
    subfolders: Vec<(PathBuf, PathBuf)>,
}

impl Drop for Staged {
    /// Newest first, as [`commit_staged`] drops what it has not swapped.
    fn drop(&mut self) {
        while let Some(dir) = self.dirs.pop() {
            drop(dir);
        }
    }
}

impl Staged {
    /// Stages `target` and returns the folder to write it in.
    fn folder(&mut self, target: &Path) -> Result<PathBuf, DemoError> {
        let dir = OutputDir::create(target).map_err(DemoError::Output)?;
        let path = dir.path().to_path_buf();
        self.dirs.push(dir);
        Ok(path)
    }

    /// Stages `target` and simulates `cfg` into it; returns the folder to read the events from.
    /// Staged before it is written, so [`Self::name_targets`] names an error of the simulation by
    /// `target`.
    fn simulate(&mut self, target: &Path, cfg: &SimConfig) -> Result<PathBuf, DemoError> {
        let path = self.folder(target)?;
        sim::simulate_to_dir(&path, cfg)?;
        Ok(path)
    }

    /// Each staged folder's temporary and its target, in the order they were staged.
    fn renames(&self) -> impl Iterator<Item = (&Path, &Path)> {
        self.dirs.iter().map(|d| (d.path(), d.target()))
    }

    /// `written`, a subfolder of a staged folder, goes in as `target`: at the commit it keeps the
    /// entries of an old `target` it does not write (a user's notes), as a folder of its own would.
    fn subfolder(&mut self, written: PathBuf, target: PathBuf) -> PathBuf {
        self.subfolders.push((written.clone(), target));
        written
    }

    /// `e` (the whole chain of causes, as `riskctl` prints it) with each staged folder's
    /// temporary name replaced by its target's, and said so: the temporaries are gone once the run
    /// has failed, so a message naming one would point at nothing. An error that names no
    /// temporary is returned as it is. Only for an error before [`Self::commit`], which takes
    /// every folder out of `self` before the first swap (its own errors name the targets).
    fn name_targets(&self, e: DemoError) -> DemoError {
        let causes = std::iter::successors(Some(&e as &(dyn std::error::Error + 'static)), |c| {
            c.source()
        });
        let mut text = crate::error_text(causes);
        let mut renamed = false;
        for (tmp, target) in self.renames() {
            let tmp = tmp.display().to_string();
            if text.contains(&tmp) {
                text = text.replace(&tmp, &target.display().to_string());
                renamed = true;
            }
        }
        if !renamed {
            return e;
        }
        DemoError::Staged(format!(
            "{text} (in the run's staged copy, removed with it; no folder of --out was changed)"
        ))
    }

    /// Where `path`, written in a staged folder, will be once it is in place.
    fn final_path(&self, path: &Path) -> PathBuf {
        self.renames()
            .find_map(|(tmp, target)| Some(target.join(path.strip_prefix(tmp).ok()?)))
            .unwrap_or_else(|| path.to_path_buf())
    }

    /// Swaps every folder in, in the order they were staged (one after another: an error or a
    /// signal between two swaps leaves the earlier ones in, each whole).
    fn commit(&mut self) -> Result<(), DemoError> {
        for (written, target) in &self.subfolders {
            if target.is_dir() && written.is_dir() {
                riskscore_output::carry_missing(target, written).map_err(DemoError::Output)?;
            }
        }
        commit_staged(std::mem::take(&mut self.dirs))
    }
}

/// The folders under `--out` that the transfer and the domain benchmarks simulate into (named
/// once: [`refuse_unswappable_later_folders`] checks them at the start).
const TRANSFER_DATA: &str = "transfer-data";
const DOMAINS_DATA: &str = "domains-data";

/// Checks now the folders the demo simulates into only after the cross-validation (the
/// transfer and domain benchmarks' data), so a file or a link in the place of one fails the run
/// at its start, not minutes later ([`riskscore_output::refuse_unswappable`]).
fn refuse_unswappable_later_folders(opts: &DemoOptions) -> Result<(), DemoError> {
    if opts.real.is_none() || opts.transfer.is_none() {
        return Ok(());
    }
    let mut later = vec![opts.out.join(TRANSFER_DATA)];
    if opts.domains.is_some() {
        let domains = opts.out.join(DOMAINS_DATA);
        later.extend([domains.join("train"), domains.join("test")]);
    }
    for folder in later {
        riskscore_output::refuse_unswappable(&folder).map_err(DemoError::Output)?;
    }
    Ok(())
}

/// What the demo did, measured.
#[derive(Clone, Debug, Serialize)]
pub struct DemoSummary {
    /// `(stage, seconds)` in execution order.
    pub stages: Vec<(String, f64)>,
    pub events: String,
    /// Sequences tested on under CV (`sequences`) and training-only ones (`extra_sequences`).
    pub sequences: usize,
    pub extra_sequences: usize,
    pub pairs_per_second: f64,
    pub drl_epochs_per_second: f64,
    pub msra_epochs_per_second: f64,
    /// int8 vs f32 DRL agreement of the final model on all observations.
    pub final_agreement: Agreement,
    pub claims: Vec<Claim>,
    /// The same claims on the transfer benchmark (empty when it did not run).
    pub transfer_claims: Vec<Claim>,
    #[serde(skip)]
    pub cv: Option<CvReport>,
    pub files: Vec<PathBuf>,
}

impl DemoSummary {
    pub fn total_seconds(&self) -> f64 {
        self.stages.iter().map(|(_, s)| s).sum()
    }
}

/// The folder's prepared sequences ([`events::load_prepared`]) and its event counts; problems are
/// reported on stderr, valid events are kept.
fn load_sequences(dir: &Path) -> Result<(Vec<Sequence>, String), DemoError> {
    let folder = crate::warnings::load_prepared(dir)?;
    Ok((folder.sequences, folder.counts.to_string()))
}

/// Pool every fold's out-of-fold scored sequences per method (each event appears once, scored by
/// the model that did not see it).
pub fn pooled_runs(folds: &[FoldOutcome]) -> Vec<(String, Vec<ScoredSequence>)> {
    let mut pooled: Vec<(String, Vec<ScoredSequence>)> = Vec::new();
    for f in folds {
        for run in &f.runs {
            match pooled.iter_mut().find(|(n, _)| *n == run.name) {
                Some((_, seqs)) => seqs.extend(run.scored.iter().cloned()),
                None => pooled.push((run.name.clone(), run.scored.clone())),
            }
        }
    }
    pooled
}

/// `event-<k>.{svg,png}`: the trajectory figure's events drawn as `riskctl plot` draws them, with
/// the final models (at their default thresholds) and the baselines.
fn event_figures(
    data_dir: &Path,
    model_dir: &Path,
    ids: &[String],
    plot_dir: &Path,
) -> Result<Vec<PathBuf>, DemoError> {
    use eval::event_figure::EventPicture;
    use eval::model_files::{named_models, ModelFile};
    if ids.is_empty() {
        return Ok(Vec::new());
    }
    let specs: Vec<String> = ["drl.rsk", "msra.rsk"]
        .iter()
        .map(|n| model_dir.join(n).display().to_string())
        .collect();
    let models = ModelFile::read_all(&specs)?;
    let mut methods = named_models(&models)?;
    let baselines = eval::Method::baselines_for(&methods);
    methods.extend(baselines);
    let mut thresholds = models
        .iter()
        .map(|m| m.default_threshold().map(Some))
        .collect::<Result<Vec<_>, _>>()?;
    thresholds.resize(methods.len(), None);
    let (set, _) = events::load_events(data_dir)?;
    let mut bundle = eval::bundle::ReportBundle::default();
    for (k, id) in ids.iter().enumerate() {
        let Some(event) = set.get(id) else { continue };
        let mut picture = EventPicture::score(event.clone(), &methods, &thresholds);
        picture.note = Some(
            "models: the demo's final DRL and MSRA, trained on every event (this one too), \
             at their kinds' default thresholds"
                .to_owned(),
        );
        for (ext, format) in [
            ("svg", plots::ImageFormat::Svg),
            ("png", plots::ImageFormat::Png),
        ] {
            bundle.add(&format!("event-{}.{ext}", k + 1), picture.render(format)?);
        }
    }
    Ok(bundle.write_into(plot_dir)?)
}

/// Run the demo. Prints progress on stderr and the tables on stdout as it goes; stdout through
/// [`crate::print_out`], so a reader that closed it (`riskctl demo | head -1`) ends the printing,
/// not the run.
pub fn run(opts: &DemoOptions) -> Result<DemoSummary, DemoError> {
    // Removed again (when still empty) if the run fails before writing anything into it.
    let out_folders = riskscore_output::NewFolders::create(&opts.out).map_err(io_err(&opts.out))?;
    // Held for the whole run (`--out/.demo.lock`, so `--out .` works): a second demo into the same
    // --out is refused now, not left to swap its folders in between this run's.
    let run_lock = opts.out.join("demo");
    let _run_lock = riskscore_output::OutputLock::acquire_for_run(&run_lock)
        .map_err(io_err(&run_lock))?
        .not_an_output();
    // Every folder is written in its staged copy and put in place at the end, with the others.
    let mut staged = Staged::default();
    let summary = run_stages(opts, &mut staged).map_err(|e| staged.name_targets(e))?;
    out_folders.keep();
    Ok(summary)
}

/// The demo's six stages, every folder written in `staged` and put in place at the end.
fn run_stages(opts: &DemoOptions, staged: &mut Staged) -> Result<DemoSummary, DemoError> {
    let mut stages: Vec<(String, f64)> = Vec::new();
    let mut files: Vec<PathBuf> = Vec::new();
    // Staged first: an --out whose report, models or plots is not a folder fails now, not after
    // the training.
    let report_dir = opts.out.join("report");
    let model_dir = opts.out.join("models");
    let plot_dir = opts.out.join("plots");
    let report_stage = staged.folder(&report_dir)?;
    let model_stage = staged.folder(&model_dir)?;
    let plot_stage = staged.folder(&plot_dir)?;
    refuse_unswappable_later_folders(opts)?;

    // 1. Data.
    let t0 = Instant::now();
    // The simulated folders are staged (`Staged::simulate`) with the others.
    let (data_dir, data_staged) = match &opts.data {
        Some(d) => (d.clone(), None),
        None => {
            let dir = opts.out.join("data");
            let cfg = SimConfig {
                seed: opts.sim_seed,
                events: opts.events,
                progress: opts.progress == Progress::Bar,
                ..SimConfig::default()
            };
            eprintln!(
                "[1/6] simulating {} events (seed {}) into {}",
                cfg.events,
                cfg.seed,
                dir.display()
            );
            let written = staged.simulate(&dir, &cfg)?;
            (dir, Some(written))
        }
    };
    // Where the simulated events are read from until they go in place.
    let data_read = data_staged.unwrap_or_else(|| data_dir.clone());
    let (sim_seqs, sim_counts) = load_sequences(&data_read)?;
    match &opts.data {
        Some(d) => eprintln!(
            "[1/6] events of {}: {sim_counts}; {} sequences",
            d.display(),
            sim_seqs.len()
        ),
        None => eprintln!(
            "      simulated events: {sim_counts}; {} sequences",
            sim_seqs.len()
        ),
    }
    let mut seqs = sim_seqs.clone();
    let mut real_seqs = Vec::new();
    let mut counts = sim_counts;
    if let Some(real) = &opts.real {
        let (r, real_counts) = load_sequences(real)?;
        eprintln!(
            "      real recordings {}: {real_counts}; {} safe sequences from {} scenario files",
            real.display(),
            r.len(),
            riskscore_train::transfer::sequences_per_scenario(&r).len()
        );
        counts = format!("{counts} + real {real_counts}");
        real_seqs = r;
        seqs.extend(real_seqs.iter().cloned());
    }
    let (extra_seqs, extra_counts) = load_extra(opts, staged)?;
    let (drl_only_seqs, drl_only_counts) = load_drl_only(&opts.extra.drl_only)?;
    let extra_counts = match (extra_counts, drl_only_counts) {
        (Some(a), Some(b)) => Some(format!("{a}; DRL only: {b}")),
        (None, Some(b)) => Some(format!("DRL only: {b}")),
        (a, None) => a,
    };
    if let Some(c) = &extra_counts {
        counts = format!("{counts}; training only: {c}");
    }
    stages.push(("simulate + load".into(), t0.elapsed().as_secs_f64()));

    // 2. Cross-validation (comparisons, training, quantisation, export, evaluation per fold).
    let t0 = Instant::now();
    let seeds = opts.seeds.max(1);
    eprintln!(
        "[2/6] {}-fold event-level cross-validation x {seeds} seeds: comparisons, DRL + MSRA training, int8, evaluation",
        opts.folds
    );
    let mut folds: Vec<FoldOutcome> = Vec::new();
    let mut first_seed_folds = 0;
    for k in 0..seeds {
        let mut config = opts.config.clone();
        config.seed = opts.config.seed.wrapping_add(k as u64);
        let cv_opts = CvOptions {
            folds: opts.folds,
            seed: config.seed,
            progress: opts.progress,
            ..CvOptions::default()
        };
        let extra = cv::ExtraTrain {
            all_models: &extra_seqs,
            drl_only: &drl_only_seqs,
        };
        let run = cv::cross_validate_with_extra(&seqs, &extra, None, &config, &cv_opts)?;
        crate::warnings::print(run.iter().flat_map(|f| &f.warnings));
        if k == 0 {
            first_seed_folds = run.len();
        }
        folds.extend(run);
        eprintln!(
            "      seed {} done ({:.1} s)",
            config.seed,
            t0.elapsed().as_secs_f64()
        );
    }
    let cv_seconds = t0.elapsed().as_secs_f64();
    stages.push(("cross-validation".into(), cv_seconds));
    let events_counts = EventCounts::from_classes(seqs.iter().map(|s| s.kind));
    let results: Vec<_> = folds.iter().map(|f| f.result.clone()).collect();
    let report = eval::aggregate(events_counts, &results);
    let claims = acceptance_claims(&report, &results, &opts.config.msra.input_names());

    // 3. Report.
    let t0 = Instant::now();
    eprintln!("[3/6] writing the reports");
    let mut bundle = eval::bundle::cv_report_bundle(&report, &results)?;
    claims::add_to(&mut bundle, &claims, &[])?;
    // Pooled out-of-fold scores of the first seed: every event exactly once.
    let pooled = pooled_runs(&folds[..first_seed_folds]);
    let (_, pooled_runs) = eval::evaluate_scored(pooled.clone())?;
    let curves: Vec<_> = pooled_runs
        .iter()
        .map(|r| (r.name.clone(), r.curve.clone()))
        .collect();
    bundle.add_csv("sequence_maxima.csv", |w| {
        eval::report::write_sequence_maxima(&pooled, w)
    })?;
    bundle.add_csv("curves.csv", |w| eval::report::write_curves_csv(&curves, w))?;
    files.extend(bundle.write_into(&report_stage)?);
    stages.push(("report".into(), t0.elapsed().as_secs_f64()));
    outln!();
    outln!(
        "Results: {}-fold event-level CV x {} seeds on {} (mean ± std over folds and seeds; DRL = deployed int8 network)",
        opts.folds,
        opts.seeds.max(1),
        data_dir.display()
    );
    outln!();
    outln!("{}", report.to_markdown());

    // Transfer benchmark: another simulator seed and mix, real scenario files held out.
    let mut transfer_claims = Vec::new();
    if let (Some(settings), false) = (&opts.transfer, real_seqs.is_empty()) {
        let t0 = Instant::now();
        let dir = opts.out.join(TRANSFER_DATA);
        let cfg = SimConfig {
            seed: settings.test_seed,
            events: settings.test_events,
            mix: settings.test_mix,
            progress: opts.progress == Progress::Bar,
            ..SimConfig::default()
        };
        eprintln!(
            "[3b]  transfer benchmark: test simulation seed {} mix {:.0}/{:.0}/{:.0} into {}, real scenario files held out",
            cfg.seed,
            cfg.mix.crash,
            cfg.mix.near_crash,
            cfg.mix.safe,
            dir.display()
        );
        let test_dir = staged.simulate(&dir, &cfg)?;
        let (test_sim, _) = load_sequences(&test_dir)?;
        // The training-only data joins the simulated training side, which every fold trains on.
        let mut train_sim = sim_seqs.clone();
        train_sim.extend(extra_seqs.iter().cloned());
        let data = riskscore_train::transfer::TransferData {
            train_sim,
            train_drl_only: drl_only_seqs.clone(),
            test_sim,
            real: real_seqs.clone(),
        };
        let topts = riskscore_train::transfer::TransferOptions {
            folds: opts.folds,
            seeds: opts.seeds,
            progress: opts.progress,
        };
        let result = riskscore_train::transfer::run(&data, &opts.config, &opts.gssm, &topts)?;
        crate::warnings::print(&result.warnings);
        transfer_claims = acceptance_claims(
            &result.report,
            &result.folds,
            &opts.config.msra.input_names(),
        );
        let transfer_dir =
            staged.subfolder(report_stage.join("transfer"), report_dir.join("transfer"));
        files.extend(transfer_report(&result, &transfer_claims, &[])?.write_into(&transfer_dir)?);
        outln!(
            "Transfer: trained on simulator seed {} + real scenario files, tested on simulator seed {} (other mix) + held-out real scenario files ({} folds x {} seeds)",
            opts.sim_seed,
            settings.test_seed,
            opts.folds,
            opts.seeds.max(1)
        );
        outln!();
        outln!("{}", result.report.to_markdown());
        stages.push(("transfer benchmark".into(), t0.elapsed().as_secs_f64()));
    }

    // The domain benchmark, like the transfer benchmark, needs real recordings.
    if let (Some(settings), Some(transfer), false) =
        (&opts.domains, &opts.transfer, real_seqs.is_empty())
    {
        let t0 = Instant::now();
        files.extend(domain_benchmark(
            opts,
            settings,
            transfer,
            &real_seqs,
            (&report_stage, &report_dir),
            staged,
        )?);
        stages.push(("domain benchmark".into(), t0.elapsed().as_secs_f64()));
    }

    // 4. Final models on all data.
    let t0 = Instant::now();
    eprintln!("[4/6] training the final DRL and MSRA on all events, quantising, exporting");
    let mut all = seqs.clone();
    all.extend(extra_seqs.iter().cloned());
    let meta = json!({
        "data": data_dir.display().to_string(),
        "real": opts.real.as_ref().map(|p| p.display().to_string()),
        "sim_seed": opts.sim_seed,
        "events": counts,
        "config_seed": opts.config.seed,
        "extra_sim": opts.extra.sim.as_ref().map(|e| json!({
            "seed": e.seed,
            "events": e.events,
            "families": e.families.to_string(),
        })),
        "extra_real": opts.extra.real.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "extra_drl_only": opts.extra.drl_only.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    });
    let (finals, model_files) = train_and_export(
        &all,
        &drl_only_seqs,
        None,
        &opts.config,
        &model_stage,
        meta,
        opts.progress,
    )?;
    crate::warnings::print(&finals.warnings);
    files.extend(model_files);
    stages.push(("final models + export".into(), t0.elapsed().as_secs_f64()));

    // 5. Plots.
    let t0 = Instant::now();
    eprintln!("[5/6] plots (pooled out-of-fold scores of the first seed)");
    let plotted: Vec<(String, eval::WarningCurve)> = curves
        .iter()
        .filter(|(n, _)| n != "DRL-f32")
        .cloned()
        .collect();
    let mut figures = plots::curve_figures(&plotted, POOLED_SCORES)?;
    let traj_methods: Vec<_> = pooled
        .iter()
        .filter(|(n, _)| n != "DRL-f32")
        .cloned()
        .collect();
    let crash_ids = traj_methods
        .first()
        .map(|(_, s)| plots::default_trajectory_events(s, 3))
        .unwrap_or_default();
    let panels = plots::trajectory_panels(&traj_methods, &crash_ids);
    figures.extend(plots::trajectory_figures(&panels, POOLED_SCORES)?);
    files.extend(eval::bundle::ReportBundle { files: figures }.write_into(&plot_stage)?);
    files.extend(event_figures(
        &data_read,
        &model_stage,
        &crash_ids,
        &plot_stage,
    )?);
    stages.push(("plots".into(), t0.elapsed().as_secs_f64()));

    // 6. Summary.
    eprintln!("[6/6] summary");
    let pairs_per_second = mean(folds.iter().map(|f| f.comparisons.pairs_per_second()));
    let drl_eps = mean(
        folds
            .iter()
            .filter_map(|f| f.drl.as_ref().map(|r| r.epochs_per_second)),
    );
    let msra_eps = mean(
        folds
            .iter()
            .filter_map(|f| f.msra.as_ref().map(|r| r.epochs_per_second)),
    );
    let training = json!({
        "folds": folds.iter().map(|f| json!({
            "seed": f.result.seed,
            "fold": f.fold,
            "comparisons": f.comparisons,
            "drl": f.drl,
            "msra": f.msra,
            "msra_params": f.msra_params,
            "int8_agreement": f.agreement,
            "times": f.times,
        })).collect::<Vec<_>>(),
        "final": {
            "drl": finals.drl.report,
            "msra": finals.msra.report,
            "msra_params": finals.msra.params,
            "int8_agreement": finals.agreement,
            "calibration": finals.drl.calibration,
            "pairs_per_second": finals.pairs_per_second,
        },
        "stages": stages,
        "claims": claims,
        "transfer_claims": transfer_claims,
        "pairs_per_second": pairs_per_second,
        "drl_epochs_per_second": drl_eps,
        "msra_epochs_per_second": msra_eps,
    });
    let tp = report_stage.join("training.json");
    // Into the staged report: it goes in place with the rest, so a plain write is whole.
    serde_json::to_vec_pretty(&training)
        .map_err(std::io::Error::from)
        .and_then(|text| std::fs::write(&tp, text))
        .map_err(io_err(&tp))?;
    files.push(tp);
    let files = files.iter().map(|f| staged.final_path(f)).collect();
    staged.commit()?;

    let summary = DemoSummary {
        stages,
        events: counts,
        sequences: seqs.len(),
        extra_sequences: extra_seqs.len(),
        pairs_per_second,
        drl_epochs_per_second: drl_eps,
        msra_epochs_per_second: msra_eps,
        final_agreement: finals.agreement,
        claims,
        transfer_claims,
        cv: Some(report),
        files,
    };
    print_summary(&summary, opts, &data_dir);
    Ok(summary)
}

/// Event-id prefix of the training-only simulated events (apart from the simulated default set's).
pub const EXTRA_SIM_PREFIX: &str = "extra-sim/";

/// The recipe's training-only sequences ([`ExtraTraining`]): simulates the extra folder into
/// `extra-data/` (staged in `staged`: [`Staged::simulate`]) and loads the extra real folders.
/// Returns them and their counts (`None`: none).
fn load_extra(
    opts: &DemoOptions,
    staged: &mut Staged,
) -> Result<(Vec<Sequence>, Option<String>), DemoError> {
    let mut seqs = Vec::new();
    let mut counts = Vec::new();
    if let Some(extra) = &opts.extra.sim {
        let dir = opts.out.join("extra-data");
        let cfg = SimConfig {
            seed: extra.seed,
            events: extra.events,
            families: extra.families.clone(),
            progress: opts.progress == Progress::Bar,
            ..SimConfig::default()
        };
        eprintln!(
            "      training only: simulating {} events of the `{}` families (seed {}) into {}",
            cfg.events,
            cfg.families,
            cfg.seed,
            dir.display()
        );
        let (mut s, c) = load_sequences(&staged.simulate(&dir, &cfg)?)?;
        // Simulated ids restart at 000001 in every folder; training groups sequences by event id
        // (validation split, pair draws), so the extra folder's events get ids of their own.
        for seq in &mut s {
            seq.event_id = format!("{EXTRA_SIM_PREFIX}{}", seq.event_id);
        }
        counts.push(format!("sim `{}` seed {} {c}", extra.families, extra.seed));
        seqs.extend(s);
    }
    for dir in &opts.extra.real {
        let (s, c) = load_sequences(dir)?;
        eprintln!(
            "      training only: real {}: {c}; {} sequences",
            dir.display(),
            s.len()
        );
        counts.push(format!("real {c} ({})", dir.display()));
        seqs.extend(s);
    }
    Ok((seqs, (!counts.is_empty()).then(|| counts.join(" + "))))
}

/// Event-id prefix of the DRL-only training sequences (`drl-only/<folder index>/<id>`).
pub const DRL_ONLY_PREFIX: &str = "drl-only/";

/// Event-id prefix of `riskctl benchmark transfer --train-only` sequences
/// (`train-only/<folder index>/<id>`).
pub const TRAIN_ONLY_PREFIX: &str = "train-only/";

/// The training-only folders DRL alone trains on ([`ExtraTraining::drl_only`]), with their
/// counts (`None`: none).
fn load_drl_only(dirs: &[PathBuf]) -> Result<(Vec<Sequence>, Option<String>), DemoError> {
    load_training_only(dirs, DRL_ONLY_PREFIX, "training only, DRL only")
}

/// Training-only folders, each sequence's event id prefixed with `<prefix><folder index>/`, with
/// their counts (`None`: none). As the extra simulated folder's: ids of their own (a simulated
/// folder's restart at 000001 and training groups sequences by event id).
pub fn load_training_only(
    dirs: &[PathBuf],
    prefix: &str,
    what: &str,
) -> Result<(Vec<Sequence>, Option<String>), DemoError> {
    let mut seqs = Vec::new();
    let mut counts = Vec::new();
    for (i, dir) in dirs.iter().enumerate() {
        let (mut s, c) = load_sequences(dir)?;
        eprintln!(
            "      {what}: {}: {c}; {} sequences",
            dir.display(),
            s.len()
        );
        for seq in &mut s {
            seq.event_id = format!("{prefix}{i}/{}", seq.event_id);
        }
        counts.push(format!("{c} ({})", dir.display()));
        seqs.extend(s);
    }
    Ok((seqs, (!counts.is_empty()).then(|| counts.join(" + "))))
}

/// Stage 3c: the default rounds of `riskctl benchmark domains`, short (`settings`' folds and
/// seeds): train without a speed band, a city or a geometry, test on it. Simulates its own two
/// folders with the operating-domain families (the training one at the demo's seed, the test one
/// at the transfer benchmark's seed and mix), staged in `staged`; writes `domains/` into the
/// staged `report/` (`report_stage`, to go in as `report_dir`).
fn domain_benchmark(
    opts: &DemoOptions,
    settings: &DomainSettings,
    transfer: &TransferSettings,
    real_freeway: &[Sequence],
    (report_stage, report_dir): (&Path, &Path),
    staged: &mut Staged,
) -> Result<Vec<PathBuf>, DemoError> {
    use riskscore_train::domains::{self, DomainData, EmptyRound, Round};
    // Staged ([`Staged::simulate`]), swapped in with the demo's other folders.
    let mut simulate =
        |folder: &str, seed: u64, mix: sim::Mix| -> Result<Vec<Sequence>, DemoError> {
            let dir = opts.out.join(DOMAINS_DATA).join(folder);
            let cfg = SimConfig {
                seed,
                events: settings.events,
                mix,
                families: sim::FamilyMix::domain(),
                progress: opts.progress == Progress::Bar,
                ..SimConfig::default()
            };
            Ok(load_sequences(&staged.simulate(&dir, &cfg)?)?.0)
        };
    let real_city = match &settings.real_city {
        Some(dir) => load_sequences(dir)?.0,
        None => Vec::new(),
    };
    eprintln!(
        "[3c]  domain benchmark: {} + {} events of the operating-domain families (seeds {} and {}), \
         {} real freeway + {} real city sequences, {} folds x {} seed(s)",
        settings.events,
        settings.events,
        opts.sim_seed,
        transfer.test_seed,
        real_freeway.len(),
        real_city.len(),
        settings.folds,
        settings.seeds
    );
    let train = simulate("train", opts.sim_seed, SimConfig::default().mix)?;
    let test = simulate("test", transfer.test_seed, transfer.test_mix)?;
    let data = DomainData::new(train, test, real_freeway.to_vec(), real_city);
    let options = riskscore_train::transfer::TransferOptions {
        folds: settings.folds,
        seeds: settings.seeds,
        progress: opts.progress,
    };
    let result = domains::run(
        &Round::defaults(),
        &data,
        &opts.config,
        &opts.gssm,
        &options,
        EmptyRound::ReportNoData,
        None,
    )?;
    crate::warnings::print(result.warnings());
    outln!(
        "Domain benchmark (short: {} folds x {} seed(s); `riskctl benchmark domains` runs 5 x 3): \
         each round trains without one slice of the operating domain and tests on it",
        settings.folds,
        settings.seeds
    );
    outln!();
    outln!("{}", result.to_markdown());
    let dir = staged.subfolder(report_stage.join("domains"), report_dir.join("domains"));
    Ok(result.bundle()?.write_into(&dir)?)
}

/// The transfer benchmark's report files, its `claims` as `claims.md` and `claims.csv` among
/// them, and over several simulator draws each draw's label and own claims (`per_draw`,
/// [`claims::add_to`]).
pub fn transfer_report(
    result: &riskscore_train::transfer::TransferResult,
    claims: &[Claim],
    per_draw: &[(&str, &[Claim])],
) -> Result<eval::bundle::ReportBundle, DemoError> {
    let mut bundle = eval::bundle::cv_report_bundle(&result.report, &result.folds)?;
    bundle.add_json("splits.json", &result.splits)?;
    claims::add_to(&mut bundle, claims, per_draw)?;
    Ok(bundle)
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.collect();
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Print claims as `[ok]` / `[FAIL]` / `[n/a]` lines under a title, each with its run tally.
pub fn print_claims(title: &str, claims: &[Claim]) {
    out!("{}", claims::to_text(title, claims));
}

/// What the metric names in the tables and claims mean.
pub const METRIC_LEGEND: &str = "\
Metrics (docs/evaluation.md): a method warns at the first frame whose risk reaches a threshold;
sweeping the threshold over all sequence maxima gives, for conflicts (crash + near-crash) vs safe
sequences: A_ROC_90/80 = area under the ROC curve where recall >= 90/80 %, normalised to 0-100;
P_PRC_90/80 = the best precision (%) at recall >= 90/80 %; mTTI_90 = the longest mean warning lead
time (s) of any threshold with precision >= 90 %. mean ± std over folds x seeds; \"(14/15)\" = the
metric exists in 14 of 15 folds (the mean is over those); n/a = it exists in none.";

/// The default run's and the `--no-real` run's headline figures, from the run recorded here
/// (`scripts/demo.sh` and `scripts/demo.sh --no-real` at commit time; docs/benchmarks.md has the
/// full tables). Quoted, not computed: the other mode is not run.
pub const WITH_REAL_FIGURES: &str =
    "with the 376 real US-101 sequences (the default; the city ones train too): DRL A_ROC_90 93.6 vs \
     TAdv 85.8, transfer 82.1 vs 75.1";
pub const WITHOUT_REAL_FIGURES: &str =
    "without any real driving (--no-real), in distribution: DRL A_ROC_90 72.3 vs TAdv 64.7 (fold std \
     8.1; 93.6 vs 85.8 with it) and P_PRC_90 88.6 vs 83.2 (MSRA: 73.6 and 87.4)";

/// One short paragraph: what was shown on which data, and the caveats that were measured.
pub fn conclusion(s: &DemoSummary, opts: &DemoOptions) -> String {
    let count = |claims: &[Claim]| {
        let ok = claims.iter().filter(|c| c.verdict == "ok").count();
        let na = claims.iter().filter(|c| c.verdict == "n/a").count();
        let na = if na > 0 {
            format!(", {na} n/a")
        } else {
            String::new()
        };
        format!("{ok} of {} claims hold{na}", claims.len())
    };
    let figure = |claims: &[Claim], baseline: &str| {
        claims
            .iter()
            .find(|c| c.method == "DRL" && c.baseline == baseline && c.metric == "A_ROC_90")
            .map(|c| {
                format!(
                    "DRL A_ROC_90 {} vs {baseline} {}",
                    format_value(c.method_mean, 2),
                    format_value(c.baseline_mean, 2)
                )
            })
            .unwrap_or_default()
    };
    let mut text = format!(
        "Conclusion: on {} ({} sequences), {}-fold event-level CV x {} seeds: {} ({}).",
        s.events,
        s.sequences,
        opts.folds,
        opts.seeds.max(1),
        count(&s.claims),
        figure(&s.claims, "TAdv")
    );
    if s.extra_sequences > 0 {
        text.push_str(&format!(
            " Training also saw {} training-only sequences (other scenario families, other \
             places) that no test fold holds.",
            s.extra_sequences
        ));
    }
    if !s.transfer_claims.is_empty() {
        text.push_str(&format!(
            " Transfer: {} ({}); its test data is another simulator seed and mix with the same \
             speed ranges plus US-101 recordings held out by file: the same freeway, not another \
             place, city or speed band.",
            count(&s.transfer_claims),
            figure(&s.transfer_claims, "TAdv")
        ));
    }
    // The recorded run's figures are of the simulated default set, not of a user's --data.
    if opts.data.is_some() {
        return text;
    }
    if opts.real.is_some() {
        text.push_str(&format!(
            " How much of the win rests on the real normal driving: {WITHOUT_REAL_FIGURES} (quoted from \
             the recorded run, docs/benchmarks.md)."
        ));
    } else {
        text.push_str(&format!(
            " This run used no real normal driving; {WITH_REAL_FIGURES} (quoted from the \
             recorded run, docs/benchmarks.md)."
        ));
    }
    text
}

/// `text` wrapped at `width` columns.
fn wrap(text: &str, width: usize) -> String {
    let mut out = String::new();
    let mut line = 0;
    for word in text.split_whitespace() {
        if line > 0 && line + 1 + word.len() > width {
            out.push('\n');
            line = 0;
        } else if line > 0 {
            out.push(' ');
            line += 1;
        }
        out.push_str(word);
        line += word.len();
    }
    out
}

fn print_summary(s: &DemoSummary, opts: &DemoOptions, data_dir: &Path) {
    if let Some(cv) = &s.cv {
        outln!("Float vs int8 DRL (fold means; DRL-f32 = same network before quantisation):");
        for name in ["DRL-f32", "DRL"] {
            let m: Vec<String> = Metric::ALL
                .iter()
                .map(|&metric| format_value(cv.mean(name, metric), 2))
                .collect();
            outln!(
                "  {name:<8} A_ROC_90 {}  A_ROC_80 {}  P_PRC_90 {}  P_PRC_80 {}  mTTI_90 {} s",
                m[0],
                m[1],
                m[2],
                m[3],
                m[4]
            );
        }
        outln!(
            "  final model on all observations: corr {:.5}, mean |int8 - f32| {:.4} (score std {:.3})",
            s.final_agreement.correlation,
            s.final_agreement.mean_abs_error,
            s.final_agreement.float_std
        );
    }
    outln!();
    outln!("{METRIC_LEGEND}");
    outln!();
    print_claims(
        "Acceptance, in distribution (fold means, strictly better; n/a: the baseline has no value to beat):",
        &s.claims,
    );
    if !s.transfer_claims.is_empty() {
        print_claims(
            "Acceptance, transfer benchmark (fold means, strictly better unless marked >=):",
            &s.transfer_claims,
        );
    }
    outln!(
        "Throughput: {:.0} comparison pairs/s, DRL {:.1} epochs/s, MSRA {:.1} epochs/s",
        s.pairs_per_second,
        s.drl_epochs_per_second,
        s.msra_epochs_per_second
    );
    outln!("Stage times:");
    for (name, secs) in &s.stages {
        outln!("  {name:<24} {secs:>7.1} s");
    }
    outln!("  {:<24} {:>7.1} s", "total", s.total_seconds());
    outln!();
    outln!("Where everything went:");
    outln!("  event data     {}", data_dir.display());
    outln!("  reports        {}", opts.out.join("report").display());
    outln!("  models         {}", opts.out.join("models").display());
    outln!("  plots          {}", opts.out.join("plots").display());
    outln!(
        "  next: riskctl inspect-model {}   |   riskctl evaluate --model {} --events DIR",
        opts.out.join("models/drl.rsk").display(),
        opts.out.join("models/drl.rsk").display()
    );
    outln!();
    outln!("{}", wrap(&conclusion(s, opts), 100));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_names_the_target_not_the_staged_temporary() {
        let d = tempfile::tempdir().unwrap();
        let mut staged = Staged::default();
        let report = staged.folder(&d.path().join("report")).unwrap();
        let written = report.join("results.md");
        let e = io_err(&written)(std::io::Error::other("disk full"));
        let text = staged.name_targets(e).to_string();
        let target = d.path().join("report/results.md");
        assert!(
            text.starts_with(&format!("{}: disk full", target.display())),
            "{text}"
        );
        assert!(text.contains("staged copy"), "{text}");
        assert!(!text.contains(&report.display().to_string()), "{text}");
        // A cause the message does not quote is kept (`model file X: cannot read` alone said
        // nothing of why).
        let blob = report.join("drl.rsk");
        let unread = eval::model_files::ModelFile::read(&blob.display().to_string()).unwrap_err();
        let text = staged
            .name_targets(DemoError::ModelFile(unread))
            .to_string();
        assert!(text.contains("report/drl.rsk: cannot read: "), "{text}");
        assert!(text.contains("os error 2"), "{text}");
        assert!(text.contains("removed with it"), "{text}");
        // An error naming no temporary is kept as it is.
        let other = io_err(Path::new("elsewhere.csv"))(std::io::Error::other("gone"));
        assert!(matches!(staged.name_targets(other), DemoError::Io { .. }));
    }
}
