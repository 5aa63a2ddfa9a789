//! End-to-end tests of `riskctl ssm`: run the real binary on small files with extra columns and bad
//! rows; check every computed value against scorer-core, the line numbers and columns in the error
//! messages, strict mode, stdin/stdout, and the golden file.
use scorer_core::{features, surrogates, VehicleState, FEATURE_NAMES};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
mod common;
use common::{riskctl, stderr, RISKCTL};

/// A small input: mixed-case header, pass-through columns before, between and after the pair
/// columns (including a quoted one with a comma), good rows and one bad row of each kind.
fn sample_input() -> String {
    let header = "Event,X_I,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,comment,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j,Tag";
    let rows = [
        // line 2: rear-end approach
        "e1,0,0,20,0,1,0,0.5,4.5,1.8,\"closing, fast\",30,0,10,0,1,0,0,4,1.9,a",
        // line 3: unparsable x_j
        "e2,0,0,20,0,1,0,0,4.5,1.8,bad,3O,0,10,0,1,0,0,4,1.9,b",
        // line 4: crossing at right angles, heading not unit length
        "e3,-30,1,10,0,2,0,0,4.5,1.8,,2,-25,0,9,0,0.5,0,4.8,2,c",
        // line 5: empty vy_j
        "e4,0,0,20,0,1,0,0,4.5,1.8,bad,30,0,10,,1,0,0,4,1.9,d",
        // line 6: non-finite acc_i
        "e5,0,0,20,0,1,0,inf,4.5,1.8,bad,30,0,10,0,1,0,0,4,1.9,e",
        // line 7: zero heading of the partner
        "e6,0,0,20,0,1,0,0,4.5,1.8,bad,30,0,10,0,0,0,0,4,1.9,f",
        // line 8: both stopped, huge TAdv; scientific notation and spaces
        "e7, 1e1 ,5,0,0,0,-1,0,4.5,1.8,,10,-20,0,0,0,-1,0,4,1.9,g",
        // line 9: short row (width_j and Tag missing)
        "e8,0,0,20,0,1,0,0,4.5,1.8,bad,30,0,10,0,1,0,0,4",
    ];
    let mut s = String::from(header);
    for r in rows {
        s.push('\n');
        s.push_str(r);
    }
    s.push('\n');
    s
}

const GOOD_LINES: [u64; 3] = [2, 4, 8];

fn write_temp(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Parse a CSV (with quotes) into header + rows.
fn read_csv(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(text.as_bytes());
    let header = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|rec| rec.unwrap().iter().map(String::from).collect())
        .collect();
    (header, rows)
}

/// The pair of a row as `riskctl ssm` hands it to scorer-core: f64 values, positions made
/// relative to the ego in f64, then f32.
fn pair_from(header: &[String], row: &[String]) -> (VehicleState, VehicleState) {
    let get = |field: &str, suffix: &str| -> f64 {
        let name = format!("{field}_{suffix}");
        let k = header
            .iter()
            .position(|h| h.eq_ignore_ascii_case(&name))
            .unwrap();
        row[k].trim().parse().unwrap()
    };
    let (x0, y0) = (get("x", "i"), get("y", "i"));
    let state = |s: &str| VehicleState {
        x: (get("x", s) - x0) as f32,
        y: (get("y", s) - y0) as f32,
        vx: get("vx", s) as f32,
        vy: get("vy", s) as f32,
        hx: get("hx", s) as f32,
        hy: get("hy", s) as f32,
        acc: get("acc", s) as f32,
        length: get("length", s) as f32,
        width: get("width", s) as f32,
    };
    (state("i"), state("j"))
}

fn parse_out(v: &str) -> f32 {
    v.parse::<f32>()
        .unwrap_or_else(|_| panic!("output value {v:?} is not a number"))
}

/// Check that the output holds the input columns untouched plus scorer-core's values.
fn check_output(input: &str, output: &str, expected_rows: usize) {
    let (in_header, in_rows) = read_csv(input);
    let (out_header, out_rows) = read_csv(output);
    let mut expected_header = in_header.clone();
    expected_header.extend(["box_distance", "ttc2d", "tadv", "ei"].map(String::from));
    expected_header.extend(FEATURE_NAMES.iter().map(|f| format!("f_{f}")));
    assert_eq!(out_header, expected_header);
    assert_eq!(out_rows.len(), expected_rows);

    let n_in = in_header.len();
    for out in &out_rows {
        // Find the input row by its pass-through columns.
        let src = in_rows
            .iter()
            .find(|r| r.len() == n_in && r[..] == out[..n_in])
            .unwrap_or_else(|| panic!("output row {out:?} does not copy an input row"));
        let (ego, partner) = pair_from(&in_header, src);
        let s = surrogates(&ego, &partner);
        let f = features(&ego, &partner);
        let expected: Vec<f32> = [s.box_distance, s.ttc2d, s.tadv, s.ei]
            .into_iter()
            .chain(f)
            .collect();
        let got: Vec<f32> = out[n_in..].iter().map(|v| parse_out(v)).collect();
        assert_eq!(got.len(), expected.len());
        for ((g, e), name) in got.iter().zip(&expected).zip(&out_header[n_in..]) {
            assert_eq!(
                g.to_bits(),
                e.to_bits(),
                "{name}: written {g}, scorer-core {e} (row {src:?})"
            );
        }
    }
}

#[test]
fn scores_good_rows_reports_bad_ones_and_passes_extra_columns_through() {
    let dir = tempfile::tempdir().unwrap();
    let input = sample_input();
    let in_path = write_temp(dir.path(), "pairs.csv", &input);
    let out_path = dir.path().join("out.csv");
    let o = riskctl(&[
        "ssm",
        "--input",
        in_path.to_str().unwrap(),
        "--output",
        out_path.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "riskctl failed: {err}");
    let output = std::fs::read_to_string(&out_path).unwrap();
    check_output(&input, &output, GOOD_LINES.len());
    assert!(no_temporaries(dir.path()), "a temporary was left");

    for (line, column) in [
        (3, "x_j"),
        (5, "vy_j"),
        (6, "acc_i"),
        (7, "hx_j"),
        (9, "width_j"),
    ] {
        let needle = format!("line {line}, column {column}:");
        assert!(err.contains(&needle), "stderr lacks {needle:?}:\n{err}");
    }
    assert!(
        err.contains("\"3O\""),
        "the unparsable text is quoted:\n{err}"
    );
    assert!(err.contains("3 rows ok, 5 rows bad"), "summary:\n{err}");

    // Sanity of the physics on the rear-end row: gap 30 - (4.5 + 4) / 2 = 25.75 m; TTC2D =
    // (front-to-front 32 - 2.25, minus the leader's length 4) / (20 - 10) m/s.
    let (header, rows) = read_csv(&output);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let e1 = rows.iter().find(|r| r[0] == "e1").unwrap();
    assert!((parse_out(&e1[col("box_distance")]) - 25.75).abs() < 1e-4);
    assert!((parse_out(&e1[col("ttc2d")]) - 2.575).abs() < 1e-4);
    assert_eq!(e1[col("comment")], "closing, fast");
    // Both stopped: TAdv = gap / 1e-6, EI no conflict.
    let e7 = rows.iter().find(|r| r[0] == "e7").unwrap();
    assert!(parse_out(&e7[col("tadv")]) > 1e6);
    assert_eq!(e7[col("ei")], "-inf");
    assert_eq!(e7[col("ttc2d")], "inf");
}

#[test]
fn strict_mode_fails_on_the_first_bad_row_and_leaves_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let in_path = write_temp(dir.path(), "pairs.csv", &sample_input());
    let out_path = dir.path().join("out.csv");
    let o = riskctl(&[
        "ssm",
        "--input",
        in_path.to_str().unwrap(),
        "--output",
        out_path.to_str().unwrap(),
        "--strict",
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "strict mode must fail:\n{err}");
    assert!(
        err.contains("line 3, column x_j:"),
        "error names the line and column:\n{err}"
    );
    assert!(
        !err.contains("line 5"),
        "strict stops at the first bad row:\n{err}"
    );
    assert!(!out_path.exists());
    assert!(no_temporaries(dir.path()), "a temporary was left");

    // A clean file passes in strict mode.
    let clean: String = sample_input()
        .lines()
        .enumerate()
        .filter(|(k, _)| *k == 0 || GOOD_LINES.contains(&(*k as u64 + 1)))
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let clean_path = write_temp(dir.path(), "clean.csv", &clean);
    let o = riskctl(&[
        "ssm",
        "-i",
        clean_path.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
        "--strict",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    check_output(
        &clean,
        &std::fs::read_to_string(&out_path).unwrap(),
        GOOD_LINES.len(),
    );
}

#[test]
fn dash_reads_stdin_and_writes_stdout() {
    let input = sample_input();
    let mut child = Command::new(RISKCTL)
        .args(["ssm", "--input", "-", "--output", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    check_output(
        &input,
        &String::from_utf8(o.stdout).unwrap(),
        GOOD_LINES.len(),
    );
    assert!(err.contains("<stdin>: line 3, column x_j:"), "{err}");
}

#[test]
fn missing_pair_columns_are_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let in_path = write_temp(dir.path(), "pairs.csv", "x_i,y_i,foo\n1,2,3\n");
    let out_path = dir.path().join("out.csv");
    let o = riskctl(&[
        "ssm",
        "--input",
        in_path.to_str().unwrap(),
        "--output",
        out_path.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(err.contains("vx_i") && err.contains("width_j"), "{err}");
    assert!(err.contains("pairs.csv"), "names the file: {err}");
    assert!(!out_path.exists());
}

#[test]
fn golden_file_scores_every_row() {
    let golden =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/golden_surrogates.csv");
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("golden_out.csv");
    let o = riskctl(&[
        "ssm",
        "--input",
        golden.to_str().unwrap(),
        "--output",
        out_path.to_str().unwrap(),
        "--strict",
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("2950 rows ok, 0 rows bad"), "{err}");
    // The golden file already has f_ columns: they are reported and kept.
    assert!(err.contains("f_l_ego"), "{err}");
    let input = std::fs::read_to_string(&golden).unwrap();
    check_output(&input, &std::fs::read_to_string(&out_path).unwrap(), 2950);
}

#[test]
fn help_explains_columns_and_bad_rows() {
    let o = riskctl(&["ssm", "--help"]);
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "--strict",
        "x_i",
        "box_distance",
        "f_psi_sur",
        "-inf",
        "line number",
    ] {
        assert!(help.contains(needle), "--help lacks {needle:?}:\n{help}");
    }
}

#[test]
fn utm_sized_coordinates_keep_their_precision() {
    // The same rear-end pair, once near the origin and once at UTM-like coordinates. In plain f32
    // the second would be rounded to 0.5 m; relative to the ego it is exact.
    let header = "id,x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j";
    let near = "near,0.25,0.5,20,0,1,0,0,4.5,1.8,30.37,0.5,10,0,1,0,0,4,1.9";
    let far = "far,500000.25,5700000.5,20,0,1,0,0,4.5,1.8,500030.37,5700000.5,10,0,1,0,0,4,1.9";
    let input = format!("{header}\n{near}\n{far}\n");
    let dir = tempfile::tempdir().unwrap();
    let in_path = write_temp(dir.path(), "utm.csv", &input);
    let out_path = dir.path().join("out.csv");
    let o = riskctl(&[
        "ssm",
        "-i",
        in_path.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
        "--strict",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let output = std::fs::read_to_string(&out_path).unwrap();
    check_output(&input, &output, 2);
    let (header, rows) = read_csv(&output);
    let n_in = 19;
    assert_eq!(header.len(), n_in + 17);
    let computed =
        |r: &Vec<String>| -> Vec<f32> { r[n_in..].iter().map(|v| parse_out(v)).collect() };
    let (a, b) = (computed(&rows[0]), computed(&rows[1]));
    for ((x, y), name) in a.iter().zip(&b).zip(&header[n_in..]) {
        assert!(
            (x - y).abs() <= 1e-4 * x.abs().max(1.0),
            "{name}: {x} vs {y}"
        );
    }
    // 30.12 m between centres minus half lengths: the centimetres survive.
    assert!(
        (b[0] - (30.12 - 4.25)).abs() < 1e-4,
        "box distance {}",
        b[0]
    );
}

/// True when no hidden temporary or lock file of the output layer is in `dir`.
fn no_temporaries(dir: &Path) -> bool {
    std::fs::read_dir(dir)
        .unwrap()
        .all(|e| !e.unwrap().file_name().to_string_lossy().starts_with('.'))
}

#[test]
fn devices_are_written_directly() {
    // /dev/null is written directly: no temporary beside it, and it stays a device.
    let dir = tempfile::tempdir().unwrap();
    let in_path = write_temp(dir.path(), "pairs.csv", &sample_input());
    let o = riskctl(&["ssm", "-i", in_path.to_str().unwrap(), "-o", "/dev/null"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_dir("/dev").unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .starts_with(".null.")));
}
