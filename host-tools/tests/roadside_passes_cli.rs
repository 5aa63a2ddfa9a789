//! `riskctl roadside-passes`: writes the 480 safe passes that load as an event folder, and refuses
//! an existing folder without touching it.
use std::process::Command;

const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

#[test]
fn writes_every_pass_as_a_safe_event_and_refuses_an_existing_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("roadside");
    let o = Command::new(RISKCTL)
        .args(["roadside-passes", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let folder = riskscore_data::events::load_prepared(
        &out,
        &riskscore_data::events::PrepareConfig::default(),
    )
    .unwrap();
    assert_eq!(folder.counts.safe, 480);
    assert_eq!(folder.counts.crash + folder.counts.near_crash, 0);
    assert!(folder.load_issues.is_empty(), "{:?}", folder.load_issues);
    assert!(
        folder.prepare_issues.is_empty(),
        "{:?}",
        folder.prepare_issues
    );

    let before = std::fs::read(out.join("frames.csv")).unwrap();
    let again = Command::new(RISKCTL)
        .args(["roadside-passes", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("exists"));
    assert_eq!(std::fs::read(out.join("frames.csv")).unwrap(), before);
}
