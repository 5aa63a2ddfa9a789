//! From scoring options to an engine's parts: the DBC files as one database, the compiled map, the
//! warning configuration, the files a run reads and writes, and the lines it prints about them.
use super::ScoringArgs;
use crate::engine::{EngineConfig, Stats};
use crate::events_out::{EventWriter, Sink};
use crate::map::{CompiledMap, MapError, MapFile, DEFAULT_MAP};
use crate::model_file::{ModelFile, ModelFileError};
use can_codec::{CanId, Database, DbcError, DbcFileError};
use riskscore_output::{AtomicFile, NamedPath};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The project DBC, compiled in, as a `--dbc` argument.
pub const BUILTIN_DBC: &str = "builtin:riskscore";

/// A scoring command's inputs could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("project DBC")]
    ProjectDbc(#[source] DbcError),
    #[error(transparent)]
    DbcFile(#[from] DbcFileError),
    #[error(
        "message id 0x{id} is defined twice: `{first}` in {first_file} and `{second}` in {second_file}"
    )]
    DuplicateId {
        id: CanId,
        first: String,
        first_file: String,
        second: String,
        second_file: String,
    },
    #[error("message id 0x{0} is defined twice")]
    Merge(CanId),
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
    #[error("--threshold must be finite")]
    Threshold,
    #[error("creating {path}")]
    Create {
        path: String,
        #[source]
        cause: std::io::Error,
    },
}

/// A file could not be created.
pub fn creating(path: &Path) -> impl FnOnce(std::io::Error) -> SetupError + '_ {
    move |cause| SetupError::Create {
        path: path.display().to_string(),
        cause,
    }
}

/// Every `--dbc` file as one database; an id defined in two files names both.
pub fn load_dbcs(paths: &[PathBuf]) -> Result<Database, SetupError> {
    let builtin = [PathBuf::from(BUILTIN_DBC)];
    let paths = if paths.is_empty() {
        &builtin[..]
    } else {
        paths
    };
    let mut db = Database::default();
    let mut origin: HashMap<CanId, (String, &PathBuf)> = HashMap::new();
    for p in paths {
        let one = if p.as_os_str() == BUILTIN_DBC {
            Database::parse(can_codec::project::PROJECT_DBC).map_err(SetupError::ProjectDbc)?
        } else {
            Database::load(p)?
        };
        for m in &one.messages {
            if let Some((name, first)) = origin.get(&m.id) {
                return Err(SetupError::DuplicateId {
                    id: m.id,
                    first: name.clone(),
                    first_file: first.display().to_string(),
                    second: m.name.clone(),
                    second_file: p.display().to_string(),
                });
            }
        }
        for m in &one.messages {
            origin.insert(m.id, (m.name.clone(), p));
        }
        db.merge(one).map_err(SetupError::Merge)?;
    }
    Ok(db)
}

/// The map of `--map` (or the project's) compiled against the `--dbc` files.
pub fn load_map(args: &ScoringArgs) -> Result<CompiledMap, SetupError> {
    let db = load_dbcs(&args.dbc)?;
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
    CompiledMap::compile(&map, &db).map_err(|cause| SetupError::Compile {
        map: args
            .map
            .as_ref()
            .map_or("(default)".into(), |p| p.display().to_string()),
        dbc: if args.dbc.is_empty() {
            "(project)".to_string()
        } else {
            args.dbc
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(" + ")
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
        return Err(SetupError::Threshold);
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
    let out = match path {
        Some(p) if atomic => Sink::Atomic(AtomicFile::create(p).map_err(creating(p))?),
        Some(p) => Sink::Streaming(std::io::BufWriter::new(
            std::fs::File::create(p).map_err(creating(p))?,
        )),
        None => Sink::Stdout(std::io::stdout()),
    };
    Ok(EventWriter::new(out, all_scores))
}

/// The files a scoring command reads, named by their option.
pub fn scoring_inputs(args: &ScoringArgs) -> Vec<NamedPath<'_>> {
    let mut v: Vec<NamedPath<'_>> = vec![("--model", args.model.as_path())];
    for p in args.dbc.iter().filter(|p| p.as_os_str() != BUILTIN_DBC) {
        v.push(("--dbc", p.as_path()));
    }
    if let Some(p) = &args.map {
        v.push(("--map", p.as_path()));
    }
    v
}

/// The closing counters of a run, as one line.
pub fn summary(s: &Stats) -> String {
    format!(
        "{} frames, {} scored, {} warning frames, {} unsent, {} decode errors, {} stale drops, {} invalid objects, {} reordered, {} off the timeline, {} log segments, {} duplicates, {} unknown ids, {} remote, {} error frames ({} bus-off), {} tracks dropped, {} table full, {} new objects, {} awaiting motion",
        s.frames, s.scored, s.warning_frames, s.warning_frames_unsent, s.decode_errors, s.stale_drops, s.invalid_objects,
        s.reordered, s.out_of_window, s.segments + 1, s.duplicates, s.unknown_ids, s.remote_frames,
        s.error_frames, s.bus_off, s.tracks_dropped, s.table_full, s.new_objects, s.motion_pending
    )
}

/// The run-end line about warnings that never reached the bus, if any did not.
pub fn unsent_note(s: &Stats, map: &CompiledMap) -> Option<String> {
    (s.warning_frames_unsent > 0).then(|| {
        let signal = &map.warning.spec.signals[map.warning.track_id].name;
        format!(
            "{} warning frames NOT SENT ({} tracks with ids the warning message's {signal} cannot carry, each named above); their warnings are in the events, not on the bus",
            s.warning_frames_unsent, s.tracks_unsent
        )
    })
}
