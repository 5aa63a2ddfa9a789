//! Running the `can-bridge` binary from an integration test (not in `mod.rs`: an example
//! includes that, and examples have no binary path).
/// Runs `can-bridge` with `args`: (exit code, stdout, stderr).
pub fn bridge(args: &[&str]) -> (Option<i32>, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_can-bridge"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}
