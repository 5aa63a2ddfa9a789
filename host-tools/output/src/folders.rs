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
        let missing: Vec<PathBuf> = dir
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && std::fs::symlink_metadata(a).is_err())
            .map(Path::to_path_buf)
            .collect();
        std::fs::create_dir_all(dir)?;
        // Shallowest first, so the signal handler (newest first) empties the deepest first.
        for m in missing.iter().rev() {
            crate::cleanup::register_empty_folder(m);
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
}
