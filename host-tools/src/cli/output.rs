//! Where a subcommand's table goes: a file (written to `<FILE>.partial`, renamed when complete,
//! removed on error), a device or pipe (written directly), or standard output for `-`.
use anyhow::Context;
use riskscore_output::is_special_file;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// `-` names standard input or output.
pub fn is_dash(p: &Path) -> bool {
    p.as_os_str() == "-"
}

/// Run `write` on the output named by `path`. `Ok(None)`: standard output was closed by its
/// reader (`| head`), which a filter treats as a normal end.
pub fn write_output<T>(
    path: &Path,
    write: impl FnOnce(Box<dyn Write + Send>) -> anyhow::Result<T>,
) -> anyhow::Result<Option<T>> {
    if is_dash(path) {
        return match write(Box::new(BufWriter::with_capacity(
            1 << 16,
            std::io::stdout(),
        ))) {
            Ok(v) => Ok(Some(v)),
            Err(e) if is_broken_pipe(&e) => Ok(None),
            Err(e) => Err(e),
        };
    }
    if is_special_file(path) {
        // A device or pipe (e.g. /dev/null): write straight into it, nothing to rename.
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .with_context(|| format!("cannot open output {}", path.display()))?;
        return write(Box::new(BufWriter::with_capacity(1 << 16, file))).map(Some);
    }
    let partial = partial_path(path);
    let file = File::create(&partial)
        .with_context(|| format!("cannot create output {}", partial.display()))?;
    match write(Box::new(BufWriter::with_capacity(1 << 16, file))) {
        Ok(v) => {
            std::fs::rename(&partial, path).with_context(|| {
                format!("cannot move {} to {}", partial.display(), path.display())
            })?;
            Ok(Some(v))
        }
        Err(e) => {
            // Never leave a half-written file that looks like a result.
            let _ = std::fs::remove_file(&partial);
            Err(e)
        }
    }
}

/// True when the error comes from writing to a closed pipe.
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// `<output>.partial` next to the output file.
fn partial_path(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

/// Writes `bytes` to `path` through a temporary file renamed into place when complete: a failed
/// run leaves the old file as it was.
pub fn write_file_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let mut out = riskscore_output::AtomicFile::create(path)
        .with_context(|| format!("{}: cannot create", path.display()))?;
    out.write_all(bytes)
        .and_then(|()| out.commit())
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// Refuses `outputs` that are, or overwrite, a `--model` file or the `--events` folder's files.
pub fn refuse_overwriting_inputs(
    models: &[riskscore_eval::model_files::ModelFile],
    events: &Path,
    outputs: &[(&str, &Path)],
) -> anyhow::Result<()> {
    let event_files = [
        events.join(riskscore_data::events::EVENTS_FILE),
        events.join(riskscore_data::events::FRAMES_FILE),
    ];
    let mut inputs: Vec<(&str, &Path)> = models
        .iter()
        .map(|m| ("--model", m.path.as_path()))
        .collect();
    inputs.extend(event_files.iter().map(|p| ("--events", p.as_path())));
    riskscore_output::refuse_overlaps(&inputs, outputs)?;
    Ok(())
}
