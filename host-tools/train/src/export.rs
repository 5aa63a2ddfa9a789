//! Trained checkpoints (JSON of float parameters) and the model blobs the ECU loads.
//!
//! A checkpoint is what `riskctl train` writes and `riskctl export-model` reads:
//!
//! ```json
//! { "format": "riskscore-checkpoint", "version": 3,
//!   "model": { "kind": "drl", "params": { "scaler": {"mean": [13], "std": [13]},   (over the DRL inputs, encoding 3)
//!                                          "layers": [{"inputs": 13, "outputs": 32,
//!                                                      "weight": [out*in, row-major], "bias": [out]}, ...] },
//!              "calibration": { "input": {"min": .., "max": ..}, "hidden": [{"min", "max"}, ...],
//!                               "observations": n, "clip_fraction": p } }
//!          | { "kind": "msra", "params": { "terms": [{"surrogate": "ttc2d", "lo", "hi", "w", "a", "b"}, ...] } },
//!   "meta": { free-form provenance: data folder, seed, config, metrics } }
//! ```
//!
//! The DRL checkpoint carries its activation calibration (measured on the training observations at
//! training time), so exporting needs no data. Blobs are written by `scorer_core::model::encode` and
//! checked by decoding them again ([`inspect`]).
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use scorer_core::model::{self, BoundedVec, Model, ModelError, OutsidePolicy, HEADER_LEN};
use scorer_core::msra::{MsraModel, MsraTerm};
use serde::{Deserialize, Serialize};
use serde_json::value::RawValue;

use crate::quantize::{self, Calibration, FloatBuffers, QuantisedDrl};
use crate::train::drl::DrlParams;
use crate::train::msra::{parse_surrogate, MsraParams};
use crate::train::GuardConfig;
use riskscore_data::events::Sequence;

pub const CHECKPOINT_FORMAT: &str = "riskscore-checkpoint";
/// Version 3: the DRL scaler and network read the core's DRL input encoding 3 (version 1 read the
/// raw features, version 2 encoding 2; both are refused: their network would be fed other inputs).
pub const CHECKPOINT_VERSION: u32 = 3;

/// The float parameters of one trained model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum CheckpointModel {
    Drl {
        params: DrlParams,
        calibration: Calibration,
    },
    Msra {
        params: MsraParams,
    },
}

/// A trained model and its provenance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    pub format: String,
    pub version: u32,
    pub model: CheckpointModel,
    #[serde(default)]
    pub meta: serde_json::Value,
}

/// Export and checkpoint failures.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a riskscore checkpoint: {message}")]
    BadCheckpoint { path: String, message: String },
    #[error("MSRA term {term}: unknown surrogate {name:?}")]
    UnknownSurrogate { term: usize, name: String },
    #[error("{0}")]
    Quantize(#[from] quantize::QuantizeError),
    #[error("the model does not encode: {0}")]
    Model(ModelError),
    #[error("{what} is only available for DRL checkpoints")]
    NotDrl { what: &'static str },
    #[error("training domain: {0}")]
    Domain(String),
    #[error("kinematic fallback: {0}")]
    Fallback(#[from] crate::fallback::FallbackError),
}

/// The top level of a checkpoint file with its model left as JSON text: the first of the two steps
/// of [`parse_checkpoint`]. Named `Checkpoint` in serde's messages (``expected struct Checkpoint``).
#[derive(Deserialize)]
#[serde(rename = "Checkpoint")]
struct CheckpointText<'a> {
    format: String,
    version: u32,
    #[serde(borrow)]
    model: &'a RawValue,
    #[serde(default)]
    meta: serde_json::Value,
}

/// The tag of a model object, read as [`CheckpointModel`]'s derived `Deserialize` reads it (a
/// string naming a variant; unknown: ``unknown variant `x`, expected `drl` or `msra` ``).
#[derive(Deserialize)]
struct ModelTag {
    kind: ModelKind,
}

#[derive(Deserialize)]
#[serde(variant_identifier, rename_all = "snake_case")]
enum ModelKind {
    Drl,
    Msra,
}

/// [`CheckpointModel::Drl`]'s fields (the `kind` beside them is ignored, as the tagged enum
/// ignores it).
#[derive(Deserialize)]
struct DrlFields {
    params: DrlParams,
    calibration: Calibration,
}

/// [`CheckpointModel::Msra`]'s fields.
#[derive(Deserialize)]
struct MsraFields {
    params: MsraParams,
}

/// A parse error of one step of [`parse_checkpoint`]: serde_json's error (its position counted
/// in the text that step read), the path of the field it is in (`None` for a syntax error), and
/// where that text starts in the file.
struct ParseFailure {
    error: serde_json::Error,
    path: Option<String>,
    base: usize,
}

/// `text` (which starts at byte `base` of the file and is the value at `path`, `""` for the
/// whole file) read as a `T`, the path of a failing field tracked.
fn read_json<'a, T: Deserialize<'a>>(
    text: &'a str,
    base: usize,
    path: &str,
) -> Result<T, ParseFailure> {
    let mut de = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let inner = e.path().to_string();
        let path = match (path, inner.as_str()) {
            (p, ".") => p.to_string(),
            ("", i) => i.to_string(),
            (p, i) if i.starts_with('[') => format!("{p}{i}"),
            (p, i) => format!("{p}.{i}"),
        };
        ParseFailure {
            error: e.into_inner(),
            path: Some(path),
            base,
        }
    })?;
    // Nothing but white space after the value (`trailing characters`, a syntax error).
    de.end().map_err(|error| ParseFailure {
        error,
        path: None,
        base,
    })?;
    Ok(value)
}

/// A checkpoint file's text read in two steps, so that a parse error names the field it is in
/// and its own position: the top level with the model as its JSON text, then the model's tag,
/// then the tagged variant's fields from that text. Read in one step, serde buffers an
/// internally tagged enum whole, which loses both: a type error inside the model was
/// ``invalid type: string "x", expected f32`` and a missing field was reported where the model
/// object closes. The values read are those of `serde_json::from_str::<Checkpoint>`: a model
/// that is no JSON object (the sequence form serde also reads, or a wrong type) is read by the
/// derived `Deserialize` itself.
fn parse_checkpoint(text: &str) -> Result<Checkpoint, ParseFailure> {
    let top: CheckpointText = read_json(text, 0, "")?;
    let raw = top.model.get();
    // The model's text is a slice of `text` (borrowed, never copied).
    let base = raw.as_ptr() as usize - text.as_ptr() as usize;
    let model = if raw.starts_with('{') {
        match read_json::<ModelTag>(raw, base, "model")?.kind {
            ModelKind::Drl => {
                let m: DrlFields = read_json(raw, base, "model")?;
                CheckpointModel::Drl {
                    params: m.params,
                    calibration: m.calibration,
                }
            }
            ModelKind::Msra => {
                let m: MsraFields = read_json(raw, base, "model")?;
                CheckpointModel::Msra { params: m.params }
            }
        }
    } else {
        read_json(raw, base, "model")?
    };
    Ok(Checkpoint {
        format: top.format,
        version: top.version,
        model,
        meta: top.meta,
    })
}

/// Byte offset in `text` of line `line`, column `column` (1-based, the column counted in bytes,
/// as serde_json counts both).
fn offset_of(text: &str, line: usize, column: usize) -> usize {
    let start = if line <= 1 {
        0
    } else {
        text.match_indices('\n')
            .nth(line - 2)
            .map_or(text.len(), |(i, _)| i + 1)
    };
    (start + column).saturating_sub(1).min(text.len())
}

/// Line and column (1-based, as serde_json counts them) of byte `offset` of `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let column = offset
        - before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1)
        + 1;
    (line, column)
}

/// Where the JSON object that closes with the `}` at byte `close` of `text` opens (`text` is
/// valid JSON up to there, which the parser has read).
fn object_start(text: &str, close: usize) -> Option<usize> {
    let bytes = text.as_bytes();
    if bytes.get(close) != Some(&b'}') {
        return None;
    }
    let mut open = Vec::new();
    let mut i = 0;
    while i < close {
        match bytes[i] {
            b'"' => {
                i += 1;
                while i < close && bytes[i] != b'"' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
            }
            b'{' | b'[' => open.push(i),
            b'}' | b']' => {
                open.pop();
            }
            _ => {}
        }
        i += 1;
    }
    open.pop().filter(|&i| bytes[i] == b'{')
}

/// A checkpoint's parse error as `line L, column C: what`, the position named once (serde_json's
/// own text ends with ` at line L column C`, which is dropped) and counted in the whole file
/// (`text`). An error in the data names the path of its field
/// (``line 12, column 18: `model.params.terms[0].w`: invalid type: string "x", expected f32``);
/// a missing field is named at the start of the object that lacks it, where serde_json names the
/// object's end (``line 8, column 9: `model.params.terms[0]` (the object that starts there) is
/// missing field `w` ``). A syntax error (`EOF while parsing a string`) names no field.
fn parse_error_message(text: &str, f: &ParseFailure) -> String {
    let e = &f.error;
    let message = e.to_string();
    if e.line() == 0 {
        return message;
    }
    let at = format!(" at line {} column {}", e.line(), e.column());
    let what = message.strip_suffix(&at).unwrap_or(&message);
    // The position in the whole file: the step's text starts at `base`.
    let (base_line, base_column) = line_column(text, f.base);
    let (line, column) = if e.line() == 1 {
        (base_line, base_column - 1 + e.column())
    } else {
        (base_line + e.line() - 1, e.column())
    };
    let path = match &f.path {
        Some(path) if e.classify() == serde_json::error::Category::Data => path,
        _ => return format!("line {line}, column {column}: {what}"),
    };
    let named = if path.is_empty() {
        "the checkpoint".to_string()
    } else {
        format!("`{path}`")
    };
    if what.starts_with("missing field `") {
        if let Some(start) = object_start(text, offset_of(text, line, column)) {
            let (line, column) = line_column(text, start);
            return format!(
                "line {line}, column {column}: {named} (the object that starts there) is {what}"
            );
        }
    }
    if path.is_empty() {
        format!("line {line}, column {column}: {what}")
    } else {
        format!("line {line}, column {column}: {named}: {what}")
    }
}

impl Checkpoint {
    pub fn new(model: CheckpointModel, meta: serde_json::Value) -> Checkpoint {
        Checkpoint {
            format: CHECKPOINT_FORMAT.into(),
            version: CHECKPOINT_VERSION,
            model,
            meta,
        }
    }

    pub fn kind_name(&self) -> &'static str {
        match self.model {
            CheckpointModel::Drl { .. } => "drl",
            CheckpointModel::Msra { .. } => "msra",
        }
    }

    pub fn save(&self, path: &Path) -> Result<(), ExportError> {
        write_blob(path, &self.to_json(path)?)
    }

    /// The checkpoint file's bytes (pretty JSON); `path` names it in an error.
    pub fn to_json(&self, path: &Path) -> Result<Vec<u8>, ExportError> {
        serde_json::to_vec_pretty(self).map_err(|e| ExportError::BadCheckpoint {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }

    pub fn load(path: &Path) -> Result<Checkpoint, ExportError> {
        let bytes = std::fs::read(path).map_err(|source| ExportError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_bytes(bytes, path)
    }

    /// A checkpoint from the bytes of a file already read; `path` names it in an error.
    pub fn from_bytes(bytes: Vec<u8>, path: &Path) -> Result<Checkpoint, ExportError> {
        let p = path.display().to_string();
        if bytes.starts_with(&model::MAGIC) {
            return Err(ExportError::BadCheckpoint {
                path: p,
                message: format!(
                    "it looks like a model blob (it starts with the blob magic {:?}), which is \
                     what export writes; a checkpoint is the JSON file `riskctl train` writes \
                     (`riskctl inspect-model` reads a blob)",
                    String::from_utf8_lossy(&model::MAGIC)
                ),
            });
        }
        let text = String::from_utf8(bytes).map_err(|e| ExportError::BadCheckpoint {
            path: p.clone(),
            message: format!(
                "not a JSON text file (byte {} is not valid UTF-8)",
                e.utf8_error().valid_up_to()
            ),
        })?;
        // A UTF-8 byte-order mark (a Windows editor saved the file) is no JSON value, but says
        // nothing against the text after it (the configuration's TOML reader skips it too).
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let c = parse_checkpoint(text).map_err(|f| ExportError::BadCheckpoint {
            path: p.clone(),
            message: parse_error_message(text, &f),
        })?;
        if c.format != CHECKPOINT_FORMAT || c.version != CHECKPOINT_VERSION {
            return Err(ExportError::BadCheckpoint {
                path: p,
                message: format!(
                    "format {:?} version {} (expected {CHECKPOINT_FORMAT:?} version {CHECKPOINT_VERSION})",
                    c.format, c.version
                ),
            });
        }
        c.check()
            .map_err(|message| ExportError::BadCheckpoint { path: p, message })?;
        Ok(c)
    }

    /// The parameters' shapes fit together and every number is finite (a JSON number beyond
    /// f32's range reads as infinity): a checkpoint edited by hand or cut by another tool is
    /// refused here, naming the field, instead of panicking in the quantiser on a short array or
    /// exporting an int8 network whose scales an infinite weight made meaningless.
    pub fn check(&self) -> Result<(), String> {
        fn finite(field: &str, values: &[f32]) -> Result<(), String> {
            match values.iter().position(|v| !v.is_finite()) {
                Some(i) => Err(format!(
                    "`{field}[{i}]` is {} (not a finite f32 number)",
                    values[i]
                )),
                None => Ok(()),
            }
        }
        fn len(field: &str, values: &[f32], expected: usize, why: &str) -> Result<(), String> {
            if values.len() == expected {
                Ok(())
            } else {
                Err(format!(
                    "`{field}` has {} values, expected {expected} ({why})",
                    values.len()
                ))
            }
        }
        match &self.model {
            CheckpointModel::Drl {
                params,
                calibration,
            } => {
                let n = scorer_core::DRL_INPUT_COUNT;
                let scaler = &params.scaler;
                let why = "one per DRL input";
                len("model.params.scaler.mean", &scaler.mean, n, why)?;
                len("model.params.scaler.std", &scaler.std, n, why)?;
                finite("model.params.scaler.mean", &scaler.mean)?;
                finite("model.params.scaler.std", &scaler.std)?;
                if let Some(i) = scaler.std.iter().position(|&s| s <= 0.0) {
                    return Err(format!(
                        "`model.params.scaler.std[{i}]` is {} (a standard deviation must be > 0)",
                        scaler.std[i]
                    ));
                }
                if params.layers.is_empty() {
                    return Err("`model.params.layers` is empty".into());
                }
                let mut inputs = n;
                for (i, l) in params.layers.iter().enumerate() {
                    let f = format!("model.params.layers[{i}]");
                    if l.inputs != inputs {
                        return Err(format!(
                            "`{f}.inputs` is {}, expected {inputs} (the {} before it)",
                            l.inputs,
                            if i == 0 {
                                "DRL inputs".to_string()
                            } else {
                                format!("outputs of layer {}", i - 1)
                            }
                        ));
                    }
                    let w = format!("{f}.weight");
                    len(&w, &l.weight, l.inputs * l.outputs, "inputs x outputs")?;
                    len(&format!("{f}.bias"), &l.bias, l.outputs, "one per output")?;
                    finite(&w, &l.weight)?;
                    finite(&format!("{f}.bias"), &l.bias)?;
                    inputs = l.outputs;
                }
                if inputs != 1 {
                    return Err(format!(
                        "the last layer, `model.params.layers[{}]`, has {inputs} outputs, expected 1 (the risk score)",
                        params.layers.len() - 1
                    ));
                }
                let ranges =
                    std::iter::once(("model.calibration.input".to_string(), calibration.input))
                        .chain(
                            calibration
                                .hidden
                                .iter()
                                .enumerate()
                                .map(|(i, r)| (format!("model.calibration.hidden[{i}]"), *r)),
                        );
                for (f, r) in ranges {
                    if !(r.min.is_finite() && r.max.is_finite() && r.min <= r.max) {
                        return Err(format!(
                            "`{f}` is [{}, {}] (min and max finite, min <= max)",
                            r.min, r.max
                        ));
                    }
                }
            }
            CheckpointModel::Msra { params } => {
                for (k, t) in params.terms.iter().enumerate() {
                    let f = format!("model.params.terms[{k}]");
                    for (name, v) in [
                        ("lo", t.lo),
                        ("hi", t.hi),
                        ("w", t.w),
                        ("a", t.a),
                        ("b", t.b),
                    ] {
                        if !v.is_finite() {
                            return Err(format!("`{f}.{name}` is {v} (not a finite f32 number)"));
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// Numeric format of an exported DRL network.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DrlFormat {
    /// The deployed int8 network (default).
    #[default]
    Int8,
    /// The f32 network (parity/reference).
    F32,
}

/// Owned bytes of a model blob written by `scorer_core::model::encode` (decode with
/// `scorer_core::model::decode`).
pub fn encode_model(m: &Model<'_>) -> Result<Vec<u8>, ExportError> {
    let len = model::encoded_len(m).map_err(ExportError::Model)?;
    let mut buf = vec![0u8; len];
    let n = model::encode(m, &mut buf).map_err(ExportError::Model)?;
    buf.truncate(n);
    Ok(buf)
}

/// The core's MSRA model of float parameters.
pub fn msra_terms(params: &MsraParams) -> Result<BoundedVec<MsraTerm, 4>, ExportError> {
    let mut terms = Vec::new();
    for (k, t) in params.terms.iter().enumerate() {
        let kind = parse_surrogate(&t.surrogate).ok_or_else(|| ExportError::UnknownSurrogate {
            term: k,
            name: t.surrogate.clone(),
        })?;
        terms.push(t.core_term(kind));
    }
    BoundedVec::from_slice(&terms).map_err(ExportError::Model)
}

/// The blob of an MSRA model.
pub fn msra_blob(params: &MsraParams) -> Result<Vec<u8>, ExportError> {
    let m = MsraModel {
        terms: msra_terms(params)?,
        gssm: None,
    };
    encode_model(&Model::Msra(m))
}

/// The blob of a quantised DRL network.
pub fn drl_int8_blob(q: &QuantisedDrl) -> Result<Vec<u8>, ExportError> {
    encode_model(&Model::DrlInt8(q.as_core()?))
}

/// The blob of a float DRL network.
pub fn drl_f32_blob(params: &DrlParams) -> Result<Vec<u8>, ExportError> {
    let fb = FloatBuffers::from_params(params);
    let blob = encode_model(&Model::DrlF32(fb.as_core()?))?;
    Ok(blob)
}

/// Export a checkpoint as a model blob (DRL: quantised with its stored calibration unless `F32`).
pub fn export(checkpoint: &Checkpoint, drl_format: DrlFormat) -> Result<Vec<u8>, ExportError> {
    match &checkpoint.model {
        CheckpointModel::Drl {
            params,
            calibration,
        } => match drl_format {
            DrlFormat::Int8 => drl_int8_blob(&quantize::quantize(params, calibration)?),
            DrlFormat::F32 => drl_f32_blob(params),
        },
        CheckpointModel::Msra { params } => msra_blob(params),
    }
}

/// Write `blob` to `path` (creating missing parent folders, removed again if the write fails).
pub fn write_blob(path: &Path, blob: &[u8]) -> Result<(), ExportError> {
    // Through the output layer: a unique temporary beside `path`, renamed over it when complete;
    // the layer makes the missing parent folders.
    let io = |source| ExportError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut f = riskscore_output::AtomicFile::create(path).map_err(io)?;
    std::io::Write::write_all(&mut f, blob).map_err(io)?;
    f.commit().map_err(io)
}

/// Write the files `(path, bytes)` of one folder as a set: nothing is renamed into place until
/// every file is written and synced (riskscore-output's `AtomicSet`), so a failure (a full disk at
/// the third file) leaves all the old files.
pub fn write_set(dir: &Path, files: &[(PathBuf, Vec<u8>)]) -> Result<(), ExportError> {
    let mut set = riskscore_output::AtomicSet::default();
    for (path, bytes) in files {
        let io = |source| ExportError::Io {
            path: path.display().to_string(),
            source,
        };
        set.create(path)
            .and_then(|f| std::io::Write::write_all(f, bytes))
            .map_err(io)?;
    }
    // The set's errors name the file too: `dir: dir/msra.json: No space left on device`.
    set.commit().map(drop).map_err(|source| ExportError::Io {
        path: dir.display().to_string(),
        source,
    })
}

/// One MSRA term as `inspect` prints it: `TAdv-corridor: w = .., a = .., b = .., clip [lo, hi]`.
fn term_text(t: &scorer_core::msra::MsraTerm) -> String {
    format!(
        "{}: w = {:.4}, a = {:.4}, b = {:.4}, clip [{}, {}]",
        t.kind.name(),
        t.weight,
        t.a,
        t.b,
        t.lo,
        t.hi
    )
}

/// Decode a blob (header, CRC, payload, validation) and describe it for humans.
pub fn inspect(blob: &[u8]) -> Result<String, ModelError> {
    let header = model::decode_header(blob)?;
    let decoded_blob = model::decode_blob(blob)?;
    let decoded = &decoded_blob.model;
    let mut s = String::new();
    let _ = writeln!(s, "header");
    let _ = writeln!(s, "  magic           RSKM");
    let _ = writeln!(s, "  format version  {}", header.version);
    let _ = writeln!(
        s,
        "  kind            {} ({})",
        header.kind.name(),
        header.kind as u8
    );
    let schema = if header.feature_schema == model::DRL_INPUT_SCHEMA {
        "DRL input encoding 3: scorer_core::encoding"
    } else {
        "the 13 features"
    };
    let _ = writeln!(s, "  input schema    {} ({schema})", header.feature_schema);
    let _ = writeln!(s, "  payload         {} bytes", header.payload_len);
    let _ = writeln!(
        s,
        "  payload CRC-32  {:#010x} (verified)",
        header.payload_crc
    );
    let _ = writeln!(
        s,
        "size\n  total           {} bytes ({} header + {} payload)",
        blob.len(),
        HEADER_LEN,
        header.payload_len
    );
    let _ = writeln!(s, "warning");
    let _ = writeln!(
        s,
        "  default threshold {} ({})",
        decoded_blob.default_threshold(),
        threshold_rule_text(&decoded_blob)
    );
    let _ = write!(s, "{}", training_domain_text(&decoded_blob));
    let _ = writeln!(s, "parameters");
    match decoded {
        Model::DrlInt8(m) => {
            let mut dims = vec![m.inputs.len().to_string()];
            let mut macs = 0usize;
            let mut weights = 0usize;
            let mut in_dim = m.inputs.len();
            for l in m.layers.iter() {
                dims.push(l.out_dim.to_string());
                macs += usize::from(l.out_dim) * in_dim;
                weights += l.weights.len();
                in_dim = usize::from(l.out_dim);
            }
            let _ = writeln!(s, "  network         int8 MLP {}", dims.join("-"));
            let _ = writeln!(
                s,
                "  inputs          {} (DRL input encoding)",
                m.inputs.len()
            );
            let _ = writeln!(s, "  input zero pt   {}", m.input_zero_point);
            let _ = writeln!(s, "  int8 weights    {weights}");
            let _ = writeln!(s, "  MACs/partner    {macs}");
            for (i, l) in m.layers.iter().enumerate() {
                let w: Vec<i8> = l.weights.iter().map(|&b| b as i8).collect();
                let (lo, hi) = w
                    .iter()
                    .fold((i8::MAX, i8::MIN), |(a, b), &x| (a.min(x), b.max(x)));
                let _ = writeln!(
                    s,
                    "  layer {i}         out {:>2}, relu {}, weights [{lo}, {hi}], output zero point {}",
                    l.out_dim, l.relu, l.output_zero_point
                );
            }
            let _ = writeln!(s, "  output scales   {:?}", m.output_scales.as_slice());
        }
        Model::DrlF32(m) => {
            let mut dims = vec![m.inputs.len().to_string()];
            let mut params = 0usize;
            for l in m.layers.iter() {
                dims.push(l.out_dim.to_string());
                params += (l.weights.len() + l.bias.len()) / 4;
            }
            let _ = writeln!(s, "  network         f32 MLP {}", dims.join("-"));
            let _ = writeln!(s, "  parameters      {params}");
        }
        Model::Msra(m) => {
            let _ = writeln!(s, "  terms           {}", m.terms.len());
            for (k, t) in m.terms.iter().enumerate() {
                let _ = writeln!(s, "  term {k}          {}", term_text(t));
            }
            let _ = writeln!(s, "  embedded GSSM   {}", m.gssm.is_some());
        }
        Model::Gssm(_) => {
            let _ = writeln!(s, "  GSSM lognormal spacing model");
        }
    }
    let _ = writeln!(
        s,
        "integrity         OK (decoded, CRC and validation passed)"
    );
    Ok(s)
}

/// The training-domain section of [`inspect`]: policy and one line per bounded input.
pub fn training_domain_text(blob: &model::ModelBlob<'_>) -> String {
    let mut s = String::from("training domain\n");
    let Some(domain) = &blob.meta.training_domain else {
        s.push_str("  none stored: unguarded (every observation counts as inside)\n");
        return s;
    };
    let names = match blob.model.kind() {
        model::ModelKind::DrlInt8 | model::ModelKind::DrlF32 => &scorer_core::DRL_INPUT_NAMES,
        model::ModelKind::Msra | model::ModelKind::Gssm => &scorer_core::FEATURE_NAMES,
    };
    let _ = writeln!(
        s,
        "  policy          {}, {} inputs bounded",
        policy_text(domain.policy),
        domain.len()
    );
    for r in domain.ranges() {
        let name = names.get(usize::from(r.input)).copied().unwrap_or("?");
        let _ = writeln!(s, "  {:<15} [{}, {}]", name, r.lo, r.hi);
    }
    if let Some(coverage) = &domain.coverage {
        let _ = writeln!(
            s,
            "  {:<15} {} of {} cells covered (scheme {}: 3 gap bands x 8 bearings x 8 headings, \
             scorer_core::geometry_cell)",
            model::geometry_coverage::GEOMETRY_INPUT_NAME,
            coverage.covered(),
            scorer_core::geometry_cell::GEOMETRY_CELLS,
            coverage.scheme
        );
    }
    if let Some(fallback) = &blob.meta.kinematic_fallback {
        let _ = writeln!(
            s,
            "  fallback        {} * R + {} outside, R = kinematic MSRA of {} terms:",
            fallback.scale,
            fallback.offset,
            fallback.len()
        );
        for (k, t) in fallback.terms().enumerate() {
            let _ = writeln!(s, "  fallback term {k} {}", term_text(&t));
        }
    }
    if let Some(blend) = &blob.meta.blend {
        let _ = writeln!(s, "  blend           {} inside", blend_text(blend));
    }
    s
}

/// A blend record's mix as the tools print it: "0.7 * model + 0.3 * fallback".
pub fn blend_text(blend: &model::Blend) -> String {
    let w = blend.network_weight;
    format!("{w} * model + {} * fallback", 1.0 - w)
}

/// What `policy` does, as the tools print it: "clamp outside", "blend (fallback outside, mixed in
/// inside)".
pub fn policy_text(policy: OutsidePolicy) -> String {
    match policy {
        OutsidePolicy::Blend => "blend (fallback outside, mixed in inside)".to_owned(),
        other => format!("{} outside", other.name()),
    }
}

/// `blob` with the training domain measured on the sequences of `train` (each input between its
/// 0.1 % and 99.9 % frame quantiles, widened to what 1 % of the sequences reached) under
/// `guard`'s policy; `GuardPolicy::None` returns the blob unchanged. Final and fold models both
/// go through here, so a benchmark measures the record the shipped model would carry. The policy
/// (default `blend`) was picked from held-out measurements (`docs/domain-guard.md`).
///
/// Under `fallback` and `blend` a DRL or GSSM blob also gets its kinematic fallback: the
/// kinematic terms of `fallback_terms` (the MSRA trained beside it) aligned to the model's scores
/// on the frames of `train` inside the measured domain ([`crate::fallback::fit`]); under `blend`
/// also the blend record with `guard.blend_weight` (a DRL's alone: a GSSM gets `fallback`). An
/// MSRA blob is itself a kinematic score and gets a `flag-only` record. A GSSM's domain is
/// measured on the safe sequences of `train` alone ([`domain_sequences`]).
///
/// A DRL whose fallback cannot be fitted on its data (its scores fall as the kinematic score
/// rises, too few frames inside, ...) gets a `flag-only` record instead, and the reason comes
/// back in [`GuardedBlob::fallback_refused`] for the caller to report: a training run or a
/// benchmark fold does not fail over a model the guard cannot pair with a kinematic stand-in.
pub fn with_measured_domain(
    blob: &[u8],
    train: &[Sequence],
    guard: &GuardConfig,
    fallback_terms: Option<&[MsraTerm]>,
) -> Result<GuardedBlob, ExportError> {
    let Some((policy, blend)) = guard.record() else {
        return Ok(GuardedBlob {
            bytes: blob.to_vec(),
            fallback: None,
            fallback_refused: None,
        });
    };
    with_domain_measured(
        blob,
        train,
        riskscore_eval::domain_ranges::DEFAULT_TAILS,
        (policy, blend),
        fallback_terms,
    )
}

/// [`with_measured_domain`] with the ranges' and cells' `tails` and a record policy (with its
/// blend record under `blend`): the one pipeline behind training's exports and `riskctl
/// calibrate-domain` (which sets the tails and fails where a fallback is refused).
pub fn with_domain_measured(
    blob: &[u8],
    train: &[Sequence],
    tails: riskscore_eval::domain_ranges::Tails,
    (policy, blend): (OutsidePolicy, Option<model::Blend>),
    fallback_terms: Option<&[MsraTerm]>,
) -> Result<GuardedBlob, ExportError> {
    if (policy == OutsidePolicy::Blend) != blend.is_some() {
        return Err(ExportError::Domain(
            "the blend policy, and only it, needs the network's share (a blend record)".into(),
        ));
    }
    let decoded = model::decode_blob(blob).map_err(ExportError::Model)?;
    let policy = match policy {
        p if p.uses_fallback() && !decoded.model.runs_a_network() => OutsidePolicy::FlagOnly,
        // Inside its domain a GSSM (SSRA is one) stays the model of normal driving it was fitted
        // as: the baseline the method is compared with, not a mix with the kinematic score.
        OutsidePolicy::Blend if matches!(decoded.model, Model::Gssm(_)) => OutsidePolicy::Fallback,
        other => other,
    };
    let pairs = || {
        train
            .iter()
            .flat_map(|s| s.frames.iter().map(|f| (&f.ego, &f.partner)))
    };
    let per_sequence = domain_sequences(&decoded.model, train)
        .into_iter()
        .map(|s| s.frames.iter().map(|f| (&f.ego, &f.partner)));
    let mut domain =
        riskscore_eval::domain_ranges::measure(&decoded.model, per_sequence, tails, policy)
            .map_err(|e| ExportError::Domain(e.to_string()))?;
    let mut fallback_refused = None;
    let fallback = if policy.uses_fallback() {
        let terms = fallback_terms.ok_or(ExportError::Domain(
            "the fallback and blend policies need the MSRA trained beside the model (its \
             kinematic terms)"
                .into(),
        ))?;
        match crate::fallback::fit(&decoded, &domain.domain(), terms, pairs()) {
            Ok(fitted) => Some(fitted),
            Err(reason) => {
                domain.policy = OutsidePolicy::FlagOnly;
                fallback_refused = Some(reason);
                None
            }
        }
    } else {
        None
    };
    let blend = blend.filter(|_| domain.policy == OutsidePolicy::Blend);
    let bytes = with_training_domain(
        blob,
        domain.domain(),
        fallback.as_ref().map(|f| f.record()),
        blend,
    )?;
    Ok(GuardedBlob {
        bytes,
        fallback,
        fallback_refused,
    })
}

/// The sequences of `train` a model's training domain is measured on: all of them, except for a
/// GSSM (SSRA is one too), a model of normal driving fitted on the safe ones: a context only
/// conflicts reached is one its spacing distribution never saw.
pub fn domain_sequences<'s>(model: &model::Model<'_>, train: &'s [Sequence]) -> Vec<&'s Sequence> {
    let normal_only = matches!(model, model::Model::Gssm(_));
    train
        .iter()
        .filter(|s| !(normal_only && s.is_conflict()))
        .collect()
}

/// A blob with its measured training-domain record ([`with_measured_domain`]).
#[derive(Debug)]
pub struct GuardedBlob {
    pub bytes: Vec<u8>,
    /// The kinematic fallback the record carries, with how it was fitted.
    pub fallback: Option<crate::fallback::FittedFallback>,
    /// Why a `fallback` policy was written as `flag-only`: the fallback could not be fitted.
    pub fallback_refused: Option<crate::fallback::FallbackError>,
}

impl GuardedBlob {
    /// The warning a user of model `name` should read when its fallback was refused.
    pub fn warning(&self, name: &str) -> Option<String> {
        self.fallback_refused.as_ref().map(|reason| {
            format!("{name}: no kinematic fallback ({reason}); its guard is flag-only")
        })
    }
}

/// `blob` with its training-domain record set to `domain`, its kinematic-fallback record to
/// `fallback` (which the fallback and blend policies need and every other policy refuses) and its
/// blend record to `blend` (the blend policy's alone); the model and the default threshold
/// unchanged, checked by decoding it again.
pub fn with_training_domain(
    blob: &[u8],
    domain: model::TrainingDomain<'_>,
    fallback: Option<model::KinematicFallback<'_>>,
    blend: Option<model::Blend>,
) -> Result<Vec<u8>, ExportError> {
    let mut decoded = model::decode_blob(blob).map_err(ExportError::Model)?;
    decoded.meta.training_domain = Some(domain);
    decoded.meta.kinematic_fallback = fallback;
    decoded.meta.blend = blend;
    let mut out = vec![0u8; model::encoded_blob_len(&decoded).map_err(ExportError::Model)?];
    let n = model::encode_blob(&decoded, &mut out).map_err(ExportError::Model)?;
    out.truncate(n);
    model::decode_blob(&out).map_err(ExportError::Model)?;
    Ok(out)
}

/// How the default threshold of a blob was chosen, in words.
pub fn threshold_rule_text(blob: &model::ModelBlob<'_>) -> String {
    let Some(op) = blob.meta.default_threshold else {
        return "no calibration stored: the kind's rule (DRL r*/2 = 2.0, MSRA half the sum of its \
                weights' magnitudes, GSSM the middle of its score mode's range)"
            .to_owned();
    };
    let data = if op.data.is_empty() {
        String::new()
    } else {
        format!(" of {}", op.data)
    };
    match op.rule {
        model::ThresholdRule::KindDefault => format!("the kind's rule, stored{data}"),
        model::ThresholdRule::SafeShare {
            target,
            measured,
            sequences,
        } => {
            // The stored f32 share is k / sequences rounded; print the count's share, so a tie
            // rounds as `riskctl calibrate` printed it from the count.
            let warned = (f64::from(measured) * f64::from(sequences)).round();
            let share = if sequences == 0 {
                0.0
            } else {
                100.0 * warned / f64::from(sequences)
            };
            format!(
                "calibrated: the smallest sequence maximum at which at most {:.1} % of {sequences} \
                 normal-driving sequences{data} warn; {} % do",
                100.0 * target,
                riskscore_eval::report::fixed(share, 1)
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calibrated_share_prints_from_its_count() {
        // 1 of 80 sequences warn: 1.25 % exactly, a tie; the f32 share is 0.0125000002 and
        // `{:.1}` of it alone printed 1.3 where `riskctl calibrate` printed 1.2 from the count.
        let mut blob =
            model::decode_blob(include_bytes!("../../../models/msra-default.rsk")).unwrap();
        blob.meta.default_threshold = Some(model::DefaultThreshold {
            threshold: 1.0,
            rule: model::ThresholdRule::SafeShare {
                target: 0.05,
                measured: 1.0 / 80.0,
                sequences: 80,
            },
            data: "",
        });
        let text = threshold_rule_text(&blob);
        assert!(
            text.ends_with("at most 5.0 % of 80 normal-driving sequences warn; 1.2 % do"),
            "{text}"
        );
    }
}
