//! Parquet output a row group at a time, with the row groups encoded on worker threads: a worker
//! turns a batch into finished column chunks ([`RowGroupEncoder::encode`]), the writing thread
//! appends them to the file in order ([`RowGroupFile::append`]). A row group's bytes depend only
//! on its rows, so the file is the same whichever thread encoded what.
use std::io::Write;

use arrow_array::RecordBatch;
use arrow_schema::{DataType, Schema, SchemaRef};
use parquet::arrow::arrow_writer::{
    compute_leaves, ArrowColumnChunk, ArrowColumnWriter, ArrowRowGroupWriterFactory,
};
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::column::writer::ColumnCloseResult;
use parquet::errors::ParquetError;
use parquet::file::properties::WriterProperties;
use parquet::file::reader::ChunkReader;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::{ColumnPath, SchemaDescriptor};

/// Most rows in one row group.
pub const MAX_ROW_GROUP_ROWS: usize = 1 << 17;

/// Computed `riskctl ssm` columns stored without compression: continuous quantities of each
/// pair (gap, relative velocity, angle, ratio) whose f32 bits almost never repeat, so Snappy
/// saves 1-9 % of their bytes (1 M real US-101 pairs: 0.91-0.99 of the plain size) for about 3 %
/// of the whole Parquet -> Parquet run's instructions. The other computed columns keep Snappy:
/// TTC2D, TAdv and EI repeat their "no conflict" infinities (0.30-0.49), the ego's features repeat
/// for each of its partners, and sizes repeat (0.06-0.40). Any reader handles a per-column codec
/// (it is a property of each column chunk in the format).
pub const UNCOMPRESSED_COLUMNS: [&str; 8] = [
    "box_distance",
    "f_vx_sur",
    "f_vy_sur",
    "f_delta_v2",
    "f_delta_v",
    "f_psi_sur",
    "f_rho",
    "f_s",
];

/// How every Parquet output of riskscore is written: Snappy (but [`UNCOMPRESSED_COLUMNS`]), row
/// groups of at most [`MAX_ROW_GROUP_ROWS`], floating-point columns without dictionary encoding.
/// Measured values rarely repeat, and the dictionary of a row group of 65,536 floats stays under
/// the size that would make the writer give it up, so it would be kept for every float column:
/// slower to write and larger than plain values. Other columns (ids, labels) keep it.
pub fn writer_properties(schema: &Schema) -> WriterProperties {
    let mut props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_max_row_group_row_count(Some(MAX_ROW_GROUP_ROWS));
    for field in schema.fields() {
        if matches!(
            field.data_type(),
            DataType::Float16 | DataType::Float32 | DataType::Float64
        ) {
            let column = ColumnPath::from(field.name().as_str());
            props = props.set_column_dictionary_enabled(column.clone(), false);
            if field.data_type() == &DataType::Float32
                && UNCOMPRESSED_COLUMNS.contains(&field.name().as_str())
            {
                props = props.set_column_compression(column, Compression::UNCOMPRESSED);
            }
        }
    }
    props.build()
}

/// The writing side: the file, its row groups appended in order.
pub struct RowGroupFile<W: Write + Send> {
    writer: SerializedFileWriter<W>,
}

/// One output column chunk of a copied row group, in output order.
pub(crate) enum Piece {
    /// The input's chunk, copied from the input file.
    Copied(ColumnCloseResult),
    /// Encoded by the worker (a computed column, or a pass-through one that is not copied).
    Encoded(ArrowColumnChunk),
}

/// An output row group made from an input row group by copying: its column chunks in order.
/// The copied chunks' bytes are not held here: the writing thread reads them from the input
/// when it writes them, so a job in flight holds only its computed chunks, however wide the
/// pass-through columns are.
pub(crate) struct CopiedGroup {
    pub pieces: Vec<Piece>,
}

/// The encoding side, shared by the workers.
pub struct RowGroupEncoder {
    factory: ArrowRowGroupWriterFactory,
    schema: SchemaRef,
}

/// A Parquet file of `schema` on `out` (the Arrow schema is stored in its metadata, as
/// [`ArrowWriter`] does), and the encoder for its row groups.
pub fn row_group_file<W: Write + Send>(
    out: W,
    schema: SchemaRef,
) -> Result<(RowGroupFile<W>, RowGroupEncoder), ParquetError> {
    let writer = ArrowWriter::try_new(out, schema.clone(), Some(writer_properties(&schema)))?;
    let (writer, factory) = writer.into_serialized_writer()?;
    Ok((RowGroupFile { writer }, RowGroupEncoder { factory, schema }))
}

impl RowGroupEncoder {
    /// The file's Arrow schema.
    pub fn schema(&self) -> &SchemaRef {
        &self.schema
    }

    /// A fresh writer for each leaf column of the file, in order.
    pub fn column_writers(&self) -> Result<Vec<ArrowColumnWriter>, ParquetError> {
        // The row group's ordinal only matters to encryption, which riskscore does not use.
        self.factory.create_column_writers(0)
    }

    /// `batch` (of the file's schema) as the column chunks of row group number `index`.
    pub fn encode(
        &self,
        batch: &RecordBatch,
        index: usize,
    ) -> Result<Vec<ArrowColumnChunk>, ParquetError> {
        let mut writers = self.factory.create_column_writers(index)?;
        let mut leaves = writers.iter_mut();
        for (field, column) in self.schema.fields().iter().zip(batch.columns()) {
            for leaf in compute_leaves(field, column)? {
                let writer = leaves.next().ok_or_else(|| {
                    ParquetError::General(format!(
                        "column {}: more leaves than the schema has",
                        field.name()
                    ))
                })?;
                writer.write(&leaf)?;
            }
        }
        writers.into_iter().map(|w| w.close()).collect()
    }
}

impl<W: Write + Send> RowGroupFile<W> {
    /// Writes one encoded row group after the ones before it.
    pub fn append(&mut self, chunks: Vec<ArrowColumnChunk>) -> Result<(), ParquetError> {
        let mut row_group = self.writer.next_row_group()?;
        for chunk in chunks {
            chunk.append_to_row_group(&mut row_group)?;
        }
        row_group.close()?;
        Ok(())
    }

    /// Writes one row group made of copied and encoded column chunks after the ones before it,
    /// the copied ones read from `input`.
    pub fn append_copied<R: ChunkReader>(
        &mut self,
        input: &R,
        group: CopiedGroup,
    ) -> Result<(), ParquetError> {
        let mut row_group = self.writer.next_row_group()?;
        for piece in group.pieces {
            match piece {
                Piece::Copied(close) => row_group.append_column(input, close)?,
                Piece::Encoded(chunk) => chunk.append_to_row_group(&mut row_group)?,
            }
        }
        row_group.close()?;
        Ok(())
    }

    /// The file's Parquet schema.
    pub fn schema_descr(&self) -> &SchemaDescriptor {
        self.writer.schema_descr()
    }

    /// Writes the footer; returns the output, flushed.
    pub fn finish(self) -> Result<W, ParquetError> {
        let mut out = self.writer.into_inner()?;
        out.flush()?;
        Ok(out)
    }
}
