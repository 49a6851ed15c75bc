//! Parquet sink: tables are declared as data (explicit Arrow types, one
//! builder call per column) and written atomically through
//! [`super::atomic`] — a temporary file in the target directory, then a
//! rename — so a reader never sees half a file.
//!
//! Every table carries key/value metadata: `quaketwin.version`, the table's
//! `quaketwin.schema` name, and whatever the stage adds (processing history as
//! JSON, settings).  Schemas are documented in docs/formats.md.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::builder::{Float64Builder, ListBuilder, StringBuilder};
use arrow_array::{
    Array, ArrayRef, BooleanArray, Float64Array, Int32Array, Int64Array, RecordBatch, StringArray,
    TimestampNanosecondArray, UInt32Array,
};
use arrow_schema::{DataType, Field, Schema, SchemaRef, TimeUnit};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;

use crate::error::{Error, Result};

/// Column-by-column builder of one Arrow record batch.  Each method names
/// the Arrow type it produces; `opt_*` columns are nullable.
#[derive(Default)]
pub struct TableBuilder {
    fields: Vec<Field>,
    columns: Vec<ArrayRef>,
}

impl TableBuilder {
    pub fn new() -> Self {
        Self::default()
    }
    fn push(mut self, field: Field, column: ArrayRef) -> Self {
        self.fields.push(field);
        self.columns.push(column);
        self
    }
    /// Float64, not null.
    pub fn f64(self, name: &str, values: Vec<f64>) -> Self {
        self.push(
            Field::new(name, DataType::Float64, false),
            Arc::new(Float64Array::from(values)),
        )
    }
    /// Float64, nullable.
    pub fn opt_f64(self, name: &str, values: Vec<Option<f64>>) -> Self {
        self.push(
            Field::new(name, DataType::Float64, true),
            Arc::new(Float64Array::from(values)),
        )
    }
    /// Int64, not null.
    pub fn i64(self, name: &str, values: Vec<i64>) -> Self {
        self.push(
            Field::new(name, DataType::Int64, false),
            Arc::new(Int64Array::from(values)),
        )
    }
    /// Int32, not null.
    pub fn i32(self, name: &str, values: Vec<i32>) -> Self {
        self.push(
            Field::new(name, DataType::Int32, false),
            Arc::new(Int32Array::from(values)),
        )
    }
    /// Int32, nullable.
    pub fn opt_i32(self, name: &str, values: Vec<Option<i32>>) -> Self {
        self.push(
            Field::new(name, DataType::Int32, true),
            Arc::new(Int32Array::from(values)),
        )
    }
    /// UInt32, not null.
    pub fn u32(self, name: &str, values: Vec<u32>) -> Self {
        self.push(
            Field::new(name, DataType::UInt32, false),
            Arc::new(UInt32Array::from(values)),
        )
    }
    /// Boolean, not null.
    pub fn bool(self, name: &str, values: Vec<bool>) -> Self {
        self.push(
            Field::new(name, DataType::Boolean, false),
            Arc::new(BooleanArray::from(values)),
        )
    }
    /// Utf8, not null.
    pub fn str<S: AsRef<str>>(self, name: &str, values: &[S]) -> Self {
        let a: StringArray = values.iter().map(|s| Some(s.as_ref())).collect();
        self.push(Field::new(name, DataType::Utf8, false), Arc::new(a))
    }
    /// Utf8, nullable.
    pub fn opt_str<S: AsRef<str>>(self, name: &str, values: &[Option<S>]) -> Self {
        let a: StringArray = values
            .iter()
            .map(|s| s.as_ref().map(|s| s.as_ref()))
            .collect();
        self.push(Field::new(name, DataType::Utf8, true), Arc::new(a))
    }
    /// Timestamp(ns, UTC), nullable: absolute times.
    pub fn opt_timestamp_ns(self, name: &str, values: Vec<Option<i64>>) -> Self {
        let a = TimestampNanosecondArray::from(values).with_timezone("UTC");
        self.push(
            Field::new(
                name,
                DataType::Timestamp(TimeUnit::Nanosecond, Some("UTC".into())),
                true,
            ),
            Arc::new(a),
        )
    }
    /// List<Float64>, not null (e.g. a mode shape per row).
    pub fn list_f64(self, name: &str, values: &[Vec<f64>]) -> Self {
        let mut b = ListBuilder::new(Float64Builder::new());
        for row in values {
            b.values().append_slice(row);
            b.append(true);
        }
        let a = b.finish();
        let field = Field::new(name, a.data_type().clone(), false);
        self.push(field, Arc::new(a))
    }
    /// List<Utf8>, not null (e.g. QA flags per channel).
    pub fn list_str(self, name: &str, values: &[Vec<String>]) -> Self {
        let mut b = ListBuilder::new(StringBuilder::new());
        for row in values {
            for s in row {
                b.values().append_value(s);
            }
            b.append(true);
        }
        let a = b.finish();
        let field = Field::new(name, a.data_type().clone(), false);
        self.push(field, Arc::new(a))
    }
    pub fn schema(&self) -> SchemaRef {
        Arc::new(Schema::new(self.fields.clone()))
    }
    pub fn build(self) -> Result<RecordBatch> {
        let schema = Arc::new(Schema::new(self.fields));
        RecordBatch::try_new(schema, self.columns)
            .map_err(|e| Error::numerical(format!("building a table: {e}")))
    }
}

/// Writes record batches (all of one schema) to `path` atomically, with
/// zstd compression and the given key/value metadata.
pub fn write_parquet(
    path: &Path,
    batches: &[RecordBatch],
    metadata: &[(String, String)],
) -> Result<()> {
    let Some(first) = batches.first() else {
        return Err(Error::output(path, "no data to write"));
    };
    let schema = first.schema();
    let mut kv: Vec<KeyValue> = vec![KeyValue::new(
        "quaketwin.version".to_string(),
        env!("CARGO_PKG_VERSION").to_string(),
    )];
    kv.extend(
        metadata
            .iter()
            .map(|(k, v)| KeyValue::new(k.clone(), v.clone())),
    );
    let props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(
            ZstdLevel::try_new(3).map_err(|e| Error::output(path, e.to_string()))?,
        ))
        .set_max_row_group_row_count(Some(1 << 20))
        .set_key_value_metadata(Some(kv))
        .build();
    write_atomically(path, |file| {
        let mut writer = ArrowWriter::try_new(file, schema.clone(), Some(props))
            .map_err(|e| Error::output(path, e.to_string()))?;
        for b in batches {
            writer
                .write(b)
                .map_err(|e| Error::output(path, e.to_string()))?;
        }
        writer
            .close()
            .map_err(|e| Error::output(path, e.to_string()))?;
        Ok(())
    })
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
    metadata: Vec<(String, Option<String>)>,
}

impl ReadTable {
    pub fn open(path: &Path) -> Result<ReadTable> {
        use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
        let loc = || crate::error::Location::file(path.display().to_string());
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
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
        let batches = builder
            .build()
            .map_err(|e| Error::input(loc(), e.to_string()))?
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|e| Error::input(loc(), e.to_string()))?;
        Ok(ReadTable {
            path: path.to_path_buf(),
            batches,
            metadata,
        })
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
}
