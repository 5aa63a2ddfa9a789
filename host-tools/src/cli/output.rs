//! Where a subcommand's output goes: a file (through riskscore-output: a unique temporary beside
//! it, renamed when complete, removed on error or Ctrl-C; missing parent folders made, and removed
//! again if the run fails), a device or pipe (written directly), or standard output for `-` (the
//! command's summary then goes to stderr: [`summary`]).
use anyhow::Context;
use riskscore_output::is_special_file;
// Shared with can-bridge: one answer to "is this standard output?" and "is this a model?".
pub use riskscore_output::{
    is_dash, is_stdout, refuse_overwriting_a_model, refuse_replacing_a_non_blob,
};
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::{Arc, Mutex};

/// Run `write` on the output named by `path`: standard output for `-` (or another name of it,
/// [`is_stdout`]), a device or pipe directly, a file through a temporary renamed into place when
/// `write` succeeded (missing parent folders are made, and removed again if the run fails).
/// `Ok(None)`: standard output was closed by its reader (`| head`), which a filter treats as a
/// normal end.
pub fn write_output<T>(
    path: &Path,
    write: impl FnOnce(Box<dyn Write + Send>) -> anyhow::Result<T>,
) -> anyhow::Result<Option<T>> {
    // `-`, `/dev/stdout` or any other name of this process's standard output: written through
    // the standard output handle (its offset is the shell's: `>>` appends).
    if is_stdout(path) {
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
        let file = riskscore_output::open_special(path)
            .with_context(|| format!("cannot open output {}", path.display()))?;
        return write(Box::new(BufWriter::with_capacity(1 << 16, file))).map(Some);
    }
    // A unique temporary beside the file, locked against a second writer, renamed into place
    // only when `write` succeeded (riskscore-output).
    let file = riskscore_output::AtomicFile::create(path)
        .with_context(|| format!("cannot create output {}", path.display()))?;
    let shared = Shared(Arc::new(Mutex::new(file)));
    let v = write(Box::new(Shared(Arc::clone(&shared.0))))?;
    let file = Arc::try_unwrap(shared.0)
        .map_err(|_| anyhow::anyhow!("{}: the output is still in use", path.display()))?
        .into_inner()
        .unwrap_or_else(|e| e.into_inner());
    file.commit()
        .with_context(|| format!("cannot write output {}", path.display()))?;
    Ok(Some(v))
}

/// The output file, shared between the writer handed to the command and [`write_output`], which
/// commits it when the command is done. Its errors name the file (`out.csv: No space left on
/// device`): the commands report them as plain I/O errors.
struct Shared(Arc<Mutex<riskscore_output::AtomicFile>>);

impl Shared {
    fn with<T>(
        &self,
        f: impl FnOnce(&mut riskscore_output::AtomicFile) -> std::io::Result<T>,
    ) -> std::io::Result<T> {
        let mut file = self.0.lock().unwrap_or_else(|e| e.into_inner());
        f(&mut file)
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", file.path().display())))
    }
}

impl Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.with(|f| f.write(buf))
    }
    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.with(|f| f.write_all(buf))
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.with(|f| f.flush())
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

/// Writes `bytes` to `path` through [`write_output`]: a file through a temporary renamed into
/// place when complete (a failed run leaves the old file as it was; missing parent folders are
/// made, and removed again if the run fails), a device or pipe directly, `-` to standard output.
pub fn write_file_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    // The errors name the file already (`cannot create output X: ...`, `X: No space left`).
    write_output(path, |mut out| {
        out.write_all(bytes)?;
        out.flush()?;
        Ok(())
    })?;
    Ok(())
}

/// How a summary names the output `path`: `standard output` for `-`, else the path.
pub fn output_name(path: &Path) -> String {
    if is_dash(path) {
        "standard output".to_owned()
    } else {
        path.display().to_string()
    }
}

/// Prints a command's human-readable summary: on standard output (through
/// [`crate::cli::print_out`]), or on stderr when the data itself goes to standard output
/// ([`is_stdout`]`(out)`), so the stream there is exactly the data.
pub fn summary(out: &Path, args: std::fmt::Arguments<'_>) {
    if is_stdout(out) {
        eprint!("{args}");
    } else {
        crate::cli::print_out(args);
    }
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
    // The files first (the more precise refusal, and one may be a link), then the folder itself:
    // nothing is written into an input folder (its other files belong to the user too).
    inputs.extend(event_files.iter().map(|p| ("--events", p.as_path())));
    inputs.push(("--events", events));
    riskscore_output::refuse_overlaps(&inputs, outputs)?;
    Ok(())
}

/// How a refused run's message names an output it did not write: "OUT left as it was" when it
/// exists, "OUT not created" when it does not.
pub fn left_alone(out: &Path) -> String {
    if std::fs::symlink_metadata(out).is_ok() {
        format!("{} left as it was", out.display())
    } else {
        format!("{} not created", out.display())
    }
}

/// Refuses an output folder `out` (given with `flag`) that exists as a file, before any work:
/// the folder's files cannot be written into it (it was `File exists (os error 17)` after the
/// data had been read).
pub fn refuse_file_as_folder(flag: &str, out: &Path, writes: &str) -> anyhow::Result<()> {
    if out.exists() && !out.is_dir() {
        anyhow::bail!(
            "{flag} {}: it is a file, not a folder: {writes} are written into a folder there; \
             {}",
            out.display(),
            left_alone(out)
        );
    }
    Ok(())
}

/// Refuses `outputs` that are, contain or lie inside one of `inputs` (`-` is skipped), and a
/// read-only output ([`riskscore_output::is_read_only`]): said at the start, not when a command
/// that computes first (train, calibrate, gssm, ablation) comes to write it.
pub fn refuse(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> anyhow::Result<()> {
    riskscore_output::refuse_overlaps(inputs, outputs)?;
    if let Some((flag, out)) = outputs
        .iter()
        .find(|(_, out)| riskscore_output::is_read_only(out))
    {
        anyhow::bail!(
            "{flag} {}: it {}",
            out.display(),
            riskscore_output::READ_ONLY
        );
    }
    Ok(())
}

/// A repeatable path option's values as [`refuse_inputs_of`] takes them: `(flag, Some(path))`.
pub fn repeated<'a>(
    flag: &'a str,
    paths: &'a [std::path::PathBuf],
) -> impl Iterator<Item = (&'a str, Option<&'a Path>)> {
    paths.iter().map(move |p| (flag, Some(p.as_path())))
}

/// Refuses `outputs` that are, contain or lie inside one of the inputs: the event folders (nothing
/// is written into one; their `events.csv`/`frames.csv` are checked too, in case one is a link)
/// and the other input `files`. Absent optional inputs are skipped.
pub fn refuse_inputs_of(
    event_folders: &[(&str, Option<&Path>)],
    files: &[(&str, Option<&Path>)],
    outputs: &[(&str, &Path)],
) -> anyhow::Result<()> {
    let mut owned: Vec<(&str, std::path::PathBuf)> = Vec::new();
    for (flag, dir) in event_folders {
        if let Some(dir) = dir {
            owned.push((flag, dir.join(riskscore_data::events::EVENTS_FILE)));
            owned.push((flag, dir.join(riskscore_data::events::FRAMES_FILE)));
        }
    }
    // After the files, whose refusal is the more precise one.
    for (flag, dir) in event_folders {
        if let Some(dir) = dir {
            owned.push((flag, dir.to_path_buf()));
        }
    }
    for (flag, file) in files {
        if let Some(file) = file {
            owned.push((flag, file.to_path_buf()));
        }
    }
    let inputs: Vec<(&str, &Path)> = owned.iter().map(|(f, p)| (*f, p.as_path())).collect();
    refuse(&inputs, outputs)
}
