//! Parquet sink: every table is built from its declaration
//! ([`crate::vocab::tables`]: names, Arrow types, nullability, units) and
//! written atomically through [`super::atomic`] — a temporary file in the
//! target directory, then a rename — so a reader never sees half a file.
//!
//! Every table carries key/value metadata: `quaketwin.version`, the table's
//! `quaketwin.schema` name and `quaketwin.description`, and whatever the stage
//! adds (processing history as JSON, settings).  They are written twice: as
//! Parquet footer key/values (where quaketwin and most tools read them) and
//! as Arrow schema metadata (pyarrow's `read_table(..).schema.metadata` shows
//! only those once the Arrow schema is embedded).  Each field carries its
//! `unit` in its Arrow field metadata.  Schemas are documented in
//! docs/formats.md, checked against the declarations.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::builder::{Float64Builder, ListBuilder, StringBuilder};
use arrow_array::{
    Array, ArrayRef, BooleanArray, Float64Array, Int32Array, Int64Array, RecordBatch, StringArray,
    TimestampNanosecondArray, UInt32Array,
};
use arrow_schema::{Field, Schema, SchemaRef};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;

use crate::error::{Error, Result};
use crate::vocab::schema::{
    ColumnSpec, ColumnType, Rows, TableSchema, DESCRIPTION_KEY, SCHEMA_KEY, VERSION_KEY,
};

/// Column-by-column builder of one Arrow record batch.  Each method names
/// the Arrow type it produces; `opt_*` columns are nullable.  A builder made
/// from a declaration ([`TableBuilder::new`]) takes the declared columns (a
/// column constant or its name) and refuses, at `build`, a column that is
/// undeclared, missing, out of order or of another type than declared.
pub struct TableBuilder {
    schema: Option<&'static TableSchema>,
    fields: Vec<Field>,
    columns: Vec<ArrayRef>,
    /// The first column that did not match the declaration (reported by `build`,
    /// so the chained calls stay infallible).
    error: Option<String>,
}

impl TableBuilder {
    /// A builder of the declared table `schema`.
    pub fn new(schema: &'static TableSchema) -> Self {
        Self::of(Some(schema))
    }
    /// A builder of a table quaketwin does not declare: files other tools
    /// wrote, or that an older quaketwin wrote (test fixtures of readers that
    /// must cope with them).  No checks, no units.
    pub fn untyped() -> Self {
        Self::of(None)
    }
    fn of(schema: Option<&'static TableSchema>) -> Self {
        TableBuilder {
            schema,
            fields: Vec::new(),
            columns: Vec::new(),
            error: None,
        }
    }
    fn push(mut self, name: &str, ty: ColumnType, nullable: bool, column: ArrayRef) -> Self {
        let field = match self.schema.map(|s| (s, s.column(name))) {
            None => Field::new(name, ty.data_type(), nullable),
            Some((s, None)) => {
                self.error
                    .get_or_insert_with(|| format!("column {name} is not declared in {}", s.file));
                Field::new(name, ty.data_type(), nullable)
            }
            Some((_, Some(spec))) => {
                if spec.ty != ty || spec.nullable != nullable {
                    let given = ColumnSpec {
                        ty,
                        nullable,
                        ..*spec
                    };
                    self.error.get_or_insert_with(|| {
                        format!(
                            "column {name} is set as {}, declared {}",
                            given.describe(),
                            spec.describe()
                        )
                    });
                }
                spec.field(name)
            }
        };
        self.fields.push(field);
        self.columns.push(column);
        self
    }
    /// The unit of the column added last, in place of the declared one: a
    /// member of a family declared with unit `varies` (`param_<name>` of
    /// twin_update/twin_update.parquet: each parameter its own unit).  Refused (at
    /// `build`) for a column declared with one unit.
    pub fn with_unit(mut self, unit: &str) -> Self {
        use crate::vocab::schema::{UNIT_KEY, UNIT_VARIES};
        let Some(field) = self.fields.pop() else {
            return self;
        };
        let declared = self.schema.and_then(|s| s.column(field.name()));
        if declared.is_some_and(|c| c.unit != UNIT_VARIES) {
            self.error
                .get_or_insert_with(|| format!("column {} has one declared unit", field.name()));
        }
        let mut metadata = field.metadata().clone();
        metadata.insert(UNIT_KEY.to_string(), unit.to_string());
        self.fields.push(field.with_metadata(metadata));
        self
    }
    /// Float64, not null.
    pub fn f64(self, name: impl AsRef<str>, values: Vec<f64>) -> Self {
        let a = Arc::new(Float64Array::from(values));
        self.push(name.as_ref(), ColumnType::F64, false, a)
    }
    /// Float64, nullable.
    pub fn opt_f64(self, name: impl AsRef<str>, values: Vec<Option<f64>>) -> Self {
        let a = Arc::new(Float64Array::from(values));
        self.push(name.as_ref(), ColumnType::F64, true, a)
    }
    /// Int64, not null.
    pub fn i64(self, name: impl AsRef<str>, values: Vec<i64>) -> Self {
        let a = Arc::new(Int64Array::from(values));
        self.push(name.as_ref(), ColumnType::I64, false, a)
    }
    /// Int32, not null.
    pub fn i32(self, name: impl AsRef<str>, values: Vec<i32>) -> Self {
        let a = Arc::new(Int32Array::from(values));
        self.push(name.as_ref(), ColumnType::I32, false, a)
    }
    /// Int32, nullable.
    pub fn opt_i32(self, name: impl AsRef<str>, values: Vec<Option<i32>>) -> Self {
        let a = Arc::new(Int32Array::from(values));
        self.push(name.as_ref(), ColumnType::I32, true, a)
    }
    /// UInt32, not null.
    pub fn u32(self, name: impl AsRef<str>, values: Vec<u32>) -> Self {
        let a = Arc::new(UInt32Array::from(values));
        self.push(name.as_ref(), ColumnType::U32, false, a)
    }
    /// UInt32, nullable.
    pub fn opt_u32(self, name: impl AsRef<str>, values: Vec<Option<u32>>) -> Self {
        let a = Arc::new(UInt32Array::from(values));
        self.push(name.as_ref(), ColumnType::U32, true, a)
    }
    /// Boolean, not null.
    pub fn bool(self, name: impl AsRef<str>, values: Vec<bool>) -> Self {
        let a = Arc::new(BooleanArray::from(values));
        self.push(name.as_ref(), ColumnType::Bool, false, a)
    }
    /// Boolean, nullable.
    pub fn opt_bool(self, name: impl AsRef<str>, values: Vec<Option<bool>>) -> Self {
        let a = Arc::new(BooleanArray::from(values));
        self.push(name.as_ref(), ColumnType::Bool, true, a)
    }
    /// Utf8, not null.
    pub fn str<S: AsRef<str>>(self, name: impl AsRef<str>, values: &[S]) -> Self {
        let a: StringArray = values.iter().map(|s| Some(s.as_ref())).collect();
        self.push(name.as_ref(), ColumnType::Utf8, false, Arc::new(a))
    }
    /// Utf8, not null: `value` on each of `rows` rows (a channel's id on each
    /// of its samples), built as one buffer of repeated bytes and computed
    /// offsets instead of a string per row.
    pub fn repeated_str(mut self, name: impl AsRef<str>, value: &str, rows: usize) -> Self {
        let width = value.len();
        let total = width
            .checked_mul(rows)
            .filter(|t| i32::try_from(*t).is_ok());
        let Some(total) = total else {
            self.error.get_or_insert_with(|| {
                format!(
                    "column {}: {rows} rows of {value:?} exceed 2 GiB",
                    name.as_ref()
                )
            });
            return self.str(name, &[] as &[&str]);
        };
        let mut bytes = Vec::with_capacity(total);
        for _ in 0..rows {
            bytes.extend_from_slice(value.as_bytes());
        }
        // In range: the last offset is `total`, checked above.
        let offsets: Vec<i32> = (0..=rows).map(|i| (i * width) as i32).collect();
        let a = StringArray::new(
            arrow_buffer::OffsetBuffer::new(offsets.into()),
            bytes.into(),
            None,
        );
        self.push(name.as_ref(), ColumnType::Utf8, false, Arc::new(a))
    }
    /// Float64, nullable: every row valid (`Some(values)`), or `rows` nulls.
    pub fn opt_f64_column(
        self,
        name: impl AsRef<str>,
        values: Option<Vec<f64>>,
        rows: usize,
    ) -> Self {
        let a: ArrayRef = match values {
            Some(v) => Arc::new(Float64Array::from(v)),
            None => Arc::new(Float64Array::new_null(rows)),
        };
        self.push(name.as_ref(), ColumnType::F64, true, a)
    }
    /// Timestamp(ns, UTC), nullable: every row valid (`Some(values)`), or
    /// `rows` nulls.
    pub fn opt_timestamp_ns_column(
        self,
        name: impl AsRef<str>,
        values: Option<Vec<i64>>,
        rows: usize,
    ) -> Self {
        let a = match values {
            Some(v) => TimestampNanosecondArray::from(v),
            None => TimestampNanosecondArray::new_null(rows),
        }
        .with_timezone("UTC");
        self.push(name.as_ref(), ColumnType::TimestampNsUtc, true, Arc::new(a))
    }
    /// Utf8, nullable.
    pub fn opt_str<S: AsRef<str>>(self, name: impl AsRef<str>, values: &[Option<S>]) -> Self {
        let a: StringArray = values
            .iter()
            .map(|s| s.as_ref().map(|s| s.as_ref()))
            .collect();
        self.push(name.as_ref(), ColumnType::Utf8, true, Arc::new(a))
    }
    /// Timestamp(ns, UTC), not null: absolute times.
    pub fn timestamp_ns(self, name: impl AsRef<str>, values: Vec<i64>) -> Self {
        let a = TimestampNanosecondArray::from(values).with_timezone("UTC");
        self.push(
            name.as_ref(),
            ColumnType::TimestampNsUtc,
            false,
            Arc::new(a),
        )
    }
    /// Timestamp(ns, UTC), nullable: absolute times.
    pub fn opt_timestamp_ns(self, name: impl AsRef<str>, values: Vec<Option<i64>>) -> Self {
        let a = TimestampNanosecondArray::from(values).with_timezone("UTC");
        self.push(name.as_ref(), ColumnType::TimestampNsUtc, true, Arc::new(a))
    }
    /// List<Float64>, not null (e.g. a mode shape per row).
    pub fn list_f64(self, name: impl AsRef<str>, values: &[Vec<f64>]) -> Self {
        let mut b = ListBuilder::new(Float64Builder::new());
        for row in values {
            b.values().append_slice(row);
            b.append(true);
        }
        self.push(
            name.as_ref(),
            ColumnType::ListF64,
            false,
            Arc::new(b.finish()),
        )
    }
    /// List<Utf8>, not null (e.g. QA flags per channel).
    pub fn list_str(self, name: impl AsRef<str>, values: &[Vec<String>]) -> Self {
        let mut b = ListBuilder::new(StringBuilder::new());
        for row in values {
            for s in row {
                b.values().append_value(s);
            }
            b.append(true);
        }
        self.push(
            name.as_ref(),
            ColumnType::ListUtf8,
            false,
            Arc::new(b.finish()),
        )
    }
    pub fn schema(&self) -> SchemaRef {
        Arc::new(Schema::new(self.fields.clone()))
    }
    /// The record batch; for a declared table, with the table's name and
    /// description as schema metadata.  A table that does not match its
    /// declaration is a bug of the writer: an internal (numerical-kind) error.
    pub fn build(self) -> Result<RecordBatch> {
        let mut schema = Schema::new(self.fields);
        if let Some(s) = self.schema {
            let fields: Vec<&Field> = schema.fields().iter().map(|f| f.as_ref()).collect();
            if let Some(e) = self.error.or_else(|| s.check_fields(&fields).err()) {
                return Err(Error::numerical(format!(
                    "internal error: {} does not match its declaration: {e}",
                    s.file
                )));
            }
            schema = schema.with_metadata(
                [
                    (SCHEMA_KEY.to_string(), s.name.to_string()),
                    (DESCRIPTION_KEY.to_string(), s.doc.to_string()),
                ]
                .into_iter()
                .collect::<BTreeMap<_, _>>(),
            );
        }
        RecordBatch::try_new(Arc::new(schema), self.columns)
            .map_err(|e| Error::numerical(format!("building a table: {e}")))
    }
}

/// Writes record batches (all of one schema) to `path` atomically, with
/// zstd compression.  The key/value metadata — `quaketwin.version`, then the
/// batch schema's own (the declaration's name and description), then
/// `metadata` — goes both into the Parquet footer and into the Arrow schema.
pub fn write_parquet(
    path: &Path,
    batches: &[RecordBatch],
    metadata: &[(String, String)],
) -> Result<()> {
    write_parquet_stream(path, metadata, batches.iter().map(|b| Ok(b.clone())))
}

/// As [`write_parquet`], with the batches made one at a time by `batches`
/// (issue 14 item 5): only the batch being written, the next one (made while
/// this one is encoded) and the row group being encoded are in memory.  The
/// file is the same as from `write_parquet` given the same batches.
pub fn write_parquet_stream(
    path: &Path,
    metadata: &[(String, String)],
    batches: impl Iterator<Item = Result<RecordBatch>> + Send,
) -> Result<()> {
    let mut batches = batches.peekable();
    if batches.peek().is_none() {
        return Err(Error::output(path, "no data to write"));
    }
    write_atomically(path, |file| {
        let first = match batches.next() {
            Some(b) => b?,
            None => return Err(Error::output(path, "no data to write")),
        };
        let (schema, props) = writer_setup(path, &first, metadata)?;
        let out = |e: parquet::errors::ParquetError| Error::output(path, e.to_string());
        let mut writer = ColumnParallelWriter::new(file, schema.clone(), props).map_err(out)?;
        let mut next = Some(Ok(first));
        while let Some(batch) = next.take() {
            let batch = batch?
                .with_schema(schema.clone())
                .map_err(|e| Error::output(path, e.to_string()))?;
            let (written, following) =
                rayon::join(|| writer.write(&batch).map_err(out), || batches.next());
            written?;
            next = following;
        }
        writer.close().map_err(out)
    })
}

/// `parquet::arrow::ArrowWriter` with the columns of each batch encoded in
/// parallel, one task per column (issue 14 item 5: a 46 M-row
/// samples/samples.parquet).  Row groups are cut where `ArrowWriter` cuts them (at
/// the row-count limit, splitting a batch), and each column writer is given
/// the same slices in the same order, so the file is byte for byte the one
/// `ArrowWriter` writes.  (No byte limit per row group and no content-defined
/// chunking are configured: `writer_setup`.)
struct ColumnParallelWriter<W: std::io::Write + Send> {
    file: parquet::file::writer::SerializedFileWriter<W>,
    factory: parquet::arrow::arrow_writer::ArrowRowGroupWriterFactory,
    schema: SchemaRef,
    max_rows: Option<usize>,
    /// The row group being encoded: one writer per leaf column, and its rows.
    in_progress: Option<(Vec<parquet::arrow::arrow_writer::ArrowColumnWriter>, usize)>,
}

type ParquetResult<T> = std::result::Result<T, parquet::errors::ParquetError>;

impl<W: std::io::Write + Send> ColumnParallelWriter<W> {
    fn new(out: W, schema: SchemaRef, props: WriterProperties) -> ParquetResult<Self> {
        let max_rows = props.max_row_group_row_count();
        let (file, factory) =
            ArrowWriter::try_new(out, schema.clone(), Some(props))?.into_serialized_writer()?;
        Ok(ColumnParallelWriter {
            file,
            factory,
            schema,
            max_rows,
            in_progress: None,
        })
    }

    /// As `ArrowWriter::write`.
    fn write(&mut self, batch: &RecordBatch) -> ParquetResult<()> {
        use parquet::arrow::arrow_writer::compute_leaves;
        use rayon::prelude::*;
        if batch.num_rows() == 0 {
            return Ok(());
        }
        let mut remaining = batch.clone();
        loop {
            if self.in_progress.is_none() {
                let index = self.file.flushed_row_groups().len();
                self.in_progress = Some((self.factory.create_column_writers(index)?, 0));
            }
            let Some((writers, buffered)) = self.in_progress.as_mut() else {
                return Ok(());
            };
            let split_at = match self.max_rows {
                Some(max) if *buffered + remaining.num_rows() > max => Some(max - *buffered),
                _ => None,
            };
            let rest = split_at.map(|to_write| {
                let rest = remaining.slice(to_write, remaining.num_rows() - to_write);
                remaining = remaining.slice(0, to_write);
                rest
            });
            let mut leaves = Vec::with_capacity(writers.len());
            for (field, column) in self.schema.fields().iter().zip(remaining.columns()) {
                leaves.extend(compute_leaves(field.as_ref(), column)?);
            }
            writers
                .par_iter_mut()
                .zip(leaves.par_iter())
                .map(|(w, leaf)| w.write(leaf))
                .collect::<ParquetResult<Vec<()>>>()?;
            *buffered += remaining.num_rows();
            if self.max_rows.is_some_and(|max| *buffered >= max) {
                self.flush()?;
            }
            match rest {
                Some(rest) => remaining = rest,
                None => return Ok(()),
            }
        }
    }

    /// As `ArrowWriter::flush`: the row group's columns closed in parallel,
    /// appended in order.
    fn flush(&mut self) -> ParquetResult<()> {
        use rayon::prelude::*;
        let Some((writers, _)) = self.in_progress.take() else {
            return Ok(());
        };
        let chunks = writers
            .into_par_iter()
            .map(|w| w.close())
            .collect::<ParquetResult<Vec<_>>>()?;
        let mut row_group = self.file.next_row_group()?;
        for chunk in chunks {
            chunk.append_to_row_group(&mut row_group)?;
        }
        row_group.close()?;
        Ok(())
    }

    /// As `ArrowWriter::close`.
    fn close(mut self) -> ParquetResult<()> {
        self.flush()?;
        self.file.close().map(|_| ())
    }
}

/// The key/value metadata of a table: `quaketwin.version`, then the batch
/// schema's own (the declaration's name and description), then `metadata`
/// (one value per key: the first wins).
fn table_metadata(first: &RecordBatch, metadata: &[(String, String)]) -> Vec<(String, String)> {
    let mut kv: Vec<(String, String)> = vec![(
        VERSION_KEY.to_string(),
        env!("CARGO_PKG_VERSION").to_string(),
    )];
    let own = first.schema().metadata().clone();
    let given = metadata.iter().map(|(k, v)| (k, v));
    for (k, v) in own.iter().chain(given) {
        if !kv.iter().any(|(key, _)| key == k) {
            kv.push((k.clone(), v.clone()));
        }
    }
    kv
}

/// The schema of `first` with the key/value entries `kv` as its metadata.
fn schema_with(first: &RecordBatch, kv: &[(String, String)]) -> SchemaRef {
    Arc::new(
        first
            .schema()
            .as_ref()
            .clone()
            .with_metadata(kv.iter().cloned().collect::<BTreeMap<_, _>>()),
    )
}

/// `batches` (all of one schema) with the metadata a file written by
/// [`write_parquet`] would carry in its Arrow schema: the in-memory form of
/// a table (the Python bindings hand these to pyarrow without a file).
pub fn with_table_metadata(
    batches: Vec<RecordBatch>,
    metadata: &[(String, String)],
) -> Result<Vec<RecordBatch>> {
    let Some(first) = batches.first() else {
        return Ok(batches);
    };
    let schema = schema_with(first, &table_metadata(first, metadata));
    batches
        .into_iter()
        .map(|b| {
            b.with_schema(schema.clone())
                .map_err(|e| Error::numerical(format!("building a table: {e}")))
        })
        .collect()
}

/// The file's Arrow schema (the batch's, with every key/value entry) and the
/// writer properties: zstd, row groups of 2²⁰ rows, the key/value metadata
/// of [`table_metadata`] — and the encodings of the declared table's rows
/// ([`series_encodings`]).  Public so that tests can write the reference
/// file with `ArrowWriter`.
pub fn writer_setup(
    path: &Path,
    first: &RecordBatch,
    metadata: &[(String, String)],
) -> Result<(SchemaRef, WriterProperties)> {
    let kv = table_metadata(first, metadata);
    let schema = schema_with(first, &kv);
    // zstd level 1: on the 64-channel hour of samples the file is the same
    // size as at level 3 (844 vs 842 MB, the byte-stream split does the
    // work) and the write about 20 % faster (benches/parquet.rs).
    let props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(
            ZstdLevel::try_new(1).map_err(|e| Error::output(path, e.to_string()))?,
        ))
        .set_max_row_group_row_count(Some(1 << 20))
        .set_key_value_metadata(Some(
            kv.into_iter().map(|(k, v)| KeyValue::new(k, v)).collect(),
        ));
    let declared = first
        .schema()
        .metadata()
        .get(SCHEMA_KEY)
        .and_then(|name| crate::vocab::tables::by_name(name));
    let props = match declared.map(|t| t.rows) {
        Some(Rows::Series) => series_encodings(props, &schema),
        Some(Rows::Results) | None => props,
    };
    Ok((schema, props.build()))
}

/// Encodings of a table of time-series samples ([`Rows::Series`]): float
/// columns byte-stream-split, 64-bit integer and timestamp columns (sample
/// index, absolute time) delta-encoded, none of them with a dictionary;
/// other columns (channel ids, DoF numbers, flags: few distinct values) keep
/// the default dictionary.  Why: Parquet tries a dictionary on every column
/// first and gives up only after a megabyte of distinct values per column
/// chunk, which for samples means hashing a sixth of the values for nothing;
/// byte-stream splitting puts the sign-and-exponent bytes of the floats
/// together, where zstd finds the structure that plain doubles hide.  On an
/// hour of 64 channels: samples/samples.parquet a quarter smaller, 928 MB instead of
/// 1.23 GB (docs/performance.md).  Every reader of Parquet 2.8 reads them
/// (pyarrow, DuckDB ≥ 0.10, polars ≥ 1.1).
fn series_encodings(
    mut props: parquet::file::properties::WriterPropertiesBuilder,
    schema: &Schema,
) -> parquet::file::properties::WriterPropertiesBuilder {
    use arrow_schema::DataType;
    use parquet::basic::Encoding;
    use parquet::schema::types::ColumnPath;
    for field in schema.fields() {
        let encoding = match field.data_type() {
            DataType::Float64 => Encoding::BYTE_STREAM_SPLIT,
            DataType::Int64 | DataType::Timestamp(_, _) => Encoding::DELTA_BINARY_PACKED,
            _ => continue,
        };
        let column = ColumnPath::from(field.name().as_str());
        props = props
            .set_column_dictionary_enabled(column.clone(), false)
            .set_column_encoding(column, encoding);
    }
    props
}

/// The atomic write helpers live in [`super::atomic`]; re-exported here
/// for the writers that have always imported them from this module.
pub use super::atomic::{write_atomically, write_bytes_atomically};

/// A Parquet file read back whole: its record batches and key/value
/// metadata, with typed column access whose errors name the file and column.
/// The read-back half of this module, shared by every table reader.
pub struct ReadTable {
    pub path: PathBuf,
    pub batches: Vec<RecordBatch>,
    /// Rows of the file (from its footer).
    pub rows: usize,
    metadata: Vec<(String, Option<String>)>,
}

impl ReadTable {
    pub fn open(path: &Path) -> Result<ReadTable> {
        let (mut table, reader) = Self::open_stream(path, None)?;
        let loc = || crate::error::Location::file(path.display().to_string());
        table.batches = reader
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|e| Error::input(loc(), e.to_string()))?;
        Ok(table)
    }

    /// The file's metadata (a table without batches, for [`ReadTable::declared`])
    /// and a reader of its record batches, to go through a big file a batch at
    /// a time; `batch_rows` sets the rows per batch (default: the reader's).
    pub fn open_stream(
        path: &Path,
        batch_rows: Option<usize>,
    ) -> Result<(
        ReadTable,
        parquet::arrow::arrow_reader::ParquetRecordBatchReader,
    )> {
        use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
        let loc = || crate::error::Location::file(path.display().to_string());
        let file = crate::input_file::open(path)?;
        let builder = ParquetRecordBatchReaderBuilder::try_new(file)
            .map_err(|e| Error::input(loc(), e.to_string()))?;
        let metadata = builder
            .metadata()
            .file_metadata()
            .key_value_metadata()
            .map(|kv| {
                kv.iter()
                    .map(|e| (e.key.clone(), e.value.clone()))
                    .collect()
            })
            .unwrap_or_default();
        let rows = usize::try_from(builder.metadata().file_metadata().num_rows()).unwrap_or(0);
        let builder = match batch_rows {
            Some(n) => builder.with_batch_size(n),
            None => builder,
        };
        let reader = builder
            .build()
            .map_err(|e| Error::input(loc(), e.to_string()))?;
        Ok((
            ReadTable {
                path: path.to_path_buf(),
                batches: Vec::new(),
                rows,
                metadata,
            },
            reader,
        ))
    }

    /// A table held in memory (an Arrow table handed over by a caller, not a
    /// file): `label` names it in errors; `metadata` is its schema's.
    pub fn in_memory(
        label: &str,
        metadata: Vec<(String, String)>,
        batches: Vec<RecordBatch>,
    ) -> ReadTable {
        let mut metadata: Vec<(String, Option<String>)> =
            metadata.into_iter().map(|(k, v)| (k, Some(v))).collect();
        metadata.sort();
        ReadTable {
            path: PathBuf::from(label),
            rows: batches.iter().map(|b| b.num_rows()).sum(),
            batches,
            metadata,
        }
    }

    /// Value of a key/value metadata entry.
    pub fn metadata(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .and_then(|(_, v)| v.as_deref())
    }

    pub fn location(&self) -> crate::error::Location {
        crate::error::Location::file(self.path.display().to_string())
    }

    /// Column `name` of `batch` as the Arrow array type `T`.
    pub fn column<T: Array + Clone + 'static>(&self, batch: &RecordBatch, name: &str) -> Result<T> {
        let col = batch
            .column_by_name(name)
            .ok_or_else(|| Error::input(self.location(), format!("column {name} missing")))?;
        col.as_any().downcast_ref::<T>().cloned().ok_or_else(|| {
            Error::input(
                self.location(),
                format!(
                    "column {name} has type {}, not the expected one",
                    col.data_type()
                ),
            )
        })
    }

    /// The declared column `spec` of `batch` as the Arrow array type `T`,
    /// after checking the file's field against the declaration (type and
    /// nullability): a file that does not match is an input error naming
    /// the file and the column.
    pub fn declared<T: Array + Clone + 'static>(
        &self,
        batch: &RecordBatch,
        spec: &ColumnSpec,
    ) -> Result<T> {
        let schema = batch.schema();
        let field = schema
            .field_with_name(spec.name)
            .map_err(|_| Error::input(self.location(), format!("column {} missing", spec.name)))?;
        if let Some(m) = spec.mismatch(field) {
            return Err(Error::input(self.location(), m));
        }
        self.column(batch, spec.name)
    }
}
