//! Running the `can-bridge` binary from an integration test (not in `mod.rs`: an example
//! includes that, and examples have no binary path).
#![allow(dead_code)]
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// Runs `can-bridge` with `args`: (exit code, stdout, stderr).
pub fn bridge(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_can-bridge"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// Runs `can-bridge` with `args` in `dir`, `input` piped to its standard input (written from a
/// thread, so a large input cannot block on a full pipe; a command that stops reading early
/// closes it): (exit code, stdout, stderr).
pub fn bridge_piped(dir: &Path, args: &[&str], input: &[u8]) -> (Option<i32>, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_can-bridge"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    let writer = std::thread::spawn(move || {
        // Broken pipe when the command refused the input before reading all of it.
        let _ = stdin.write_all(&input);
    });
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}
