//! `riskctl inspect-model` names a file that is nearly a training checkpoint (JSON that does not
//! load as one) with the loader's reason; the `riskctl calibrate-domain --help` examples run as
//! written from the repository's root; the shipped blobs are named as `riskctl evaluate` names
//! their rows (`riskscore_eval::scoring::model_row_name`).
mod common;

use std::path::{Path, PathBuf};

use common::{riskctl, riskctl_in, shipped_model, stderr};
use riskscore_train::export::{Checkpoint, CheckpointModel};
use riskscore_train::train::msra::{MsraParams, MsraTermParams};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A valid MSRA checkpoint (one TTC2D term), as `riskctl train` writes it, at `dir/msra.json`.
fn msra_checkpoint(dir: &Path) -> PathBuf {
    let path = dir.join("msra.json");
    let ck = Checkpoint::new(
        CheckpointModel::Msra {
            params: MsraParams {
                terms: vec![MsraTermParams {
                    surrogate: "ttc2d".into(),
                    lo: 0.0,
                    hi: 10.0,
                    w: 1.0,
                    a: 1.0,
                    b: 0.0,
                }],
            },
        },
        serde_json::Value::Null,
    );
    ck.save(&path).unwrap();
    Checkpoint::load(&path).expect("the test's checkpoint loads");
    path
}

/// `riskctl inspect-model FILE`'s standard error; the command must fail with exit code 1.
fn inspect_fails(file: &Path) -> String {
    let o = riskctl(&["inspect-model", file.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    err
}

/// A checkpoint cut short (a copy interrupted, a download stopped) was reported as
/// `integrity check failed: not a model blob: magic [7b, 0a, 20, 20], expected "RSKM"`, with no
/// word of checkpoints; now it is named as a checkpoint that does not load, with the parse error's
/// line and column and how to get a blob.
#[test]
fn inspect_model_names_a_truncated_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let full = msra_checkpoint(dir.path());
    // The valid checkpoint keeps its message.
    let err = inspect_fails(&full);
    assert!(err.contains("it is a training checkpoint"), "{err}");
    let bytes = std::fs::read(&full).unwrap();
    let cut = dir.path().join("cut.json");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = inspect_fails(&cut);
    let file = cut.display().to_string();
    assert!(
        err.contains(&format!(
            "{file}: not a model blob: it looks like a training checkpoint"
        )),
        "{err}"
    );
    assert!(err.contains("but it does not load as one"), "{err}");
    assert!(
        err.contains("EOF while parsing") && err.contains("line ") && err.contains("column "),
        "{err}"
    );
    // The position is named once (it was `line 9, column 24: ... at line 9 column 24`).
    assert_eq!(err.matches("line ").count(), 1, "{err}");
    assert!(
        err.contains("riskctl export-model CHECKPOINT --out MODEL.rsk"),
        "{err}"
    );
    assert!(!err.contains("integrity check failed"), "{err}");
}

/// A checkpoint with a field removed (or renamed by hand), or of another version, is named as a
/// checkpoint that does not load, with the field (or the versions) the loader names.
#[test]
fn inspect_model_names_a_checkpoint_with_a_missing_field_or_another_version() {
    let dir = tempfile::tempdir().unwrap();
    let full = msra_checkpoint(dir.path());
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&full).unwrap()).unwrap();

    let mut missing = json.clone();
    let term = &mut missing["model"]["params"]["terms"][0];
    term.as_object_mut().unwrap().remove("w").unwrap();
    let path = dir.path().join("missing.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&missing).unwrap()).unwrap();
    let err = inspect_fails(&path);
    assert!(
        err.contains("it looks like a training checkpoint")
            && err.contains("but it does not load as one"),
        "{err}"
    );
    assert!(
        err.contains("missing field `w`") && err.contains("line "),
        "{err}"
    );
    assert_eq!(err.matches("line ").count(), 1, "{err}");
    assert!(err.contains("riskctl export-model"), "{err}");
    // Named at the term that lacks it, where it starts (it was where the model closes).
    assert!(
        err.contains(
            "line 8, column 9: `model.params.terms[0]` (the object that starts there) is \
             missing field `w`"
        ),
        "{err}"
    );

    // A string for a number names the field's path (it was serde's bare `invalid type: string
    // "x", expected f32`, at the position where the model closes).
    let mut typed = json.clone();
    typed["model"]["params"]["terms"][0]["w"] = serde_json::json!("x");
    let path = dir.path().join("typed.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&typed).unwrap()).unwrap();
    let err = inspect_fails(&path);
    assert!(
        err.contains(
            "line 14, column 18: `model.params.terms[0].w`: invalid type: string \"x\", \
             expected f32"
        ),
        "{err}"
    );
    assert_eq!(err.matches("line ").count(), 1, "{err}");

    let mut old = json.clone();
    old["version"] = serde_json::json!(2);
    let path = dir.path().join("old.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&old).unwrap()).unwrap();
    let err = inspect_fails(&path);
    assert!(
        err.contains("it looks like a training checkpoint") && err.contains("version 2"),
        "{err}"
    );

    // JSON meant as a checkpoint but without the format's name: it still starts like one.
    let mut renamed = json;
    let format = renamed.as_object_mut().unwrap().remove("format").unwrap();
    renamed["fromat"] = format;
    let path = dir.path().join("renamed.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&renamed).unwrap()).unwrap();
    let err = inspect_fails(&path);
    assert!(
        err.contains("it looks like a training checkpoint")
            && err.contains("but it does not load as one"),
        "{err}"
    );
    let path = dir.path().join("other.json");
    std::fs::write(&path, "{\"model\": ").unwrap();
    let err = inspect_fails(&path);
    assert!(
        err.contains("it starts like JSON, as a training checkpoint does")
            && err.contains("but it does not load as one")
            && err.contains("line 1"),
        "{err}"
    );
}

/// Bytes that are neither a blob nor JSON keep the blob's integrity error, with no word of
/// checkpoints.
#[test]
fn inspect_model_keeps_the_integrity_error_for_random_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("noise.rsk");
    // A fixed xorshift stream; its first byte is no `{` or white space.
    let mut x: u32 = 0x9E37_79B9;
    let mut bytes: Vec<u8> = (0..512)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 24) as u8
        })
        .collect();
    bytes[0] = 0x8F;
    std::fs::write(&path, &bytes).unwrap();
    let err = inspect_fails(&path);
    assert!(
        err.contains(&format!("{}: integrity check failed", path.display())),
        "{err}"
    );
    assert!(!err.contains("checkpoint"), "{err}");
    assert!(!err.contains("JSON"), "{err}");
}

/// The `riskctl` command lines of the examples at the end of `calibrate-domain --help`, each
/// joined over its `\` continuations and split into words (without the leading `riskctl`).
fn calibrate_domain_examples() -> Vec<Vec<String>> {
    let o = riskctl(&["calibrate-domain", "--help"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let help = String::from_utf8(o.stdout).unwrap();
    let examples = &help[help.find("\nExample").expect("an Example(s) section")..];
    let mut commands = Vec::new();
    let mut current: Option<String> = None;
    for line in examples.lines() {
        let line = line.trim();
        let (text, continues) = match line.strip_suffix('\\') {
            Some(text) => (text, true),
            None => (line, false),
        };
        match current.as_mut() {
            Some(command) => command.push_str(&format!(" {text}")),
            None if text.starts_with("riskctl ") => current = Some(text.to_owned()),
            None => continue,
        }
        if !continues {
            commands.push(current.take().unwrap());
        }
    }
    assert!(current.is_none(), "an example ends in `\\`: {current:?}");
    commands
        .iter()
        .map(|c| c.split_whitespace().skip(1).map(str::to_owned).collect())
        .collect()
}

/// The flags of the examples whose value is a path read, and written.
const INPUT_FLAGS: [&str; 3] = ["--model", "--events", "--fallback-from"];
const OUTPUT_FLAGS: [&str; 1] = ["--out"];

/// The help's examples named `data/sim` and `data/ngsim-us101`, neither of which exists (the
/// shipped extract is `data/ngsim-us101-safe`; a simulated folder is what `riskctl simulate
/// --out` writes). Every path an example reads now exists in the repository or is written by an
/// earlier example; and the examples run, in order, as written from the repository's root (in a
/// copy of it holding `models/` and `data/`, so that nothing is written into the repository).
#[test]
fn calibrate_domain_help_examples_name_real_paths_and_run() {
    let examples = calibrate_domain_examples();
    assert!(
        examples.iter().any(|e| e[0] == "calibrate-domain"),
        "{examples:?}"
    );
    let mut written: Vec<String> = Vec::new();
    for words in &examples {
        assert!(
            ["simulate", "calibrate-domain"].contains(&words[0].as_str()),
            "{words:?}"
        );
        for (i, word) in words.iter().enumerate() {
            let flag = i.checked_sub(1).map(|f| words[f].as_str());
            if flag.is_some_and(|f| OUTPUT_FLAGS.contains(&f)) {
                written.push(word.clone());
            } else if flag.is_some_and(|f| INPUT_FLAGS.contains(&f)) {
                assert!(
                    repo().join(word).exists() || written.contains(word),
                    "{words:?}: {word} neither exists in the repository nor is written by an \
                     earlier example"
                );
            } else {
                assert!(
                    !word.contains('/'),
                    "{words:?}: {word} is a path of a flag this test does not know"
                );
            }
        }
    }

    let dir = tempfile::tempdir().unwrap();
    for shared in ["models", "data"] {
        std::os::unix::fs::symlink(repo().join(shared), dir.path().join(shared)).unwrap();
    }
    for words in &examples {
        let args: Vec<&str> = words.iter().map(String::as_str).collect();
        let o = riskctl_in(dir.path(), &args);
        assert!(o.status.success(), "riskctl {words:?}: {}", stderr(&o));
    }
    // Each calibrate-domain example wrote its blob, with the policy it asked for.
    for words in examples.iter().filter(|e| e[0] == "calibrate-domain") {
        let at = |flag: &str| &words[words.iter().position(|w| w == flag).unwrap() + 1];
        let out = dir.path().join(at("--out"));
        let o = riskctl(&["inspect-model", out.to_str().unwrap()]);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", stderr(&o));
        let policy = text
            .lines()
            .find_map(|l| l.trim().strip_prefix("policy"))
            .map(str::trim_start);
        assert!(
            policy.is_some_and(|p| p.starts_with(&format!("{} ", at("--policy")))),
            "{words:?}: {text}"
        );
    }
}

/// `calibrate-domain` warned about a calibrated threshold only when it added or changed a blend
/// weight: a policy change or a refitted fallback left "5.0 % do" in the blob, silently, with
/// 14.7 % of the same sequences warning. Now any change of what the guard scores warns; a guard
/// that scores as before (flag-only, like no record) does not.
#[test]
fn calibrate_domain_warns_when_it_changes_the_scores_a_calibrated_threshold_was_chosen_on() {
    let dir = tempfile::tempdir().unwrap();
    let events = repo().join("data/ngsim-us101-safe");
    let run = |model: &Path, extra: &[&str], out: &str| {
        let out = dir.path().join(out);
        let mut args = vec![
            "calibrate-domain",
            "--model",
            model.to_str().unwrap(),
            "--events",
            events.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = riskctl(&args);
        let err = stderr(&o);
        assert!(o.status.success(), "{err}");
        (out, err.contains("run `riskctl calibrate` on it again"))
    };
    let shipped = shipped_model("drl-default.rsk");
    let msra = shipped_model("msra-default.rsk");
    // Blend -> flag-only: the scores change.
    let (flag_only, warned) = run(&shipped, &[], "flag-only.rsk");
    assert!(warned, "blend -> flag-only");
    // Blend at the same weight, the fallback refitted on other frames: they change too.
    let reblend = [
        "--policy",
        "blend",
        "--fallback-from",
        msra.to_str().unwrap(),
    ];
    assert!(
        run(&shipped, &reblend, "reblend.rsk").1,
        "refitted fallback"
    );
    // Flag-only again (new ranges, same scores: those of the bare network): no warning.
    assert!(
        !run(&flag_only, &[], "again.rsk").1,
        "flag-only -> flag-only"
    );
    // The DRL's own fallback terms (the reference TAdv) come from the DRL blob itself; the
    // shipped MSRA's read TAdv-corridor.
    let own = [
        "--policy",
        "blend",
        "--fallback-from",
        shipped.to_str().unwrap(),
    ];
    let (own, _) = run(&shipped, &own, "own.rsk");
    let text = |p: &Path| {
        String::from_utf8_lossy(&riskctl(&["inspect-model", p.to_str().unwrap()]).stdout)
            .to_string()
    };
    let own_text = text(&own);
    assert!(own_text.contains("fallback term 0 TAdv:"), "{own_text}");
    let msra_text = text(&dir.path().join("reblend.rsk"));
    assert!(
        msra_text.contains("fallback term 0 TAdv-corridor:"),
        "{msra_text}"
    );
    // A blob with neither MSRA terms nor a fallback record is refused, named.
    let o = riskctl(&[
        "calibrate-domain",
        "--model",
        shipped.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--policy",
        "blend",
        "--fallback-from",
        flag_only.to_str().unwrap(),
        "--out",
        dir.path().join("y.rsk").to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(
        err.contains("flag-only.rsk: a DRL blob without a kinematic fallback"),
        "{err}"
    );
}

/// `calibrate` counted a folder named twice (`d` and `d/`) twice, in the share and in the blob's
/// record ("d + d"), and said nothing of safe events that yield no sequence, which the threshold
/// is then chosen without (`evaluate` lists them).
#[test]
fn calibrate_reads_a_repeated_folder_once_and_lists_events_without_a_sequence() {
    use riskscore_data::events::EventWriter;
    let dir = tempfile::tempdir().unwrap();
    let normal = dir.path().join("normal");
    let mut w = EventWriter::create(&normal).unwrap();
    for k in 0..6 {
        w.write_event(&common::calm_following(
            format!("calm-{k}"),
            10.0 + k as f32,
            10.0,
        ))
        .unwrap();
    }
    // Three frames, 0.2 s: too short for a safe sequence.
    let mut short = common::calm_following("short".into(), 12.0, 10.0);
    short.frames.truncate(3);
    short.t_end = 0.2;
    w.write_event(&short).unwrap();
    w.finish().unwrap();
    let out = dir.path().join("msra.rsk");
    let again = format!("{}/", normal.display());
    let o = riskctl(&[
        "calibrate",
        "--model",
        shipped_model("msra-default.rsk").to_str().unwrap(),
        "--normal",
        normal.to_str().unwrap(),
        "--normal",
        &again,
        "--false-alarm-rate",
        "50",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains(&format!("note: --normal {again} is")), "{err}");
    assert!(err.contains("it is read once"), "{err}");
    assert!(
        err.contains(&format!(
            "1 event(s) of {} yield no sequence under the preparation rules",
            normal.display()
        )) && err.contains("event `short`"),
        "{err}"
    );
    let text = String::from_utf8_lossy(&riskctl(&["inspect-model", out.to_str().unwrap()]).stdout)
        .to_string();
    assert!(
        text.contains("of 6 normal-driving sequences of normal warn"),
        "{text}"
    );
}

/// The shipped blobs' row names, one for each method (`model_row_name`, the only row namer): an
/// MSRA blob with a GSSM term is `MSRA-GSSM`, and `riskctl evaluate` prints that row.
#[test]
fn shipped_blobs_are_named_as_riskctl_evaluate_names_their_rows() {
    for (file, row) in [
        ("gssm-default.rsk", "GSSM"),
        ("ssra-default.rsk", "SSRA"),
        ("msra-gssm.rsk", "MSRA-GSSM"),
        ("drl-default.rsk", "DRL"),
        ("msra-default.rsk", "MSRA"),
    ] {
        let bytes = std::fs::read(shipped_model(file)).unwrap();
        let model = scorer_core::model::decode(&bytes).unwrap();
        assert_eq!(
            riskscore_eval::scoring::model_row_name(&model),
            row,
            "{file}"
        );
    }
    let out = riskctl_in(
        &repo(),
        &[
            "evaluate",
            "--model",
            "models/msra-gssm.rsk",
            "--events",
            "data/ngsim-us101-safe",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    let rows: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("| "))
        .filter_map(|l| l.split(" |").next())
        .filter(|name| name.starts_with("MSRA"))
        .collect();
    assert!(!rows.is_empty(), "{text}");
    assert!(rows.iter().all(|&name| name == "MSRA-GSSM"), "{text}");
}
