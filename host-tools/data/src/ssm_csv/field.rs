//! Writing one CSV field the way the `csv` crate's default writer does, byte for byte (the
//! header and pass-through columns of `ssm` output, CSV and Parquet paths alike).

/// Append one CSV field, quoted when it holds a delimiter, quote or line break (the `csv` crate's
/// rule for its default writer).
pub fn push_field(out: &mut Vec<u8>, field: &[u8]) {
    let needs_quotes = field
        .iter()
        .any(|&b| matches!(b, b',' | b'"' | b'\n' | b'\r'));
    if !needs_quotes {
        out.extend_from_slice(field);
        return;
    }
    out.push(b'"');
    for &b in field {
        if b == b'"' {
            out.push(b'"');
        }
        out.push(b);
    }
    out.push(b'"');
}
