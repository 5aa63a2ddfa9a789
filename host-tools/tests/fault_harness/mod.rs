//! The fault suites' shared harness (riskctl: `host-tools/tests/faults.rs`; can-bridge:
//! `can-bridge/tests/faults.rs`, which includes this file by path): running a command against a
//! scratch folder and checking the output layer's contract (non-zero exit, the file named, every
//! pre-existing file byte for byte unchanged, no temporary left), and the two faults a test
//! cannot fake: a full disk and a read-only folder, both small tmpfs mounts (root only).
#![allow(dead_code)]
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// One command that writes. `OUT` in `args` and `long` stands for the output.
pub struct Writer {
    pub name: &'static str,
    pub args: &'static str,
    /// The output the scratch folder already holds (a folder when it ends in `/`).
    pub out: &'static str,
    /// The arguments that are input paths: each is tried as the output and as a missing input.
    pub inputs: &'static [&'static str],
    /// The file a second writer finds locked first (`OUT` for the output itself).
    pub lock: &'static str,
    /// A run over the same output long enough to be interrupted, if the command has one, and
    /// whether it writes from the start (so a temporary shows it is in the middle of writing).
    pub long: Option<(&'static str, Streams)>,
}

#[derive(Clone, Copy, PartialEq)]
pub enum Streams {
    /// The output is written as the run goes: interrupted once its temporary appears.
    Yes,
    /// The run computes first and writes at the end: interrupted while it computes.
    No,
}

impl Writer {
    /// The output path without the folder marker.
    pub fn out(&self) -> &'static str {
        self.out.trim_end_matches('/')
    }

    /// The arguments with `OUT` = `out`.
    pub fn args_to(&self, args: &str, out: &str) -> Vec<String> {
        args.split_whitespace()
            .map(|a| {
                if a == "OUT" {
                    out.to_string()
                } else {
                    a.replace("OUT/", &format!("{out}/"))
                }
            })
            .collect()
    }

    /// Puts an old output at `dir/out` (a folder with the user's notes, or a file).
    pub fn place_old_output(&self, dir: &Path) {
        let path = dir.join(self.out());
        if self.out.ends_with('/') {
            std::fs::create_dir_all(&path).unwrap();
            std::fs::write(path.join("notes.txt"), "my notes\n").unwrap();
        } else if self.out.ends_with(".rsk") {
            // A blob writer replaces an old blob only (anything else is refused as not one):
            // the old output starts like one.
            std::fs::write(&path, format!("RSKM old output of {}\n", self.name)).unwrap();
        } else {
            std::fs::write(&path, format!("old output of {}\n", self.name)).unwrap();
        }
    }
}

/// The paths an output must never be, for the input argument `input`: the input itself, and for
/// a folder the files in it.
fn forbidden_outputs(dir: &Path, input: &str) -> Vec<String> {
    let mut out = vec![input.to_string()];
    if dir.join(input).is_dir() {
        let mut files: Vec<String> = std::fs::read_dir(dir.join(input))
            .unwrap()
            .map(|e| format!("{input}/{}", e.unwrap().file_name().to_string_lossy()))
            .filter(|f| {
                f.ends_with("events.csv") || f.ends_with("frames.csv") || f.ends_with(".xml")
            })
            .collect();
        files.sort();
        out.extend(files);
    }
    out
}

/// Each of `path`'s spellings: as given, `./path`, a symlink to it and (files) a hard link to it,
/// the links made in `dir` under names starting with `tag`.
fn spellings(dir: &Path, path: &str, tag: &str) -> Vec<String> {
    let mut v = vec![path.to_string(), format!("./{path}")];
    let sym = format!("{tag}-sym");
    let _ = std::fs::remove_file(dir.join(&sym));
    std::os::unix::fs::symlink(dir.join(path), dir.join(&sym)).unwrap();
    v.push(sym);
    if dir.join(path).is_file() {
        let hard = format!("{tag}-hard");
        let _ = std::fs::remove_file(dir.join(&hard));
        std::fs::hard_link(dir.join(path), dir.join(&hard)).unwrap();
        v.push(hard);
    }
    v
}

/// Output = input: every writer, every input (and a folder input's files), every spelling.
pub fn output_is_input(program: &str, dir: &Path, writers: &[Writer]) {
    let mut failures = Failures::default();
    let mut cases = 0;
    for (n, w) in writers.iter().enumerate() {
        for input in w.inputs {
            for (k, target) in forbidden_outputs(dir, input).iter().enumerate() {
                for out in spellings(dir, target, &format!("w{n}-{k}")) {
                    cases += 1;
                    let args = w.args_to(w.args, &out);
                    failures.check(
                        format!("{}: output {out}", w.name),
                        refused(program, dir, &args, &[&out]),
                    );
                }
            }
        }
    }
    failures.assert_none(cases);
}

/// Each input of each writer missing in turn: refused naming it, the old output untouched.
pub fn missing_input(program: &str, dir: &Path, writers: &[Writer]) {
    let mut failures = Failures::default();
    let mut cases = 0;
    for w in writers {
        for input in w.inputs {
            cases += 1;
            let missing = format!("no-such-{}", input.replace('.', "-"));
            let args: Vec<String> = w
                .args_to(w.args, w.out())
                .into_iter()
                .map(|a| if a == *input { missing.clone() } else { a })
                .collect();
            failures.check(
                format!("{}: missing {missing}", w.name),
                refused(program, dir, &args, &[&missing]),
            );
        }
    }
    failures.assert_none(cases);
}

/// The output exists as the other kind: a folder where a file is written (N73), a file where a
/// folder is written. Refused naming it, and nothing in the folder or the file changes.
pub fn output_of_the_wrong_kind(program: &str, dir: &Path, writers: &[Writer]) {
    let mut failures = Failures::default();
    let folder = dir.join("a-folder");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::write(folder.join("kept.txt"), "mine\n").unwrap();
    std::fs::write(dir.join("a-file"), "mine\n").unwrap();
    for w in writers {
        let out = if w.out.ends_with('/') {
            "a-file"
        } else {
            "a-folder"
        };
        failures.check(
            format!("{}: output {out}", w.name),
            refused(program, dir, &w.args_to(w.args, out), &[out]),
        );
    }
    failures.assert_none(writers.len());
}

/// Another process holds each writer's output lock: refused with [`BUSY`], naming the output.
pub fn second_writer(program: &str, dir: &Path, writers: &[Writer]) {
    let mut failures = Failures::default();
    for w in writers {
        let target = dir.join(w.lock.replace("OUT", w.out()));
        std::fs::create_dir_all(target.parent().unwrap()).unwrap();
        let lock = riskscore_output::OutputLock::acquire(&target).unwrap();
        failures.check(
            format!("{}: output locked by another process", w.name),
            refused(program, dir, &w.args_to(w.args, w.out()), &[BUSY, w.out()]),
        );
        drop(lock);
    }
    failures.assert_none(writers.len());
}

/// Every writer into `dir/mnt/OUT`, a small tmpfs holding its old output, after `fault` (fill
/// the disk, make it read-only) was done to the mount. Skipped (said) when not root.
pub fn every_writer_into(
    program: &str,
    dir: &Path,
    writers: &[Writer],
    case: &str,
    fault: impl Fn(&Tmpfs),
) {
    let Some(tmpfs) = Tmpfs::mount(&dir.join("mnt"), 512, case) else {
        return;
    };
    for w in writers {
        w.place_old_output(&dir.join("mnt"));
    }
    fault(&tmpfs);
    let mut failures = Failures::default();
    for w in writers {
        let out = format!("mnt/{}", w.out());
        failures.check(
            format!("{}: {case}", w.name),
            refused(program, dir, &w.args_to(w.args, &out), &[&out]),
        );
    }
    failures.assert_none(writers.len());
}

/// Ctrl-C in the middle of each writer's long run over its old output (SIGTERM for every other
/// one); while a streaming run writes, a real second run of the same command is refused.
pub fn ctrl_c_and_second_run(program: &str, dir: &Path, writers: &[Writer]) {
    let mut failures = Failures::default();
    let mut cases = 0;
    for w in writers {
        let Some((long, streams)) = w.long else {
            continue;
        };
        let stop = if cases % 2 == 0 {
            Stop::Int
        } else {
            Stop::Term
        };
        cases += 1;
        let before = snapshot(dir);
        let mut child = Command::new(program)
            .current_dir(dir)
            .args(w.args_to(long, w.out()))
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let target = dir.join(w.out());
        let watch = vec![target.clone(), target.parent().unwrap().to_path_buf()];
        let writing = streams == Streams::Yes;
        if writing {
            if let Err(e) = wait_for_temporary(&watch, &mut child) {
                failures.check(format!("{}: Ctrl-C", w.name), Err(e));
                let _ = child.kill();
                let _ = child.wait();
                restore(dir, &before);
                continue;
            }
            let o = run(program, dir, &w.args_to(w.args, w.out()));
            let stderr = String::from_utf8_lossy(&o.stderr);
            if o.status.success() || !stderr.contains(BUSY) || !stderr.contains(w.out()) {
                failures.check(
                    format!("{}: second run while the first writes", w.name),
                    Err(format!("{:?}: {stderr}", o.status)),
                );
            }
        } else {
            std::thread::sleep(Duration::from_millis(300));
        }
        let o = interrupt(child, stop);
        failures.check(
            format!("{}: Ctrl-C", w.name),
            interrupted_cleanly(&o, stop, w.out(), writing, &before, dir),
        );
        restore(dir, &before);
    }
    failures.assert_none(cases);
}

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
        self.fill_leaving(0);
    }

    /// Fills the disk but for `free` bytes (whole pages).
    pub fn fill_leaving(&self, free: u64) {
        use std::io::Write;
        let path = self.path.join("filler");
        let mut f = std::fs::File::create(&path).unwrap();
        let block = vec![0x5a_u8; 4096];
        while f.write_all(&block).and_then(|()| f.sync_all()).is_ok() {}
        let len = f.metadata().unwrap().len();
        f.set_len(len.saturating_sub(free)).unwrap();
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
            // A temporary, or the lock a run that computes first takes on its output at start.
            n.starts_with('.') && (n.ends_with(".tmp") || n.ends_with(".lock"))
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

/// A signal that stops a run, and the exit status the output layer's handler gives it.
#[derive(Clone, Copy)]
pub enum Stop {
    /// Ctrl-C: exit 130.
    Int,
    /// `kill`, a service manager: exit 143.
    Term,
}

impl Stop {
    /// The signal's name for `kill -NAME` (and `SIGNAME` in messages).
    pub fn name(self) -> &'static str {
        match self {
            Stop::Int => "INT",
            Stop::Term => "TERM",
        }
    }

    /// The exit status the handler gives the run.
    pub fn exit_code(self) -> i32 {
        match self {
            Stop::Int => 130,
            Stop::Term => 143,
        }
    }
}

/// Sends `stop` to `child` (`kill -NAME PID`).
pub fn send(child: &Child, stop: Stop) {
    let kill = Command::new("kill")
        .args([&format!("-{}", stop.name()), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
}

/// Sends `stop` to `child` and collects its output.
pub fn interrupt(child: Child, stop: Stop) -> Output {
    send(&child, stop);
    child.wait_with_output().unwrap()
}

/// Checks an interrupted run: exit 130 or 143 (the layer's handler, not the default signal
/// death), the target named when the run was writing, and `dir` as `before`.
pub fn interrupted_cleanly(
    o: &Output,
    stop: Stop,
    target: &str,
    writing: bool,
    before: &BTreeMap<PathBuf, Vec<u8>>,
    dir: &Path,
) -> Result<(), String> {
    let stderr = String::from_utf8_lossy(&o.stderr);
    if o.status.code() != Some(stop.exit_code()) {
        return Err(format!(
            "SIG{}: exit {:?}, not {}; stderr: {stderr}",
            stop.name(),
            o.status,
            stop.exit_code()
        ));
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
