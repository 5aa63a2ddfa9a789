//! The ego of the previous row, kept so that a row with the same ego is not parsed twice.
//!
//! Pair files list an ego's partners on consecutive rows (one row per partner, the ego's nine
//! fields repeated): 94 % of the rows of the NGSIM US-101 pairs repeat the previous row's ego.
//! A row whose ego fields are byte for byte those of the last parsed ego gets the same values
//! back without parsing them: the same bytes always parse to the same values, so the result
//! (and every error) is what parsing would give.
use super::row_fields::RowFields;

/// The last ego parsed without error: its nine field texts and their values.
#[derive(Default)]
pub struct LastEgo {
    /// The nine fields joined by commas, as a plain line holds them; field `k` ends at
    /// `ends[k]`. A kept field never holds a comma (it parsed as a number), so a plain line's
    /// span of the nine fields equals `texts` exactly when each field equals its own.
    texts: Vec<u8>,
    ends: [usize; 9],
    values: Option<[f64; 9]>,
}

impl LastEgo {
    /// The values of the last ego when `record`'s fields `columns` are the same bytes.
    pub(crate) fn values_if_same<F: RowFields + ?Sized>(
        &self,
        record: &F,
        columns: &[usize; 9],
    ) -> Option<[f64; 9]> {
        let values = self.values?;
        // The usual header lists the nine ego columns side by side: one comparison of the
        // span instead of nine.
        let side_by_side = columns
            .iter()
            .enumerate()
            .all(|(i, &k)| k == columns[0] + i);
        if side_by_side {
            if let Some(span) = record.plain_span(columns[0], columns[8]) {
                return (span == self.texts.as_slice()).then_some(values);
            }
        }
        let mut start = 0;
        for (&k, &end) in columns.iter().zip(&self.ends) {
            if record.field(k)? != &self.texts[start..end] {
                return None;
            }
            start = end + 1;
        }
        Some(values)
    }

    /// Remember `values`, parsed from `record`'s fields `columns`.
    pub(crate) fn keep<F: RowFields + ?Sized>(
        &mut self,
        record: &F,
        columns: &[usize; 9],
        values: [f64; 9],
    ) {
        self.texts.clear();
        for (i, (&k, end)) in columns.iter().zip(self.ends.iter_mut()).enumerate() {
            if i > 0 {
                self.texts.push(b',');
            }
            self.texts
                .extend_from_slice(record.field(k).unwrap_or_default());
            *end = self.texts.len();
        }
        self.values = Some(values);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Fields(Vec<&'static [u8]>);

    impl RowFields for Fields {
        fn field_count(&self) -> usize {
            self.0.len()
        }
        fn field(&self, k: usize) -> Option<&[u8]> {
            self.0.get(k).copied()
        }
    }

    /// A plain line: its fields are the pieces between commas, and it has a span.
    struct Line(&'static [u8]);

    impl RowFields for Line {
        fn field_count(&self) -> usize {
            self.0.split(|&b| b == b',').count()
        }
        fn field(&self, k: usize) -> Option<&[u8]> {
            self.0.split(|&b| b == b',').nth(k)
        }
        fn plain_span(&self, first: usize, last: usize) -> Option<&[u8]> {
            let start: usize = self
                .0
                .split(|&b| b == b',')
                .take(first)
                .map(|f| f.len() + 1)
                .sum();
            let end = start
                + self.0[start..]
                    .split(|&b| b == b',')
                    .take(last - first + 1)
                    .map(|f| f.len() + 1)
                    .sum::<usize>()
                - 1;
            (last < self.field_count()).then(|| &self.0[start..end])
        }
    }

    const COLUMNS: [usize; 9] = [1, 2, 3, 4, 5, 6, 7, 8, 9];

    fn row(fields: [&'static str; 10]) -> Fields {
        Fields(fields.iter().map(|f| f.as_bytes()).collect())
    }

    #[test]
    fn only_the_same_bytes_in_the_same_fields_give_the_values_back() {
        let kept = row(["a", "1", "2", "3", "4", "1", "0", "0", "4.5", "1.8"]);
        let values = [1.0, 2.0, 3.0, 4.0, 1.0, 0.0, 0.0, 4.5, 1.8];
        let mut last = LastEgo::default();
        assert_eq!(
            last.values_if_same(&kept, &COLUMNS),
            None,
            "nothing kept yet"
        );
        last.keep(&kept, &COLUMNS, values);
        // Other pass-through text: still the same ego.
        let same = row(["b", "1", "2", "3", "4", "1", "0", "0", "4.5", "1.8"]);
        assert_eq!(last.values_if_same(&same, &COLUMNS), Some(values));
        // The same concatenation cut differently, the same value written differently, a
        // different last field, a missing field: all parsed again.
        for other in [
            row(["a", "12", "", "3", "4", "1", "0", "0", "4.5", "1.8"]),
            row(["a", "1.0", "2", "3", "4", "1", "0", "0", "4.5", "1.8"]),
            row(["a", "1", "2", "3", "4", "1", "0", "0", "4.5", "1.9"]),
        ] {
            assert_eq!(last.values_if_same(&other, &COLUMNS), None);
        }
        let short = Fields(vec![b"a", b"1", b"2"]);
        assert_eq!(last.values_if_same(&short, &COLUMNS), None);
    }

    #[test]
    fn a_plain_line_compared_as_one_span_answers_like_field_by_field() {
        let values = [1.0, 2.0, 3.0, 4.0, 1.0, 0.0, 0.0, 4.5, 1.8];
        let lines: [&'static [u8]; 7] = [
            b"a,1,2,3,4,1,0,0,4.5,1.8,z",
            b"b,1,2,3,4,1,0,0,4.5,1.8",
            b"a,12,,3,4,1,0,0,4.5,1.8,z",
            b"a,1,2,3,4,1,0,0,4.5,1.8,,",
            b"a,1,2,3,4,1,0,0,4.5,1.80,z",
            b"a,1,2,3,4,1,0,0,4.5",
            b"a,1,2,3,4,1,0,0,4.5,1.8",
        ];
        // Side by side (one span) and in another order (field by field).
        let shuffled = [9, 1, 2, 3, 4, 5, 6, 7, 8];
        for columns in [COLUMNS, shuffled] {
            for kept in lines {
                let mut last = LastEgo::default();
                last.keep(&Line(kept), &columns, values);
                for line in lines {
                    let as_fields = Fields(line.split(|&b| b == b',').collect());
                    assert_eq!(
                        last.values_if_same(&Line(line), &columns),
                        last.values_if_same(&as_fields, &columns),
                        "kept {kept:?}, line {line:?}"
                    );
                }
            }
        }
    }
}
