//! Host side of the firmware build: linker script, the embedded model blobs and the golden inputs.
//!
//! Writes into `OUT_DIR` (the firmware embeds them with `include_bytes!`):
//! - `drl.rsk`, `msra.rsk`: the model blobs (see [`model_blob`] for where they come from);
//! - `inputs.bin`: a subset of `tests/data/golden_surrogates.csv` (see [`pack_inputs`]).
use std::collections::BTreeMap;
use std::env;
use std::fs;
use std::path::{Path, PathBuf};

#[path = "test_models.rs"]
mod test_models;

/// Rows taken from each case family of the golden file (evenly spaced over the family).
const ROWS_PER_FAMILY: usize = 30;
/// Input columns of the golden CSV, in `VehicleState` field order, ego (`_i`) then partner (`_j`).
const STATE_FIELDS: [&str; 9] = ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"];

fn main() {
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    let repo = manifest.join("../..");

    // cortex-m-rt's link.x includes memory.x from the linker search path.
    fs::copy(manifest.join("memory.x"), out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        println!("cargo:rustc-link-arg=-Tlink.x");
    }
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=test_models.rs");

    for (name, shipped) in [("drl", "drl-default.rsk"), ("msra", "msra-default.rsk")] {
        let (blob, source) = model_blob(&repo.join("models").join(shipped), name);
        fs::write(out.join(format!("{name}.rsk")), &blob).expect("write model blob");
        fs::write(out.join(format!("{name}.source")), source).expect("write model source");
    }

    let golden = repo.join("tests/data/golden_surrogates.csv");
    println!("cargo:rerun-if-changed={}", golden.display());
    let packed = pack_inputs(&golden).unwrap_or_else(|e| panic!("{}: {e}", golden.display()));
    fs::write(out.join("inputs.bin"), packed).expect("write inputs.bin");
}

/// The blob embedded as model `name`: the shipped `models/<name>-default.rsk` when it exists, else
/// a deterministic test model encoded by `scorer_core::model::encode` (test_models.rs).
/// Returns the blob and a one-line description of its source that the firmware reports.
fn model_blob(shipped: &Path, name: &str) -> (Vec<u8>, String) {
    println!("cargo:rerun-if-changed={}", shipped.display());
    if shipped.exists() {
        let blob = fs::read(shipped).unwrap_or_else(|e| panic!("{}: {e}", shipped.display()));
        return (blob, format!("models/{}", file_name(shipped)));
    }
    let blob = match name {
        "drl" => test_models::drl_int8(),
        _ => test_models::msra(),
    };
    (blob, format!("generated test model ({name})"))
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Packs `ROWS_PER_FAMILY` rows of every case family, interleaved family by family (so any prefix of
/// the list covers every family), as little-endian records:
/// `u32 count`, then per record `u32 csv_line` (1-based, header = line 1) and 18 `f32`
/// (ego then partner, `VehicleState` field order).
fn pack_inputs(path: &Path) -> Result<Vec<u8>, String> {
    let text = fs::read_to_string(path).map_err(|e| e.to_string())?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("empty file")?.split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or(format!("line 1: no column `{name}`"))
    };
    let case_col = col("case")?;
    let mut cols = Vec::new();
    for suffix in ["i", "j"] {
        for f in STATE_FIELDS {
            cols.push(col(&format!("{f}_{suffix}"))?);
        }
    }

    // family -> [(csv line, 18 values)]
    let mut families: BTreeMap<String, Vec<(u32, Vec<f32>)>> = BTreeMap::new();
    for (i, line) in lines.enumerate() {
        let line_no = i + 2;
        let fields: Vec<&str> = line.split(',').collect();
        let case = fields
            .get(case_col)
            .ok_or(format!("line {line_no}: missing `case`"))?;
        let mut values = Vec::with_capacity(cols.len());
        for &c in &cols {
            let raw = fields
                .get(c)
                .ok_or(format!("line {line_no}: missing `{}`", header[c]))?;
            let v: f32 = raw
                .parse()
                .map_err(|e| format!("line {line_no}, field `{}`: {raw:?}: {e}", header[c]))?;
            values.push(v);
        }
        families
            .entry((*case).to_string())
            .or_default()
            .push((line_no as u32, values));
    }

    let picked: Vec<Vec<&(u32, Vec<f32>)>> = families
        .values()
        .map(|rows| {
            let n = rows.len().min(ROWS_PER_FAMILY);
            (0..n).map(|k| &rows[k * rows.len() / n]).collect()
        })
        .collect();
    let mut records = Vec::new();
    let longest = picked.iter().map(Vec::len).max().unwrap_or(0);
    for k in 0..longest {
        for family in &picked {
            if let Some(r) = family.get(k) {
                records.push(*r);
            }
        }
    }

    let mut out = Vec::new();
    out.extend_from_slice(&(records.len() as u32).to_le_bytes());
    for (line, values) in records {
        out.extend_from_slice(&line.to_le_bytes());
        for v in values {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}
