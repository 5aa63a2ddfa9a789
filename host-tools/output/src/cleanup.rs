//! What a Ctrl-C or SIGTERM leaves behind: nothing. Every temporary file, temporary folder and
//! lock file of the layer is registered here while it exists; [`remove_temporaries_on_signals`]
//! installs (once) a signal-hook handler thread that removes them, puts a folder moved aside
//! back, says which outputs were left as they were, and exits with 130 (SIGINT) or 143 (SIGTERM).
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};

#[derive(Debug, PartialEq)]
enum Undo {
    /// Remove this file or folder.
    Remove(PathBuf),
    /// A folder made for the run: remove it if it is (still) empty.
    RemoveEmptyFolder(PathBuf),
    /// A folder output moved aside during its swap: put it back at `target` if that is empty.
    Restore { aside: PathBuf, target: PathBuf },
}

static PENDING: Mutex<Vec<Undo>> = Mutex::new(Vec::new());

/// The outputs being written now (one per lock held), named when a signal stops the run.
static TARGETS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> MutexGuard<'static, Vec<Undo>> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

fn targets() -> MutexGuard<'static, Vec<PathBuf>> {
    TARGETS.lock().unwrap_or_else(|e| e.into_inner())
}

pub(crate) fn register_target(target: &Path) {
    targets().push(target.to_path_buf());
}

pub(crate) fn unregister_target(target: &Path) {
    let mut list = targets();
    if let Some(i) = list.iter().rposition(|t| t == target) {
        list.remove(i);
    }
}

/// What the handler says on stderr: the program, the signal, and the outputs it left alone.
fn interrupted_message(signal: &str, targets: &[PathBuf]) -> String {
    let program = std::env::args_os()
        .next()
        .map(PathBuf::from)
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_default();
    if targets.is_empty() {
        return format!("{program}: interrupted ({signal}): nothing was written");
    }
    // Said after the clean-up: an output that did not exist before the run does not exist now.
    let (kept, new): (Vec<&PathBuf>, Vec<&PathBuf>) = targets
        .iter()
        .partition(|t| std::fs::symlink_metadata(t).is_ok());
    let names = |list: &[&PathBuf]| {
        let names: Vec<String> = list.iter().map(|t| t.display().to_string()).collect();
        names.join(", ")
    };
    let mut said = Vec::new();
    if !kept.is_empty() {
        said.push(format!("{} left as it was", names(&kept)));
    }
    if !new.is_empty() {
        said.push(format!("{} not created", names(&new)));
    }
    format!(
        "{program}: interrupted ({signal}): the unfinished output was removed; {}",
        said.join("; ")
    )
}

/// The list of undos, held while something is created and registered through it. A signal's
/// clean-up takes the same lock (and keeps it until the process exits), so it runs either before
/// the thing exists or after it is registered: a temporary created just as Ctrl-C arrives is
/// never left behind unregistered.
pub(crate) struct Registrar(MutexGuard<'static, Vec<Undo>>);

impl Registrar {
    pub(crate) fn remove(&mut self, path: &Path) {
        self.0.push(Undo::Remove(path.to_path_buf()));
    }

    pub(crate) fn remove_empty_folder(&mut self, path: &Path) {
        self.0.push(Undo::RemoveEmptyFolder(path.to_path_buf()));
    }

    pub(crate) fn restore(&mut self, aside: &Path, target: &Path) {
        self.0.push(Undo::Restore {
            aside: aside.to_path_buf(),
            target: target.to_path_buf(),
        });
    }
}

/// Holds the list of undos: create, then register through it (see [`Registrar`]). Nothing that
/// registers by itself may run while it is held (the lock is not re-entrant).
pub(crate) fn registrar() -> Registrar {
    Registrar(pending())
}

pub(crate) fn register(path: &Path) {
    registrar().remove(path);
}

pub(crate) fn unregister(path: &Path) {
    pending().retain(|u| !matches!(u, Undo::Remove(p) if p == path));
}

pub(crate) fn unregister_empty_folder(path: &Path) {
    pending().retain(|u| !matches!(u, Undo::RemoveEmptyFolder(p) if p == path));
}

pub(crate) fn unregister_restore(aside: &Path) {
    pending().retain(|u| !matches!(u, Undo::Restore { aside: a, .. } if a == aside));
}

fn undo(u: Undo) {
    match u {
        Undo::Remove(p) => {
            if p.is_dir() {
                let _ = std::fs::remove_dir_all(&p);
            } else {
                let _ = std::fs::remove_file(&p);
            }
        }
        Undo::RemoveEmptyFolder(p) => {
            let _ = std::fs::remove_dir(&p);
        }
        Undo::Restore { aside, target } => {
            if !target.exists() {
                let _ = std::fs::rename(&aside, &target);
            }
        }
    }
}

/// Undoes everything registered, newest first. Holds the registry until the process exits, so
/// no new temporary can appear behind it.
fn undo_all() -> MutexGuard<'static, Vec<Undo>> {
    let mut list = pending();
    while let Some(u) = list.pop() {
        undo(u);
    }
    list
}

/// Installs, once per process, the handler that on SIGINT or SIGTERM removes every temporary
/// and lock file of this layer and exits with 128 + the signal number (130, 143). Call it at the
/// start of a command-line program that writes files; later calls do nothing.
pub fn remove_temporaries_on_signals() -> std::io::Result<()> {
    static INSTALLED: OnceLock<()> = OnceLock::new();
    if INSTALLED.get().is_some() {
        return Ok(());
    }
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
    std::thread::Builder::new()
        .name("output-cleanup".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let _held = undo_all();
                let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
                eprintln!("{}", interrupted_message(name, &targets()));
                std::process::exit(128 + sig);
            }
        })?;
    let _ = INSTALLED.set(());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undo_removes_registered_files_and_restores_an_aside_folder() {
        let d = tempfile::tempdir().unwrap();
        let tmp = d.path().join(".x.tmp");
        std::fs::write(&tmp, "half").unwrap();
        register(&tmp);
        let (aside, target) = (d.path().join(".out.old"), d.path().join("out"));
        std::fs::create_dir(&aside).unwrap();
        std::fs::write(aside.join("kept"), "old").unwrap();
        registrar().restore(&aside, &target);
        // Other tests of this process register too: undo only this test's entries.
        let mine: Vec<Undo> = {
            let mut list = pending();
            let (mine, rest) = list
                .drain(..)
                .partition(|u| matches!(u, Undo::Remove(p) | Undo::RemoveEmptyFolder(p) | Undo::Restore { aside: p, .. } if p.starts_with(d.path())));
            *list = rest;
            mine
        };
        assert_eq!(mine.len(), 2);
        mine.into_iter().rev().for_each(undo);
        assert!(!tmp.exists());
        assert_eq!(std::fs::read_to_string(target.join("kept")).unwrap(), "old");
    }

    #[test]
    fn the_interrupted_message_names_every_output_left_alone() {
        let d = tempfile::tempdir().unwrap();
        let (out, ev, new) = (
            d.path().join("out.csv"),
            d.path().join("ev"),
            d.path().join("new"),
        );
        std::fs::write(&out, "old").unwrap();
        std::fs::create_dir(&ev).unwrap();
        let m = interrupted_message("SIGINT", &[out.clone(), ev.clone(), new.clone()]);
        assert!(m.contains("interrupted (SIGINT)"), "{m}");
        let (out, ev, new) = (out.display(), ev.display(), new.display());
        assert!(
            m.ends_with(&format!("{out}, {ev} left as it was; {new} not created")),
            "{m}"
        );
        let m = interrupted_message("SIGTERM", &[]);
        assert!(
            m.ends_with("interrupted (SIGTERM): nothing was written"),
            "{m}"
        );
    }
}
