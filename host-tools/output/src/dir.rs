//! A folder output built complete as a new sibling temporary folder, then swapped in as a whole.
use std::io;
use std::path::{Path, PathBuf};

use crate::lock::{hidden_name, parent_of, OutputLock};

/// A folder output (a report): every file is written into [`OutputDir::path`], a new temporary
/// folder beside the target, and [`OutputDir::commit`] swaps it in as a whole: the old folder is
/// renamed aside, the new one renamed in, the old one removed (on failure the old one is put
/// back). Files of the old folder that the run does not write (a user's notes) are carried over
/// by hard link, so nothing the run does not own disappears. Dropped without `commit`, the
/// temporary folder is removed and the target is untouched. The target is locked against a
/// second process while this lives. Every error it returns names the path it concerns, so a
/// caller does not add it again.
pub struct OutputDir {
    target: PathBuf,
    tmp: Option<PathBuf>,
    _lock: OutputLock,
}

fn err(path: &Path, what: &str, e: io::Error) -> io::Error {
    io::Error::new(e.kind(), format!("{}: {what}: {e}", path.display()))
}

/// Carries `src` (a file, link or folder of the old output) to `dst` without touching `src`.
fn carry(src: &Path, dst: &Path) -> io::Result<()> {
    let meta = std::fs::symlink_metadata(src)?;
    if meta.is_dir() {
        std::fs::create_dir(dst)?;
        for e in std::fs::read_dir(src)? {
            let e = e?;
            carry(&e.path(), &dst.join(e.file_name()))?;
        }
        Ok(())
    } else if meta.file_type().is_symlink() {
        std::os::unix::fs::symlink(std::fs::read_link(src)?, dst)
    } else if std::fs::hard_link(src, dst).is_err() {
        std::fs::copy(src, dst).map(|_| ())
    } else {
        Ok(())
    }
}

/// Refuses, before anything is written, `-` (standard output), a target that is not a folder, or
/// one the final swap could not rename: a symbolic link (renaming it would move the link, not the
/// folder) or a mount point (a rename cannot move it), or one whose parent is not a folder. Found
/// at the end instead, the whole run's output would be lost. What [`OutputDir::create`] checks; a run that
/// stages a folder late calls it at its start.
pub fn refuse_unswappable(target: &Path) -> io::Result<()> {
    use std::os::unix::fs::MetadataExt;
    crate::overlap::refuse_dash_folder(target)?;
    let parent = parent_of(target);
    if let Some(file) = [parent, target]
        .into_iter()
        .find(|p| p.exists() && !p.is_dir())
    {
        return Err(io::Error::new(
            io::ErrorKind::AlreadyExists,
            format!("{} exists and is not a folder", file.display()),
        ));
    }
    let Ok(meta) = std::fs::symlink_metadata(target) else {
        return Ok(());
    };
    let refuse = |why: &str| {
        Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{} is {why}: the output folder is swapped in as a whole, which needs a plain \
                 folder (give the folder it leads to, or another output)",
                target.display()
            ),
        ))
    };
    if meta.file_type().is_symlink() {
        return refuse("a symbolic link");
    }
    if meta.is_dir() && crate::file::is_read_only(target) {
        // The swap would replace it whatever its mode, and leave its old copy behind where the
        // files in it cannot be removed (`.NAME.XXXXXX.old/`).
        return Err(io::Error::new(
            io::ErrorKind::PermissionDenied,
            format!("{} {}", target.display(), crate::file::READ_ONLY),
        ));
    }
    let parent = std::fs::metadata(parent).map_err(|e| err(parent, "cannot read", e))?;
    if meta.is_dir() && meta.dev() != parent.dev() {
        return refuse("a mount point");
    }
    Ok(())
}

/// Refuses a new entry whose name the old folder holds as the other kind: a folder of the user's
/// where the run writes a file (`results.md/` holding notes) would be removed with the old folder,
/// and a file where the run writes a folder likewise. A link counts as a file (it is replaced, not
/// what it points to).
fn refuse_kind_clashes(old: &Path, new: &Path) -> io::Result<()> {
    for e in std::fs::read_dir(new).map_err(|e| err(new, "cannot read", e))? {
        let e = e.map_err(|e| err(new, "cannot read", e))?;
        refuse_kind_clash(
            &old.join(e.file_name()),
            e.file_type().is_ok_and(|t| t.is_dir()),
        )?;
    }
    Ok(())
}

/// Refuses `theirs`, an entry of an old output folder, when the run writes a folder there and it
/// is not one, or a file there and it is a folder (see [`refuse_kind_clashes`]); a missing entry
/// is fine. What a command that knows its output names checks at its start.
pub fn refuse_kind_clash(theirs: &Path, writes_folder: bool) -> io::Result<()> {
    let Ok(before) = std::fs::symlink_metadata(theirs) else {
        return Ok(());
    };
    if before.is_dir() == writes_folder {
        return Ok(());
    }
    let (is, writes) = if writes_folder {
        ("a file", "folder")
    } else {
        ("a folder", "file")
    };
    Err(io::Error::new(
        io::ErrorKind::AlreadyExists,
        format!(
            "{} is {is}, not the {writes} this run writes there: it would be lost with the old \
             output, so it is left as it is and nothing was put in place (move it, or choose \
             another output)",
            theirs.display()
        ),
    ))
}

/// Carries every entry of the folder `old` that `new` does not have into `new` (see [`carry`]):
/// what [`OutputDir::commit`] does for the old target, and what a caller does for a subfolder it
/// wrote fresh inside a staged folder (an old subfolder's own notes are kept with it).
pub fn carry_missing(old: &Path, new: &Path) -> io::Result<()> {
    refuse_kind_clashes(old, new)?;
    for e in std::fs::read_dir(old).map_err(|e| err(old, "cannot read", e))? {
        let e = e.map_err(|e| err(old, "cannot read", e))?;
        let dst = new.join(e.file_name());
        if std::fs::symlink_metadata(&dst).is_err() {
            carry(&e.path(), &dst).map_err(|x| err(&e.path(), "cannot keep", x))?;
        }
    }
    Ok(())
}

impl OutputDir {
    /// Locks `target` and creates the new temporary folder beside it (creating missing parent
    /// folders, removed again if the run does not commit). Refuses a target that exists and is
    /// not a folder, a symbolic link or a mount point.
    pub fn create(target: &Path) -> io::Result<Self> {
        refuse_unswappable(target)?;
        let parent = parent_of(target);
        // The lock creates the missing parent folders (removed again if the run fails).
        let lock = OutputLock::acquire(target)
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", target.display())))?;
        let prefix = hidden_name(target, ".")?;
        let mut undo = crate::cleanup::registrar();
        let tmp = tempfile::Builder::new()
            .prefix(prefix.file_name().unwrap_or_default())
            .suffix(".tmp")
            // What `create_dir` would give (0o777 less the umask), not tempfile's 0o700.
            .permissions(std::os::unix::fs::PermissionsExt::from_mode(0o777))
            .tempdir_in(parent)
            .map_err(|e| err(target, "cannot create a temporary folder beside it", e))?
            .keep();
        undo.remove(&tmp);
        drop(undo);
        Ok(Self {
            target: target.to_path_buf(),
            tmp: Some(tmp),
            _lock: lock,
        })
    }

    /// Where the new files go until [`OutputDir::commit`].
    pub fn path(&self) -> &Path {
        self.tmp.as_deref().expect("open until commit")
    }

    /// The final folder.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// What [`Self::commit`] would refuse of the old folder's entries (a name the run writes as
    /// the other kind), checked without changing anything: a caller that swaps several folders
    /// checks them all before the first swap.
    pub fn check_commit(&self) -> io::Result<()> {
        match &self.tmp {
            Some(tmp) if self.target.is_dir() => refuse_kind_clashes(&self.target, tmp),
            _ => Ok(()),
        }
    }

    /// Swaps the complete new folder in for the old one (see the type's documentation).
    pub fn commit(mut self) -> io::Result<()> {
        let tmp = self.tmp.clone().expect("open until commit");
        let target = self.target.clone();
        // The run's own files are synced before an old folder's are carried in: those are the
        // user's (hard links, already on disk), and one they cannot read must not fail the run
        // at its end.
        sync_tree(&tmp)?;
        if target.is_dir() {
            carry_missing(&target, &tmp)?;
            if let Ok(m) = std::fs::metadata(&target) {
                let _ = std::fs::set_permissions(&tmp, m.permissions());
            }
            sync_dir(&tmp);
            let mut undo = crate::cleanup::registrar();
            let aside = tempfile::Builder::new()
                .prefix(hidden_name(&target, ".")?.file_name().unwrap_or_default())
                .suffix(".old")
                .tempdir_in(parent_of(&target))
                .map_err(|e| err(&target, "cannot create a folder beside it", e))?
                .keep();
            undo.restore(&aside, &target);
            drop(undo);
            // `aside` is empty: renaming a folder over an empty folder replaces it.
            if let Err(e) = std::fs::rename(&target, &aside) {
                crate::cleanup::unregister_restore(&aside);
                let _ = std::fs::remove_dir(&aside);
                return Err(err(&target, "cannot move the old folder aside", e));
            }
            if let Err(e) = std::fs::rename(&tmp, &target) {
                let _ = std::fs::rename(&aside, &target);
                crate::cleanup::unregister_restore(&aside);
                return Err(err(&target, "cannot move the new folder in", e));
            }
            self.done(&tmp);
            crate::cleanup::register(&aside);
            crate::cleanup::unregister_restore(&aside);
            let _ = std::fs::remove_dir_all(&aside);
            crate::cleanup::unregister(&aside);
        } else {
            std::fs::rename(&tmp, &target)
                .map_err(|e| err(&target, "cannot move the new folder in", e))?;
            self.done(&tmp);
        }
        sync_dir(parent_of(&target));
        self._lock.keep_folders();
        Ok(())
    }

    fn done(&mut self, tmp: &Path) {
        crate::cleanup::unregister(tmp);
        self.tmp = None;
    }
}

fn sync_dir(dir: &Path) {
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Syncs every file below `dir` (and the folders), so the folder swapped in never holds a file
/// whose data is still in memory: a power loss right after the swap would leave it empty. Files
/// written by an [`crate::AtomicFile`] are synced already; a second sync of them is cheap.
fn sync_tree(dir: &Path) -> io::Result<()> {
    for e in std::fs::read_dir(dir).map_err(|e| err(dir, "cannot read", e))? {
        let e = e.map_err(|e| err(dir, "cannot read", e))?;
        let path = e.path();
        let kind = e.file_type().map_err(|x| err(&path, "cannot read", x))?;
        if kind.is_dir() {
            sync_tree(&path)?;
        } else if kind.is_file() {
            std::fs::File::open(&path)
                .and_then(|f| f.sync_all())
                .map_err(|x| err(&path, "cannot sync", x))?;
        }
    }
    sync_dir(dir);
    Ok(())
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let _ = std::fs::remove_dir_all(&tmp);
            crate::cleanup::unregister(&tmp);
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
    fn a_folder_is_swapped_whole_or_not_at_all() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("report");
        // New folder.
        let o = OutputDir::create(&out).unwrap();
        std::fs::write(o.path().join("a.md"), "one").unwrap();
        assert!(!out.exists(), "written before commit");
        o.commit().unwrap();
        assert_eq!(names(&out), ["a.md"]);
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        // A failed run (dropped): nothing changes, nothing is left.
        {
            let o = OutputDir::create(&out).unwrap();
            std::fs::write(o.path().join("a.md"), "two").unwrap();
            assert!(
                OutputDir::create(&out).is_err(),
                "a second writer was let in"
            );
        }
        assert_eq!(std::fs::read_to_string(out.join("a.md")).unwrap(), "one");
        assert_eq!(names(d.path()), ["report"]);
        // A successful run replaces its files and keeps the user's.
        let o = OutputDir::create(&out).unwrap();
        std::fs::write(o.path().join("a.md"), "three").unwrap();
        std::fs::write(o.path().join("b.csv"), "x").unwrap();
        o.commit().unwrap();
        assert_eq!(names(&out), ["a.md", "b.csv", "notes.txt"]);
        assert_eq!(std::fs::read_to_string(out.join("a.md")).unwrap(), "three");
        assert_eq!(
            std::fs::read_to_string(out.join("notes.txt")).unwrap(),
            "mine"
        );
        assert_eq!(names(d.path()), ["report"], "temporaries left");
    }

    #[test]
    fn a_missing_parent_is_made_and_removed_again_unless_committed() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("x/y/report");
        {
            let o = OutputDir::create(&out).unwrap();
            std::fs::write(o.path().join("a.md"), "one").unwrap();
        }
        assert_eq!(names(d.path()), Vec::<String>::new(), "new folders left");
        let o = OutputDir::create(&out).unwrap();
        std::fs::write(o.path().join("a.md"), "one").unwrap();
        o.commit().unwrap();
        assert_eq!(names(&d.path().join("x/y")), ["report"]);
        // Locked for the run first (evaluate): the run's lock made the folders.
        let run = d.path().join("r/s/report");
        {
            let _lock = OutputLock::acquire_for_run(&run).unwrap();
            let _o = OutputDir::create(&run).unwrap();
        }
        assert_eq!(names(d.path()), ["x"], "new folders left");
    }

    #[test]
    fn a_file_in_the_way_or_a_file_parent_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let f = d.path().join("plain");
        std::fs::write(&f, "keep").unwrap();
        assert!(OutputDir::create(&f).is_err());
        assert!(OutputDir::create(&f.join("sub")).is_err());
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "keep");
        assert_eq!(names(d.path()), ["plain"]);
    }

    #[test]
    fn a_user_s_folder_under_a_result_file_s_name_is_never_removed() {
        // `evaluate --out rep` with rep/results.md/ a folder of notes: the swap removed it.
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("rep");
        std::fs::create_dir_all(out.join("results.md")).unwrap();
        std::fs::write(out.join("results.md/note"), "keep").unwrap();
        std::fs::write(out.join("sub"), "a file where the run writes a folder").unwrap();
        for (name, folder) in [("results.md", false), ("sub", true)] {
            let o = OutputDir::create(&out).unwrap();
            if folder {
                std::fs::create_dir(o.path().join(name)).unwrap();
            } else {
                std::fs::write(o.path().join(name), "new").unwrap();
            }
            let e = o.commit().unwrap_err();
            assert!(e.to_string().contains(&format!("rep/{name} is a ")), "{e}");
            assert_eq!(
                std::fs::read_to_string(out.join("results.md/note")).unwrap(),
                "keep"
            );
            assert!(std::fs::read_to_string(out.join("sub")).is_ok());
            assert_eq!(names(d.path()), ["rep"], "temporaries left");
        }
    }

    #[test]
    fn a_clash_one_level_down_is_refused_and_checked_before_a_swap() {
        // The demo carries an old report/transfer/ into its new one: a folder of notes under a
        // result file's name there went with the old report.
        let d = tempfile::tempdir().unwrap();
        let (old, new) = (d.path().join("old"), d.path().join("new"));
        std::fs::create_dir_all(old.join("results.md")).unwrap();
        std::fs::write(old.join("results.md/note"), "keep").unwrap();
        std::fs::create_dir(&new).unwrap();
        std::fs::write(new.join("results.md"), "new").unwrap();
        let e = carry_missing(&old, &new).unwrap_err();
        assert!(e.to_string().contains("results.md is a folder"), "{e}");
        // check_commit says what commit would refuse, and changes nothing.
        let out = d.path().join("rep");
        std::fs::create_dir_all(out.join("results.md")).unwrap();
        let o = OutputDir::create(&out).unwrap();
        std::fs::write(o.path().join("results.md"), "new").unwrap();
        assert!(o.check_commit().is_err());
        assert!(out.join("results.md").is_dir());
        drop(o);
        assert_eq!(names(d.path()), ["new", "old", "rep"]);
    }

    #[test]
    fn a_read_only_folder_is_refused_and_left_as_it_is() {
        use std::os::unix::fs::PermissionsExt;
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("rep");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o555)).unwrap();
        let e = OutputDir::create(&out).err().expect("refused");
        assert!(e.to_string().contains("rep is read-only"), "{e}");
        assert_eq!(names(d.path()), ["rep"], "temporaries left");
        std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o755)).unwrap();
        assert!(OutputDir::create(&out).is_ok());
    }

    #[test]
    fn a_file_parent_is_named_as_the_folder_in_the_way() {
        let d = tempfile::tempdir().unwrap();
        let f = d.path().join("plain");
        std::fs::write(&f, "keep").unwrap();
        let e = refuse_unswappable(&f.join("train")).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{} exists and is not a folder", f.display())
        );
        assert!(refuse_unswappable(&d.path().join("new/train")).is_ok());
    }

    #[test]
    fn a_symlinked_folder_is_refused_at_create_not_at_commit() {
        // Before, the link was accepted and the final rename failed, losing the run's output.
        let d = tempfile::tempdir().unwrap();
        let real = d.path().join("real");
        std::fs::create_dir(&real).unwrap();
        std::fs::write(real.join("a.md"), "old").unwrap();
        let link = d.path().join("link");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        let e = OutputDir::create(&link).err().expect("refused");
        assert!(e.to_string().contains("is a symbolic link"), "{e}");
        assert_eq!(std::fs::read_to_string(real.join("a.md")).unwrap(), "old");
        assert_eq!(names(d.path()), ["link", "real"]);
        // The folder it leads to is a plain folder.
        let o = OutputDir::create(&real).unwrap();
        std::fs::write(o.path().join("a.md"), "new").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read_to_string(link.join("a.md")).unwrap(), "new");
    }

    #[test]
    fn carry_missing_keeps_an_old_subfolder_s_notes() {
        let d = tempfile::tempdir().unwrap();
        let (old, new) = (d.path().join("old"), d.path().join("new"));
        std::fs::create_dir_all(old.join("sub")).unwrap();
        std::fs::create_dir(&new).unwrap();
        std::fs::write(old.join("a.md"), "old a").unwrap();
        std::fs::write(old.join("notes.txt"), "mine").unwrap();
        std::fs::write(old.join("sub/x"), "x").unwrap();
        std::fs::write(new.join("a.md"), "new a").unwrap();
        carry_missing(&old, &new).unwrap();
        assert_eq!(names(&new), ["a.md", "notes.txt", "sub"]);
        assert_eq!(std::fs::read_to_string(new.join("a.md")).unwrap(), "new a");
        assert_eq!(std::fs::read_to_string(new.join("sub/x")).unwrap(), "x");
        assert_eq!(
            std::fs::read_to_string(old.join("notes.txt")).unwrap(),
            "mine"
        );
    }
}
