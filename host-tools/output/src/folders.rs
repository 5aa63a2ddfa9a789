//! Folders an output needs, created for one run and removed again (when still empty) if the run
//! does not complete: a failed run into a new folder leaves no empty folder behind.
use std::io;
use std::path::{Path, PathBuf};

/// The folders [`NewFolders::create`] had to make, deepest first. Dropped without
/// [`NewFolders::keep`] (an error, Ctrl-C through the signal handler), each is removed if it is
/// still empty; folders that existed before are never touched.
#[derive(Debug)]
pub struct NewFolders {
    created: Vec<PathBuf>,
}

impl NewFolders {
    /// Creates `dir` and its missing parents, remembering which were missing.
    pub fn create(dir: &Path) -> io::Result<Self> {
        crate::overlap::refuse_dash_folder(dir)?;
        let missing: Vec<PathBuf> = dir
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && std::fs::symlink_metadata(a).is_err())
            .map(Path::to_path_buf)
            .collect();
        let mut undo = crate::cleanup::registrar();
        std::fs::create_dir_all(dir)?;
        // Shallowest first, so the signal handler (newest first) empties the deepest first.
        for m in missing.iter().rev() {
            undo.remove_empty_folder(m);
        }
        Ok(Self { created: missing })
    }

    /// The run completed: the folders stay.
    pub fn keep(mut self) {
        for d in self.created.drain(..) {
            crate::cleanup::unregister_empty_folder(&d);
        }
    }
}

impl Drop for NewFolders {
    fn drop(&mut self) {
        for d in self.created.drain(..) {
            let _ = std::fs::remove_dir(&d);
            crate::cleanup::unregister_empty_folder(&d);
        }
    }
}

/// Creates the missing parent folders of the output `target` for one run (see [`NewFolders`]);
/// `None` when there was nothing to create. The error names the folder.
pub(crate) fn parent_folders(target: &Path) -> io::Result<Option<NewFolders>> {
    let parent = crate::lock::parent_of(target);
    if parent.is_dir() {
        return Ok(None);
    }
    NewFolders::create(parent).map(Some).map_err(|e| {
        io::Error::new(
            e.kind(),
            format!("cannot create the folder {}: {e}", parent.display()),
        )
    })
}

/// Creates (or truncates) `path` for a live capture written as it goes (`can-bridge monitor
/// --out`, `live --events-out`): not through a temporary, so it can be followed while it grows.
/// Its missing parent folders are made like every other output's (and removed again if the file
/// cannot be created); the error names the folder or the file.
pub fn create_live_file(path: &Path) -> io::Result<std::fs::File> {
    let folders = parent_folders(path)?;
    let file = std::fs::File::create(path)?;
    if let Some(f) = folders {
        f.keep();
    }
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_made_for_a_failed_run_go_and_old_ones_stay() {
        let d = tempfile::tempdir().unwrap();
        let deep = d.path().join("a/b/c");
        drop(NewFolders::create(&deep).unwrap());
        assert!(!d.path().join("a").exists(), "new folders left");
        std::fs::create_dir(d.path().join("a")).unwrap();
        {
            let f = NewFolders::create(&deep).unwrap();
            // Something the run did not make keeps its folder.
            std::fs::write(d.path().join("a/b/mine"), "x").unwrap();
            drop(f);
        }
        assert!(!deep.exists());
        assert!(d.path().join("a/b/mine").exists());
        NewFolders::create(&d.path().join("k/l")).unwrap().keep();
        assert!(d.path().join("k/l").is_dir());
    }

    #[test]
    fn a_live_capture_gets_its_folders_and_a_failed_one_leaves_none() {
        let d = tempfile::tempdir().unwrap();
        create_live_file(&d.path().join("m/n/cap.log")).unwrap();
        assert!(d.path().join("m/n/cap.log").is_file());
        // A file in the way of a folder: refused, naming the folder.
        let e = create_live_file(&d.path().join("m/n/cap.log/x/y.log")).unwrap_err();
        assert!(e.to_string().contains("cap.log/x"), "{e}");
        // The folders are made but the file cannot be (its name is too long): they go again.
        let long = "z".repeat(300);
        assert!(create_live_file(&d.path().join("r/s").join(long)).is_err());
        assert!(!d.path().join("r").exists(), "new folders left");
    }
}
