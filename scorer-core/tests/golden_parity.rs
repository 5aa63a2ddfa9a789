//! Parity of features and surrogates with the published reference implementations, on the 2,950
//! golden configurations in `tests/data/golden_surrogates.csv` (conventions in
//! `tests/data/golden_README.md`).
//!
//! - Features and `box_distance`: every row within `1e-3 + 1e-4 * |ref|` (angles modulo 2 pi).
//! - TTC2D, TAdv, EI: at least 99.5 % of rows agree (same finite/infinite class, finite values
//!   within `1e-3 + 1e-3 * |ref|`); every disagreeing row is printed with both values.
//!
//! Run with `-- --nocapture` to see the agreement summary.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use scorer_core::{box_distance, ei, features, tadv, ttc2d, VehicleState, FEATURE_NAMES};
use std::collections::HashMap;
use std::path::PathBuf;

struct Row {
    line: usize,
    case: String,
    ego: VehicleState,
    partner: VehicleState,
    values: HashMap<String, f64>,
}

impl Row {
    fn get(&self, column: &str) -> f64 {
        *self
            .values
            .get(column)
            .unwrap_or_else(|| panic!("line {}: no column {column}", self.line))
    }
}

fn golden_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/golden_surrogates.csv")
}

fn load() -> Vec<Row> {
    let path = golden_path();
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .expect("empty golden file")
        .split(',')
        .collect();
    let mut rows = Vec::new();
    for (index, line) in lines.enumerate() {
        let line_no = index + 2;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields.len(), header.len(), "line {line_no}: field count");
        let mut values = HashMap::new();
        let mut case = String::new();
        for (name, field) in header.iter().zip(&fields) {
            if *name == "case" {
                case = field.to_string();
            } else {
                let v: f64 = field
                    .parse()
                    .unwrap_or_else(|e| panic!("line {line_no}, column {name}: {field:?}: {e}"));
                values.insert(name.to_string(), v);
            }
        }
        let state = |suffix: &str| {
            let g = |n: &str| values[&format!("{n}_{suffix}")] as f32;
            VehicleState {
                x: g("x"),
                y: g("y"),
                vx: g("vx"),
                vy: g("vy"),
                hx: g("hx"),
                hy: g("hy"),
                acc: g("acc"),
                length: g("length"),
                width: g("width"),
            }
        };
        let ego = state("i");
        let partner = state("j");
        rows.push(Row {
            line: line_no,
            case,
            ego,
            partner,
            values,
        });
    }
    assert_eq!(rows.len(), 2950, "the golden file has 2,950 configurations");
    rows
}

/// Difference of two angles folded into [0, pi].
fn angle_gap(a: f64, b: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let d = (a - b).rem_euclid(tau);
    d.min(tau - d)
}

#[test]
fn features_and_box_distance_match_every_row() {
    let rows = load();
    let mut failures = Vec::new();
    let mut worst = vec![0.0f64; FEATURE_NAMES.len() + 1];
    for row in &rows {
        let f = features(&row.ego, &row.partner);
        let mut checks: Vec<(String, f64, f64, bool)> = FEATURE_NAMES
            .iter()
            .zip(f)
            .map(|(name, ours)| {
                let is_angle = matches!(*name, "psi_sur" | "rho");
                (
                    format!("f_{name}"),
                    ours as f64,
                    row.get(&format!("f_{name}")),
                    is_angle,
                )
            })
            .collect();
        checks.push((
            "CurrentD".into(),
            box_distance(&row.ego, &row.partner) as f64,
            row.get("CurrentD"),
            false,
        ));
        for (k, (name, ours, reference, is_angle)) in checks.into_iter().enumerate() {
            let err = if is_angle {
                angle_gap(ours, reference)
            } else {
                (ours - reference).abs()
            };
            let tol = 1e-3 + 1e-4 * reference.abs();
            worst[k] = worst[k].max(err / tol);
            if err.is_nan() || err > tol {
                failures.push(format!(
                    "line {} ({}): {name}: ours {ours} reference {reference}",
                    row.line, row.case
                ));
            }
        }
    }
    for (k, w) in worst.iter().enumerate() {
        let name = FEATURE_NAMES.get(k).copied().unwrap_or("box_distance");
        println!("{name:>12}: worst error / tolerance = {w:.3}");
    }
    for f in &failures {
        println!("{f}");
    }
    assert!(
        failures.is_empty(),
        "{} feature/box_distance mismatches",
        failures.len()
    );
}

/// Same class (finite / +inf / -inf) and, when finite, within `1e-3 + 1e-3 * |ref|`.
fn surrogate_agrees(ours: f32, reference: f64) -> bool {
    let ours = ours as f64;
    if reference.is_finite() || ours.is_finite() {
        ours.is_finite()
            && reference.is_finite()
            && (ours - reference).abs() <= 1e-3 + 1e-3 * reference.abs()
    } else {
        ours == reference
    }
}

fn check_surrogate(column: &str, f: fn(&VehicleState, &VehicleState) -> f32) {
    let rows = load();
    let mut disagreements = Vec::new();
    for row in &rows {
        let ours = f(&row.ego, &row.partner);
        let reference = row.get(column);
        if !surrogate_agrees(ours, reference) {
            disagreements.push(format!(
                "line {} ({}): {column}: ours {ours} reference {reference}",
                row.line, row.case
            ));
        }
    }
    let agree = rows.len() - disagreements.len();
    let share = agree as f64 / rows.len() as f64;
    println!(
        "{column}: {agree}/{} rows agree ({:.2} %)",
        rows.len(),
        100.0 * share
    );
    for d in &disagreements {
        println!("{d}");
    }
    assert!(
        share >= 0.995,
        "{column}: only {:.2} % of rows agree",
        100.0 * share
    );
}

#[test]
fn ttc2d_matches_reference() {
    check_surrogate("TTC2D", ttc2d);
}

#[test]
fn tadv_matches_reference() {
    check_surrogate("TAdv", tadv);
}

#[test]
fn ei_matches_reference() {
    check_surrogate("EI", ei);
}
