//! From scoring options to an engine's parts: the DBC files as one database, the compiled map, the
//! warning configuration, the files a run reads and writes, and the lines it prints about them.
use super::ScoringArgs;
use crate::cli_values::is_std_stream;
use crate::engine::{EngineConfig, Stats};
use crate::events_out::{EventWriter, Sink};
use crate::map::{BusDatabase, BusPart, Clash, CompiledMap, MapError, MapFile, DEFAULT_MAP};
use crate::model_file::{ModelFile, ModelFileError};
use can_codec::{Database, DbcError, DbcFileError};
use riskscore_output::{AtomicFile, NamedPath};
use std::path::{Path, PathBuf};

/// The project DBC, compiled in, as a `--dbc` argument.
pub const BUILTIN_DBC: &str = "builtin:riskscore";

/// A scoring command's inputs could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("project DBC")]
    ProjectDbc(#[source] DbcError),
    #[error("--dbc {0}: no such built-in DBC (the one built in is `{BUILTIN_DBC}`)")]
    UnknownBuiltin(String),
    #[error(transparent)]
    DbcFile(#[from] DbcFileError),
    #[error("{}", clash_text(.0))]
    Clashes(Vec<Clash>),
    #[error("reading map {path}")]
    ReadMap {
        path: String,
        #[source]
        cause: std::io::Error,
    },
    #[error("map {path}")]
    ParseMap {
        path: String,
        #[source]
        cause: MapError,
    },
    #[error("default map")]
    DefaultMap(#[source] MapError),
    #[error("map {map} against DBC {dbc}")]
    Compile {
        map: String,
        dbc: String,
        #[source]
        cause: MapError,
    },
    #[error(transparent)]
    Model(#[from] ModelFileError),
    /// An output file holds a user's model blob or training checkpoint (riskctl's refusal).
    #[error(transparent)]
    WouldReplaceModel(#[from] riskscore_output::ExistingFileError),
    /// The warning threshold is NaN or infinite; `origin` says where it came from: `--threshold`,
    /// or the model file's default threshold (naming the file).
    #[error("{origin} must be finite, not {threshold}")]
    Threshold { threshold: f32, origin: String },
    #[error("{flag} {path}: stdout carries the report; give a path (standard output is not an output here)")]
    NotToStdout { flag: &'static str, path: String },
    #[error("--warnings-out {warnings} and the JSON events (--events-out, stdout by default) would both go to stdout: give --events-out FILE")]
    BothToStdout { warnings: String },
    #[error("--urgent {urgent} is below the warning threshold {threshold} ({source_of}): level 2 is only given to a warning, so every warning would be urgent; give --urgent at or above the threshold")]
    UrgentBelowThreshold {
        urgent: f32,
        threshold: f32,
        source_of: &'static str,
    },
    #[error("creating {path}")]
    Create {
        path: String,
        #[source]
        cause: std::io::Error,
    },
}

fn clash_text(clashes: &[Clash]) -> String {
    let list: Vec<String> = clashes.iter().map(Clash::to_string).collect();
    format!(
        "{} message {} defined twice on one bus: {}; files of different buses: bind each to its bus (`--dbc can0=radar.dbc --dbc can1=powertrain.dbc`, or the map's [bus] table)",
        clashes.len(),
        if clashes.len() == 1 { "id is" } else { "ids are" },
        list.join("; ")
    )
}

/// A file could not be created.
pub fn creating(path: &Path) -> impl FnOnce(std::io::Error) -> SetupError + '_ {
    move |cause| SetupError::Create {
        path: path.display().to_string(),
        cause,
    }
}

/// A `--dbc` argument: `FILE` (every bus) or `BUS=FILE` (the interface the file's messages are
/// on; [`crate::cli_values::dbc_bus`], a too long BUS is refused when parsed). A path with `=`
/// in its first component that is not meant as a bus: write it `./a=b.dbc`.
pub fn dbc_binding(arg: &Path) -> (Option<&str>, &Path) {
    match arg.to_str().and_then(crate::cli_values::dbc_bus) {
        Some((bus, file)) => (Some(bus), Path::new(file)),
        None => (None, arg),
    }
}

fn load_one(path: &Path) -> Result<Database, SetupError> {
    if path.as_os_str() == BUILTIN_DBC {
        Database::parse(can_codec::project::PROJECT_DBC).map_err(SetupError::ProjectDbc)
    } else if path.to_str().is_some_and(|p| p.starts_with("builtin:")) && !path.exists() {
        Err(SetupError::UnknownBuiltin(path.display().to_string()))
    } else {
        Ok(Database::load(path)?)
    }
}

/// The DBC files of the vehicle, each bound to its bus or to every bus; every id defined twice
/// on one bus is named, all at once.
pub fn load_dbcs(files: &[(Option<String>, PathBuf)]) -> Result<BusDatabase, SetupError> {
    let builtin = [(None, PathBuf::from(BUILTIN_DBC))];
    let files = if files.is_empty() {
        &builtin[..]
    } else {
        files
    };
    let mut all = BusDatabase::default();
    let mut clashes = Vec::new();
    for (bus, path) in files {
        let part = BusPart {
            bus: bus.clone(),
            origin: path.display().to_string(),
            db: load_one(path)?,
        };
        if let Err(mut c) = all.add(part) {
            clashes.append(&mut c);
        }
    }
    if clashes.is_empty() {
        Ok(all)
    } else {
        Err(SetupError::Clashes(clashes))
    }
}

/// The DBC files of a run: `--dbc` (each `FILE` or `BUS=FILE`), else the map's `[bus]` table
/// (paths relative to the map file), else the project DBC.
pub fn dbc_files(args: &ScoringArgs, map: Option<&MapFile>) -> Vec<(Option<String>, PathBuf)> {
    if !args.dbc.is_empty() {
        return args
            .dbc
            .iter()
            .map(|p| {
                let (bus, file) = dbc_binding(p);
                (bus.map(str::to_string), file.to_path_buf())
            })
            .collect();
    }
    let dir = args
        .map
        .as_ref()
        .and_then(|p| p.parent())
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let mut files = Vec::new();
    for (bus, list) in map.map(|m| &m.bus).into_iter().flatten() {
        for f in list {
            let path = if f == BUILTIN_DBC {
                PathBuf::from(f)
            } else {
                dir.join(f)
            };
            files.push((Some(bus.clone()), path));
        }
    }
    files
}

/// The map of `--map` (or the project's) compiled against the DBC files of [`dbc_files`].
pub fn load_map(args: &ScoringArgs) -> Result<CompiledMap, SetupError> {
    let map = match &args.map {
        Some(p) => {
            let path = || p.display().to_string();
            let text = std::fs::read_to_string(p).map_err(|cause| SetupError::ReadMap {
                path: path(),
                cause,
            })?;
            MapFile::parse(&text).map_err(|cause| SetupError::ParseMap {
                path: path(),
                cause,
            })?
        }
        None => MapFile::parse(DEFAULT_MAP).map_err(SetupError::DefaultMap)?,
    };
    if !args.dbc.is_empty() && !map.bus.is_empty() {
        eprintln!("can-bridge: --dbc given: the map's [bus] table is not used");
    }
    let db = load_dbcs(&dbc_files(args, Some(&map)))?;
    CompiledMap::compile_on(&map, &db).map_err(|cause| SetupError::Compile {
        map: args
            .map
            .as_ref()
            .map_or("(default)".into(), |p| p.display().to_string()),
        dbc: if db.parts.len() == 1 && db.parts[0].origin == BUILTIN_DBC {
            "(project)".to_string()
        } else {
            db.describe()
        },
        cause,
    })
}

/// Says where every scorer input comes from and which are derived or defaulted.
pub fn print_inputs(map: &CompiledMap) {
    for line in map.input_report() {
        eprintln!("can-bridge: input {line}");
    }
}

/// The engine's warning and freshness parameters from the options (the threshold defaults to the
/// model's own, [`ModelFile::default_threshold`]).
pub fn engine_config(args: &ScoringArgs, model: &ModelFile) -> Result<EngineConfig, SetupError> {
    let threshold = match args.threshold {
        Some(t) => t,
        None => {
            let t = model.default_threshold()?;
            // Said once at start: warnings mean little without the threshold they fire at.
            eprintln!("can-bridge: threshold {t} (the model's default; --threshold overrides)");
            t
        }
    };
    if !threshold.is_finite() {
        // Not reachable from the model today (a blob's default is finite once it loads: see
        // tests/threshold_origin.rs), but said right if that ever changes.
        return Err(SetupError::Threshold {
            threshold,
            origin: if args.threshold.is_some() {
                "--threshold".to_string()
            } else {
                format!(
                    "the default threshold of model file {}",
                    model.path.display()
                )
            },
        });
    }
    if let Some(urgent) = args.urgent.filter(|u| *u < threshold) {
        return Err(SetupError::UrgentBelowThreshold {
            urgent,
            threshold,
            source_of: if args.threshold.is_some() {
                "--threshold"
            } else {
                "the model's default"
            },
        });
    }
    Ok(EngineConfig {
        threshold,
        urgent: args.urgent,
        hysteresis: args.hysteresis,
        min_on_us: args.min_on_ms * 1000,
        stale_us: args.stale_ms * 1000,
        latch: args.latch,
    })
}

/// JSON Lines events to stdout or `path`: offline (`atomic`) through a temporary file renamed at
/// the end of a successful run, live written as it goes.
pub fn open_events(
    path: &Option<PathBuf>,
    all_scores: bool,
    atomic: bool,
) -> Result<EventWriter, SetupError> {
    if let Some(p) = path {
        riskscore_output::refuse_overwriting_a_model("--events-out", p, "JSON Lines events")?;
    }
    let out = match path {
        // `-`: standard output, as `--log -` is standard input (not a file named `-`).
        Some(p) if is_std_stream(p) => Sink::Stdout(std::io::stdout()),
        Some(p) if atomic => Sink::Atomic(AtomicFile::create(p).map_err(creating(p))?),
        Some(p) => Sink::Streaming(std::io::BufWriter::new(
            riskscore_output::create_live_file(p).map_err(creating(p))?,
        )),
        None => Sink::Stdout(std::io::stdout()),
    };
    Ok(EventWriter::new(out, all_scores))
}

/// The files a scoring command reads, named by their option.
pub fn scoring_inputs(args: &ScoringArgs) -> Vec<NamedPath<'_>> {
    let mut v: Vec<NamedPath<'_>> = vec![("--model", args.model.as_path())];
    for p in &args.dbc {
        let (_, file) = dbc_binding(p);
        if file.as_os_str() != BUILTIN_DBC {
            v.push(("--dbc", file));
        }
    }
    if let Some(p) = &args.map {
        v.push(("--map", p.as_path()));
    }
    v
}

/// The closing counters of a run, as one line.
pub fn summary(s: &Stats) -> String {
    format!(
        "{} frames, {} scored, {} warning frames, {} unsent, {} decode errors, {} stale drops, {} invalid objects, {} reordered, {} off the timeline, {} log segments, {} duplicates, {} unknown ids, {} remote, {} error frames ({} bus-off), {} tracks dropped, {} table full, {} new objects, {} awaiting motion, {} outside the view, {} outside the training domain",
        s.frames, s.scored, s.warning_frames, s.warning_frames_unsent, s.decode_errors, s.stale_drops, s.invalid_objects,
        s.reordered, s.out_of_window, crate::timeline::segment_count(s.frames, s.segments), s.duplicates, s.unknown_ids, s.remote_frames,
        s.error_frames, s.bus_off, s.tracks_dropped, s.table_full, s.new_objects, s.motion_pending, s.outside_view,
        s.out_of_domain
    )
}

/// Why a run that received frames scored nothing, if it did.
#[derive(Debug, PartialEq)]
pub enum NothingScored {
    /// Not one frame was a message the map reads (a wrong `--dbc`, `--map` or bus name), the
    /// log held no data frame at all, or nothing was scored while frames the map reads came on
    /// another bus: an error for offline commands.
    NothingMapped(String),
    /// Mapped messages were decoded, but no partner update could be scored.
    NoUpdate(String),
}

/// The run-end verdict when frames came in and nothing was scored (`None` otherwise);
/// `unreadable`: lines of the log that were no frame.
pub fn nothing_scored(s: &Stats, unreadable: usize) -> Option<NothingScored> {
    let data_frames = s.frames.saturating_sub(s.error_frames + s.remote_frames);
    if s.scored > 0 {
        return None;
    }
    if data_frames == 0 {
        let what = match (s.frames, unreadable) {
            (0, 0) => "the log has no frame line".to_string(),
            (0, n) => format!("{n} unreadable lines (listed above) and no frame line"),
            (f, 0) => format!("{f} frames, error and remote frames only"),
            (f, n) => format!(
                "{n} unreadable lines (listed above), {f} frames, error and remote frames only"
            ),
        };
        return Some(NothingScored::NothingMapped(format!(
            "nothing was scored: no CAN data frame ({what})"
        )));
    }
    if s.decoded == 0 && s.decode_errors == 0 {
        let other_bus = if s.unknown_other_bus > 0 {
            format!(
                "; {} of them are messages the map reads on another bus: the log's interface names do not match the buses of --dbc BUS=FILE or the map's [bus]",
                s.unknown_other_bus
            )
        } else {
            String::new()
        };
        return Some(NothingScored::NothingMapped(format!(
            "nothing was scored: none of the {data_frames} data frames is a message the map reads ({} have ids the map does not read on their interface{other_bus}); check --dbc, --map and the bus names (docs/can-bridge.md, \"Bring your own vehicle\")",
            s.unknown_ids
        )));
    }
    let counts = format!(
        "{} mapped messages decoded ({} undecodable), but no partner update could be scored ({} invalid objects, {} stale drops, {} awaiting motion, {} outside the view)",
        s.decoded, s.decode_errors, s.invalid_objects, s.stale_drops, s.motion_pending, s.outside_view
    );
    // Frames the map reads, but on another bus: the radar is on the log, bound to the wrong
    // interface. That is a configuration error like a log of unmapped ids, not a drive that
    // really held ego frames only, so it fails (and leaves the old outputs) instead of exit 0.
    if s.unknown_other_bus > 0 {
        return Some(NothingScored::NothingMapped(format!(
            "nothing was scored: {counts}; {} frames are messages the map reads on another bus: the log's interface names do not match the buses of --dbc BUS=FILE or the map's [bus]",
            s.unknown_other_bus
        )));
    }
    Some(NothingScored::NoUpdate(format!(
        "nothing was scored: {counts}; is every ego field the map needs on the log?"
    )))
}

/// Offline commands and `replay`: a log without one line (blank lines aside) is an error that
/// says so and names the log (`--log -`: standard input): a failed capture, a wrong path or a
/// producer that wrote nothing, never "no warnings" (or "0 frames sent"). `done`: what did not
/// happen, "scored" or "sent".
pub fn refuse_empty_log(
    path: &Path,
    report: &crate::logfile::LogReport,
    done: &str,
) -> Result<(), super::Failure> {
    if report.frames > 0 || report.bad_lines() > 0 {
        return Ok(());
    }
    let name = crate::logfile::describe(path);
    let blank = match report.blank {
        0 => String::new(),
        n => format!(" ({n} blank lines)"),
    };
    Err(super::Failure::Input(super::InputError::NothingMapped(
        format!("nothing was {done}: {name} holds no frames: the log is empty{blank}"),
    )))
}

/// Offline commands: a log whose frames all carry one timestamp, which dropped track updates as
/// duplicates, is an error naming the log and its first frame's line
/// ([`crate::logfile::LogReport::stuck_timestamps`]); the outputs are not written.
pub fn refuse_stuck_timestamps(
    path: &Path,
    report: &crate::logfile::LogReport,
    stats: &Stats,
) -> Result<(), super::Failure> {
    match report.stuck_timestamps(stats.duplicates, stats.scored) {
        Some(m) => Err(super::Failure::Input(super::InputError::StuckTimestamps(
            format!("{}: {m}", crate::logfile::describe(path)),
        ))),
        None => Ok(()),
    }
}

/// Offline commands: a log with no mapped message is an error (its outputs are not written); one
/// whose mapped messages gave no update gets a note.
/// `unreadable`: the log's lines that were no frame (listed before this is called).
pub fn refuse_nothing_scored(
    s: &Stats,
    who: &str,
    unreadable: usize,
) -> Result<(), super::Failure> {
    match nothing_scored(s, unreadable) {
        Some(NothingScored::NothingMapped(m)) => {
            Err(super::Failure::Input(super::InputError::NothingMapped(m)))
        }
        Some(NothingScored::NoUpdate(m)) => {
            eprintln!("{who}: {m}");
            Ok(())
        }
        None => Ok(()),
    }
}

/// The run-end line about warnings that never reached the bus, if any did not.
pub fn unsent_note(s: &Stats, map: &CompiledMap) -> Option<String> {
    (s.warning_frames_unsent > 0).then(|| {
        let signal = &map.warning.spec.signals[map.warning.track_id].name;
        format!(
            "{} warning frames NOT SENT ({} tracks with ids the warning message's {signal} cannot carry, named above as far as --max-problems allows); their warnings are in the events, not on the bus",
            s.warning_frames_unsent, s.tracks_unsent
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_that_scored_nothing_says_why() {
        let foreign = Stats {
            frames: 5,
            unknown_ids: 5,
            ..Stats::default()
        };
        assert!(matches!(
            nothing_scored(&foreign, 0),
            Some(NothingScored::NothingMapped(m)) if m.contains("5 have ids the map does not read on their interface)")
        ));
        let ego_only = Stats {
            frames: 5,
            decoded: 5,
            ..Stats::default()
        };
        assert!(matches!(
            nothing_scored(&ego_only, 0),
            Some(NothingScored::NoUpdate(m)) if m.contains("5 mapped messages decoded")
        ));
        let objects_on_another_bus = Stats {
            frames: 5,
            decoded: 2,
            unknown_ids: 3,
            unknown_other_bus: 3,
            ..Stats::default()
        };
        // Before: NoUpdate, a note with exit 0 and the old outputs emptied.
        assert!(matches!(
            nothing_scored(&objects_on_another_bus, 0),
            Some(NothingScored::NothingMapped(m)) if m.contains("(0 invalid objects, 0 stale drops, 0 awaiting motion, 0 outside the view); 3 frames are messages the map reads on another bus: the log's interface names do not match")
        ));
        let scored = Stats {
            frames: 5,
            decoded: 5,
            scored: 1,
            ..Stats::default()
        };
        assert_eq!(nothing_scored(&scored, 0), None);
        assert!(matches!(
            nothing_scored(&Stats::default(), 0),
            Some(NothingScored::NothingMapped(m)) if m.contains("no CAN data frame")
        ));
        assert!(matches!(
            nothing_scored(&Stats::default(), 3),
            Some(NothingScored::NothingMapped(m)) if m.contains("(3 unreadable lines (listed above)")
        ));
    }
}
