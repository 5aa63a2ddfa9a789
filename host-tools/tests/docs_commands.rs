//! The user guides against the code: every `riskctl` flag a guide shows exists in that
//! (sub)command's `--help`, every relative link between the guides reaches a file and, with
//! `#anchor`, a heading of it, and the configuration block of docs/gssm.md is the built-in
//! default. A reader follows the guides literally; a renamed flag or heading must take the guide
//! with it.
mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::riskctl;

/// The guides checked here (README.md and the docs pages a user reads to run `riskctl`).
const GUIDES: [&str; 13] = [
    "README.md",
    "docs/benchmarks.md",
    "docs/domain-guard.md",
    "docs/domain.md",
    "docs/evaluation.md",
    "docs/event-format.md",
    "docs/fuzzing.md",
    "docs/glossary.md",
    "docs/gssm.md",
    "docs/outputs.md",
    "docs/real-data.md",
    "docs/scale.md",
    "docs/training.md",
];

/// `riskctl`'s subcommands; the value lists the sub-subcommands of those that have them.
const SUBCOMMANDS: [(&str, &[&str]); 19] = [
    ("ssm", &[]),
    ("simulate", &[]),
    ("train", &[]),
    ("evaluate", &[]),
    ("score", &[]),
    ("ablation", &[]),
    ("export-model", &[]),
    ("inspect-model", &[]),
    ("calibrate", &[]),
    ("calibrate-domain", &[]),
    ("plot", &[]),
    ("roadside-passes", &[]),
    (
        "gssm",
        &["fit", "align", "msra", "ship", "cv", "augmentation", "nll"],
    ),
    ("import", &["commonroad"]),
    ("events-to-candump", &[]),
    ("demo", &[]),
    ("benchmark", &["transfer", "domains"]),
    ("completions", &[]),
    ("man", &[]),
];

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(repo().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The guide as logical lines: a line ending in `\` continues on the next, and an inline code
/// span (single backticks) that wraps is one line; fenced blocks are kept line by line.
fn logical_lines(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fenced = false;
    let mut current = String::new();
    let mut start = 0;
    let mut in_span = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            if !current.is_empty() {
                out.push((start, std::mem::take(&mut current)));
            }
            fenced = !fenced;
            in_span = false;
            continue;
        }
        if current.is_empty() {
            start = i + 1;
        }
        let (body, continued) = match line.trim_end().strip_suffix('\\') {
            Some(b) => (b, true),
            None => (line, false),
        };
        current.push_str(body);
        if !fenced {
            in_span ^= body.matches('`').count() % 2 == 1;
        }
        if continued || (in_span && !fenced) {
            current.push(' ');
        } else {
            out.push((start, std::mem::take(&mut current)));
        }
    }
    if !current.is_empty() {
        out.push((start, current));
    }
    out
}

/// One command a guide shows: the (sub)command paths it may mean and the flags it uses.
struct Shown {
    line: usize,
    paths: Vec<Vec<String>>,
    flags: Vec<String>,
}

fn shown_commands(text: &str) -> Vec<Shown> {
    let mut shown = Vec::new();
    for (line, logical) in logical_lines(text) {
        let mut rest = logical.as_str();
        while let Some(at) = rest.find("riskctl ") {
            let before = rest[..at].chars().last();
            let after = &rest[at + "riskctl ".len()..];
            rest = after;
            if before.is_some_and(|c| c.is_alphanumeric() || c == '-' || c == '_') {
                continue;
            }
            // The command ends at a comment, a pipe, the end of its code span or of its clause.
            let end = ["`", " #", " | ", ";", "(", ")", ", ", ": "]
                .iter()
                .filter_map(|t| after.find(t))
                .min()
                .unwrap_or(after.len());
            let mut words = after[..end].split_whitespace();
            let Some(top) = words.next() else { continue };
            let Some((_, subs)) = SUBCOMMANDS.iter().find(|(name, _)| *name == top) else {
                continue;
            };
            let mut words: Vec<&str> = words.collect();
            let paths: Vec<Vec<String>> = if subs.is_empty() {
                vec![vec![top.to_owned()]]
            } else {
                let named: Vec<&str> = words
                    .first()
                    .map(|w| w.split('|').filter(|s| subs.contains(s)).collect())
                    .unwrap_or_default();
                if named.is_empty() {
                    // No subcommand named (`riskctl gssm ...`): any of its subcommands.
                    subs.iter()
                        .map(|s| vec![top.to_owned(), (*s).to_owned()])
                        .collect()
                } else {
                    words.remove(0);
                    named
                        .iter()
                        .map(|s| vec![top.to_owned(), (*s).to_owned()])
                        .collect()
                }
            };
            let flags = words
                .iter()
                .filter_map(|w| w.trim_start_matches('[').strip_prefix("--"))
                .filter(|w| w.starts_with(|c: char| c.is_ascii_lowercase()))
                .map(|w| {
                    let name: String = w
                        .chars()
                        .take_while(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || *c == '-')
                        .collect();
                    format!("--{}", name.trim_end_matches('-'))
                })
                .collect();
            shown.push(Shown { line, paths, flags });
        }
    }
    shown
}

/// Whether `help` names `flag` as a whole word (`--out` is not found in `--out-dir`).
fn names_flag(help: &str, flag: &str) -> bool {
    let word = |c: char| c.is_ascii_alphanumeric() || c == '-';
    help.match_indices(flag).any(|(i, _)| {
        let before = help[..i].chars().last();
        let after = help[i + flag.len()..].chars().next();
        !before.is_some_and(word) && !after.is_some_and(word)
    })
}

#[test]
fn every_riskctl_flag_a_guide_shows_exists() {
    let mut helps: BTreeMap<Vec<String>, String> = BTreeMap::new();
    let mut missing = Vec::new();
    let mut checked = 0;
    for guide in GUIDES {
        for shown in shown_commands(&read(guide)) {
            for flag in &shown.flags {
                checked += 1;
                let known = shown.paths.iter().any(|path| {
                    let help = helps.entry(path.clone()).or_insert_with(|| {
                        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
                        args.push("--help");
                        let out = riskctl(&args);
                        assert!(out.status.success(), "riskctl {args:?} failed");
                        String::from_utf8_lossy(&out.stdout).into_owned()
                    });
                    names_flag(help, flag)
                });
                if !known {
                    missing.push(format!(
                        "{guide}:{}: riskctl {} has no {flag}",
                        shown.line,
                        shown.paths[0].join(" ")
                    ));
                }
            }
        }
    }
    assert!(
        checked > 200,
        "only {checked} flags found: is the parser still right?"
    );
    assert!(
        missing.is_empty(),
        "flags the guides show but riskctl lacks:\n{}",
        missing.join("\n")
    );
}

/// GitHub's anchor of a heading: lower case, spaces to `-`, punctuation other than `-`/`_` dropped.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced && line.starts_with('#') {
            out.push(anchor(line.trim_start_matches('#')));
        }
    }
    out
}

#[test]
fn every_relative_link_of_a_guide_reaches_its_file_and_heading() {
    let mut broken = Vec::new();
    for guide in GUIDES {
        let text = read(guide);
        let dir = repo().join(guide).parent().unwrap().to_path_buf();
        for (n, line) in text.lines().enumerate() {
            for (i, _) in line.match_indices("](") {
                let target = &line[i + 2..];
                let Some(end) = target.find(')') else {
                    continue;
                };
                let target = &target[..end];
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let (file, anchor) = match target.split_once('#') {
                    Some((f, a)) => (f, Some(a)),
                    None => (target, None),
                };
                let path = if file.is_empty() {
                    repo().join(guide)
                } else {
                    dir.join(file)
                };
                if !path.exists() {
                    broken.push(format!("{guide}:{}: {target}: no such file", n + 1));
                } else if let Some(a) = anchor {
                    let markdown = file.is_empty() || file.ends_with(".md");
                    if markdown && !anchors(&path).iter().any(|h| h == a) {
                        broken.push(format!("{guide}:{}: {target}: no such heading", n + 1));
                    }
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_gssm_configuration_block_of_docs_gssm_md_is_the_default() {
    let text = read("docs/gssm.md");
    let start = text
        .find("```toml\n")
        .expect("docs/gssm.md has a toml block")
        + 8;
    let block = &text[start..start + text[start..].find("```").unwrap()];
    let parsed = riskscore_train::gssm::GssmConfig::from_toml(block, "docs/gssm.md")
        .unwrap_or_else(|e| panic!("docs/gssm.md's configuration does not parse: {e}"));
    assert_eq!(parsed, riskscore_train::gssm::GssmConfig::default());
}

/// The configuration keys a guide names in code spans (`optimiser.learning_rate`,
/// `[comparisons.physics] lane_shift`, `fit.batch`), as dotted paths.
fn named_config_keys(text: &str) -> Vec<(usize, String)> {
    const SECTIONS: [&str; 9] = [
        "comparisons",
        "objective",
        "optimiser",
        "drl",
        "msra",
        "quantisation",
        "guard",
        "fit",
        "ssra",
    ];
    const FILE_ENDINGS: [&str; 6] = ["rsk", "json", "csv", "md", "toml", "rs"];
    let mut keys = Vec::new();
    for (n, line) in text.lines().enumerate() {
        for span in line.split('`').skip(1).step_by(2) {
            let path = if let Some(inner) = span.strip_prefix('[') {
                let Some((section, rest)) = inner.split_once(']') else {
                    continue;
                };
                let key = rest.split(['=', ' ']).find(|w| !w.is_empty()).unwrap_or("");
                if key.is_empty() {
                    section.to_owned()
                } else {
                    format!("{section}.{key}")
                }
            } else {
                span.split(['=', ' ']).next().unwrap_or("").to_owned()
            };
            let parts: Vec<&str> = path.split('.').collect();
            let plausible = parts.len() >= 2 || span.starts_with('[');
            let well_formed = parts.iter().all(|p| {
                !p.is_empty()
                    && p.chars()
                        .all(|c| c.is_ascii_lowercase() || c == '_' || c == '*')
            });
            if plausible
                && well_formed
                && SECTIONS.contains(&parts[0])
                && !FILE_ENDINGS.contains(parts.last().unwrap())
            {
                keys.push((n + 1, path));
            }
        }
    }
    keys
}

/// Whether the dotted `path` (with `*` for any table) names a key of `value`.
fn has_key(value: &serde_json::Value, path: &[&str]) -> bool {
    let Some((first, rest)) = path.split_first() else {
        return true;
    };
    let serde_json::Value::Object(map) = value else {
        return false;
    };
    if *first == "*" {
        map.values().any(|v| has_key(v, rest))
    } else {
        map.get(*first).is_some_and(|v| has_key(v, rest))
    }
}

#[test]
fn every_configuration_key_a_guide_names_exists() {
    let train = serde_json::to_value(riskscore_train::train::TrainConfig::default()).unwrap();
    let gssm = serde_json::to_value(riskscore_train::gssm::GssmConfig::default()).unwrap();
    let mut unknown = Vec::new();
    let mut checked = 0;
    for guide in GUIDES {
        for (line, key) in named_config_keys(&read(guide)) {
            checked += 1;
            let path: Vec<&str> = key.split('.').collect();
            if !has_key(&train, &path) && !has_key(&gssm, &path) {
                unknown.push(format!("{guide}:{line}: `{key}`"));
            }
        }
    }
    assert!(
        checked > 20,
        "only {checked} keys found: is the parser still right?"
    );
    assert!(
        unknown.is_empty(),
        "configuration keys the guides name but neither configs/train.toml's nor the GSSM \
         configuration's parser knows:\n{}",
        unknown.join("\n")
    );
}

/// The backticked names in the first cell of every row of the first table after `heading`.
fn first_column_of_table_after(text: &str, heading: &str) -> Vec<String> {
    let start = text
        .find(heading)
        .unwrap_or_else(|| panic!("no {heading:?}"));
    let mut names = Vec::new();
    let mut in_table = false;
    for line in text[start..].lines().skip(1) {
        if !line.starts_with('|') {
            if in_table {
                break;
            }
            continue;
        }
        in_table = true;
        let cell = line.split('|').nth(1).unwrap_or("");
        names.extend(cell.split('`').skip(1).step_by(2).map(str::to_owned));
    }
    names
}

#[test]
fn the_sequences_out_columns_of_docs_evaluation_md_are_the_written_ones() {
    let text = read("docs/evaluation.md");
    let documented = first_column_of_table_after(&text, "**Per-sequence rows**");
    assert_eq!(documented, riskscore_train::domains::sequences::COLUMNS);
    let claims = format!("`round,{}`", riskscore_eval::claims::CSV_COLUMNS.join(","));
    assert!(
        text.contains(&claims),
        "docs/evaluation.md does not give claims.csv's columns as {claims}"
    );
}

#[test]
fn the_events_csv_columns_of_docs_event_format_md_are_the_written_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let run = riskctl(&["simulate", "--events", "3", "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", common::stderr(&run));
    let events = std::fs::read_to_string(out.join("events.csv")).unwrap();
    let header: Vec<&str> = events.lines().next().unwrap().split(',').collect();
    let guide = read("docs/event-format.md");
    let documented = first_column_of_table_after(&guide, "## `events.csv`");
    assert_eq!(documented, header);

    // scenarios.csv as `riskctl simulate` and `riskctl import commonroad` write it.
    let imported = dir.path().join("real");
    let scenarios = repo().join("host-tools/tests/data/commonroad");
    let run = riskctl(&[
        "import",
        "commonroad",
        "--out",
        imported.to_str().unwrap(),
        scenarios.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", common::stderr(&run));
    for folder in [&out, &imported] {
        let provenance = std::fs::read_to_string(folder.join("scenarios.csv")).unwrap();
        let header = format!("`{}`", provenance.lines().next().unwrap());
        assert!(
            guide.contains(&header),
            "docs/event-format.md does not give scenarios.csv's columns as {header}"
        );
    }
}
