//! Streaming CSV scoring of ego/partner pairs: the engine behind `riskctl ssm`.
//!
//! Input: any CSV whose header contains the 18 pair columns [`STATE_FIELDS`] with the suffixes
//! `_i` (ego) and `_j` (partner), matched case-insensitively; other columns are passed through in
//! their original order. Output: the input columns, then [`SURROGATE_COLUMNS`], then the 13
//! features as `f_<name>`. Infinities are written `inf` / `-inf`; finite values in the shortest
//! form that reads back to the same f32.
//!
//! Positions are made relative to the ego's centre in f64 before they become f32: all measures
//! depend only on relative positions, and this keeps centimetre precision for world coordinates
//! as large as UTM eastings/northings (f32 alone resolves 0.5 m at 5,000 km).
//!
//! Every number comes from `scorer-core` ([`scorer_core::surrogates`], [`scorer_core::features`]);
//! this module only parses, validates and writes.
//!
//! The file is processed as a pipeline of chunks of whole records (see [`split`]): the calling
//! thread reads and cuts the input and writes the results in input order, worker threads parse,
//! score and format whole chunks. At most a fixed number of chunks is in flight, so memory does
//! not grow with the file, and the output is byte for byte what a one-row-at-a-time writer
//! produces.
//!
//! A bad row (missing or empty field, unparsable number, non-finite or out-of-f32-range value,
//! zero heading vector, negative length or width, wrong number of fields, a line over the length
//! cap, a quoted field that is never closed) is reported with its line number (and column where
//! there is one) and skipped; in strict mode the first one stops the run. Pass-through columns are
//! copied byte for byte, whatever their encoding.
use scorer_core::geometry::unit_heading;
use scorer_core::surrogates::surrogates_and_features;
use scorer_core::{VehicleState, FEATURE_NAMES};

mod field;
mod last_ego;
mod number;
mod pipeline;
mod row_fields;
pub mod split;

pub use number::{parse_plain_decimal, push_f32, F32Texts};
// The record layer, shared with the Parquet path (`riskscore_eval::parquet_io`).
pub use field::push_field;
pub use last_ego::LastEgo;
pub use pipeline::{for_each_record, read_header, record_reader, FieldBuf};
pub use pipeline::{score_csv, SsmOptions, SsmSummary};
pub use row_fields::RowFields;
pub use split::DEFAULT_MAX_RECORD_BYTES;

/// The per-vehicle input fields, in [`VehicleState`] order; columns are `<field>_i` / `<field>_j`.
pub const STATE_FIELDS: [&str; 9] = ["x", "y", "vx", "vy", "hx", "hy", "acc", "length", "width"];

/// The surrogate columns appended after the input columns.
pub const SURROGATE_COLUMNS: [&str; 4] = ["box_distance", "ttc2d", "tadv", "ei"];

/// A problem with the file as a whole.
#[derive(Debug, thiserror::Error)]
pub enum SsmError {
    #[error("the header has no column(s) {missing}; expected x,y,vx,vy,hx,hy,acc,length,width with suffixes _i and _j (case-insensitive)")]
    MissingColumns { missing: String },
    #[error("column {name} appears twice in the header (columns {first} and {second})")]
    DuplicateColumn {
        name: String,
        first: usize,
        second: usize,
    },
    #[error("the input is empty (no header line)")]
    EmptyInput,
    #[error("header, column {column}: name \"{name}\" is not UTF-8, and a Parquet column name must be: rename it, or write CSV output, which keeps the bytes")]
    NonUtf8Name { column: usize, name: String },
    #[error("header (line {line}): {}; no row can be read without the header (--max-line-bytes sets the limit)", .problem.what())]
    BadHeader {
        line: u64,
        problem: split::SplitProblem,
    },
    #[error("{0}")]
    BadRow(RowError),
    #[error("reading input")]
    Read(#[source] std::io::Error),
    #[error("writing output")]
    Io(#[from] std::io::Error),
}

/// Why a row was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RowProblem {
    #[error("missing field")]
    Missing,
    #[error("cannot parse {0:?} as a number")]
    Unparsable(String),
    #[error("value {0} is not finite")]
    NotFinite(String),
    #[error("value {0} is outside the f32 range")]
    OutOfRange(String),
    #[error("value {0} is negative (a vehicle size must be >= 0)")]
    NegativeSize(String),
    #[error("heading vector ({0}, {1}) is zero (or too short to normalise in f32)")]
    ZeroHeading(String, String),
    #[error("row has {found} fields but the header has {expected}")]
    FieldCount { found: usize, expected: usize },
    #[error("malformed CSV: {0}")]
    Csv(String),
    #[error("line longer than {limit} bytes (skipped to the next line)")]
    TooLong { limit: usize },
    #[error("quoted field not closed (by the end of the input or within {limit} bytes); reading resumes on the next line")]
    UnterminatedQuote { limit: usize },
    #[error("text \"{0}\" is not UTF-8, and a Parquet text column holds UTF-8 only (CSV output keeps the bytes; or convert the input, e.g. iconv -f latin1 -t utf-8)")]
    NotUtf8(String),
}

impl RowProblem {
    /// A short name of the kind of problem, the same for every row with it (for summaries).
    pub fn kind(&self) -> &'static str {
        match self {
            RowProblem::Missing => "missing field",
            RowProblem::Unparsable(_) => "not a number",
            RowProblem::NotFinite(_) => "not finite",
            RowProblem::OutOfRange(_) => "outside the f32 range",
            RowProblem::NegativeSize(_) => "negative size",
            RowProblem::ZeroHeading(..) => "zero heading",
            RowProblem::FieldCount { .. } => "too many fields",
            RowProblem::Csv(_) => "malformed CSV",
            RowProblem::TooLong { .. } => "line too long",
            RowProblem::UnterminatedQuote { .. } => "unterminated quote",
            RowProblem::NotUtf8(_) => "not UTF-8",
        }
    }
}

impl From<split::SplitProblem> for RowProblem {
    fn from(p: split::SplitProblem) -> Self {
        match p {
            split::SplitProblem::TooLong { limit } => RowProblem::TooLong { limit },
            split::SplitProblem::UnterminatedQuote { limit } => {
                RowProblem::UnterminatedQuote { limit }
            }
        }
    }
}

/// A rejected row: its 1-based line number in the input, the column at fault and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}{}: {problem}", column.as_deref().map(|c| format!(", column {c}")).unwrap_or_default())]
pub struct RowError {
    pub line: u64,
    pub column: Option<String>,
    pub problem: RowProblem,
}

/// Where the pair columns sit in the input header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PairColumns {
    /// Column index of `<field>_i` for each of [`STATE_FIELDS`].
    pub ego: [usize; 9],
    /// Column index of `<field>_j` for each of [`STATE_FIELDS`].
    pub partner: [usize; 9],
    /// The header as read (trimmed, byte-order mark removed), for messages, matching and
    /// Parquet output; bytes that are not UTF-8 show as U+FFFD here.
    pub names: Vec<String>,
    /// The same names as bytes, exactly as in the input (trimmed): what a CSV output's header
    /// repeats, whatever their encoding.
    pub name_bytes: Vec<Vec<u8>>,
}

impl PairColumns {
    /// Locate the 18 pair columns (case-insensitive, exact names) in `header`.
    pub fn from_header(header: &csv::StringRecord) -> Result<Self, SsmError> {
        // Trimmed, and without the byte-order mark that spreadsheet exports put in front.
        let names: Vec<String> = header
            .iter()
            .map(|h| h.trim_start_matches('\u{feff}').trim().to_string())
            .collect();
        let find = |wanted: &str| -> Result<Option<usize>, SsmError> {
            let mut hits = names
                .iter()
                .enumerate()
                .filter(|(_, n)| n.eq_ignore_ascii_case(wanted))
                .map(|(k, _)| k);
            let first = hits.next();
            match (first, hits.next()) {
                (Some(first), Some(second)) => Err(SsmError::DuplicateColumn {
                    name: wanted.to_string(),
                    first: first + 1,
                    second: second + 1,
                }),
                (first, _) => Ok(first),
            }
        };
        let mut missing = Vec::new();
        let mut ego = [0usize; 9];
        let mut partner = [0usize; 9];
        for (suffix, slots) in [("i", &mut ego), ("j", &mut partner)] {
            for (field, slot) in STATE_FIELDS.iter().zip(slots.iter_mut()) {
                let wanted = format!("{field}_{suffix}");
                match find(&wanted)? {
                    Some(k) => *slot = k,
                    None => missing.push(wanted),
                }
            }
        }
        if !missing.is_empty() {
            return Err(SsmError::MissingColumns {
                missing: missing.join(", "),
            });
        }
        let name_bytes = names.iter().map(|n| n.as_bytes().to_vec()).collect();
        Ok(Self {
            ego,
            partner,
            names,
            name_bytes,
        })
    }

    /// [`Self::from_header`] for a header read as bytes: the names are matched as text, and the
    /// bytes are kept for the output.
    pub fn from_header_bytes(fields: Vec<Vec<u8>>) -> Result<Self, SsmError> {
        let header: csv::StringRecord = fields
            .iter()
            .map(|f| String::from_utf8_lossy(f).into_owned())
            .collect();
        let mut columns = Self::from_header(&header)?;
        // UTF-8 names as matched (trimmed as text); others trimmed of ASCII blanks.
        for (kept, field) in columns.name_bytes.iter_mut().zip(&fields) {
            if std::str::from_utf8(field).is_err() {
                *kept = field.trim_ascii().to_vec();
            }
        }
        Ok(columns)
    }

    /// The first header name that is not UTF-8: its 1-based column and its text with the
    /// offending bytes written `\xNN`.
    pub fn non_utf8_name(&self) -> Option<(usize, String)> {
        self.name_bytes
            .iter()
            .position(|n| std::str::from_utf8(n).is_err())
            .map(|k| (k + 1, escape_non_utf8(&self.name_bytes[k])))
    }

    /// The CSV output header line: the input names as bytes, then the computed columns.
    pub fn output_header_line(&self) -> Vec<u8> {
        let mut line = Vec::new();
        let computed = self.output_header().split_off(self.names.len());
        let names = self
            .name_bytes
            .iter()
            .map(Vec::as_slice)
            .chain(computed.iter().map(|c| c.as_bytes()));
        for (k, name) in names.enumerate() {
            if k > 0 {
                line.push(b',');
            }
            field::push_field(&mut line, name);
        }
        line.push(b'\n');
        line
    }

    /// The output header: the input header followed by the surrogate and feature columns.
    pub fn output_header(&self) -> Vec<String> {
        self.names
            .iter()
            .cloned()
            .chain(SURROGATE_COLUMNS.iter().map(|c| c.to_string()))
            .chain(FEATURE_NAMES.iter().map(|f| format!("f_{f}")))
            .collect()
    }

    /// Output columns that already exist in the input (they will appear twice).
    pub fn clashing_output_columns(&self) -> Vec<String> {
        self.output_header()
            .into_iter()
            .skip(self.names.len())
            .filter(|c| self.names.iter().any(|n| n == c))
            .collect()
    }

    /// Parse and validate the ego and partner states of one record. Positions are returned
    /// relative to the ego's centre (the ego is at the origin).
    /// `last_ego`: the ego of the previous row, reused when this row repeats it (see [`LastEgo`]).
    pub fn parse_pair<F: RowFields + ?Sized>(
        &self,
        record: &F,
        line: u64,
        last_ego: &mut LastEgo,
    ) -> Result<(VehicleState, VehicleState), RowError> {
        let (ego, partner) = self.parsed_values(record, line, last_ego)?;
        self.build_pair(ego, partner, line)
    }

    /// The 2 x 9 pair values of one record, parsed once, each checked on its own (field count,
    /// missing, number, finite, size sign); [`Self::build_pair`] checks the pair as a whole.
    fn parsed_values<F: RowFields + ?Sized>(
        &self,
        record: &F,
        line: u64,
        last_ego: &mut LastEgo,
    ) -> Result<([f64; 9], [f64; 9]), RowError> {
        if record.field_count() > self.names.len() {
            return Err(RowError {
                line,
                column: None,
                problem: RowProblem::FieldCount {
                    found: record.field_count(),
                    expected: self.names.len(),
                },
            });
        }
        // A short row is bad when it lacks a pair column (name the first one); missing trailing
        // pass-through columns are tolerated and written empty.
        let first_missing = self
            .ego
            .iter()
            .chain(self.partner.iter())
            .copied()
            .filter(|&k| k >= record.field_count())
            .min();
        if let Some(k) = first_missing {
            return Err(RowError {
                line,
                column: self.names.get(k).cloned(),
                problem: RowProblem::Missing,
            });
        }
        let ego = match last_ego.values_if_same(record, &self.ego) {
            Some(values) => values,
            None => {
                let values = self.parse_state(record, &self.ego, line)?;
                last_ego.keep(record, &self.ego, values);
                values
            }
        };
        let partner = self.parse_state(record, &self.partner, line)?;
        Ok((ego, partner))
    }

    /// Validate the 2 x 9 values of a pair (already parsed, in [`STATE_FIELDS`] order) and build
    /// the two states. Both positions are made relative to the ego, subtracted in f64: every
    /// measure depends only on relative positions, and this keeps centimetres even for UTM-sized
    /// world coordinates, which f32 alone would round to half a metre.
    pub fn pair_from_values(
        &self,
        ego: [f64; 9],
        partner: [f64; 9],
        line: u64,
    ) -> Result<(VehicleState, VehicleState), RowError> {
        // The usual case in one branch-free pass; the per-value checks below name the culprit.
        if !(values_pass_checks(&ego) && values_pass_checks(&partner)) {
            self.first_bad_value(&ego, &partner, line)?;
        }
        self.build_pair(ego, partner, line)
    }

    /// [`Self::pair_from_values`] for rows that list an ego's partners one after another:
    /// `last_ego` holds the values and state of the last ego that passed, and an ego with the
    /// same values (bit for bit) takes that state without being checked and built again. The
    /// state depends on the ego's values alone, so the result and every error are the same.
    pub fn pair_from_values_reusing(
        &self,
        ego: [f64; 9],
        partner: [f64; 9],
        line: u64,
        last_ego: &mut Option<([f64; 9], VehicleState)>,
    ) -> Result<(VehicleState, VehicleState), RowError> {
        if let Some((values, ego_state)) = last_ego.as_ref() {
            if values
                .iter()
                .zip(&ego)
                .all(|(a, b)| a.to_bits() == b.to_bits())
            {
                // The ego passed every check before: only the partner can be at fault.
                if !values_pass_checks(&partner) {
                    self.first_bad_value(&ego, &partner, line)?;
                }
                let partner_state =
                    self.to_state(partner, (ego[0], ego[1]), &self.partner, line)?;
                return Ok((*ego_state, partner_state));
            }
        }
        let pair = self.pair_from_values(ego, partner, line)?;
        *last_ego = Some((ego, pair.0));
        Ok(pair)
    }

    /// The error of the first value (ego, then partner, in [`STATE_FIELDS`] order) that fails
    /// [`check_value`].
    fn first_bad_value(
        &self,
        ego: &[f64; 9],
        partner: &[f64; 9],
        line: u64,
    ) -> Result<(), RowError> {
        for (values, columns) in [(ego, &self.ego), (partner, &self.partner)] {
            for ((&v, &k), field) in values.iter().zip(columns).zip(STATE_FIELDS) {
                check_value(v, field).map_err(|problem| RowError {
                    line,
                    column: self.names.get(k).cloned(),
                    problem,
                })?;
            }
        }
        Ok(())
    }

    /// The two states from checked values, positions relative to the ego.
    fn build_pair(
        &self,
        ego: [f64; 9],
        partner: [f64; 9],
        line: u64,
    ) -> Result<(VehicleState, VehicleState), RowError> {
        let origin = (ego[0], ego[1]);
        Ok((
            self.to_state(ego, origin, &self.ego, line)?,
            self.to_state(partner, origin, &self.partner, line)?,
        ))
    }

    /// Parse and validate the values of one record (as in the input, positions not yet relative).
    pub fn parse_values<F: RowFields + ?Sized>(
        &self,
        record: &F,
        line: u64,
        last_ego: &mut LastEgo,
    ) -> Result<([f64; 9], [f64; 9]), RowError> {
        let (ego, partner) = self.parsed_values(record, line, last_ego)?;
        self.build_pair(ego, partner, line)?;
        Ok((ego, partner))
    }

    /// Parse the nine values of one vehicle (f64; validated by [`Self::pair_from_values`]).
    fn parse_state<F: RowFields + ?Sized>(
        &self,
        record: &F,
        columns: &[usize; 9],
        line: u64,
    ) -> Result<[f64; 9], RowError> {
        let mut v = [0f64; 9];
        // The usual row: nine plain decimals that pass the checks, seen in one pass each; the
        // loop below parses the rest and names the first value at fault.
        let mut plain = true;
        for (&k, slot) in columns.iter().zip(v.iter_mut()) {
            match record.field(k).and_then(number::parse_plain_decimal) {
                Some(wide) => *slot = wide,
                None => {
                    plain = false;
                    break;
                }
            }
        }
        if plain && values_pass_checks(&v) {
            return Ok(v);
        }
        for ((&k, field), slot) in columns.iter().zip(STATE_FIELDS).zip(v.iter_mut()) {
            let err = |problem| RowError {
                line,
                column: self.names.get(k).cloned(),
                problem,
            };
            let bytes = record.field(k).unwrap_or_default();
            // Most values are plain decimals: parsed exactly as below, without the detour.
            if let Some(wide) = number::parse_plain_decimal(bytes) {
                if let Err(problem) = check_value(wide, field) {
                    let raw = String::from_utf8_lossy(bytes);
                    return Err(err(with_text(problem, &raw)));
                }
                *slot = wide;
                continue;
            }
            let raw = match std::str::from_utf8(bytes) {
                Ok(text) => text.trim(),
                Err(_) => {
                    return Err(err(RowProblem::Unparsable(
                        String::from_utf8_lossy(bytes).into_owned(),
                    )))
                }
            };
            if raw.is_empty() {
                return Err(err(RowProblem::Missing));
            }
            let wide: f64 = raw
                .parse()
                .map_err(|_| err(RowProblem::Unparsable(raw.to_string())))?;
            // The value's own text in messages, as the user wrote it.
            check_value(wide, field).map_err(|problem| err(with_text(problem, raw)))?;
            *slot = wide;
        }
        Ok(v)
    }

    /// Build the f32 state of one vehicle with its position relative to `origin` (subtracted in
    /// f64), and check that scorer-core can normalise its heading.
    fn to_state(
        &self,
        v: [f64; 9],
        origin: (f64, f64),
        columns: &[usize; 9],
        line: u64,
    ) -> Result<VehicleState, RowError> {
        let [x, y, vx, vy, hx, hy, acc, length, width] = v;
        let state = VehicleState {
            x: (x - origin.0) as f32,
            y: (y - origin.1) as f32,
            vx: vx as f32,
            vy: vy as f32,
            hx: hx as f32,
            hy: hy as f32,
            acc: acc as f32,
            length: length as f32,
            width: width as f32,
        };
        let column = |k: usize| columns.get(k).and_then(|&c| self.names.get(c)).cloned();
        if !(state.x.is_finite() && state.y.is_finite()) {
            let k = if state.x.is_finite() { 1 } else { 0 };
            return Err(RowError {
                line,
                column: column(k),
                problem: RowProblem::OutOfRange(format!("{}", if k == 0 { x } else { y })),
            });
        }
        if unit_heading(&state).is_none() {
            return Err(RowError {
                line,
                column: column(4),
                problem: RowProblem::ZeroHeading(hx.to_string(), hy.to_string()),
            });
        }
        Ok(state)
    }
}

/// Check one input value: finite, within the f32 range, and >= 0 for a size. The problem names
/// the value as formatted from f64 (callers with the original text substitute it).
pub fn check_value(wide: f64, field: &str) -> Result<(), RowProblem> {
    let text = || wide.to_string();
    if !wide.is_finite() {
        return Err(RowProblem::NotFinite(text()));
    }
    if !(wide as f32).is_finite() {
        return Err(RowProblem::OutOfRange(text()));
    }
    // Sign first: the name comparison runs for negative values only (18 values a row).
    if wide < 0.0 && (field == "length" || field == "width") {
        return Err(RowProblem::NegativeSize(text()));
    }
    Ok(())
}

/// True when every one of a vehicle's nine values (in [`STATE_FIELDS`] order) passes
/// [`check_value`]: `wide as f32` is finite exactly when `wide` is finite and within the f32
/// range (NaN included: it is not finite as f32 either).
fn values_pass_checks(values: &[f64; 9]) -> bool {
    let in_range = values
        .iter()
        .fold(true, |ok, &v| ok & (v as f32).is_finite());
    in_range & (values[7] >= 0.0) & (values[8] >= 0.0)
}

/// `bytes` as text, each byte that is not part of valid UTF-8 written `\xNN` (for messages).
pub fn escape_non_utf8(bytes: &[u8]) -> String {
    let mut text = String::new();
    for chunk in bytes.utf8_chunks() {
        text.push_str(chunk.valid());
        for b in chunk.invalid() {
            text.push_str(&format!("\\x{b:02X}"));
        }
    }
    text
}

/// `problem` with the offending value spelled as in the input.
fn with_text(problem: RowProblem, raw: &str) -> RowProblem {
    match problem {
        RowProblem::NotFinite(_) => RowProblem::NotFinite(raw.to_string()),
        RowProblem::OutOfRange(_) => RowProblem::OutOfRange(raw.to_string()),
        RowProblem::NegativeSize(_) => RowProblem::NegativeSize(raw.to_string()),
        other => other,
    }
}

/// A value as written to the output: `inf`, `-inf`, `nan`, or the shortest decimal that reads
/// back to the same f32.
pub fn format_value(v: f32) -> String {
    let mut s = String::new();
    write_value(&mut s, v);
    s
}

/// [`format_value`] into a reused buffer (cleared first).
pub fn write_value(buf: &mut String, v: f32) {
    let mut bytes = std::mem::take(buf).into_bytes();
    bytes.clear();
    push_f32(&mut bytes, v);
    // push_f32 writes ASCII only.
    *buf = String::from_utf8(bytes).unwrap_or_default();
}

/// The computed columns of one pair, in output order (surrogates, then features).
pub fn computed_values(ego: &VehicleState, partner: &VehicleState) -> [f32; 17] {
    let (s, f) = surrogates_and_features(ego, partner);
    let mut out = [0f32; 17];
    let computed = [s.box_distance, s.ttc2d, s.tadv, s.ei].into_iter().chain(f);
    for (slot, v) in out.iter_mut().zip(computed) {
        *slot = v;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_one_pass_value_check_agrees_with_check_value() {
        let samples = [
            0.0,
            -0.0,
            -1.0,
            2.5,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::from(f32::MAX),
            f64::from(f32::MAX) * (1.0 + 1e-9),
            -f64::from(f32::MAX) * 2.0,
            1e-50,
        ];
        for &v in &samples {
            for slot in 0..9 {
                let mut values = [1.0f64; 9];
                values[slot] = v;
                let per_value = values
                    .iter()
                    .zip(STATE_FIELDS)
                    .all(|(&w, field)| check_value(w, field).is_ok());
                assert_eq!(values_pass_checks(&values), per_value, "{v} in {slot}");
            }
        }
    }

    #[test]
    fn reusing_the_last_ego_gives_the_same_pairs_and_errors() {
        let names: Vec<Vec<u8>> = HEADER.split(',').map(|n| n.as_bytes().to_vec()).collect();
        let columns = PairColumns::from_header_bytes(names).unwrap();
        let good_ego = [100.0, 5.0, 20.0, 0.0, 1.0, 0.0, 0.0, 4.5, 1.8];
        let other_ego = [130.0, 5.0, 10.0, 1.0, 1.0, 0.5, 0.2, 4.0, 1.7];
        let partner = |k: usize| [110.0 + k as f64, 8.0, 18.0, 0.0, 1.0, 0.0, 0.0, 4.0, 1.9];
        let mut bad_partner = partner(9);
        bad_partner[7] = -1.0;
        let mut zero_heading = partner(3);
        (zero_heading[4], zero_heading[5]) = (0.0, 0.0);
        let mut bad_ego = good_ego;
        bad_ego[2] = f64::INFINITY;
        let mut negative_zero = good_ego;
        negative_zero[3] = -0.0;
        // Runs of one ego with good and bad partners, a bad ego between them, and an ego equal
        // to the last one but for the sign of a zero.
        let rows = [
            (good_ego, partner(1)),
            (good_ego, bad_partner),
            (good_ego, partner(2)),
            (good_ego, zero_heading),
            (bad_ego, partner(1)),
            (good_ego, partner(4)),
            (negative_zero, partner(5)),
            (other_ego, bad_partner),
            (other_ego, partner(6)),
            (other_ego, partner(7)),
            (good_ego, partner(8)),
        ];
        let mut last = None;
        for (line, (ego, partner)) in rows.into_iter().enumerate() {
            let line = line as u64 + 2;
            assert_eq!(
                columns.pair_from_values_reusing(ego, partner, line, &mut last),
                columns.pair_from_values(ego, partner, line),
                "line {line}"
            );
        }
    }

    const HEADER: &str = "id,X_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j,note";

    fn run(body: &str, strict: bool) -> (Result<SsmSummary, SsmError>, String, Vec<RowError>) {
        let input = format!("{HEADER}\n{body}");
        let mut out = Vec::new();
        let mut bad = Vec::new();
        let r = score_csv(
            input.as_bytes(),
            &mut out,
            SsmOptions {
                strict,
                ..SsmOptions::default()
            },
            |e| bad.push(e.clone()),
        );
        (r, String::from_utf8(out).unwrap(), bad)
    }

    #[test]
    fn header_is_matched_case_insensitively_and_extended() {
        let (r, out, bad) = run("7,0,0,10,0,1,0,0,4,2,30,0,5,0,1,0,0,4,2,hello\n", false);
        let r = r.unwrap();
        assert_eq!((r.rows_ok, r.rows_bad), (1, 0));
        assert!(bad.is_empty());
        let mut lines = out.lines();
        let header = lines.next().unwrap();
        assert!(header.starts_with("id,X_i,"));
        assert!(header.ends_with(",note,box_distance,ttc2d,tadv,ei,f_l_ego,f_l_sur,f_w_comb,f_vy_ego,f_vx_sur,f_vy_sur,f_v_ego2,f_v_sur2,f_delta_v2,f_delta_v,f_psi_sur,f_rho,f_s"));
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(row[0], "7");
        assert_eq!(row[19], "hello");
        assert_eq!(row[20], "26"); // box distance 30 - 4
        assert_eq!(row[21], "5.2"); // ttc2d 26 / 5
    }

    #[test]
    fn bad_rows_name_line_and_column() {
        let body = "1,0,0,10,0,1,0,0,4,2,30,0,5,0,1,0,0,4,2,a\n\
                    2,0,0,10,0,1,0,0,4,2,abc,0,5,0,1,0,0,4,2,b\n\
                    3,0,0,10,0,0,0,0,4,2,30,0,5,0,1,0,0,4,2,c\n\
                    4,0,0,10,0,1,0,0,4,2,30,0,5,0,1,0,0,4\n\
                    5,0,0,nan,0,1,0,0,4,2,30,0,5,0,1,0,0,4,2,e\n";
        let (r, out, bad) = run(body, false);
        let r = r.unwrap();
        assert_eq!((r.rows_ok, r.rows_bad), (1, 4));
        assert_eq!(out.lines().count(), 2);
        let got: Vec<(u64, Option<&str>)> =
            bad.iter().map(|e| (e.line, e.column.as_deref())).collect();
        assert_eq!(
            got,
            vec![
                (3, Some("x_j")),
                (4, Some("hx_i")),
                (5, Some("width_j")),
                (6, Some("vx_i"))
            ]
        );
        assert_eq!(bad[0].problem, RowProblem::Unparsable("abc".into()));
    }

    #[test]
    fn strict_stops_at_first_bad_row() {
        let body = "1,0,0,10,0,1,0,0,4,2,30,0,5,0,1,0,0,4,2,a\n2,0,0,10,0,1,0,0,-4,2,30,0,5,0,1,0,0,4,2,b\n";
        let (r, _, _) = run(body, true);
        match r {
            Err(SsmError::BadRow(e)) => {
                assert_eq!(e.line, 3);
                assert_eq!(e.column.as_deref(), Some("length_i"));
            }
            other => panic!("expected a bad row, got {other:?}"),
        }
    }

    #[test]
    fn missing_columns_are_listed() {
        let mut out = Vec::new();
        let err = score_csv(
            "x_i,y_i\n1,2\n".as_bytes(),
            &mut out,
            SsmOptions::default(),
            |_| {},
        )
        .unwrap_err();
        match err {
            SsmError::MissingColumns { missing } => {
                assert!(missing.starts_with("vx_i, vy_i, hx_i,"), "{missing}");
                assert!(missing.ends_with("length_j, width_j"), "{missing}");
                assert_eq!(missing.split(", ").count(), 16);
            }
            other => panic!("expected missing columns, got {other:?}"),
        }
    }

    #[test]
    fn header_bytes_that_are_not_utf8_reach_the_output_unchanged() {
        let mut input = format!("{HEADER},t").into_bytes();
        input.extend_from_slice(b"\xf6\n7,0,0,10,0,1,0,0,4,2,30,0,5,0,1,0,0,4,2,a,b\n");
        let mut out = Vec::new();
        let r = score_csv(input.as_slice(), &mut out, SsmOptions::default(), |_| {}).unwrap();
        assert_eq!(r.rows_ok, 1);
        let header = out.split(|&b| b == b'\n').next().unwrap();
        assert!(header.starts_with(format!("{HEADER},t").as_bytes()));
        assert!(header.windows(4).any(|w| w == b",t\xf6,"));
    }

    #[test]
    fn values_round_trip_and_infinities_are_spelled_out() {
        assert_eq!(format_value(f32::INFINITY), "inf");
        assert_eq!(format_value(f32::NEG_INFINITY), "-inf");
        for v in [0.1f32, -2.5e-7, 1.0e7, 20159736.0, core::f32::consts::PI] {
            assert_eq!(
                format_value(v).parse::<f32>().unwrap().to_bits(),
                v.to_bits()
            );
        }
    }

    #[test]
    fn byte_order_mark_and_padding_in_header_are_ignored() {
        let input = format!(
            "\u{feff}{}\n0,0,10,0,1,0,0,4,2,30,0,5,0,1,0,0,4,2\n",
            [
                " x_i", "y_i ", "vx_i", "vy_i", "hx_i", "hy_i", "acc_i", "length_i", "width_i",
                "x_j", "y_j", "vx_j", "vy_j", "hx_j", "hy_j", "acc_j", "length_j", "width_j",
            ]
            .join(",")
        );
        let mut out = Vec::new();
        let r = score_csv(
            input.as_bytes(),
            &mut out,
            SsmOptions {
                strict: true,
                ..SsmOptions::default()
            },
            |_| {},
        )
        .unwrap();
        assert_eq!(r.rows_ok, 1);
        assert!(String::from_utf8(out).unwrap().starts_with("x_i,y_i,vx_i"));
    }
}
