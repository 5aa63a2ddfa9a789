//! Page checksums of a column chunk that is copied, not decoded: the parquet crate verifies a
//! page's CRC-32 only when it decodes the page, so a copied chunk's pages are walked here (their
//! Thrift headers read just far enough to find each page's size and checksum) and every page
//! that carries a checksum is verified against its bytes, as the decoding path does.

/// Why a column chunk's pages do not read back.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum PageDamage {
    /// A page's CRC-32 does not match its bytes.
    Checksum,
    /// A page header cannot be read, or a page runs past the chunk's end.
    Layout,
}

/// Verifies the checksum of every page of `chunk` (a column chunk's bytes: its pages, each a
/// Thrift compact `PageHeader` followed by `compressed_page_size` bytes) that has one.
pub(crate) fn verify_pages(chunk: &[u8]) -> Result<(), PageDamage> {
    let mut at = 0;
    while at < chunk.len() {
        let mut header = Compact {
            bytes: chunk,
            at,
            depth: 0,
        };
        let (size, crc) = header.page_header()?;
        let start = header.at;
        let end = usize::try_from(size)
            .ok()
            .and_then(|n| start.checked_add(n))
            .filter(|&end| end <= chunk.len())
            .ok_or(PageDamage::Layout)?;
        if let Some(crc) = crc {
            if crc32fast::hash(&chunk[start..end]) != crc as u32 {
                return Err(PageDamage::Checksum);
            }
        }
        at = end;
    }
    Ok(())
}

/// A reader of the Thrift compact protocol, enough to skip what it does not need.
struct Compact<'a> {
    bytes: &'a [u8],
    at: usize,
    depth: usize,
}

/// Nesting deeper than this is not a page header (and would only exhaust the stack).
const MAX_DEPTH: usize = 16;

const BOOL_TRUE: u8 = 1;
const BOOL_FALSE: u8 = 2;
const BYTE: u8 = 3;
const I16: u8 = 4;
const I32: u8 = 5;
const I64: u8 = 6;
const DOUBLE: u8 = 7;
const BINARY: u8 = 8;
const LIST: u8 = 9;
const SET: u8 = 10;
const MAP: u8 = 11;
const STRUCT: u8 = 12;

impl Compact<'_> {
    fn byte(&mut self) -> Result<u8, PageDamage> {
        let b = *self.bytes.get(self.at).ok_or(PageDamage::Layout)?;
        self.at += 1;
        Ok(b)
    }

    fn varint(&mut self) -> Result<u64, PageDamage> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.byte()?;
            value |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return Ok(value);
            }
        }
        Err(PageDamage::Layout)
    }

    fn zigzag(&mut self) -> Result<i64, PageDamage> {
        let v = self.varint()?;
        Ok((v >> 1) as i64 ^ -((v & 1) as i64))
    }

    fn skip_bytes(&mut self, n: u64) -> Result<(), PageDamage> {
        let end = usize::try_from(n)
            .ok()
            .and_then(|n| self.at.checked_add(n))
            .filter(|&end| end <= self.bytes.len())
            .ok_or(PageDamage::Layout)?;
        self.at = end;
        Ok(())
    }

    /// The next field's (id, type) of a struct, `None` at its end.
    fn field(&mut self, last_id: i64) -> Result<Option<(i64, u8)>, PageDamage> {
        let b = self.byte()?;
        if b == 0 {
            return Ok(None);
        }
        let delta = i64::from(b >> 4);
        let id = if delta == 0 {
            self.zigzag()?
        } else {
            last_id + delta
        };
        Ok(Some((id, b & 0x0f)))
    }

    /// Skips a value of `kind`; `in_collection`: a boolean takes a byte (in a struct field it
    /// is the field's type).
    fn skip(&mut self, kind: u8, in_collection: bool) -> Result<(), PageDamage> {
        match kind {
            BOOL_TRUE | BOOL_FALSE if !in_collection => Ok(()),
            BOOL_TRUE | BOOL_FALSE | BYTE => self.skip_bytes(1),
            I16 | I32 | I64 => self.varint().map(drop),
            DOUBLE => self.skip_bytes(8),
            BINARY => {
                let n = self.varint()?;
                self.skip_bytes(n)
            }
            LIST | SET => {
                let b = self.byte()?;
                let n = match b >> 4 {
                    15 => self.varint()?,
                    n => u64::from(n),
                };
                self.nested(|c| (0..n).try_for_each(|_| c.skip(b & 0x0f, true)))
            }
            MAP => {
                let n = self.varint()?;
                if n == 0 {
                    return Ok(());
                }
                let kinds = self.byte()?;
                self.nested(|c| {
                    (0..n).try_for_each(|_| {
                        c.skip(kinds >> 4, true)?;
                        c.skip(kinds & 0x0f, true)
                    })
                })
            }
            STRUCT => self.nested(|c| {
                let mut last = 0;
                while let Some((id, kind)) = c.field(last)? {
                    c.skip(kind, false)?;
                    last = id;
                }
                Ok(())
            }),
            _ => Err(PageDamage::Layout),
        }
    }

    fn nested(
        &mut self,
        inside: impl FnOnce(&mut Self) -> Result<(), PageDamage>,
    ) -> Result<(), PageDamage> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(PageDamage::Layout);
        }
        inside(self)?;
        self.depth -= 1;
        Ok(())
    }

    /// Reads a `PageHeader`: its `compressed_page_size` (field 3) and `crc` (field 4).
    fn page_header(&mut self) -> Result<(i64, Option<i32>), PageDamage> {
        let (mut size, mut crc, mut last) = (None, None, 0);
        while let Some((id, kind)) = self.field(last)? {
            match (id, kind) {
                (3, I32) => size = Some(self.zigzag()?),
                (4, I32) => crc = Some(self.zigzag()? as i32),
                _ => self.skip(kind, false)?,
            }
            last = id;
        }
        Ok((size.ok_or(PageDamage::Layout)?, crc))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::{Float64Array, RecordBatch, StringArray};
    use arrow_schema::{DataType, Field, Schema};
    use bytes::Bytes;
    use parquet::arrow::ArrowWriter;
    use parquet::file::properties::WriterProperties;
    use parquet::file::reader::{FileReader, SerializedFileReader};
    use std::sync::Arc;

    /// 200 pair rows in two row groups, every page with its CRC-32 (pyarrow; the script that
    /// made it is beside it).
    const CHECKSUMMED: &[u8] = include_bytes!("../../../tests/data/parquet/crc.parquet");

    /// Each column chunk's byte range in `file`.
    fn chunks(file: &[u8]) -> Vec<(usize, usize)> {
        let reader = SerializedFileReader::new(Bytes::copy_from_slice(file)).unwrap();
        let groups = reader.metadata().row_groups().to_vec();
        groups
            .iter()
            .flat_map(|g| g.columns().iter())
            .map(|c| {
                let (start, length) = c.byte_range();
                (start as usize, (start + length) as usize)
            })
            .collect()
    }

    /// A dictionary-encoded text column and a float column in several pages each, without
    /// checksums (the parquet crate does not write them).
    fn unchecksummed() -> Vec<u8> {
        let rows = 5000;
        let schema = Arc::new(Schema::new(vec![
            Field::new("id", DataType::Utf8, true),
            Field::new("x", DataType::Float64, false),
        ]));
        let ids: StringArray = (0..rows)
            .map(|k| (k % 11 != 0).then(|| format!("v{}", k % 37)))
            .collect();
        let xs = Float64Array::from((0..rows).map(|k| k as f64 * 0.25).collect::<Vec<_>>());
        let batch = RecordBatch::try_new(schema.clone(), vec![Arc::new(ids), Arc::new(xs)]);
        let props = WriterProperties::builder()
            .set_data_page_row_count_limit(700)
            .set_write_batch_size(100)
            .build();
        let mut out = Vec::new();
        let mut writer = ArrowWriter::try_new(&mut out, schema, Some(props)).unwrap();
        writer.write(&batch.unwrap()).unwrap();
        writer.close().unwrap();
        out
    }

    /// Where the data of the chunk's first page starts (after its header).
    fn first_page_data(chunk: &[u8]) -> usize {
        let mut header = Compact {
            bytes: chunk,
            at: 0,
            depth: 0,
        };
        header.page_header().unwrap();
        header.at
    }

    #[test]
    fn intact_pages_pass_with_and_without_checksums() {
        for file in [CHECKSUMMED.to_vec(), unchecksummed()] {
            for (start, end) in chunks(&file) {
                assert_eq!(verify_pages(&file[start..end]), Ok(()));
            }
        }
    }

    #[test]
    fn a_flipped_bit_in_the_data_of_a_checksummed_page_is_found() {
        let ranges = chunks(CHECKSUMMED);
        assert_eq!(ranges.len(), 36);
        for (start, end) in ranges {
            let chunk = &CHECKSUMMED[start..end];
            for at in [chunk.len() - 1, first_page_data(chunk)] {
                let mut damaged = chunk.to_vec();
                damaged[at] ^= 0x10;
                assert_eq!(
                    verify_pages(&damaged),
                    Err(PageDamage::Checksum),
                    "byte {at} of {start}..{end}"
                );
            }
        }
        // Without checksums the same flip cannot be seen.
        let file = unchecksummed();
        let (start, end) = chunks(&file)[1];
        let mut damaged = file[start..end].to_vec();
        damaged[end - start - 1] ^= 0x10;
        assert_eq!(verify_pages(&damaged), Ok(()));
    }

    #[test]
    fn a_cut_chunk_or_a_damaged_header_cannot_be_walked() {
        let (start, end) = chunks(CHECKSUMMED)[0];
        let chunk = &CHECKSUMMED[start..end];
        assert_eq!(
            verify_pages(&chunk[..chunk.len() - 5]),
            Err(PageDamage::Layout)
        );
        // The first byte of a header: a field of type 0 (not a Thrift type) or a stop.
        let mut damaged = chunk.to_vec();
        damaged[0] = 0x10;
        assert_eq!(verify_pages(&damaged), Err(PageDamage::Layout));
    }
}
