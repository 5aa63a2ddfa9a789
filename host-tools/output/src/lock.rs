//! One writer per output: an advisory lock (`flock`, through std's `File::try_lock`) on a lock
//! file `.NAME.lock` beside the target. A second process asking for the same target is refused at
//! once with a clear message; the lock file is removed when the writer is done.
use std::fs::{File, OpenOptions};
use std::io;
use std::path::{Path, PathBuf};

/// Holds the lock on one output target until dropped.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    target: PathBuf,
    file: Option<File>,
    /// This process already held the lock for the run when this one was asked for (a command
    /// that locks its output before it computes, then writes it through an `OutputDir`):
    /// dropping it changes nothing.
    nested: bool,
    /// Taken with [`OutputLock::acquire_for_run`].
    for_run: bool,
    /// The folders this lock had to create for its target (`--out a/b/c.csv` with no `a/b`):
    /// removed again, when still empty, once the lock file is gone, unless the output was
    /// committed ([`OutputLock::keep_folders`]). Declared last: dropped after the lock file.
    folders: Option<crate::NewFolders>,
}

/// The lock files this process holds for a whole run ([`OutputLock::acquire_for_run`]): asking
/// again for one of them is the run's own writer, not a second one.
static HELD: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

fn held() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    HELD.lock().unwrap_or_else(|e| e.into_inner())
}

pub(crate) fn parent_of(target: &Path) -> &Path {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

pub(crate) fn hidden_name(target: &Path, suffix: &str) -> io::Result<PathBuf> {
    let name = target.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            "the output path has no file name",
        )
    })?;
    let mut n = std::ffi::OsString::from(".");
    n.push(name);
    n.push(suffix);
    Ok(parent_of(target).join(n))
}

impl OutputLock {
    /// Locks `target` for this process, or fails with `WouldBlock` when another process writes it.
    ///
    /// A missing parent folder of `target` is created (with its missing parents): every output
    /// of the layer is written that way, like `mkdir -p`. The folders made are removed again when
    /// still empty if the output is not committed (an error, Ctrl-C: see [`crate::NewFolders`]).
    pub fn acquire(target: &Path) -> io::Result<Self> {
        use std::os::unix::fs::MetadataExt;
        let path = hidden_name(target, ".lock")?;
        if held().contains(&path) {
            return Ok(Self {
                path,
                target: target.to_path_buf(),
                file: None,
                nested: true,
                for_run: false,
                folders: None,
            });
        }
        let folders = crate::folders::parent_folders(target)?;
        for _ in 0..8 {
            // Held from the open that may create the lock file to its registration.
            let mut undo = crate::cleanup::registrar();
            let file = OpenOptions::new()
                .create(true)
                .truncate(false)
                .write(true)
                .open(&path)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    return Err(io::Error::new(
                        io::ErrorKind::WouldBlock,
                        format!(
                            "another process is writing this output now (it holds {}); wait for it to finish or choose another output",
                            path.display()
                        ),
                    ))
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(e),
            }
            // The holder before us may have removed the lock file between our open and our lock:
            // only a lock on the file that is still at `path` counts.
            let ours = file.metadata()?;
            match std::fs::metadata(&path) {
                Ok(now) if now.dev() == ours.dev() && now.ino() == ours.ino() => {
                    undo.remove(&path);
                    drop(undo);
                    crate::cleanup::register_target(target);
                    return Ok(Self {
                        path,
                        target: target.to_path_buf(),
                        file: Some(file),
                        nested: false,
                        for_run: false,
                        folders,
                    });
                }
                _ => continue,
            }
        }
        Err(io::Error::new(
            io::ErrorKind::WouldBlock,
            format!("cannot take the lock {}: it keeps changing", path.display()),
        ))
    }

    /// Locks `target` for a whole run that computes before it writes: a second process is
    /// refused now rather than after both have computed. The run's own writer
    /// ([`crate::OutputDir`], [`crate::AtomicFile`]) may then take the lock again in this process.
    pub fn acquire_for_run(target: &Path) -> io::Result<Self> {
        let mut lock = Self::acquire(target)?;
        if !lock.nested {
            lock.for_run = true;
            held().push(lock.path.clone());
        }
        Ok(lock)
    }

    /// Leaves this lock's target out of the interrupt message ("... left as it was"): for a run
    /// lock on a name that is no output of its own (the demo's `--out/.demo.lock`).
    pub fn not_an_output(self) -> Self {
        crate::cleanup::unregister_target(&self.target);
        self
    }

    /// The output was committed: the folders made for it stay.
    pub(crate) fn keep_folders(&mut self) {
        if let Some(f) = self.folders.take() {
            f.keep();
        }
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        if self.nested {
            return;
        }
        if self.for_run {
            held().retain(|p| p != &self.path);
        }
        // Removed while still locked, so a waiting process re-opens a fresh file (see acquire).
        let _ = std::fs::remove_file(&self.path);
        crate::cleanup::unregister(&self.path);
        crate::cleanup::unregister_target(&self.target);
        drop(self.file.take());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_writer_is_refused_and_the_lock_file_goes_away() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("out.csv");
        // Another process's lock: the same file locked through another open file description.
        let other = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(d.path().join(".out.csv.lock"))
            .unwrap();
        other.try_lock().unwrap();
        let e = OutputLock::acquire(&target).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::WouldBlock);
        assert!(e.to_string().contains("another process"), "{e}");
        drop(other);
        std::fs::remove_file(d.path().join(".out.csv.lock")).unwrap();
        // In this process, too, unless the lock was taken for the run.
        let first = OutputLock::acquire(&target).unwrap();
        assert!(OutputLock::acquire(&target).is_err());
        drop(first);
        let again = OutputLock::acquire(&target).unwrap();
        drop(again);
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
    }

    #[test]
    fn the_holder_may_ask_again_and_keeps_the_lock_until_its_first_is_dropped() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("report");
        assert!(OutputLock::acquire(&target).is_ok());
        let first = OutputLock::acquire_for_run(&target).unwrap();
        let inner = OutputLock::acquire(&target).unwrap();
        drop(inner);
        // Still locked: another writer (here, another open file description) is refused.
        let other = OpenOptions::new()
            .write(true)
            .open(d.path().join(".report.lock"))
            .unwrap();
        assert!(other.try_lock().is_err());
        drop(first);
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
    }
}
