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
    pub fn acquire(target: &Path) -> io::Result<Self> {
        use std::os::unix::fs::MetadataExt;
        let path = hidden_name(target, ".lock")?;
        for _ in 0..8 {
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
                    crate::cleanup::register(&path);
                    crate::cleanup::register_target(target);
                    return Ok(Self {
                        path,
                        target: target.to_path_buf(),
                        file: Some(file),
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
}

impl Drop for OutputLock {
    fn drop(&mut self) {
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
        let first = OutputLock::acquire(&target).unwrap();
        let e = OutputLock::acquire(&target).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::WouldBlock);
        assert!(e.to_string().contains("another process"), "{e}");
        drop(first);
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
        let again = OutputLock::acquire(&target).unwrap();
        drop(again);
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
    }
}
