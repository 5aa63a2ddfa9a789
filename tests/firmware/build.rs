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

    let models = repo.join("models");
    let (msra, msra_source) = model_blob(&models.join("msra-default.rsk"), "msra");
    let (drl, drl_source) = model_blob(&models.join("drl-default.rsk"), "drl");
    let (drl, drl_source) = with_blend_guard(drl, drl_source, &msra);
    for (name, blob, source) in [("drl", drl, drl_source), ("msra", msra, msra_source)] {
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

/// The training domain the embedded DRL blob gets when it carries none: the 13 DRL-input ranges
/// that `riskctl calibrate-domain --model models/drl-default.rsk --events data/ngsim-us101-safe`
/// measures (0.1 % tails). The firmware then measures and checks the guarded per-partner path
/// with a full record, whatever the shipped blob holds.
const FIRMWARE_DOMAIN: [(u8, f32, f32); 13] = [
    (0, -4.615_120_4, 4.615_120_4),
    (1, 2.7432, 17.6784),
    (2, 1.4935, 2.57555),
    (3, 0.0, 19.8272),
    (4, -1.518_611_4, 1.531_767_8),
    (5, 0.0, 19.8272),
    (6, 0.925_482_15, 1.000_000_2),
    (7, -0.378_791_36, 0.378_791_36),
    (8, 0.109_856_98, 3.410_424_5),
    (9, -2.443_866, 2.363_714),
    // `ln(0.5 + 0)`: the miss gap of boxes that would touch.
    (10, -std::f32::consts::LN_2, 3.467_095_1),
    (11, -3.571_726_3, 3.571_108_3),
    (12, -1.725_845_8, 1.689_262_5),
];

/// The fallback the embedded DRL blob gets: the kinematic terms of the embedded MSRA blob, on
/// the scale `riskctl calibrate-domain --policy fallback --fallback-from models/msra-default.rsk`
/// fits for the shipped DRL on `data/ngsim-us101-safe` (mean and spread on the frames inside). The
/// instructions do not depend on the values; the parity test checks the bits whatever they are.
const FIRMWARE_FALLBACK_SCALE: f32 = 6.164_552;
const FIRMWARE_FALLBACK_OFFSET: f32 = -19.346_514;

/// `blob` guarded by the costliest policy: its training-domain ranges and geometry coverage (or
/// [`FIRMWARE_DOMAIN`] when it has none) under `Blend` (its own blend weight, or the training
/// default 0.7), with the kinematic terms of `msra_blob` as its fallback. An observation inside
/// then computes the network, the four surrogates and the MSRA terms on top of the DRL inputs and
/// the guard; one outside skips the network.
fn with_blend_guard(blob: Vec<u8>, source: String, msra_blob: &[u8]) -> (Vec<u8>, String) {
    use scorer_core::model::kinematic_fallback::term_to_bytes;
    use scorer_core::model::{self, Blend, InputRange, KinematicFallback, Model, OutsidePolicy};
    let mut decoded = model::decode_blob(&blob).expect("the DRL blob decodes");
    let Ok(Model::Msra(msra)) = model::decode(msra_blob) else {
        panic!("the MSRA slot holds no MSRA model");
    };
    let term_bytes: Vec<u8> = msra
        .terms
        .iter()
        .filter(|t| t.kind != scorer_core::SurrogateKind::Gssm)
        .flat_map(term_to_bytes)
        .collect();
    let (ranges, coverage): (Vec<u8>, _) = match &decoded.meta.training_domain {
        Some(domain) => (domain.range_bytes.to_vec(), domain.coverage),
        None => (
            FIRMWARE_DOMAIN
                .iter()
                .flat_map(|&(input, lo, hi)| InputRange { input, lo, hi }.to_bytes())
                .collect(),
            None,
        ),
    };
    decoded.meta.training_domain = Some(
        model::TrainingDomain::new(OutsidePolicy::Blend, ranges.leak()).with_coverage(coverage),
    );
    // 0.7 is training's default (`riskscore_train::train::DEFAULT_BLEND_WEIGHT`; the firmware
    // build depends on scorer-core alone); the instructions do not depend on the value.
    decoded.meta.blend = Some(decoded.meta.blend.unwrap_or(Blend {
        network_weight: 0.7,
    }));
    decoded.meta.kinematic_fallback = Some(KinematicFallback::new(
        FIRMWARE_FALLBACK_SCALE,
        FIRMWARE_FALLBACK_OFFSET,
        term_bytes.leak(),
    ));
    let mut out = vec![0u8; model::encoded_blob_len(&decoded).expect("size")];
    let n = model::encode_blob(&decoded, &mut out).expect("encode the guarded DRL blob");
    out.truncate(n);
    (out, format!("{source} + blend guard (build.rs)"))
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
