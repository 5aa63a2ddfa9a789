//! Arrow batches as CSV rows: strings quoted when they need it, f32 and f64 in the shortest form
//! that reads back to the same value, laid out exactly as Rust's `Display` writes them (so the
//! text of a value does not depend on whether it came through CSV or Parquet), nulls empty.
use std::io::Write;

use arrow_array::cast::AsArray;
use arrow_array::types::*;
use arrow_array::{Array, BooleanArray, PrimitiveArray, RecordBatch};
use arrow_buffer::NullBuffer;
use arrow_schema::DataType;

use super::ColumnarError;
use riskscore_data::ssm_csv::{push_field, F32Texts};

/// One column, its type resolved once per batch.
enum Cells<'a> {
    Utf8(&'a arrow_array::StringArray),
    LargeUtf8(&'a arrow_array::LargeStringArray),
    Utf8View(&'a arrow_array::StringViewArray),
    F32(&'a PrimitiveArray<Float32Type>),
    F64(&'a PrimitiveArray<Float64Type>),
    I8(&'a PrimitiveArray<Int8Type>),
    I16(&'a PrimitiveArray<Int16Type>),
    I32(&'a PrimitiveArray<Int32Type>),
    I64(&'a PrimitiveArray<Int64Type>),
    U8(&'a PrimitiveArray<UInt8Type>),
    U16(&'a PrimitiveArray<UInt16Type>),
    U32(&'a PrimitiveArray<UInt32Type>),
    U64(&'a PrimitiveArray<UInt64Type>),
    Bool(&'a BooleanArray),
}

impl<'a> Cells<'a> {
    /// `None`: the type has no CSV form here.
    fn of(column: &'a dyn Array) -> Option<Self> {
        Some(match column.data_type() {
            DataType::Utf8 => Cells::Utf8(column.as_string::<i32>()),
            DataType::LargeUtf8 => Cells::LargeUtf8(column.as_string::<i64>()),
            DataType::Utf8View => Cells::Utf8View(column.as_string_view()),
            DataType::Float32 => Cells::F32(column.as_primitive()),
            DataType::Float64 => Cells::F64(column.as_primitive()),
            DataType::Int8 => Cells::I8(column.as_primitive()),
            DataType::Int16 => Cells::I16(column.as_primitive()),
            DataType::Int32 => Cells::I32(column.as_primitive()),
            DataType::Int64 => Cells::I64(column.as_primitive()),
            DataType::UInt8 => Cells::U8(column.as_primitive()),
            DataType::UInt16 => Cells::U16(column.as_primitive()),
            DataType::UInt32 => Cells::U32(column.as_primitive()),
            DataType::UInt64 => Cells::U64(column.as_primitive()),
            DataType::Boolean => Cells::Bool(column.as_boolean()),
            _ => return None,
        })
    }

    /// Appends row `row` (not null) to `line`, quoted if it needs it.
    fn push(&self, line: &mut Vec<u8>, row: usize, texts: &mut F32Texts) {
        match self {
            Cells::Utf8(a) => push_field(line, a.value(row).as_bytes()),
            Cells::LargeUtf8(a) => push_field(line, a.value(row).as_bytes()),
            Cells::Utf8View(a) => push_field(line, a.value(row).as_bytes()),
            Cells::F32(a) => texts.push(line, a.value(row)),
            Cells::F64(a) => push_f64(line, a.value(row)),
            Cells::I8(a) => push_int(line, i128::from(a.value(row))),
            Cells::I16(a) => push_int(line, i128::from(a.value(row))),
            Cells::I32(a) => push_int(line, i128::from(a.value(row))),
            Cells::I64(a) => push_int(line, i128::from(a.value(row))),
            Cells::U8(a) => push_int(line, i128::from(a.value(row))),
            Cells::U16(a) => push_int(line, i128::from(a.value(row))),
            Cells::U32(a) => push_int(line, i128::from(a.value(row))),
            Cells::U64(a) => push_int(line, i128::from(a.value(row))),
            Cells::Bool(a) => line.extend_from_slice(if a.value(row) { b"true" } else { b"false" }),
        }
    }
}

/// Appends every row of `batch` to `out` as a CSV line (no header); `line` is scratch space.
pub(crate) fn write_csv_rows<W: Write>(
    batch: &RecordBatch,
    out: &mut W,
    line: &mut Vec<u8>,
) -> Result<(), ColumnarError> {
    // Each column with its null mask (`None`: no nulls), as `Array::is_null` reads it.
    let cells: Vec<(Cells, Option<&NullBuffer>)> = batch
        .columns()
        .iter()
        .enumerate()
        .map(|(k, column)| {
            Cells::of(column.as_ref())
                .map(|c| (c, column.nulls()))
                .ok_or_else(|| ColumnarError::CsvType {
                    name: batch.schema().field(k).name().clone(),
                    found: column.data_type().clone(),
                })
        })
        .collect::<Result<_, _>>()?;
    let mut texts = F32Texts::default();
    line.clear();
    for row in 0..batch.num_rows() {
        for (k, (cell, nulls)) in cells.iter().enumerate() {
            if k > 0 {
                line.push(b',');
            }
            if !nulls.is_some_and(|n| n.is_null(row)) {
                cell.push(line, row, &mut texts);
            }
        }
        line.push(b'\n');
        // Written in pieces of about 64 KiB, not row by row.
        if line.len() >= 1 << 16 {
            out.write_all(line)?;
            line.clear();
        }
    }
    out.write_all(line)?;
    line.clear();
    Ok(())
}

/// An integer in decimal.
fn push_int(out: &mut Vec<u8>, v: i128) {
    if v < 0 {
        out.push(b'-');
    }
    let mut digits = [0u8; 40];
    let mut n = v.unsigned_abs();
    let mut k = digits.len();
    loop {
        k -= 1;
        digits[k] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[k..]);
}

/// `v` exactly as `format!("{v}")` writes it (`inf`/`-inf` as `inf`/`-inf`).
///
/// Fast path: the shortest decimal that reads back to `v` is the one with the fewest fraction
/// digits `d` such that `round(|v| x 10^d) / 10^d == |v|`, as long as `|v| x 10^d < 2^50`: there
/// the scaled value's error is far below 1/2 (so the rounding finds the decimal), one ulp of `v`
/// spans less than one step of 10^-d (so the decimal is the only one with `d` digits), and the
/// division is exact up to one correct rounding (both operands are exact f64), which is what
/// parsing the decimal gives. Everything else (huge, tiny, signed zero) goes to `Display`.
pub(crate) fn push_f64(out: &mut Vec<u8>, v: f64) {
    const SCALE: [f64; 16] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
    ];
    const LIMIT: f64 = (1u64 << 50) as f64;
    const NEAR: f64 = 1.0 / (1u64 << 48) as f64;
    if v.is_infinite() {
        out.extend_from_slice(if v > 0.0 { b"inf" } else { b"-inf" });
        return;
    }
    let a = v.abs();
    if v.is_finite() && a != 0.0 {
        for (d, scale) in SCALE.iter().enumerate() {
            let scaled = a * scale;
            if scaled >= LIMIT {
                break;
            }
            // Below 2^50 the decimal is within scaled x 2^-52 of `scaled`: a cheap test first
            // (no libm `round`, no division), then the exact one.
            let n = (scaled + 0.5) as u64;
            let near = (scaled - n as f64).abs() <= scaled * NEAR;
            if near && n as f64 / scale == a {
                if v < 0.0 {
                    out.push(b'-');
                }
                push_fixed(out, n, d);
                return;
            }
        }
    }
    let _ = write!(out, "{v}");
}

/// `n / 10^d` in positional notation, `d` fraction digits (the last one not zero when d > 0).
fn push_fixed(out: &mut Vec<u8>, n: u64, d: usize) {
    let mut digits = [0u8; 20];
    let mut k = digits.len();
    let mut m = n;
    loop {
        k -= 1;
        digits[k] = b'0' + (m % 10) as u8;
        m /= 10;
        if m == 0 {
            break;
        }
    }
    let text = &digits[k..];
    if d == 0 {
        out.extend_from_slice(text);
    } else if text.len() > d {
        let (int, frac) = text.split_at(text.len() - d);
        out.extend_from_slice(int);
        out.push(b'.');
        out.extend_from_slice(frac);
    } else {
        out.extend_from_slice(b"0.");
        out.extend(std::iter::repeat_n(b'0', d - text.len()));
        out.extend_from_slice(text);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(v: f64) -> String {
        let mut out = Vec::new();
        push_f64(&mut out, v);
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn f64_text_is_display_on_typical_and_edge_values() {
        let mut values = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            0.2,
            0.3,
            4.5,
            -4.5,
            1.8,
            30.0,
            1e15,
            1e16,
            1e22,
            1e300,
            5e-324,
            1e-7,
            0.000123,
            123456.789,
            2.5e-10,
            9007199254740993.0,
            0.1 + 0.2,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::NAN,
            1125899906842623.9,
            562949953421311.5,
        ];
        // Decimal text as sensors and CSV files hold it: up to 9 fraction digits, UTM-sized.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..400_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let digits = (x % 10) as i32;
            let int = ((x >> 8) % 10_000_000) as f64;
            let frac = ((x >> 32) % 1_000_000_000) as f64;
            let v: f64 = format!("{}.{:09}", int, frac as u64)
                [..(int.to_string().len() + 1 + digits as usize).max(1)]
                .trim_end_matches('.')
                .parse()
                .unwrap();
            values.push(if x & 1 == 0 { v } else { -v });
            // And arbitrary bit patterns.
            values.push(f64::from_bits(x));
        }
        for v in values {
            if v.is_nan() {
                continue;
            }
            assert_eq!(text(v), format!("{v}"), "bits {:#x}", v.to_bits());
        }
    }

    #[test]
    fn integers_are_plain_decimal() {
        for v in [
            0i128,
            7,
            -7,
            10,
            -128,
            65_535,
            i128::from(i64::MIN),
            i128::from(u64::MAX),
        ] {
            let mut out = Vec::new();
            push_int(&mut out, v);
            assert_eq!(String::from_utf8(out).unwrap(), v.to_string());
        }
    }
}
