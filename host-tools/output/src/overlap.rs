//! Refusing an output that is, contains, or lies inside one of the run's inputs.
use std::path::{Path, PathBuf};

/// How an output overlaps an input (or another output).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Overlap {
    /// The same file (through a link, `./x` vs `x`, a hard link).
    Same,
    /// The output is a folder that holds the input.
    Contains,
    /// The output would be written inside the input folder.
    Inside,
}

/// An output path that would overwrite, replace or write into one of the inputs (or another
/// output).
#[derive(Debug, thiserror::Error)]
#[error("{output_flag} {} {} {input_flag} {}: {}", output.display(), self.verb(), input.display(), self.refusal())]
pub struct SamePathError {
    pub output_flag: String,
    pub output: PathBuf,
    pub input_flag: String,
    pub input: PathBuf,
    pub overlap: Overlap,
}

impl SamePathError {
    fn verb(&self) -> &'static str {
        match self.overlap {
            Overlap::Same => "is the same file as",
            Overlap::Contains => "contains",
            Overlap::Inside => "lies inside",
        }
    }
    fn refusal(&self) -> &'static str {
        match self.overlap {
            Overlap::Same => "refusing to overwrite it",
            Overlap::Contains => "refusing to replace it",
            Overlap::Inside => "refusing to write into an input",
        }
    }
}

/// `(flag, path)` of a file a command reads or writes, e.g. `("--log", drive.log)`.
pub type NamedPath<'a> = (&'a str, &'a Path);

type FileId = (u64, u64);

fn file_id(p: &Path) -> Option<FileId> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

fn or_dot(p: &Path) -> &Path {
    if p.as_os_str().is_empty() {
        Path::new(".")
    } else {
        p
    }
}

/// The ids of `p` (when it exists) and of every folder above it, found through the deepest
/// existing ancestor made canonical (so `..` and symlinks are resolved, not read lexically).
fn chain(p: &Path) -> Vec<FileId> {
    let mut ids = Vec::new();
    let Some(existing) = p.ancestors().map(or_dot).find(|a| a.exists()) else {
        return ids;
    };
    let Ok(real) = existing.canonicalize() else {
        return ids;
    };
    ids.extend(real.ancestors().filter_map(file_id));
    ids
}

/// The path with its parent directory canonicalised (the file itself need not exist), for
/// comparing paths that are not written yet.
fn normalised(p: &Path) -> PathBuf {
    let parent = or_dot(p.parent().unwrap_or(Path::new("."))).to_path_buf();
    let parent = parent.canonicalize().unwrap_or(parent);
    match p.file_name() {
        Some(name) => parent.join(name),
        None => parent,
    }
}

fn overlap(output: &Path, input: &Path) -> Option<Overlap> {
    if normalised(output) == normalised(input) {
        return Some(Overlap::Same);
    }
    let input_id = file_id(input)?;
    let output_id = file_id(output);
    if output_id == Some(input_id) {
        return Some(Overlap::Same);
    }
    if chain(output).contains(&input_id) {
        return Some(Overlap::Inside);
    }
    if let Some(o) = output_id {
        if chain(input).contains(&o) {
            return Some(Overlap::Contains);
        }
    }
    None
}

/// `p` absolute, with its existing part made canonical (links and `..` resolved) and the rest
/// appended as written (`.` and `..` there taken lexically: nothing below exists to link).
fn resolved(p: &Path) -> PathBuf {
    let absolute = std::env::current_dir().map_or_else(|_| p.to_path_buf(), |d| d.join(p));
    let existing = absolute
        .ancestors()
        .find(|a| a.exists())
        .unwrap_or(Path::new("/"));
    let mut out = existing
        .canonicalize()
        .unwrap_or_else(|_| existing.to_path_buf());
    for part in absolute.strip_prefix(existing).unwrap_or(Path::new("")) {
        match part.to_str() {
            Some(".") => {}
            Some("..") => {
                out.pop();
            }
            _ => out.push(part),
        }
    }
    out
}

/// `-` given as a path: standard input or output, by the command-line convention.
pub fn is_dash(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Refuses `-` as a folder to write: by the command-line convention it is standard output,
/// which cannot hold a folder (a folder of that name is `./-`).
pub fn refuse_dash_folder(target: &Path) -> std::io::Result<()> {
    if is_dash(target) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "`-` (standard output) cannot hold a folder; write `./-` for a folder of that name",
        ));
    }
    Ok(())
}

/// True when `path` is `folder` or lies below it, whether or not either exists yet: for an output
/// inside a folder the run will create whole, which the inode comparison of [`refuse_overlaps`]
/// cannot see before the folder exists.
pub fn lies_within(path: &Path, folder: &Path) -> bool {
    resolved(path).starts_with(resolved(folder))
}

/// True when `path` exists and is neither a regular file nor a directory (a device, FIFO or
/// socket: written directly, never renamed over), or names an open file descriptor
/// (`/dev/stdout`, `/dev/fd/N`, `/proc/self/fd/N`) whatever it is open on: with standard output
/// redirected to a file, renaming over `/dev/stdout` would replace the link in `/dev` itself.
pub fn is_special_file(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) || names_a_descriptor(path)
}

/// True when `path`, or a symbolic link on its way, is a descriptor link of `/proc` or `/dev/fd`.
fn names_a_descriptor(path: &Path) -> bool {
    let is_fd_link = |p: &Path| {
        let parts: Vec<&str> = p
            .components()
            .map(|c| c.as_os_str().to_str().unwrap_or(""))
            .collect();
        matches!(
            parts.as_slice(),
            ["/", "dev", "fd", _] | ["/", "proc", _, "fd", _]
        )
    };
    let mut p = path.to_path_buf();
    // A chain of links, as far as the kernel follows one.
    for _ in 0..40 {
        if is_fd_link(&p) {
            return true;
        }
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => match std::fs::read_link(&p) {
                Ok(next) => p = p.parent().unwrap_or(Path::new("/")).join(next),
                Err(_) => return false,
            },
            _ => return false,
        }
    }
    false
}

/// Refuses, before anything is read or written, an output that is, contains or lies inside an
/// input (compared by device and inode, so symlinks, hard links and `./x` vs `x` count), and two
/// outputs that name the same file. An output that is a device or pipe (`/dev/null`) or `-` is
/// not checked: writing to it destroys nothing, and two outputs may share it.
pub fn refuse_overlaps(
    inputs: &[NamedPath<'_>],
    outputs: &[NamedPath<'_>],
) -> Result<(), SamePathError> {
    let err = |o: &NamedPath<'_>, i: &NamedPath<'_>, overlap| SamePathError {
        output_flag: o.0.to_string(),
        output: o.1.to_path_buf(),
        input_flag: i.0.to_string(),
        input: i.1.to_path_buf(),
        overlap,
    };
    for (n, o) in outputs.iter().enumerate() {
        if is_special_file(o.1) || is_dash(o.1) {
            continue;
        }
        for i in inputs {
            if is_dash(i.1) || is_special_file(i.1) {
                continue;
            }
            if let Some(kind) = overlap(o.1, i.1) {
                return Err(err(o, i, kind));
            }
        }
        for other in &outputs[..n] {
            if is_dash(other.1) {
                continue;
            }
            if normalised(o.1) == normalised(other.1)
                || file_id(o.1).is_some() && file_id(o.1) == file_id(other.1)
            {
                return Err(err(o, other, Overlap::Same));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lies_within_sees_folders_that_do_not_exist_yet_through_links_and_dots() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("out");
        let report = out.join("report");
        // Neither exists: compared as written, `.` and `..` taken lexically.
        assert!(lies_within(&report.join("rows.csv"), &report));
        assert!(lies_within(&out.join("x/../report/./rows.csv"), &report));
        assert!(!lies_within(&out.join("rows.csv"), &report));
        assert!(!lies_within(&out.join("report-2/rows.csv"), &report));
        // A link to the parent leads into the folder to be created.
        std::fs::create_dir(&out).unwrap();
        std::os::unix::fs::symlink(&out, d.path().join("link")).unwrap();
        assert!(lies_within(&d.path().join("link/report/rows.csv"), &report));
    }

    #[test]
    fn the_same_file_through_links_and_dots_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let input = d.path().join("drive.log");
        std::fs::write(&input, "x").unwrap();
        let dotted = d.path().join(".").join("drive.log");
        let e = refuse_overlaps(&[("--log", &input)], &[("--events-out", &dotted)]).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("--events-out") && msg.contains("--log"),
            "{msg}"
        );
        assert!(
            msg.contains("drive.log") && msg.contains("is the same file as"),
            "{msg}"
        );
        let link = d.path().join("link.log");
        std::os::unix::fs::symlink(&input, &link).unwrap();
        assert!(refuse_overlaps(&[("--log", &input)], &[("--out", &link)]).is_err());
        let hard = d.path().join("hard.log");
        std::fs::hard_link(&input, &hard).unwrap();
        assert!(refuse_overlaps(&[("--log", &input)], &[("--out", &hard)]).is_err());
        let (a, b) = (d.path().join("a.jsonl"), d.path().join("b.jsonl"));
        assert!(refuse_overlaps(&[], &[("--events-out", &a), ("--warnings-out", &a)]).is_err());
        assert!(refuse_overlaps(
            &[("--log", &input)],
            &[("--events-out", &a), ("--warnings-out", &b)]
        )
        .is_ok());
    }

    #[test]
    fn an_output_inside_or_around_an_input_folder_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let events = d.path().join("events");
        std::fs::create_dir(&events).unwrap();
        std::fs::write(events.join("frames.csv"), "x").unwrap();
        // Inside, also when the file does not exist yet and through a symlinked folder.
        let e = refuse_overlaps(
            &[("--events", &events)],
            &[("--out", &events.join("new.csv"))],
        )
        .unwrap_err();
        assert_eq!(e.overlap, Overlap::Inside);
        assert!(e.to_string().contains("lies inside"), "{e}");
        let link = d.path().join("elink");
        std::os::unix::fs::symlink(&events, &link).unwrap();
        let deep = link.join("sub").join("x.csv");
        assert!(refuse_overlaps(&[("--events", &events)], &[("--out", &deep)]).is_err());
        // Contains: the output folder holds the input file.
        let e = refuse_overlaps(
            &[("--model", &events.join("frames.csv"))],
            &[("--out", d.path())],
        )
        .unwrap_err();
        assert_eq!(e.overlap, Overlap::Contains);
        // `..` is resolved, not read lexically: events/../other is beside events, not in it.
        let beside = events.join("..").join("other");
        assert!(refuse_overlaps(&[("--events", &events)], &[("--out", &beside)]).is_ok());
    }

    #[test]
    fn descriptor_paths_are_written_directly_whatever_they_are_open_on() {
        // This process's stdout may be a pipe or a file (under `cargo test`): either way the
        // path is never renamed over.
        for p in [
            "/dev/stdout",
            "/dev/fd/1",
            "/proc/self/fd/1",
            "/proc/self/fd/2",
        ] {
            if std::fs::metadata(p).is_ok() {
                assert!(is_special_file(Path::new(p)), "{p}");
            }
        }
        let d = tempfile::tempdir().unwrap();
        let link = d.path().join("out");
        std::os::unix::fs::symlink("/proc/self/fd/1", &link).unwrap();
        assert!(is_special_file(&link));
        std::fs::write(d.path().join("plain"), "x").unwrap();
        assert!(!is_special_file(&d.path().join("plain")));
        assert!(!is_special_file(&d.path().join("missing")));
    }

    #[test]
    fn devices_dashes_and_missing_inputs_are_not_overlaps() {
        let null = Path::new("/dev/null");
        assert!(refuse_overlaps(&[], &[("--events-out", null), ("--warnings-out", null)]).is_ok());
        assert!(
            refuse_overlaps(&[("--input", Path::new("-"))], &[("--out", Path::new("-"))]).is_ok()
        );
        let d = tempfile::tempdir().unwrap();
        let missing = d.path().join("missing");
        assert!(
            refuse_overlaps(&[("--input", &missing)], &[("--out", &d.path().join("o"))]).is_ok()
        );
    }
}
