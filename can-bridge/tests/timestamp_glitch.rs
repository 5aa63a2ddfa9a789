//! A frame stamped 1-5 s ahead of the stream (a timestamp glitch) against a real gap of 1-5 s (the
//! bus silent, then frames continue from the later time): the glitch costs that frame alone, the
//! gap costs nothing and its outputs are byte-identical to those recorded before the glitch rule
//! (`tests/timestamp_glitch/`, written by the code that accepted a frame up to 5 s ahead at once).
//!
//! `BLESS_TIMESTAMP_GLITCH=1 cargo test -p can-bridge --test timestamp_glitch` rewrites the
//! recorded outputs (only ever with a reviewed reason).
mod common;
use can_codec::Frame;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

const T0: u64 = 1_700_000_000_000_000;

/// `frames` as `candump -L can0 can1` could print them: the ego's frames on can0, printed 3 ms
/// late (so after object frames up to 3 ms newer), the objects' on can1.
fn two_ifaces(frames: &[(u64, Frame)]) -> String {
    let db = project_db();
    let ego = [id_of(&db, "EGO_MOTION"), id_of(&db, "EGO_SIZE")];
    let mut lines: Vec<(u64, usize)> = frames
        .iter()
        .enumerate()
        .map(|(i, (t, f))| (t + if ego.contains(&f.id) { 3_000 } else { 0 }, i))
        .collect();
    lines.sort();
    let mut s = String::new();
    for (_, i) in lines {
        let (t, f) = &frames[i];
        let iface = if ego.contains(&f.id) { "can0" } else { "can1" };
        can_codec::format_line(&mut s, *t, iface, f);
        s.push('\n');
    }
    s
}

/// 20 s of drive, the bus silent for `gap_us` after cycle 100 (first frame after it `gap_us`
/// after the last before it).
fn real_gap(gap_us: u64) -> Vec<(u64, Frame)> {
    let mut log = two_track_drive(&project_db(), 0..100, T0);
    let last = log.last().unwrap().0;
    log.extend(two_track_drive(&project_db(), 100..200, last + gap_us));
    log
}

/// 20 s of drive with the frames at `at` (indices into the clean log) stamped `ahead_us` ahead.
fn glitched(at: &[usize], ahead_us: u64) -> Vec<(u64, Frame)> {
    let mut log = two_track_drive(&project_db(), 0..200, T0);
    for &i in at {
        log[i].0 += ahead_us;
    }
    log
}

/// What `score-log` writes for a log: the events (all scores), the warning frames, and stderr.
struct Outputs {
    events: String,
    warnings: String,
    stderr: String,
    ok: bool,
}

fn score_log(frames: &[(u64, Frame)], extra: &[&str]) -> Outputs {
    score_log_text(&candump_log(frames), extra)
}

fn score_log_text(log: &str, extra: &[&str]) -> Outputs {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("drive.log"), log).unwrap();
    std::fs::write(tmp.path().join("model.rsk"), msra_blob()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_can-bridge"))
        .current_dir(tmp.path())
        .args([
            "score-log",
            "--log",
            "drive.log",
            "--model",
            "model.rsk",
            "--threshold",
            "1.5",
            "--all-scores",
            "--events-out",
            "events.jsonl",
            "--warnings-out",
            "warnings.log",
        ])
        .args(extra)
        .output()
        .unwrap();
    let read = |name: &str| std::fs::read_to_string(tmp.path().join(name)).unwrap_or_default();
    Outputs {
        events: read("events.jsonl"),
        warnings: read("warnings.log"),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        ok: out.status.success(),
    }
}

fn recorded(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("timestamp_glitch")
        .join(name)
}

/// `score-log`'s outputs on `frames` equal those recorded as `case` (or record them, blessing).
fn assert_as_recorded(case: &str, frames: &[(u64, Frame)], extra: &[&str]) -> Outputs {
    let out = score_log(frames, extra);
    assert!(out.ok, "{}", out.stderr);
    let files = [
        (format!("{case}.events.jsonl"), &out.events),
        (format!("{case}.warnings.log"), &out.warnings),
        (format!("{case}.stderr"), &out.stderr),
    ];
    if std::env::var_os("BLESS_TIMESTAMP_GLITCH").is_some() {
        std::fs::create_dir_all(recorded("")).unwrap();
        for (name, text) in &files {
            std::fs::write(recorded(name), text).unwrap();
        }
    }
    for (name, text) in &files {
        let want = std::fs::read_to_string(recorded(name))
            .unwrap_or_else(|e| panic!("{}: {e}", recorded(name).display()));
        // Of stderr, the run summary and the per-line problems (the start-up listing of the
        // map's inputs and the sanity notes do not depend on the timeline).
        let (text, want) = if name.ends_with(".stderr") {
            (run_lines(text), run_lines(&want))
        } else {
            ((*text).clone(), want)
        };
        assert!(
            text == want,
            "{case}: {name} differs from the recorded output\n--- now\n{text}"
        );
    }
    out
}

/// The lines of `score-log`'s stderr that report on the run: the summary, problems by log line
/// and the lost-lines verdict.
fn run_lines(stderr: &str) -> String {
    stderr
        .lines()
        .filter(|l| {
            l.starts_with("score-log: ") && !l.starts_with("score-log: sanity")
                || l.starts_with("drive.log")
                || l.contains("drive.log: lost")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Count of `what` in the run summary (`N what`), from stderr.
fn count(stderr: &str, what: &str) -> u64 {
    let i = stderr
        .find(&format!(" {what}"))
        .unwrap_or_else(|| panic!("no `{what}` in {stderr}"));
    let digits: String = stderr[..i]
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect();
    digits.chars().rev().collect::<String>().parse().unwrap()
}

#[test]
fn a_real_gap_of_2_s_or_4_9_s_loses_nothing_and_outputs_as_before() {
    for (case, gap_us) in [("gap_2s", 2_000_000u64), ("gap_4_9s", 4_900_000)] {
        let log = real_gap(gap_us);
        // With the reorder window (default) and without: the same outputs.
        for extra in [&[][..], &["--merge-wait-ms", "0"][..]] {
            let out = assert_as_recorded(case, &log, extra);
            assert_eq!(count(&out.stderr, "reordered"), 0, "{}", out.stderr);
            assert_eq!(count(&out.stderr, "off the timeline"), 0, "{}", out.stderr);
            assert_eq!(count(&out.stderr, "log segments"), 1, "{}", out.stderr);
            assert_eq!(count(&out.stderr, "scored"), 400, "{}", out.stderr);
            // The tracks went stale in the gap (the stale rule, not a new segment).
            assert!(out.events.contains(r#""reason":"stale""#), "{}", out.events);
        }
    }
    // Two interfaces interleaved with 3 ms inversions, put back in order by the window.
    let out = score_log_text(&two_ifaces(&real_gap(2_000_000)), &[]);
    let want = score_log(&real_gap(2_000_000), &[]);
    assert!(out.ok, "{}", out.stderr);
    assert_eq!(out.events, want.events);
    assert_eq!(out.warnings, want.warnings);
}

/// `score-log` on `log` loses exactly the frames of `lines` (off the timeline, each named by its
/// line) and otherwise scores and warns as on the clean drive, with and without the window.
fn assert_costs_only(log: &[(u64, Frame)], lines: &[u64]) {
    let clean = score_log(&two_track_drive(&project_db(), 0..200, T0), &[]);
    for extra in [&[][..], &["--merge-wait-ms", "0"][..]] {
        let out = score_log(log, extra);
        assert!(out.ok, "{}", out.stderr);
        let e = &out.stderr;
        assert_eq!(count(e, "off the timeline"), lines.len() as u64, "{e}");
        assert_eq!(count(e, "reordered"), 0, "{e}");
        assert_eq!(count(e, "log segments"), 1, "{e}");
        assert_eq!(count(e, "tracks dropped"), 0, "{e}");
        for line in lines {
            let (t, f) = log[*line as usize - 1];
            let named = format!("drive.log:{line}: frame {} at {t} us is far outside", f.id);
            assert!(e.contains(&named), "{named}: {e}");
        }
        assert!(
            e.contains(&format!("lost {} of 2000 lines", lines.len())),
            "{e}"
        );
        assert!(out.events == clean.events, "{}", out.events);
        assert!(out.warnings == clean.warnings, "{}", out.warnings);
    }
}

#[test]
fn one_frame_stamped_2_s_or_4_9_s_ahead_costs_that_frame_alone() {
    // Before: the frame was taken as the newest, the frames after it were a jump back of 2 s and
    // started a new log segment (both tracks and the ego dropped, an update lost as stale).
    assert_costs_only(&glitched(&[1000], 2_000_000), &[1001]);
    assert_costs_only(&glitched(&[1000], 4_900_000), &[1001]);
    // Mid-cycle (an object frame).
    assert_costs_only(&glitched(&[1003], 2_000_000), &[1004]);
}

#[test]
fn two_consecutive_frames_stamped_ahead_cost_those_two() {
    assert_costs_only(&glitched(&[1000, 1001], 2_000_000), &[1001, 1002]);
}

#[test]
fn a_frame_stamped_ahead_at_the_very_end_and_a_gap_just_before_the_end_are_as_before() {
    // The last frame stamped 2 s ahead cannot be told from a gap before it: it is processed, as
    // before (it makes no other frame late), and nothing is lost.
    let out = assert_as_recorded("ahead_last", &glitched(&[1999], 2_000_000), &[]);
    assert_eq!(count(&out.stderr, "off the timeline"), 0, "{}", out.stderr);
    // A real 2 s gap followed by only 2 frames (too few to confirm it): processed.
    let mut log = two_track_drive(&project_db(), 0..100, T0);
    let last = log.last().unwrap().0;
    log.extend(
        two_track_drive(&project_db(), 100..101, last + 2_000_000)
            .into_iter()
            .take(2),
    );
    let out = assert_as_recorded("gap_then_2_frames", &log, &[]);
    assert_eq!(count(&out.stderr, "off the timeline"), 0, "{}", out.stderr);
    assert!(
        out.stderr.contains("1002 lines; 1002 frames"),
        "{}",
        out.stderr
    );
}
