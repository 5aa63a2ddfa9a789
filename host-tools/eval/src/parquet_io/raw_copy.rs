//! Parquet -> Parquet without re-encoding what does not change: the input's columns are the
//! output's first columns, value for value, so an input row group whose rows are all good is
//! written as one output row group whose pass-through column chunks are the input's bytes,
//! copied as they are (codec, encodings, statistics and the page index if the input has one),
//! followed by the 17 computed chunks. Only the 18 pair columns are decoded, by the worker that
//! scores the row group, from its own positional reads of the file; the page checksums of the
//! copied chunks are verified ([`super::page_checksums`]), their values are not (a text column
//! that is not UTF-8 is copied as it is).
//!
//! A pass-through column is copied when its Parquet column descriptors (physical and logical
//! type, repetition, levels, path) are the ones the output schema gives it; any other is decoded
//! and encoded again with the output's settings, in the same worker. Readers see the output's
//! Arrow schema (stored by [`super::row_groups::row_group_file`], as before), so a table read
//! back is equal to the re-encoded one.
use std::fs::File;
use std::io::{BufReader, Read};
use std::ops::Range;
use std::sync::Arc;

use bytes::Bytes;
use parquet::arrow::arrow_reader::{
    ArrowReaderMetadata, ArrowReaderOptions, ParquetRecordBatchReader,
    ParquetRecordBatchReaderBuilder,
};
use parquet::arrow::arrow_writer::compute_leaves;
use parquet::arrow::ProjectionMask;
use parquet::column::writer::ColumnCloseResult;
use parquet::errors::ParquetError;
use parquet::file::metadata::PageIndexPolicy;
use parquet::file::reader::{ChunkReader, Length};
use parquet::schema::types::SchemaDescriptor;

use super::page_checksums::{verify_pages, PageDamage};
use super::row_groups::{CopiedGroup, Piece, RowGroupEncoder};
use super::{locate_checksum_error, ColumnarError};
use crate::arrow_kernel::{pair_columns, ssm_kernel};
use riskscore_data::ssm_csv::{PairColumns, RowError};

/// Largest input row group copied whole. Its 17 computed column chunks are held until written,
/// for each of the jobs in flight (about 4-5 bytes a value once encoded: ~20 MB at this size);
/// a larger row group is decoded on the calling thread and cut into row groups of
/// [`super::ssm_parallel::Cutting::rows_to_parquet`] rows, as before, so memory stays bounded
/// whatever row groups the input has.
pub const RAW_MAX_ROWS: usize = 256 * 1024;

/// A file read by position (`pread`), so that workers and the writing thread read it at once
/// without sharing a cursor (a [`File`]'s clones share one).
#[derive(Clone)]
pub(crate) struct PositionalFile(Arc<File>);

impl PositionalFile {
    pub fn new(file: File) -> Self {
        Self(Arc::new(file))
    }

    pub fn file(&self) -> &File {
        &self.0
    }
}

fn read_at(file: &File, buf: &mut [u8], offset: u64) -> std::io::Result<usize> {
    #[cfg(unix)]
    {
        std::os::unix::fs::FileExt::read_at(file, buf, offset)
    }
    #[cfg(windows)]
    {
        std::os::windows::fs::FileExt::seek_read(file, buf, offset)
    }
}

/// A [`Read`] from a position of a [`PositionalFile`] on.
pub(crate) struct ReadAt {
    file: Arc<File>,
    position: u64,
}

impl Read for ReadAt {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = read_at(&self.file, buf, self.position)?;
        self.position += n as u64;
        Ok(n)
    }
}

impl Length for PositionalFile {
    fn len(&self) -> u64 {
        self.0.metadata().map_or(0, |m| m.len())
    }
}

impl ChunkReader for PositionalFile {
    // Buffered: the parquet crate reads page headers a few bytes at a time.
    type T = BufReader<ReadAt>;

    fn get_read(&self, start: u64) -> Result<Self::T, ParquetError> {
        Ok(BufReader::new(ReadAt {
            file: self.0.clone(),
            position: start,
        }))
    }

    fn get_bytes(&self, start: u64, length: usize) -> Result<Bytes, ParquetError> {
        let mut buffer = vec![0; length];
        let mut filled = 0;
        while filled < length {
            match read_at(&self.0, &mut buffer[filled..], start + filled as u64)? {
                0 => {
                    return Err(ParquetError::EOF(format!(
                        "the file ends before byte {} of {length} at offset {start}",
                        filled
                    )))
                }
                n => filled += n,
            }
        }
        Ok(buffer.into())
    }
}

/// What a worker made of an input row group.
pub(crate) enum GroupOutcome {
    Copied {
        rows: u64,
        group: CopiedGroup,
    },
    /// A row had a problem: the row group must go the old way (lenient), or the run stops
    /// (strict). These are the rows of the first batch that had one.
    BadRows(Vec<RowError>),
}

/// The input file and what the copying path knows about it.
pub(crate) struct RawSource {
    file: PositionalFile,
    metadata: ArrowReaderMetadata,
    /// Per input field: its column chunks are copied (else decoded and encoded again).
    copied: Vec<bool>,
    /// Input fields decoded by the workers: the pair columns and the fields not copied.
    projection: ProjectionMask,
    /// The pair columns in a decoded (projected) batch.
    projected_pairs: PairColumns,
    /// For each field not copied: its index in a decoded batch and in the output.
    reencoded: Vec<(usize, usize)>,
    /// Per output field: its leaf columns.
    output_leaves: Vec<Range<usize>>,
    /// Per input field: its leaf columns.
    input_leaves: Vec<Range<usize>>,
}

/// The leaf columns of each top-level field, in field order.
fn leaves_per_field(schema: &SchemaDescriptor, fields: usize) -> Vec<Range<usize>> {
    let mut ranges: Vec<Range<usize>> = vec![0..0; fields];
    for leaf in 0..schema.num_columns() {
        let root = schema.get_column_root_idx(leaf);
        if let Some(range) = ranges.get_mut(root) {
            if range.start == range.end {
                *range = leaf..leaf + 1;
            } else {
                range.end = leaf + 1;
            }
        }
    }
    ranges
}

impl RawSource {
    /// The source for `file`, whose metadata and Arrow schema were read (`metadata`), its pair
    /// columns at `pairs`; `output` is the output's Parquet schema.
    pub fn new(
        file: PositionalFile,
        metadata: ArrowReaderMetadata,
        pairs: &PairColumns,
        output: &SchemaDescriptor,
        output_fields: usize,
    ) -> Result<Self, ColumnarError> {
        let input = metadata.parquet_schema();
        let fields = metadata.schema().fields().len();
        let input_leaves = leaves_per_field(input, fields);
        let output_leaves = leaves_per_field(output, output_fields);
        let copied: Vec<bool> = (0..fields)
            .map(|k| {
                let (from, to) = (&input_leaves[k], &output_leaves[k]);
                from.len() == to.len()
                    && from.start < from.end
                    && from
                        .clone()
                        .zip(to.clone())
                        .all(|(i, o)| input.column(i) == output.column(o))
            })
            .collect();
        let is_pair = |k: usize| pairs.ego.contains(&k) || pairs.partner.contains(&k);
        let decoded: Vec<usize> = (0..fields).filter(|&k| is_pair(k) || !copied[k]).collect();
        let reencoded = decoded
            .iter()
            .enumerate()
            .filter(|(_, &k)| !copied[k])
            .map(|(p, &k)| (p, k))
            .collect();
        let projection = ProjectionMask::roots(input, decoded.iter().copied());
        let projected_schema = metadata.schema().project(&decoded)?;
        let projected_pairs = pair_columns(&projected_schema)?;
        Ok(Self {
            file,
            metadata,
            copied,
            projection,
            projected_pairs,
            reencoded,
            output_leaves,
            input_leaves,
        })
    }

    pub fn num_groups(&self) -> usize {
        self.metadata.metadata().num_row_groups()
    }

    pub fn group_rows(&self, group: usize) -> usize {
        self.metadata.metadata().row_group(group).num_rows().max(0) as usize
    }

    /// Every column of row group `group`, in batches of `rows`.
    pub fn group_batches(
        &self,
        group: usize,
        rows: usize,
    ) -> Result<ParquetRecordBatchReader, ColumnarError> {
        Ok(ParquetRecordBatchReaderBuilder::new_with_metadata(
            self.file.clone(),
            self.metadata.clone(),
        )
        .with_row_groups(vec![group])
        .with_batch_size(rows)
        .build()?)
    }

    pub fn file(&self) -> &File {
        self.file.file()
    }

    /// The input, to copy column chunks from.
    pub fn input(&self) -> &PositionalFile {
        &self.file
    }

    /// Scores row group `group` (its first row is row `first_row` of the file, counting from 0)
    /// in batches of `batch_rows`, and makes its output row group if every row is good.
    pub fn score_group(
        &self,
        group: usize,
        first_row: u64,
        batch_rows: usize,
        encoder: &RowGroupEncoder,
    ) -> Result<GroupOutcome, ColumnarError> {
        let reader = ParquetRecordBatchReaderBuilder::new_with_metadata(
            self.file.clone(),
            self.metadata.clone(),
        )
        .with_row_groups(vec![group])
        .with_projection(self.projection.clone())
        .with_batch_size(batch_rows)
        .build()?;
        let mut writers = encoder.column_writers()?;
        let computed_from = self.copied.len();
        let mut rows = 0u64;
        for batch in reader {
            let batch = batch.map_err(|e| locate_checksum_error(e, self.file()))?;
            let scored = ssm_kernel(&self.projected_pairs, &batch, first_row + rows)?;
            if !scored.bad.is_empty() {
                return Ok(GroupOutcome::BadRows(scored.bad));
            }
            rows += batch.num_rows() as u64;
            let fields = encoder.schema().fields();
            let reencoded = self.reencoded.iter().map(|&(p, k)| (k, batch.column(p)));
            let computed = scored
                .computed
                .columns()
                .iter()
                .enumerate()
                .map(|(c, column)| (computed_from + c, column));
            for (k, column) in reencoded.chain(computed) {
                let mut leaves = self.output_leaves[k].clone();
                for leaf in compute_leaves(&fields[k], column)? {
                    let writer = leaves.next().and_then(|l| writers.get_mut(l));
                    let writer = writer.ok_or_else(|| {
                        ParquetError::General(format!(
                            "column {}: more leaves than the schema has",
                            fields[k].name()
                        ))
                    })?;
                    writer.write(&leaf)?;
                }
            }
        }
        let meta = self.metadata.metadata().row_group(group);
        let mut writers: Vec<_> = writers.into_iter().map(Some).collect();
        let mut pieces = Vec::with_capacity(writers.len());
        for (k, leaves) in self.output_leaves.iter().enumerate() {
            if self.copied.get(k) == Some(&true) {
                for leaf in self.input_leaves[k].clone() {
                    let column = meta.column(leaf);
                    let (start, length) = column.byte_range();
                    let damage = usize::try_from(length)
                        .map_err(|_| PageDamage::Layout)
                        .and_then(|n| {
                            self.file
                                .get_bytes(start, n)
                                .map_err(|_| PageDamage::Layout)
                        })
                        .and_then(|chunk| verify_pages(&chunk));
                    if let Err(damage) = damage {
                        return Err(damaged(group, &column.column_path().string(), damage));
                    }
                    // The input's page index goes with the pages where it has one (the writer
                    // moves its page offsets to where the chunk lands).
                    let page_index = self.metadata.metadata().page_index();
                    pieces.push(Piece::Copied(ColumnCloseResult {
                        bytes_written: column.compressed_size().max(0) as u64,
                        rows_written: rows,
                        metadata: column.clone(),
                        bloom_filter: None,
                        column_index: page_index
                            .and_then(|p| p.column_index(group, leaf))
                            .cloned(),
                        offset_index: page_index
                            .and_then(|p| p.offset_index(group, leaf))
                            .cloned(),
                    }));
                }
            } else {
                for leaf in leaves.clone() {
                    let writer = writers.get_mut(leaf).and_then(Option::take);
                    let writer = writer.ok_or_else(|| {
                        ParquetError::General(format!("no column writer for leaf {leaf}"))
                    })?;
                    pieces.push(Piece::Encoded(writer.close()?));
                }
            }
        }
        Ok(GroupOutcome::Copied {
            rows,
            group: CopiedGroup { pieces },
        })
    }
}

/// The error for a copied column chunk whose pages do not read back.
fn damaged(row_group: usize, column: &str, damage: PageDamage) -> ColumnarError {
    match damage {
        PageDamage::Checksum => ColumnarError::PageChecksum {
            row_group,
            column: column.to_string(),
        },
        PageDamage::Layout => ColumnarError::Parquet(ParquetError::General(format!(
            "row group {row_group} (counting from 0), column {column}: its pages cannot be \
             read (a page header is damaged or a page runs past the column chunk): the file is \
             damaged, no output written"
        ))),
    }
}

/// Reads the metadata of a Parquet input (and its Arrow schema, and its page index if it has
/// one, to copy with the pages) once, for every worker.
pub(crate) fn read_metadata(file: &PositionalFile) -> Result<ArrowReaderMetadata, ParquetError> {
    let options = ArrowReaderOptions::new().with_page_index_policy(PageIndexPolicy::Optional);
    ArrowReaderMetadata::load(file, options)
}
