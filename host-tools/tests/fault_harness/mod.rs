//! The fault suites' shared harness (riskctl: `host-tools/tests/faults.rs`; can-bridge:
//! `can-bridge/tests/faults.rs`, which includes this file by path): running a command against a
//! scratch folder and checking the output layer's contract (non-zero exit, the file named, every
//! pre-existing file byte for byte unchanged, no temporary left), and the two faults a test
//! cannot fake: a full disk and a read-only folder, both small tmpfs mounts (root only).
#![allow(dead_code)]
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

/// What the output layer says when a second process writes the same target.
pub const BUSY: &str = "another process is writing";

/// Every entry under `dir` (hidden ones too) with its bytes; a symlink is recorded as its target,
/// a folder as `<dir>`.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(dir).unwrap().to_path_buf();
            let meta = std::fs::symlink_metadata(&p).unwrap();
            if meta.file_type().is_symlink() {
                let target = std::fs::read_link(&p).unwrap();
                out.insert(rel, format!("-> {}", target.display()).into_bytes());
            } else if meta.is_dir() {
                out.insert(rel, b"<dir>".to_vec());
                stack.push(p);
            } else {
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

/// The paths that differ between two snapshots (changed, gone or new).
pub fn changes(
    before: &BTreeMap<PathBuf, Vec<u8>>,
    after: &BTreeMap<PathBuf, Vec<u8>>,
) -> Vec<PathBuf> {
    before
        .keys()
        .chain(after.keys().filter(|k| !before.contains_key(*k)))
        .filter(|k| before.get(*k) != after.get(*k))
        .cloned()
        .collect()
}

/// Runs `program args` in `dir`.
pub fn run(program: &str, dir: &Path, args: &[String]) -> Output {
    Command::new(program)
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run the command")
}

/// Runs `program args` in `dir` and checks the fault contract: a non-zero exit that is neither a
/// panic nor a signal, a message naming every one of `names`, and `dir` byte for byte as before
/// (so no temporary or lock file is left either). Returns what is wrong, if anything.
pub fn refused(program: &str, dir: &Path, args: &[String], names: &[&str]) -> Result<(), String> {
    let before = snapshot(dir);
    let o = run(program, dir, args);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let stdout: String = String::from_utf8_lossy(&o.stdout)
        .chars()
        .take(160)
        .collect();
    let said = format!("stderr: {}", stderr.trim_end());
    let changed = changes(&before, &snapshot(dir));
    if !changed.is_empty() {
        restore(dir, &before);
    }
    let wrong = match o.status.code() {
        Some(0) => Some(format!("exit 0 (stdout: {stdout})")),
        Some(101) => Some("panicked".to_string()),
        None => Some("killed by a signal".to_string()),
        Some(_) => None,
    };
    let unnamed: Vec<_> = names.iter().filter(|n| !stderr.contains(*n)).collect();
    match wrong {
        Some(w) => Err(format!("{w}; changed or left {changed:?}; {said}")),
        None if !changed.is_empty() => Err(format!("changed or left {changed:?}; {said}")),
        None if !unnamed.is_empty() => {
            Err(format!("the message does not name {unnamed:?}; {said}"))
        }
        None => Ok(()),
    }
}

/// Puts `dir` back as `before` recorded it, so one failing case does not spoil the next.
pub fn restore(dir: &Path, before: &BTreeMap<PathBuf, Vec<u8>>) {
    let now = snapshot(dir);
    for gone in now.keys().rev().filter(|k| !before.contains_key(*k)) {
        let p = dir.join(gone);
        let _ = std::fs::remove_file(&p).or_else(|_| std::fs::remove_dir_all(&p));
    }
    for (rel, bytes) in before {
        let p = dir.join(rel);
        if now.get(rel) == Some(bytes) {
            continue;
        }
        let _ = std::fs::remove_file(&p);
        if bytes == b"<dir>" {
            let _ = std::fs::create_dir_all(&p);
        } else if let Some(target) = bytes.strip_prefix(b"-> ") {
            let target = PathBuf::from(String::from_utf8_lossy(target).into_owned());
            let _ = std::os::unix::fs::symlink(target, &p);
        } else {
            let _ = std::fs::remove_dir_all(&p);
            if let Some(parent) = p.parent() {
                let _ = std::fs::create_dir_all(parent);
            }
            let _ = std::fs::write(&p, bytes);
        }
    }
}

/// Collects the failures of a table of cases and reports them all at once.
#[derive(Default)]
pub struct Failures(Vec<String>);

impl Failures {
    pub fn check(&mut self, case: impl std::fmt::Display, result: Result<(), String>) {
        if let Err(e) = result {
            self.0.push(format!("{case}: {e}"));
        }
    }

    pub fn assert_none(self, cases: usize) {
        assert!(
            self.0.is_empty(),
            "{} of {cases} cases failed:\n{}",
            self.0.len(),
            self.0.join("\n")
        );
    }
}

/// True when this process may mount a tmpfs; otherwise says the case is skipped.
fn may_mount(case: &str) -> bool {
    let uid = Command::new("id").arg("-u").output().ok();
    let root = uid.is_some_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    if !root {
        eprintln!("{case}: skipped: needs root for tmpfs");
    }
    root
}

/// A small tmpfs mounted on a folder for one test (unmounted when dropped): a disk that fills
/// up, or a folder that is read-only even for root (chmod does not stop root).
pub struct Tmpfs {
    path: PathBuf,
}

impl Tmpfs {
    /// Mounts a tmpfs of `size_kib` on `path` (created); `None` (the case is skipped, said on
    /// stderr) when not running as root.
    pub fn mount(path: &Path, size_kib: u32, case: &str) -> Option<Tmpfs> {
        if !may_mount(case) {
            return None;
        }
        std::fs::create_dir_all(path).unwrap();
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size_kib}k"), "tmpfs"])
            .arg(path)
            .status()
            .unwrap();
        assert!(ok.success(), "{case}: cannot mount a tmpfs on {path:?}");
        Some(Tmpfs {
            path: path.to_path_buf(),
        })
    }

    /// Fills the rest of the disk with `filler`, so the next byte written fails with ENOSPC.
    pub fn fill(&self) {
        use std::io::Write;
        let mut f = std::fs::File::create(self.path.join("filler")).unwrap();
        let block = vec![0x5a_u8; 4096];
        while f.write_all(&block).and_then(|()| f.sync_all()).is_ok() {}
    }

    /// Remounts the tmpfs read-only.
    pub fn make_read_only(&self) {
        let ok = Command::new("mount")
            .args(["-o", "remount,ro"])
            .arg(&self.path)
            .status()
            .unwrap();
        assert!(ok.success(), "cannot remount {:?} read-only", self.path);
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.path).status();
    }
}

/// True when `dir` holds one of the layer's hidden temporaries (`.NAME.XXXXXX.tmp`).
fn holds_temporary(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|entries| {
        entries.flatten().any(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.starts_with('.') && n.ends_with(".tmp")
        })
    })
}

/// Waits until a temporary of `child` appears in one of `dirs` (the run is writing). `Err` when
/// the run ended first or nothing appeared within 20 s.
pub fn wait_for_temporary(dirs: &[PathBuf], child: &mut Child) -> Result<(), String> {
    let start = Instant::now();
    loop {
        if dirs.iter().any(|d| holds_temporary(d)) {
            return Ok(());
        }
        if let Some(status) = child.try_wait().unwrap() {
            return Err(format!("the run ended ({status}) before it wrote"));
        }
        if start.elapsed() > Duration::from_secs(20) {
            return Err("no temporary appeared within 20 s".into());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Sends SIGINT to `child` and collects its output.
pub fn interrupt(child: Child) -> Output {
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    child.wait_with_output().unwrap()
}

/// Checks an interrupted run: exit 130 (the layer's handler, not the default signal death), the
/// target named when the run was writing, and `dir` as `before`.
pub fn interrupted_cleanly(
    o: &Output,
    target: &str,
    writing: bool,
    before: &BTreeMap<PathBuf, Vec<u8>>,
    dir: &Path,
) -> Result<(), String> {
    let stderr = String::from_utf8_lossy(&o.stderr);
    if o.status.code() != Some(130) {
        return Err(format!("exit {:?}, not 130; stderr: {stderr}", o.status));
    }
    if writing && !stderr.contains(target) {
        return Err(format!("the message does not name {target}: {stderr}"));
    }
    let changed = changes(before, &snapshot(dir));
    if !changed.is_empty() {
        return Err(format!("changed or left {changed:?}; stderr: {stderr}"));
    }
    Ok(())
}
