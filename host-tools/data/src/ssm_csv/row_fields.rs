//! One parsed CSV record seen as its fields' bytes, whichever `csv` record type holds it.

/// The fields of one parsed CSV record, as bytes (pass-through columns need not be UTF-8).
pub trait RowFields {
    fn field_count(&self) -> usize;
    fn field(&self, k: usize) -> Option<&[u8]>;
    /// Fields `first..=last` as they stand in the line, with the one comma between each two,
    /// when the record is a plain line (no quotes: no field holds a comma); `None` when the
    /// record is not plain or has no field `last`.
    fn plain_span(&self, _first: usize, _last: usize) -> Option<&[u8]> {
        None
    }
}

impl RowFields for csv::StringRecord {
    fn field_count(&self) -> usize {
        self.len()
    }
    fn field(&self, k: usize) -> Option<&[u8]> {
        self.get(k).map(str::as_bytes)
    }
}

impl RowFields for csv::ByteRecord {
    fn field_count(&self) -> usize {
        self.len()
    }
    fn field(&self, k: usize) -> Option<&[u8]> {
        self.get(k)
    }
}
