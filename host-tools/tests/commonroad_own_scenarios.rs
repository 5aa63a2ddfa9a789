//! `riskctl import commonroad` on scenarios a user brings: files from the CommonRoad dataset
//! converters (highD, inD, ...), simulator interfaces or hand editing, which differ from the
//! NGSIM benchmark files the committed extracts come from (geo-referenced coordinates, road users
//! given by an initial state only, ...). The XML is built here, so every expected number follows
//! from the text of the test.
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::Command;

use riskscore_data::import::commonroad::{
    import_to_dir, parse_scenario, safe_interactions, scenario_files, Ignored, InteractionRules,
    Problem, FAR_COORDINATE_M,
};

const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

/// One recorded state: (step, x, y, orientation, speed).
type State = (i64, f64, f64, f64, f64);

fn state_xml(tag: &str, (step, x, y, orientation, speed): State) -> String {
    format!(
        "<{tag}><position><point><x>{x}</x><y>{y}</y></point></position>\
         <orientation><exact>{orientation}</exact></orientation><time><exact>{step}</exact></time>\
         <velocity><exact>{speed}</exact></velocity>\
         <acceleration><exact>0</exact></acceleration></{tag}>\n"
    )
}

/// A car (4.5 m x 1.8 m) with the given states: the first is its `<initialState>`, the rest its
/// `<trajectory>` (none: no `<trajectory>` element at all).
fn car(id: u32, states: &[State]) -> String {
    let mut s = format!(
        "<dynamicObstacle id=\"{id}\"><type>car</type><shape><rectangle><length>4.5</length>\
         <width>1.8</width></rectangle></shape>\n{}",
        state_xml("initialState", states[0])
    );
    if states.len() > 1 {
        s.push_str("<trajectory>\n");
        for st in &states[1..] {
            s.push_str(&state_xml("state", *st));
        }
        s.push_str("</trajectory>\n");
    }
    s.push_str("</dynamicObstacle>\n");
    s
}

fn scenario(cars: &[String]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<commonRoad commonRoadVersion=\"2020a\" \
         benchmarkID=\"ZAM_Own-1_1_T-1\" timeStepSize=\"0.1\">\n",
    );
    for c in cars {
        s.push_str(c);
    }
    let _ = writeln!(s, "</commonRoad>");
    s
}

/// 50 states at 0.1 s of a car driving east at 10 m/s from (x0, y0).
fn east(x0: f64, y0: f64) -> Vec<State> {
    (0..50).map(|k| (k, x0 + k as f64, y0, 0.0, 10.0)).collect()
}

/// Two cars side by side in adjacent lanes, 0.1 m between their boxes (centres 1.9 m apart on
/// 1.8 m wide cars, 0.5 m longitudinal offset), shifted by `(ox, oy)`.
fn side_by_side(ox: f64, oy: f64) -> String {
    scenario(&[
        car(1, &east(ox, oy + 0.3)),
        car(2, &east(ox + 0.5, oy + 2.2)),
    ])
}

/// The same recorded traffic in a geo-referenced frame (a UTM easting and northing, as files with
/// such coordinates have) gives the same interactions as in a local frame: positions are taken
/// relative to a local origin before they become `f32`, which resolves a northing of 5,400 km to
/// only 0.5 m and would round two cars 0.1 m apart into overlapping boxes (dropped as recording
/// artefacts: nothing imported).
#[test]
fn utm_coordinates_are_taken_relative_to_a_local_origin() {
    let rules = InteractionRules::default();
    let local = parse_scenario(&side_by_side(0.0, 0.0), "local.xml", "local").unwrap();
    assert_eq!(local.origin, (0.0, 0.0));
    let (found_local, counts_local) = safe_interactions(&local, &rules);
    assert_eq!(counts_local.sequences, 2);
    assert!((found_local[0].min_gap - 0.1).abs() < 1e-4);

    let utm = parse_scenario(&side_by_side(500_000.0, 5_400_000.0), "utm.xml", "utm").unwrap();
    assert_eq!(utm.origin, (500_000.0, 5_400_000.0));
    // Positions relative to the origin, exactly as recorded minus the origin.
    let s0 = utm.tracks[1].states[0];
    assert!(
        (s0.x - 0.5).abs() < 1e-6 && (s0.y - 2.2).abs() < 1e-6,
        "{s0:?}"
    );
    let (found, counts) = safe_interactions(&utm, &rules);
    assert_eq!(counts.overlap_frames, 0, "{counts:?}");
    assert_eq!(counts.sequences, 2, "{counts:?}");
    for (a, b) in found.iter().zip(&found_local) {
        assert_eq!(a.event.frames.len(), b.event.frames.len());
        assert!(
            (a.min_gap - b.min_gap).abs() < 1e-4,
            "{} {}",
            a.min_gap,
            b.min_gap
        );
        // Written positions are local: within the resolution f32 keeps to the centimetre.
        let f = &a.event.frames[0];
        assert!(f.ego.x.abs() < 100.0 && f.ego.y.abs() < 100.0, "{f:?}");
    }

    // A file within FAR_COORDINATE_M keeps its own frame (the committed extracts).
    let near = FAR_COORDINATE_M - 100.0;
    let kept = parse_scenario(&side_by_side(near, 0.0), "near.xml", "near").unwrap();
    assert_eq!(kept.origin, (0.0, 0.0));
    assert_eq!(kept.tracks[0].states[0].x, near);
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "riskscore-own-scenarios-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The command says which files were moved and by how much, and the event folder holds the
/// local positions.
#[test]
fn the_import_names_the_files_moved_to_a_local_origin() {
    let dir = temp_dir("utm");
    let input = dir.join("utm.xml");
    std::fs::write(&input, side_by_side(500_000.0, 5_400_000.0)).unwrap();
    let out = dir.join("out");
    let o = Command::new(RISKCTL)
        .args(["import", "commonroad", "--out"])
        .arg(&out)
        .arg(&input)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        stdout.contains("local origin in 1 file(s)")
            && stdout.contains("minus (500000, 5400000) m"),
        "{stdout}"
    );
    assert!(stdout.contains("wrote 2 safe sequences"), "{stdout}");
    let frames = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let first = frames.lines().nth(1).unwrap();
    assert!(first.starts_with("utm/1-2@0#0,0,0,0.3,"), "{first}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A dynamic obstacle with an `<initialState>` and no `<trajectory>` is valid CommonRoad (the
/// prediction is optional; converters write one for a road user seen at a single step): it is
/// ignored and counted like other road users that are not tracks, not reported as malformed.
#[test]
fn an_obstacle_with_only_an_initial_state_is_ignored_not_an_issue() {
    let text = scenario(&[
        car(1, &east(0.0, 0.0)),
        car(2, &east(15.0, 0.0)),
        car(3, &[(20, 40.0, 0.0, 0.0, 10.0)]),
    ]);
    let s = parse_scenario(&text, "own.xml", "own").unwrap();
    assert!(s.issues.is_empty(), "{:?}", s.issues);
    assert_eq!(s.ignored, [("3".to_string(), Ignored::InitialStateOnly)]);
    assert_eq!(s.tracks.len(), 2);
    assert_eq!(
        Ignored::InitialStateOnly.to_string(),
        "initial state only, no trajectory"
    );
    // Neither an initial state nor a trajectory: still a malformed road user, with its line.
    let broken = text.replace(&state_xml("initialState", (20, 40.0, 0.0, 0.0, 10.0)), "");
    let s = parse_scenario(&broken, "own.xml", "own").unwrap();
    assert_eq!(s.issues.len(), 1);
    let line = 1 + broken
        .lines()
        .position(|l| l.starts_with("<dynamicObstacle id=\"3\""))
        .unwrap();
    assert!(
        s.issues[0].to_string().starts_with(&format!(
            "own.xml:{line}: <dynamicObstacle id=3>: missing <trajectory>"
        )),
        "{}",
        s.issues[0]
    );
}

/// A compressed scenario file is named with its format, whether it was given by name (any
/// extension) or found in a folder as `*.xml.gz`, where the search used to pass over it in
/// silence; the other files are imported.
#[test]
fn compressed_files_are_named_with_their_format_and_the_rest_is_imported() {
    let dir = temp_dir("compressed");
    let input = dir.join("in");
    std::fs::create_dir_all(&input).unwrap();
    std::fs::write(
        input.join("a.xml"),
        scenario(&[car(1, &east(0.0, 0.0)), car(2, &east(15.0, 0.0))]),
    )
    .unwrap();
    // The gzip magic number and deflate method, then anything: never read as text.
    let gzip = [
        0x1F, 0x8B, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x03, 0xDF,
    ];
    std::fs::write(input.join("b.xml.gz"), gzip).unwrap();
    std::fs::write(input.join("c.xml"), gzip).unwrap();
    let (files, _) = scenario_files(std::slice::from_ref(&input)).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["a.xml", "b.xml.gz", "c.xml"]);

    let summary = import_to_dir(
        std::slice::from_ref(&input),
        &dir.join("out"),
        &InteractionRules::default(),
    )
    .unwrap();
    assert_eq!(summary.files, 1);
    assert_eq!(summary.counts.sequences, 2);
    let issues: Vec<String> = summary.issues.iter().map(ToString::to_string).collect();
    assert_eq!(issues.len(), 2, "{issues:?}");
    for (issue, name) in summary.issues.iter().zip(["b.xml.gz", "c.xml"]) {
        assert!(issue.file.ends_with(name), "{issue}");
        assert_eq!(issue.line, 1);
        assert_eq!(issue.problem, Problem::Compressed("gzip"), "{issue}");
        assert!(
            issue.to_string().ends_with(
                ":1: gzip-compressed: decompress it first (scenario files are read as XML text)"
            ),
            "{issue}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A road user without an `id` (or with an empty one) is skipped with an issue naming its line:
/// event ids are built from obstacle ids, and two of them used to write clashing events
/// (`own/1-?@0#0` twice) that an event folder then dropped, both rows, far from the cause.
#[test]
fn a_road_user_without_an_id_is_an_issue_not_a_clashing_event() {
    let text = scenario(&[
        car(1, &east(0.0, 0.0)),
        car(2, &east(15.0, 0.0)),
        car(3, &east(30.0, 0.0)),
        car(4, &east(7.5, 0.0)),
    ])
    .replace("<dynamicObstacle id=\"2\">", "<dynamicObstacle>")
    .replace("<dynamicObstacle id=\"3\">", "<dynamicObstacle id=\" \">");
    let s = parse_scenario(&text, "own.xml", "own").unwrap();
    let ids: Vec<&str> = s.tracks.iter().map(|t| t.id.as_str()).collect();
    assert_eq!(ids, ["1", "4"]);
    let line = |id: &str| {
        1 + text
            .lines()
            .position(|l| l.starts_with(&format!("<dynamicObstacle{id}>")))
            .unwrap()
    };
    let issues: Vec<String> = s.issues.iter().map(ToString::to_string).collect();
    assert_eq!(
        issues,
        [
            format!(
                "own.xml:{}: <dynamicObstacle id=?>: missing attribute `id`",
                line("")
            ),
            format!(
                "own.xml:{}: <dynamicObstacle id= >: missing attribute `id`",
                line(" id=\" \"")
            ),
        ]
    );
    let (found, _) = safe_interactions(&s, &InteractionRules::default());
    let mut event_ids: Vec<&str> = found.iter().map(|f| f.event.id.as_str()).collect();
    event_ids.sort_unstable();
    assert_eq!(event_ids, ["own/1-4@0#0", "own/4-1@0#0"]);
}

/// The long help teaches what a user bringing their own files needs: which values are read (and
/// that intervals are refused), when the command fails, and what to do with the folder next.
#[test]
fn the_help_says_what_is_read_when_it_fails_and_what_comes_next() {
    let o = Command::new(RISKCTL)
        .args(["import", "commonroad", "--help"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "<intervalStart>/<intervalEnd> value is refused",
        "<acceleration>\nis optional",
        "beyond 100 km",
        "only when no file could be read or no safe sequence",
        "riskctl demo --real DIR",
        "--extra-real DIR",
        "by scenario file, never by event",
    ] {
        assert!(help.contains(needle), "help lacks {needle:?}:\n{help}");
    }
}

/// A UTF-16 file (a text editor's "Unicode" save) is refused naming its encoding, as the
/// documentation says of every encoding but UTF-8 and ISO-8859-1; it was refused as "not UTF-8
/// (invalid byte 0xFF) and no other encoding declared", though its declaration says UTF-16.
#[test]
fn a_utf16_file_is_refused_naming_its_encoding() {
    let dir = temp_dir("utf16");
    let text = scenario(&[car(1, &east(0.0, 0.0)), car(2, &east(15.0, 0.0))])
        .replace("encoding=\"UTF-8\"", "encoding=\"UTF-16\"");
    let mut le = vec![0xFF, 0xFE];
    let mut be = vec![0xFE, 0xFF];
    for unit in text.encode_utf16() {
        le.extend(unit.to_le_bytes());
        be.extend(unit.to_be_bytes());
    }
    for (name, bytes, encoding) in [("le.xml", le, "UTF-16LE"), ("be.xml", be, "UTF-16BE")] {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let issue = riskscore_data::import::commonroad::read_scenario(&path).unwrap_err();
        assert_eq!(issue.line, 1);
        assert_eq!(
            issue.problem,
            Problem::Encoding(format!("{encoding} (byte-order mark)")),
            "{issue}"
        );
        assert!(
            issue.to_string().ends_with(&format!(
                "{name}:1: encoding \"{encoding} (byte-order mark)\" is not supported (UTF-8 and \
                 ISO-8859-1 are): convert the file to UTF-8"
            )),
            "{issue}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A hand-edited file with a document type declaration is well-formed XML: it is refused naming
/// the declaration and its line, not as "not well-formed XML: XML with DTD detected" at line 1.
#[test]
fn a_doctype_is_refused_naming_the_declaration_and_its_line() {
    let text = scenario(&[car(1, &east(0.0, 0.0)), car(2, &east(15.0, 0.0))]).replacen(
        "?>\n",
        "?>\n<!-- edited by hand -->\n<!DOCTYPE commonRoad>\n",
        1,
    );
    let issue = parse_scenario(&text, "own.xml", "own").unwrap_err();
    assert_eq!(issue.problem, Problem::Doctype);
    assert_eq!(
        issue.to_string(),
        "own.xml:3: a <!DOCTYPE ...> declaration is not read (its entities could expand without \
         bound): remove that line; CommonRoad files have none"
    );
}

/// A file cut short (a truncated copy) was reported at line 1, where the parser puts an
/// unexpected end; its last line is where it ends.
#[test]
fn a_truncated_file_is_reported_at_its_last_line() {
    let text = scenario(&[car(1, &east(0.0, 0.0)), car(2, &east(15.0, 0.0))]);
    let half = &text[..text.len() / 2];
    // Cut after a tag (the root never closed) and inside one (the stream ends in it).
    let after_tag = &half[..half.rfind('>').unwrap() + 1];
    let in_tag = &half[..half.rfind('>').unwrap() - 1];
    for cut in [after_tag, in_tag] {
        let issue = parse_scenario(cut, "cut.xml", "cut").unwrap_err();
        let last = 1 + cut.trim_end().matches('\n').count();
        assert!(last > 5, "the test file is too short to tell");
        assert!(
            issue
                .to_string()
                .starts_with(&format!("cut.xml:{last}: not well-formed XML")),
            "{issue}"
        );
    }
}

/// A trajectory whose first state repeats the initial state at the same step (files converted
/// from OpenSCENARIO by CommonRoad's tools do this) is read once, not refused: every road user
/// of such a file used to be skipped ("time step 0 does not follow step 0"). A first state at the
/// same step with other values is still an error naming it.
#[test]
fn a_trajectory_repeating_the_initial_state_is_read_once() {
    let repeat = |id: u32, states: &[State], change: f64| {
        let first = states[0];
        car(id, states).replacen(
            "<trajectory>\n",
            &format!(
                "<trajectory>\n{}",
                state_xml(
                    "state",
                    (first.0, first.1 + change, first.2, first.3, first.4)
                )
            ),
            1,
        )
    };
    let text = scenario(&[
        repeat(1, &east(0.0, 0.0), 0.0),
        repeat(2, &east(15.0, 0.0), 0.0),
    ]);
    let s = parse_scenario(&text, "osc.xml", "osc").unwrap();
    assert!(s.issues.is_empty(), "{:?}", s.issues);
    let steps: Vec<i64> = s.tracks[0].states.iter().map(|st| st.step).collect();
    assert_eq!(steps, (0..50).collect::<Vec<_>>());
    let (_, counts) = safe_interactions(&s, &InteractionRules::default());
    assert_eq!(counts.sequences, 2);

    let text = scenario(&[repeat(1, &east(0.0, 0.0), 0.5), car(2, &east(15.0, 0.0))]);
    let s = parse_scenario(&text, "osc.xml", "osc").unwrap();
    assert_eq!(s.tracks.len(), 1);
    assert_eq!(s.issues.len(), 1);
    assert!(
        s.issues[0].to_string().contains(
            "<dynamicObstacle id=1> <state> #1: time step 0 does not follow step 0 of the previous state"
        ),
        "{}",
        s.issues[0]
    );
}
