//! Writing output files without ever destroying input data: every output is written to a
//! temporary file next to its destination and renamed over it only when the run succeeded, and
//! an output path that names one of the run's inputs is refused before anything is opened.
//!
//! Used by every command that writes files (`can-bridge score-log`/`check`, `riskctl
//! events-to-candump`/`evaluate`), so the rules are the same everywhere. Limitations: the
//! same-file test compares device and inode on Unix (symlinks and hard links are seen through);
//! elsewhere it compares canonical paths.
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// An output path that would overwrite one of the inputs (or another output).
#[derive(Debug, thiserror::Error)]
#[error("{output_flag} {} is the same file as {input_flag} {}: refusing to overwrite it", output.display(), input.display())]
pub struct SamePathError {
    pub output_flag: String,
    pub output: PathBuf,
    pub input_flag: String,
    pub input: PathBuf,
}

/// `(flag, path)` of a file a command reads or writes, e.g. `("--log", drive.log)`.
pub type NamedPath<'a> = (&'a str, &'a Path);

fn same_existing_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        matches!(
            (a.canonicalize(), b.canonicalize()),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

/// The path with its parent directory canonicalised (the file itself need not exist), for
/// comparing two outputs that are not written yet.
fn normalised(p: &Path) -> PathBuf {
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let parent = parent.canonicalize().unwrap_or(parent);
    match p.file_name() {
        Some(name) => parent.join(name),
        None => parent,
    }
}

/// Refuses when an output names the same file as an input, or two outputs name the same file.
/// Directory inputs and outputs (event folders) are passed as the files inside them. An output
/// that is a device or pipe (`/dev/null`, `/dev/stdout`) is not checked: writing to it destroys
/// nothing, and two outputs may well share it.
pub fn refuse_overlaps(
    inputs: &[NamedPath<'_>],
    outputs: &[NamedPath<'_>],
) -> Result<(), SamePathError> {
    let err = |o: &NamedPath<'_>, i: &NamedPath<'_>| SamePathError {
        output_flag: o.0.to_string(),
        output: o.1.to_path_buf(),
        input_flag: i.0.to_string(),
        input: i.1.to_path_buf(),
    };
    for (n, o) in outputs.iter().enumerate() {
        if is_special_file(o.1) {
            continue;
        }
        for i in inputs {
            if same_existing_file(o.1, i.1) || normalised(o.1) == normalised(i.1) {
                return Err(err(o, i));
            }
        }
        for other in &outputs[..n] {
            if normalised(o.1) == normalised(other.1) || same_existing_file(o.1, other.1) {
                return Err(err(o, other));
            }
        }
    }
    Ok(())
}

/// A file written under a temporary name in the destination's directory and renamed over the
/// destination by [`AtomicFile::commit`]. Dropped without `commit` (an error, a panic), the
/// temporary file is removed and the destination is untouched.
///
/// A destination that exists and is not a regular file (`/dev/null`, a FIFO, a terminal) is
/// written directly: renaming a file over a device would replace the device itself.
pub struct AtomicFile {
    /// Open while being written; `None` once flushed and synced.
    file: Option<io::BufWriter<File>>,
    /// The temporary file; `None` when the destination is written directly.
    tmp: Option<PathBuf>,
    dest: PathBuf,
    /// In place (renamed, or written directly and flushed): nothing to clean up.
    done: bool,
}

/// True when `path` exists and is neither a regular file nor a directory (a device, FIFO or
/// socket: written directly, never renamed over).
pub fn is_special_file(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

impl AtomicFile {
    /// Creates the temporary file `.NAME.tmp-PID` next to `dest` (or opens `dest` itself when it
    /// is a device or pipe).
    pub fn create(dest: &Path) -> io::Result<Self> {
        let (file, tmp) = if is_special_file(dest) {
            (std::fs::OpenOptions::new().write(true).open(dest)?, None)
        } else {
            let name = dest.file_name().ok_or_else(|| {
                io::Error::new(io::ErrorKind::InvalidInput, "output path has no file name")
            })?;
            let mut tmp_name = std::ffi::OsString::from(".");
            tmp_name.push(name);
            tmp_name.push(format!(".tmp-{}", std::process::id()));
            let tmp = dest.with_file_name(tmp_name);
            (File::create(&tmp)?, Some(tmp))
        };
        Ok(Self {
            file: Some(io::BufWriter::with_capacity(1 << 16, file)),
            tmp,
            dest: dest.to_path_buf(),
            done: false,
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.dest
    }

    /// Flushes and syncs the temporary file (flushes a direct destination).
    fn sync(&mut self) -> io::Result<()> {
        if let Some(w) = self.file.take() {
            let file = w.into_inner().map_err(|e| e.into_error())?;
            if self.tmp.is_some() {
                file.sync_all()?;
            }
        }
        Ok(())
    }

    /// Renames the synced temporary file over the destination.
    fn rename_into_place(&mut self) -> io::Result<()> {
        if let Some(tmp) = &self.tmp {
            std::fs::rename(tmp, &self.dest)?;
        }
        self.done = true;
        Ok(())
    }

    /// Flushes, syncs and renames the temporary file over the destination.
    pub fn commit(mut self) -> io::Result<()> {
        self.sync()?;
        self.rename_into_place()
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.as_mut().expect("open").write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.file.as_mut().expect("open").write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.file.as_mut().expect("open").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.done {
            if let Some(tmp) = &self.tmp {
                let _ = std::fs::remove_file(tmp);
            }
        }
    }
}

/// Several outputs of one run (a report folder), each an [`AtomicFile`], renamed into place
/// together by [`AtomicSet::commit`] only after every one was written and synced. Dropped without
/// `commit`, every temporary file is removed and no destination changes. Limitation: the renames
/// are one per file, so a rename failing half-way (a destination turned into a directory, a
/// permission changed during the run) can leave some files new and some old; each file is still
/// whole.
#[derive(Default)]
pub struct AtomicSet {
    files: Vec<AtomicFile>,
}

impl AtomicSet {
    /// Starts the output `dest` (see [`AtomicFile::create`]).
    pub fn create(&mut self, dest: &Path) -> io::Result<&mut AtomicFile> {
        self.files.push(AtomicFile::create(dest)?);
        Ok(self.files.last_mut().expect("just pushed"))
    }

    /// Syncs every file, then renames each over its destination; returns the destinations.
    pub fn commit(mut self) -> io::Result<Vec<PathBuf>> {
        for f in &mut self.files {
            // On error `self` is dropped: every temporary file is removed.
            f.sync()?;
        }
        let mut done = Vec::with_capacity(self.files.len());
        let mut first_error = None;
        for f in &mut self.files {
            match f.rename_into_place() {
                Ok(()) => done.push(f.dest.clone()),
                Err(e) => {
                    first_error.get_or_insert(io::Error::new(
                        e.kind(),
                        format!("{}: {e}", f.dest.display()),
                    ));
                }
            }
        }
        match first_error {
            Some(e) => Err(e),
            None => Ok(done),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("can-codec-output-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn commit_replaces_and_drop_leaves_the_destination_untouched() {
        let d = tmpdir("commit");
        let dest = d.join("out.log");
        std::fs::write(&dest, "old").unwrap();
        {
            let mut f = AtomicFile::create(&dest).unwrap();
            f.write_all(b"half").unwrap();
            // dropped: a failed run
        }
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        assert_eq!(
            std::fs::read_dir(&d).unwrap().count(),
            1,
            "temporary file left behind"
        );
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "new");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
    }

    #[test]
    fn overlapping_paths_are_refused_through_links_and_dots() {
        let d = tmpdir("overlap");
        let input = d.join("drive.log");
        std::fs::write(&input, "x").unwrap();
        let dotted = d.join(".").join("drive.log");
        let e = refuse_overlaps(&[("--log", &input)], &[("--events-out", &dotted)]).unwrap_err();
        assert!(e.to_string().contains("--events-out"), "{e}");
        #[cfg(unix)]
        {
            let link = d.join("link.log");
            std::os::unix::fs::symlink(&input, &link).unwrap();
            assert!(refuse_overlaps(&[("--log", &input)], &[("--out", &link)]).is_err());
        }
        let a = d.join("a.jsonl");
        assert!(refuse_overlaps(&[], &[("--events-out", &a), ("--warnings-out", &a)]).is_err());
        let b = d.join("b.jsonl");
        assert!(refuse_overlaps(
            &[("--log", &input)],
            &[("--events-out", &a), ("--warnings-out", &b)]
        )
        .is_ok());
    }

    #[test]
    fn a_set_changes_nothing_until_every_file_is_committed() {
        let d = tmpdir("set");
        let (a, b) = (d.join("a.csv"), d.join("b.png"));
        std::fs::write(&a, "old a").unwrap();
        {
            let mut set = AtomicSet::default();
            set.create(&a).unwrap().write_all(b"new a").unwrap();
            set.create(&b).unwrap().write_all(b"new b").unwrap();
            // dropped: the run failed after writing both
        }
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
        assert!(!b.exists());
        assert_eq!(
            std::fs::read_dir(&d).unwrap().count(),
            1,
            "temporary files left"
        );
        let mut set = AtomicSet::default();
        set.create(&a).unwrap().write_all(b"new a").unwrap();
        set.create(&b).unwrap().write_all(b"new b").unwrap();
        assert_eq!(set.commit().unwrap(), vec![a.clone(), b.clone()]);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 2);
    }

    #[cfg(unix)]
    #[test]
    fn a_device_is_written_directly_and_never_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        if !std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
            return; // not a sane /dev/null to begin with; nothing to check here
        }
        let mut f = AtomicFile::create(null).unwrap();
        f.write_all(b"discarded").unwrap();
        f.commit().unwrap();
        let mut set = AtomicSet::default();
        set.create(null).unwrap().write_all(b"discarded").unwrap();
        assert_eq!(set.commit().unwrap(), vec![null.to_path_buf()]);
        // Two outputs may share a device.
        assert!(refuse_overlaps(&[], &[("--events-out", null), ("--warnings-out", null)]).is_ok());
        let m = std::fs::metadata(null).unwrap();
        assert!(m.file_type().is_char_device(), "/dev/null was replaced");
    }
}
