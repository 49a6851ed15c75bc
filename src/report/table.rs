//! Loose loading of the pipeline's Parquet outputs for the report.
//!
//! The report must keep working while table schemas evolve, so a table is
//! loaded as named columns of a few display-oriented kinds (numbers, text,
//! booleans, lists) and looked up by name.  Sections ask for the columns they
//! know (named by the declarations of `vocab::tables`), show what is there
//! and list what is missing, unknown or not of the declared type — they
//! never fail because a column was renamed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use arrow_array::cast::AsArray;
use arrow_array::types::{
    Float32Type, Float64Type, Int16Type, Int32Type, Int64Type, Int8Type, TimestampNanosecondType,
    UInt16Type, UInt32Type, UInt64Type, UInt8Type,
};
use arrow_array::{Array, ArrayRef};
use arrow_schema::{DataType, SchemaRef, TimeUnit};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ProjectionMask;

use crate::error::{Error, Location, Result};
use crate::vocab::schema::TableSchema;

/// One column, converted to the kind the report displays.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    /// Any integer or floating-point column; `integer` keeps integers
    /// printing without decimals.
    Number {
        values: Vec<Option<f64>>,
        integer: bool,
    },
    Bool(Vec<Option<bool>>),
    /// Strings, and timestamps rendered as ISO 8601 UTC.
    Text(Vec<Option<String>>),
    TextList(Vec<Option<Vec<String>>>),
    NumberList(Vec<Option<Vec<f64>>>),
    /// A type the report does not display; the Arrow type is kept for the
    /// "unsupported column" note.
    Unsupported(String),
}

/// A Parquet file loaded by column name.
#[derive(Debug, Clone)]
pub struct Table {
    pub path: PathBuf,
    pub rows: usize,
    /// Column names in file order.
    pub names: Vec<String>,
    pub columns: BTreeMap<String, Column>,
    /// Key/value metadata of the file (`quaketwin.*`).
    pub metadata: BTreeMap<String, String>,
    /// The file's Arrow schema (all columns, also those not loaded).
    pub schema: SchemaRef,
}

fn location(path: &Path) -> Location {
    Location::file(path.display().to_string())
}

/// Loads `path`; with `only`, loads just those top-level columns (those that
/// exist) to keep big long-format tables cheap.
pub fn load(path: &Path, only: Option<&[&str]>) -> Result<Table> {
    let (mut table, reader) = open(path, only, None)?;
    for batch in reader {
        let batch = batch.map_err(|e| Error::input(location(path), e.to_string()))?;
        table.rows += batch.num_rows();
        for (field, array) in batch.schema().fields().iter().zip(batch.columns()) {
            let name = field.name().clone();
            if !table.columns.contains_key(&name) {
                table.names.push(name.clone());
            }
            let part = convert(array);
            match table.columns.get_mut(&name) {
                Some(existing) => append(existing, part),
                None => {
                    table.columns.insert(name, part);
                }
            }
        }
    }
    Ok(table)
}

/// The table of `path` without its rows: metadata, schema, the number of
/// rows (from the footer) and the columns of `only` that exist, empty but of
/// their kind — what [`Table::missing`] and the type checks need — for a
/// table too big to load, gone through with [`for_each_batch`].
pub fn load_head(path: &Path, only: Option<&[&str]>) -> Result<Table> {
    let (mut table, reader) = open(path, only, None)?;
    table.rows = usize::try_from(reader.metadata_rows).unwrap_or(0);
    for field in reader.schema.fields() {
        let empty = arrow_array::new_empty_array(field.data_type());
        table.names.push(field.name().clone());
        table.columns.insert(field.name().clone(), convert(&empty));
    }
    Ok(table)
}

/// Calls `each` on every record batch of `path` (the columns of `only`, at
/// most `batch_rows` rows at a time), in file order.
pub fn for_each_batch(
    path: &Path,
    only: Option<&[&str]>,
    batch_rows: usize,
    mut each: impl FnMut(&arrow_array::RecordBatch) -> Result<()>,
) -> Result<()> {
    let (_, reader) = open(path, only, Some(batch_rows))?;
    for batch in reader.reader {
        each(&batch.map_err(|e| Error::input(location(path), e.to_string()))?)?;
    }
    Ok(())
}

/// A reader of the projected columns, its schema and the file's row count.
struct Batches {
    reader: parquet::arrow::arrow_reader::ParquetRecordBatchReader,
    schema: SchemaRef,
    metadata_rows: i64,
}

impl Iterator for Batches {
    type Item = std::result::Result<arrow_array::RecordBatch, arrow_schema::ArrowError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.reader.next()
    }
}

/// An empty table (metadata and schema of `path`) and a reader of its rows.
fn open(path: &Path, only: Option<&[&str]>, batch_rows: Option<usize>) -> Result<(Table, Batches)> {
    let file = crate::input_file::open(path)?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| Error::input(location(path), format!("not a readable Parquet file: {e}")))?;
    let metadata: BTreeMap<String, String> = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .map(|kv| {
            kv.iter()
                .filter_map(|e| e.value.clone().map(|v| (e.key.clone(), v)))
                .collect()
        })
        .unwrap_or_default();
    let schema = builder.schema().clone();
    let metadata_rows = builder.metadata().file_metadata().num_rows();
    let builder = match batch_rows {
        Some(n) => builder.with_batch_size(n),
        None => builder,
    };
    let builder = match only {
        Some(wanted) => {
            let roots: Vec<usize> = schema
                .fields()
                .iter()
                .enumerate()
                .filter(|(_, f)| wanted.contains(&f.name().as_str()))
                .map(|(i, _)| i)
                .collect();
            let mask = ProjectionMask::roots(builder.parquet_schema(), roots);
            builder.with_projection(mask)
        }
        None => builder,
    };
    let reader = builder
        .build()
        .map_err(|e| Error::input(location(path), e.to_string()))?;
    let projected = arrow_array::RecordBatchReader::schema(&reader);
    Ok((
        Table {
            path: path.to_path_buf(),
            rows: 0,
            names: Vec::new(),
            columns: BTreeMap::new(),
            metadata,
            schema,
        },
        Batches {
            reader,
            schema: projected,
            metadata_rows,
        },
    ))
}

fn append(into: &mut Column, part: Column) {
    match (into, part) {
        (Column::Number { values, .. }, Column::Number { values: v, .. }) => values.extend(v),
        (Column::Bool(a), Column::Bool(b)) => a.extend(b),
        (Column::Text(a), Column::Text(b)) => a.extend(b),
        (Column::TextList(a), Column::TextList(b)) => a.extend(b),
        (Column::NumberList(a), Column::NumberList(b)) => a.extend(b),
        _ => {}
    }
}

macro_rules! numbers {
    ($array:expr, $t:ty, $integer:expr) => {{
        let a = $array.as_primitive::<$t>();
        Column::Number {
            values: (0..a.len())
                .map(|i| (!a.is_null(i)).then(|| a.value(i) as f64))
                .collect(),
            integer: $integer,
        }
    }};
}

/// The values of a numeric array (`None` for another kind).
pub fn number_values(array: &ArrayRef) -> Option<Vec<Option<f64>>> {
    match convert(array) {
        Column::Number { values, .. } => Some(values),
        _ => None,
    }
}

/// Converts one Arrow array to a display column.
pub fn convert(array: &ArrayRef) -> Column {
    match array.data_type() {
        DataType::Float64 => numbers!(array, Float64Type, false),
        DataType::Float32 => numbers!(array, Float32Type, false),
        DataType::Int8 => numbers!(array, Int8Type, true),
        DataType::Int16 => numbers!(array, Int16Type, true),
        DataType::Int32 => numbers!(array, Int32Type, true),
        DataType::Int64 => numbers!(array, Int64Type, true),
        DataType::UInt8 => numbers!(array, UInt8Type, true),
        DataType::UInt16 => numbers!(array, UInt16Type, true),
        DataType::UInt32 => numbers!(array, UInt32Type, true),
        DataType::UInt64 => numbers!(array, UInt64Type, true),
        DataType::Boolean => {
            let a = array.as_boolean();
            Column::Bool(
                (0..a.len())
                    .map(|i| (!a.is_null(i)).then(|| a.value(i)))
                    .collect(),
            )
        }
        DataType::Utf8 => {
            let a = array.as_string::<i32>();
            Column::Text(
                (0..a.len())
                    .map(|i| (!a.is_null(i)).then(|| a.value(i).to_string()))
                    .collect(),
            )
        }
        DataType::LargeUtf8 => {
            let a = array.as_string::<i64>();
            Column::Text(
                (0..a.len())
                    .map(|i| (!a.is_null(i)).then(|| a.value(i).to_string()))
                    .collect(),
            )
        }
        DataType::Timestamp(TimeUnit::Nanosecond, _) => {
            let a = array.as_primitive::<TimestampNanosecondType>();
            Column::Text(
                (0..a.len())
                    .map(|i| (!a.is_null(i)).then(|| crate::vocab::format_epoch_ns(a.value(i))))
                    .collect(),
            )
        }
        DataType::List(inner) | DataType::LargeList(inner) => {
            let lists: Vec<Option<ArrayRef>> = match array.data_type() {
                DataType::List(_) => {
                    let a = array.as_list::<i32>();
                    (0..a.len())
                        .map(|i| (!a.is_null(i)).then(|| a.value(i)))
                        .collect()
                }
                _ => {
                    let a = array.as_list::<i64>();
                    (0..a.len())
                        .map(|i| (!a.is_null(i)).then(|| a.value(i)))
                        .collect()
                }
            };
            match inner.data_type() {
                DataType::Utf8 | DataType::LargeUtf8 => Column::TextList(
                    lists
                        .into_iter()
                        .map(|l| {
                            l.map(|l| match convert(&l) {
                                Column::Text(v) => v.into_iter().flatten().collect(),
                                _ => Vec::new(),
                            })
                        })
                        .collect(),
                ),
                t if t.is_numeric() => Column::NumberList(
                    lists
                        .into_iter()
                        .map(|l| {
                            l.and_then(|l| number_values(&l))
                                .map(|v| v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
                        })
                        .collect(),
                ),
                other => Column::Unsupported(format!("list<{other}>")),
            }
        }
        other => Column::Unsupported(other.to_string()),
    }
}

impl Table {
    /// The file as the output directory names it: `modes/modes.parquet`
    /// for a table in its own folder, else the file name.
    pub fn file_name(&self) -> String {
        let run = crate::vocab::schema::run_dir_of(&self.path);
        self.path
            .strip_prefix(&run)
            .map(|p| p.to_string_lossy().into_owned())
            .unwrap_or_default()
    }
    pub fn has(&self, name: &str) -> bool {
        self.columns.contains_key(name)
    }
    pub fn number(&self, name: &str) -> Option<&[Option<f64>]> {
        match self.columns.get(name) {
            Some(Column::Number { values, .. }) => Some(values),
            _ => None,
        }
    }
    pub fn text(&self, name: &str) -> Option<&[Option<String>]> {
        match self.columns.get(name) {
            Some(Column::Text(v)) => Some(v),
            _ => None,
        }
    }
    pub fn boolean(&self, name: &str) -> Option<&[Option<bool>]> {
        match self.columns.get(name) {
            Some(Column::Bool(v)) => Some(v),
            _ => None,
        }
    }
    pub fn text_list(&self, name: &str) -> Option<&[Option<Vec<String>>]> {
        match self.columns.get(name) {
            Some(Column::TextList(v)) => Some(v),
            _ => None,
        }
    }
    /// Text of a cell whatever the column kind (numbers as their exact
    /// decimal form); used for grouping keys such as `direction`.
    pub fn key(&self, name: &str, row: usize) -> Option<String> {
        column_key(self.columns.get(name)?, row)
    }
    /// Expected columns absent from the file (or present with a kind the
    /// caller cannot use — `kinds_ok` decides).
    pub fn missing<'a>(&self, expected: &[&'a str]) -> Vec<&'a str> {
        expected.iter().filter(|n| !self.has(n)).copied().collect()
    }
    /// The file's columns whose Arrow type is not the declared one (the
    /// report still shows them as found; a section says so).
    pub fn type_mismatches(&self, declared: &TableSchema) -> Vec<String> {
        self.schema
            .fields()
            .iter()
            .filter_map(|f| declared.column(f.name())?.type_mismatch(f))
            .collect()
    }
    /// Columns of the file the section does not know.
    pub fn unknown(&self, known: &[&str]) -> Vec<String> {
        self.names
            .iter()
            .filter(|n| !known.contains(&n.as_str()))
            .cloned()
            .collect()
    }
    /// Row indices grouped by the values of `key` columns, groups in order of
    /// first appearance (stable, deterministic).
    pub fn groups(&self, keys: &[&str]) -> Vec<(Vec<String>, Vec<usize>)> {
        let mut out: Vec<(Vec<String>, Vec<usize>)> = Vec::new();
        let mut index: BTreeMap<Vec<String>, usize> = BTreeMap::new();
        for row in 0..self.rows {
            let k: Vec<String> = keys
                .iter()
                .map(|c| self.key(c, row).unwrap_or_else(|| "—".to_string()))
                .collect();
            match index.get(&k) {
                Some(&g) => out[g].1.push(row),
                None => {
                    index.insert(k.clone(), out.len());
                    out.push((k, vec![row]));
                }
            }
        }
        out
    }
}

/// [`Table::key`] of a column.
pub fn column_key(column: &Column, row: usize) -> Option<String> {
    match column {
        Column::Text(v) => v.get(row).cloned().flatten(),
        Column::Number { values, .. } => values.get(row).copied().flatten().map(|x| {
            if x.fract() == 0.0 && x.abs() < 1e15 {
                format!("{}", x as i64)
            } else {
                format!("{x}")
            }
        }),
        Column::Bool(v) => v.get(row).copied().flatten().map(|b| b.to_string()),
        _ => None,
    }
}
