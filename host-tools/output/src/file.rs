//! Files written under a unique temporary name beside the target, synced, and renamed into place
//! only on commit.
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use tempfile::{NamedTempFile, TempPath};

use crate::lock::{hidden_name, parent_of, OutputLock};
use crate::overlap::is_special_file;
use crate::writeback::WritebackFile;

enum Sink {
    /// A unique temporary file beside the target (`.NAME.XXXXXX.tmp`), written through its
    /// plain `File` so that an error reads as the system's (`No space left on device`), not as
    /// tempfile's, which names the temporary instead of the target. Written back to disk while
    /// it grows (see [`WritebackFile`]), so that the sync in `commit` is short.
    Temp(BufWriter<WritebackFile>, TempPath),
    /// A device or pipe, written directly.
    Direct(BufWriter<File>),
    /// Committed (or being committed).
    Closed,
}

/// A file written under a unique temporary name in the destination's folder and renamed over the
/// destination by [`AtomicFile::commit`]. Dropped without `commit` (an error, a panic), the
/// temporary file is removed and the destination is untouched. While it lives, the destination
/// is locked against a second process (see [`OutputLock`]).
///
/// A destination that exists and is not a regular file (`/dev/null`, a FIFO, a terminal) is
/// written directly: renaming a file over a device would replace the device itself.
pub struct AtomicFile {
    sink: Sink,
    tmp: Option<PathBuf>,
    dest: PathBuf,
    // Boxed: an `AtomicFile` is held in enums beside small writers (`can-bridge`'s sinks).
    _lock: Option<Box<OutputLock>>,
}

/// Why a read-only output is refused, after its name: one wording for every writer.
pub const READ_ONLY: &str = "is read-only (nobody may write it): it is left as it is; make it \
                             writable (chmod u+w) or choose another output";

/// True when `path` exists without any write permission (`chmod 444`, `555`): a user's sign that
/// it must not change. Read from the mode bits, so it holds for root too (who could write it), and
/// a symbolic link is not followed (an output replaces the link, not what it leads to). Outputs
/// are refused on it ([`AtomicFile::create`], [`crate::OutputDir::create`]); a command that
/// computes first checks its outputs with it at its start.
pub fn is_read_only(path: &Path) -> bool {
    std::fs::symlink_metadata(path)
        .is_ok_and(|m| !m.file_type().is_symlink() && m.permissions().readonly())
}

/// Opens a device, pipe or descriptor path ([`is_special_file`]) to write into it directly.
/// In append mode: a descriptor path (`/dev/fd/3` with the shell's `3>>log`) opens the file
/// again, and without it the writing would start at byte 0 of `log`, over what was there.
pub fn open_special(dest: &Path) -> io::Result<File> {
    std::fs::OpenOptions::new().append(true).open(dest)
}

/// A unique temporary file beside `dest`, registered for removal on a signal.
pub(crate) fn temp_beside(dest: &Path) -> io::Result<NamedTempFile> {
    let prefix = hidden_name(dest, ".")?;
    let prefix = prefix.file_name().unwrap_or_default().to_os_string();
    // The mode a plain `File::create` would give (0o666 less the umask), not tempfile's 0o600;
    // a file that is replaced keeps its own mode.
    let mut undo = crate::cleanup::registrar();
    let tmp = tempfile::Builder::new()
        .prefix(&prefix)
        .suffix(".tmp")
        .permissions(std::fs::Permissions::from_mode(0o666))
        .tempfile_in(parent_of(dest))?;
    undo.remove(tmp.path());
    drop(undo);
    if let Ok(old) = std::fs::metadata(dest) {
        tmp.as_file().set_permissions(old.permissions())?;
    }
    Ok(tmp)
}

impl AtomicFile {
    /// Locks `dest` and creates its temporary file (or opens `dest` itself when it is a device or
    /// pipe). Missing parent folders are created, and removed again (when still empty) if the
    /// file is not committed.
    pub fn create(dest: &Path) -> io::Result<Self> {
        if is_special_file(dest) {
            let file = open_special(dest)?;
            return Ok(Self {
                sink: Sink::Direct(BufWriter::with_capacity(1 << 16, file)),
                tmp: None,
                dest: dest.to_path_buf(),
                _lock: None,
            });
        }
        if dest.is_dir() {
            return Err(io::Error::new(
                io::ErrorKind::IsADirectory,
                "is a folder, not a file",
            ));
        }
        if is_read_only(dest) {
            // A rename replaces it whatever its mode; `cp` would refuse, and so do we.
            return Err(io::Error::new(io::ErrorKind::PermissionDenied, READ_ONLY));
        }
        let lock = OutputLock::acquire(dest)?;
        let (file, tmp) = temp_beside(dest)?.into_parts();
        Ok(Self {
            tmp: Some(tmp.to_path_buf()),
            sink: Sink::Temp(
                BufWriter::with_capacity(1 << 16, WritebackFile::new(file)),
                tmp,
            ),
            dest: dest.to_path_buf(),
            _lock: Some(Box::new(lock)),
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.dest
    }

    /// Flushes and syncs; returns the temporary file's path, still unnamed (`None` for a device).
    fn sync(&mut self) -> io::Result<Option<TempPath>> {
        match std::mem::replace(&mut self.sink, Sink::Closed) {
            Sink::Temp(w, tmp) => {
                w.into_inner().map_err(|e| e.into_error())?.finish()?;
                Ok(Some(tmp))
            }
            Sink::Direct(mut w) => {
                w.flush()?;
                Ok(None)
            }
            Sink::Closed => Ok(None),
        }
    }

    fn persist(&mut self, tmp: Option<TempPath>) -> io::Result<()> {
        if let Some(tmp) = tmp {
            // On failure the PathPersistError's path is dropped: the temporary is removed.
            tmp.persist(&self.dest).map_err(|e| e.error)?;
            if let Some(p) = self.tmp.take() {
                crate::cleanup::unregister(&p);
            }
            if let Ok(dir) = File::open(parent_of(&self.dest)) {
                let _ = dir.sync_all();
            }
            if let Some(lock) = &mut self._lock {
                lock.keep_folders();
            }
        }
        Ok(())
    }

    /// Flushes, syncs and renames the temporary file over the destination.
    pub fn commit(mut self) -> io::Result<()> {
        let tmp = self.sync()?;
        self.persist(tmp)
    }
}

fn closed() -> io::Error {
    io::Error::other("output already committed")
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.sink {
            Sink::Temp(w, _) => w.write(buf),
            Sink::Direct(w) => w.write(buf),
            Sink::Closed => Err(closed()),
        }
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match &mut self.sink {
            Sink::Temp(w, _) => w.write_all(buf),
            Sink::Direct(w) => w.write_all(buf),
            Sink::Closed => Err(closed()),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match &mut self.sink {
            Sink::Temp(w, _) => w.flush(),
            Sink::Direct(w) => w.flush(),
            Sink::Closed => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        // The TempPath (if still open) removes itself; forget its registration.
        self.sink = Sink::Closed;
        if let Some(p) = self.tmp.take() {
            let _ = std::fs::remove_file(&p);
            crate::cleanup::unregister(&p);
        }
    }
}

/// Several outputs of one run (an event folder's files), each an [`AtomicFile`], renamed into
/// place together by [`AtomicSet::commit`] only after every one was written and synced. Dropped
/// without `commit`, every temporary file is removed and no destination changes. For a folder
/// that must change as a whole, use [`crate::OutputDir`].
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

    /// Adds a file created elsewhere, so it is renamed together with the others.
    pub fn push(&mut self, file: AtomicFile) {
        self.files.push(file);
    }

    /// Syncs every file, then renames each over its destination; returns the destinations.
    pub fn commit(mut self) -> io::Result<Vec<PathBuf>> {
        let mut synced = Vec::with_capacity(self.files.len());
        for f in &mut self.files {
            // On error `self` is dropped: every temporary file is removed.
            let tmp = f
                .sync()
                .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", f.dest.display())))?;
            synced.push(tmp);
        }
        let mut done = Vec::with_capacity(self.files.len());
        for (f, tmp) in self.files.iter_mut().zip(synced) {
            f.persist(tmp)
                .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", f.dest.display())))?;
            done.push(f.dest.clone());
        }
        Ok(done)
    }
}

impl Drop for AtomicSet {
    fn drop(&mut self) {
        // Newest first: a folder the first file had to create (for all of them) is empty, and
        // removed, only once the temporaries and locks of the later files are gone.
        while let Some(f) = self.files.pop() {
            drop(f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn commit_replaces_and_drop_leaves_the_destination_untouched() {
        let d = tempfile::tempdir().unwrap();
        let dest = d.path().join("out.log");
        std::fs::write(&dest, "old").unwrap();
        {
            let mut f = AtomicFile::create(&dest).unwrap();
            f.write_all(b"half").unwrap();
            // The temporary is unique and hidden, beside the target; the target is locked.
            let n = names(d.path());
            assert_eq!(n.len(), 3, "{n:?}");
            assert!(n
                .iter()
                .any(|x| x.starts_with(".out.log.") && x.ends_with(".tmp")));
            assert!(
                AtomicFile::create(&dest).is_err(),
                "a second writer was let in"
            );
        }
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        assert_eq!(
            names(d.path()),
            ["out.log"],
            "temporary or lock left behind"
        );
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "new");
        assert_eq!(names(d.path()), ["out.log"]);
        // A replaced file keeps its mode; a new one is readable like File::create's.
        std::fs::set_permissions(&dest, std::fs::Permissions::from_mode(0o640)).unwrap();
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"newer").unwrap();
        f.commit().unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&dest), 0o640);
        let fresh = d.path().join("fresh.log");
        AtomicFile::create(&fresh).unwrap().commit().unwrap();
        assert_ne!(
            mode(&fresh) & 0o044,
            0,
            "new file is private: {:o}",
            mode(&fresh)
        );
    }

    #[test]
    fn a_target_that_cannot_hold_a_file_fails_before_writing() {
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("plain");
        std::fs::write(&file, "keep").unwrap();
        assert!(AtomicFile::create(&file.join("out.csv")).is_err());
        assert!(AtomicFile::create(d.path()).is_err());
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep");
        assert_eq!(names(d.path()), ["plain"]);
    }

    #[test]
    fn a_read_only_file_is_refused_and_left_as_it_is() {
        // A rename replaced it (mode kept) where `cp` would have refused.
        use std::os::unix::fs::PermissionsExt;
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("s.csv");
        std::fs::write(&file, "old").unwrap();
        std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o444)).unwrap();
        let e = AtomicFile::create(&file).err().expect("refused");
        assert!(e.to_string().contains("is read-only"), "{e}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "old");
        assert_eq!(names(d.path()), ["s.csv"]);
        std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o644)).unwrap();
        assert!(AtomicFile::create(&file).is_ok());
    }

    #[test]
    fn a_descriptor_path_appends_to_the_file_it_is_open_on() {
        use std::os::fd::AsRawFd;
        let d = tempfile::tempdir().unwrap();
        let log = d.path().join("log");
        std::fs::write(&log, "old\n").unwrap();
        // As the shell's `3>>log`: a descriptor open on the file, named by its /proc path.
        let held = std::fs::OpenOptions::new().append(true).open(&log).unwrap();
        let path = PathBuf::from(format!("/proc/self/fd/{}", held.as_raw_fd()));
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&log).unwrap(), "old\nnew");
        assert_eq!(names(d.path()), ["log"]);
    }

    #[test]
    fn missing_parent_folders_are_made_and_removed_again_unless_committed() {
        let d = tempfile::tempdir().unwrap();
        let dest = d.path().join("a/b/out.csv");
        {
            let mut f = AtomicFile::create(&dest).unwrap();
            f.write_all(b"half").unwrap();
            assert!(d.path().join("a/b").is_dir());
        }
        assert_eq!(names(d.path()), Vec::<String>::new(), "new folders left");
        // A set into a new folder: the folder goes with the last temporary.
        {
            let mut set = AtomicSet::default();
            set.create(&d.path().join("s/one")).unwrap();
            set.create(&d.path().join("s/two")).unwrap();
        }
        assert_eq!(names(d.path()), Vec::<String>::new(), "new folders left");
        let mut f = AtomicFile::create(&dest).unwrap();
        f.write_all(b"whole").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "whole");
        assert_eq!(names(&d.path().join("a/b")), ["out.csv"]);
        // A file where a folder is needed: refused, naming the folder; nothing made.
        let e = AtomicFile::create(&dest.join("x/y.csv")).err().unwrap();
        assert!(e.to_string().contains("a/b/out.csv/x"), "{e}");
        assert_eq!(names(&d.path().join("a/b")), ["out.csv"]);
    }

    #[test]
    fn a_set_changes_nothing_until_every_file_is_committed() {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("a.csv"), d.path().join("b.png"));
        std::fs::write(&a, "old a").unwrap();
        {
            let mut set = AtomicSet::default();
            set.create(&a).unwrap().write_all(b"new a").unwrap();
            set.create(&b).unwrap().write_all(b"new b").unwrap();
        }
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
        assert_eq!(names(d.path()), ["a.csv"]);
        let mut set = AtomicSet::default();
        set.create(&a).unwrap().write_all(b"new a").unwrap();
        set.create(&b).unwrap().write_all(b"new b").unwrap();
        assert_eq!(set.commit().unwrap(), vec![a.clone(), b.clone()]);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
        assert_eq!(names(d.path()), ["a.csv", "b.png"]);
    }

    #[test]
    fn a_device_is_written_directly_and_never_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        if !std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
            return;
        }
        let mut f = AtomicFile::create(null).unwrap();
        f.write_all(b"discarded").unwrap();
        f.commit().unwrap();
        let mut set = AtomicSet::default();
        set.create(null).unwrap().write_all(b"discarded").unwrap();
        assert_eq!(set.commit().unwrap(), vec![null.to_path_buf()]);
        assert!(std::fs::metadata(null)
            .unwrap()
            .file_type()
            .is_char_device());
    }
}
