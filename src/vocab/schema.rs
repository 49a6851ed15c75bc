//! Table schemas as data (the arrow-rs model): a table is a name, a file, a
//! description and an ordered list of typed, documented columns with units.
//! The declarations themselves are in [`super::tables`]; this module holds
//! the types, their Arrow form, the checks a written or read table must pass
//! and the Markdown rendering docs/formats.md is checked against.  It lives
//! in the vocabulary, not in the sinks, so that code reading our outputs
//! back needs no writer.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use arrow_schema::{DataType, Field, TimeUnit};

/// Key/value metadata key of the table name (Arrow schema metadata and Parquet footer).
pub const SCHEMA_KEY: &str = "quaketwin.schema";
/// Key of the quaketwin version that wrote a file.
pub const VERSION_KEY: &str = "quaketwin.version";
/// Key of the table's one-line description.
pub const DESCRIPTION_KEY: &str = "quaketwin.description";
/// Arrow field metadata key of a column's unit.
pub const UNIT_KEY: &str = "unit";
/// Arrow field metadata key of a column's meaning (the declaration's doc):
/// pyarrow shows it as `schema.field(name).metadata[b"description"]`.
pub const FIELD_DESCRIPTION_KEY: &str = "description";
/// Unit of a numeric column whose unit differs from row to row or entry to
/// entry; the column's description says where each one's unit is stated
/// (a `unit` column, a metadata entry, or the field of each family member).
pub const UNIT_VARIES: &str = "varies";
/// Unit of a numeric column on a scale of its own (a cost, a singular
/// value of a scaled matrix): comparable within the column, not a
/// physical quantity.
pub const UNIT_ARBITRARY: &str = "arbitrary";

/// The Arrow types quaketwin tables use (plain types only: no extension
/// types, so pyarrow, DuckDB and polars read them without adapters).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnType {
    F64,
    I32,
    I64,
    U32,
    Bool,
    Utf8,
    /// Timestamp(ns, UTC): absolute times.
    TimestampNsUtc,
    /// List<Float64> (items nullable, as Arrow's list builder makes them).
    ListF64,
    /// List<Utf8>.
    ListUtf8,
}

impl ColumnType {
    /// The Arrow data type of a column of this type.
    pub fn data_type(self) -> DataType {
        match self {
            ColumnType::F64 => DataType::Float64,
            ColumnType::I32 => DataType::Int32,
            ColumnType::I64 => DataType::Int64,
            ColumnType::U32 => DataType::UInt32,
            ColumnType::Bool => DataType::Boolean,
            ColumnType::Utf8 => DataType::Utf8,
            ColumnType::TimestampNsUtc => {
                DataType::Timestamp(TimeUnit::Nanosecond, Some("UTC".into()))
            }
            ColumnType::ListF64 => DataType::new_list(DataType::Float64, true),
            ColumnType::ListUtf8 => DataType::new_list(DataType::Utf8, true),
        }
    }

    /// The name docs/formats.md uses.
    pub fn doc_name(self) -> &'static str {
        match self {
            ColumnType::F64 => "float64",
            ColumnType::I32 => "int32",
            ColumnType::I64 => "int64",
            ColumnType::U32 => "uint32",
            ColumnType::Bool => "bool",
            ColumnType::Utf8 => "utf8",
            ColumnType::TimestampNsUtc => "timestamp[ns, UTC]",
            ColumnType::ListF64 => "list<float64>",
            ColumnType::ListUtf8 => "list<utf8>",
        }
    }
}

/// One declared column.  A name with `<…>` (`param_<name>`, `pom_<j>`)
/// declares a family: zero or more consecutive columns whose names start with
/// the part before `<` (tables whose width depends on the data).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColumnSpec {
    pub name: &'static str,
    pub ty: ColumnType,
    pub nullable: bool,
    /// SI unit (`m/s^2`, `Hz`…), `1` for a dimensionless quantity,
    /// [`UNIT_VARIES`] or [`UNIT_ARBITRARY`] for a number without one unit,
    /// empty for a value that is not a physical quantity (ids, labels,
    /// indices, counts, flags, times — a timestamp's type carries its unit).
    pub unit: &'static str,
    pub doc: &'static str,
}

/// Writers pass a column constant where a name is expected.
impl AsRef<str> for ColumnSpec {
    fn as_ref(&self) -> &str {
        self.name
    }
}

impl ColumnSpec {
    /// The common prefix of a column family, `None` for a single column.
    pub fn family_prefix(&self) -> Option<&'static str> {
        self.name.find('<').map(|i| &self.name[..i])
    }

    /// The name of the member `suffix` of a column family (`pom_` + `3`).
    pub fn member(&self, suffix: &str) -> String {
        format!("{}{suffix}", self.family_prefix().unwrap_or(self.name))
    }

    /// Whether a column named `name` is this column (or one of this family).
    pub fn matches(&self, name: &str) -> bool {
        match self.family_prefix() {
            Some(p) => name.len() > p.len() && name.starts_with(p),
            None => name == self.name,
        }
    }

    /// The Arrow field of this column (named `name`, a member of a family
    /// having its own name), its unit and meaning in its metadata (so a
    /// user reading the file alone learns what each column is).
    pub fn field(&self, name: &str) -> Field {
        Field::new(name, self.ty.data_type(), self.nullable).with_metadata(HashMap::from([
            (UNIT_KEY.to_string(), self.unit.to_string()),
            (FIELD_DESCRIPTION_KEY.to_string(), self.doc.to_string()),
        ]))
    }

    /// Type and nullability, as messages name them (`float64, nullable`).
    pub fn describe(&self) -> String {
        format!("{}, {}", self.ty.doc_name(), nullability(self.nullable))
    }

    /// Why a field of a file does not have this column's type, if it does
    /// not.  A list's item field may have any name (Arrow says `item`,
    /// parquet-mr and pyarrow may say `element`): only the item type counts.
    pub fn type_mismatch(&self, field: &Field) -> Option<String> {
        let expected = self.ty.data_type();
        let same = match (field.data_type(), &expected) {
            (DataType::List(a), DataType::List(b)) => a.data_type() == b.data_type(),
            (a, b) => a == b,
        };
        (!same).then(|| {
            format!(
                "column {} has type {}, declared {}",
                field.name(),
                field.data_type(),
                self.ty.doc_name()
            )
        })
    }

    /// Why a field of a file is not this column (type or nullability), if it is not.
    pub fn mismatch(&self, field: &Field) -> Option<String> {
        if let Some(m) = self.type_mismatch(field) {
            return Some(m);
        }
        (field.is_nullable() != self.nullable).then(|| {
            format!(
                "column {} is {}, declared {}",
                field.name(),
                nullability(field.is_nullable()),
                nullability(self.nullable)
            )
        })
    }
}

fn nullability(nullable: bool) -> &'static str {
    if nullable {
        "nullable"
    } else {
        "not nullable"
    }
}

/// What a table's rows are, which decides how its columns are encoded
/// (`sinks::parquet`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rows {
    /// Rows of results (channels, modes, spectra…): Parquet's default
    /// encodings, a dictionary first.
    Results,
    /// Samples of time series (one row per sample, millions of rows): nearly
    /// every float and every sample index or time is distinct, so floats are
    /// byte-stream-split and 64-bit integers and times delta-encoded, with
    /// no dictionary attempt (docs/formats.md).
    Series,
}

/// The file, relative to a run's output directory, of a table whose file
/// name is `file_name` (`modes.parquet` → `modes/modes.parquet`): each table
/// in a folder of its own, so that a glob over a folder (`out/modes/*.parquet`)
/// reads one schema, and the glob across tables that DuckDB and polars refuse
/// (`out/*.parquet`) matches nothing (docs/formats.md).  A name that is
/// already a relative path is returned as it is.
pub fn table_file(file_name: &str) -> String {
    match file_name.strip_suffix(".parquet") {
        Some(stem) if !file_name.contains('/') => format!("{stem}/{file_name}"),
        _ => file_name.to_string(),
    }
}

/// [`TableSchema::locate`] for a table file given by its path relative to
/// the output directory (`modes/modes.parquet`).
pub fn locate_table_file(dir: &Path, file: &str) -> PathBuf {
    let nested = dir.join(file);
    if nested.exists() {
        return nested;
    }
    match file.rsplit_once('/') {
        Some((_, flat)) if dir.join(flat).is_file() => dir.join(flat),
        _ => nested,
    }
}

/// The output directory of the run a table file belongs to: the folder
/// above the table's own (`out/modes/modes.parquet` → `out`), or the file's
/// folder for a flat file of a run made before the per-table folders
/// (`out/modes.parquet` → `out`).
pub fn run_dir_of(table_path: &Path) -> PathBuf {
    let parent = table_path.parent().unwrap_or(Path::new("."));
    let own_folder = table_path
        .file_stem()
        .is_some_and(|stem| Some(stem) == parent.file_name());
    match (own_folder, parent.parent()) {
        (true, Some(grand)) => grand.to_path_buf(),
        _ => parent.to_path_buf(),
    }
}

/// One declared table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableSchema {
    /// The `quaketwin.schema` value.
    pub name: &'static str,
    /// The file the stage writes, relative to the output directory: a folder
    /// of the table's own, `modes/modes.parquet` ([`table_file`]; a stage may
    /// write the same schema under another name, e.g.
    /// `samples_as_recorded/samples_as_recorded.parquet`).
    pub file: &'static str,
    pub doc: &'static str,
    pub rows: Rows,
    pub columns: &'static [ColumnSpec],
}

impl TableSchema {
    /// The table's file name without its folder (`modes.parquet`): where
    /// quaketwin versions before the per-table folders wrote it, directly in
    /// the output directory.
    pub fn flat_file(&self) -> &'static str {
        self.file.rsplit('/').next().unwrap_or(self.file)
    }

    /// The table's file in the output directory `dir` of a run to read
    /// back: `dir/<table>/<table>.parquet`, or the flat `dir/<table>.parquet`
    /// of a run made before the per-table folders when only that exists.
    pub fn locate(&self, dir: &Path) -> PathBuf {
        locate_table_file(dir, self.file)
    }

    /// The declared column `name` belongs to (a family member included).
    pub fn column(&self, name: &str) -> Option<&'static ColumnSpec> {
        self.columns.iter().find(|c| c.matches(name))
    }

    /// Checks the fields of a table against the declaration: every column
    /// present, in order, of its type and nullability, nothing extra.  The
    /// message names the first problem.
    pub fn check_fields(&self, fields: &[&Field]) -> std::result::Result<(), String> {
        let mut i = 0;
        for c in self.columns {
            if c.family_prefix().is_some() {
                while i < fields.len() && c.matches(fields[i].name()) {
                    if let Some(m) = c.mismatch(fields[i]) {
                        return Err(m);
                    }
                    i += 1;
                }
                continue;
            }
            match fields.get(i) {
                Some(f) if f.name() == c.name => {
                    if let Some(m) = c.mismatch(f) {
                        return Err(m);
                    }
                    i += 1;
                }
                found => {
                    let elsewhere = fields.iter().any(|f| f.name() == c.name);
                    return Err(match (elsewhere, found) {
                        (true, _) => format!("column {} is out of order", c.name),
                        (false, Some(f)) => {
                            format!("column {} missing (found {} instead)", c.name, f.name())
                        }
                        (false, None) => format!("column {} missing", c.name),
                    });
                }
            }
        }
        match fields.get(i) {
            Some(f) => Err(format!("column {} is not declared", f.name())),
            None => Ok(()),
        }
    }

    /// The Markdown table of the columns (docs/formats.md holds it
    /// verbatim).  Names, types and units are code spans, so `<…>` shows.
    pub fn markdown(&self) -> String {
        let mut s = String::from("| column | type | unit | meaning |\n|---|---|---|---|\n");
        for c in self.columns {
            let null = if c.nullable { " (null)" } else { "" };
            let unit = if c.unit.is_empty() {
                String::new()
            } else {
                format!("`{}`", c.unit)
            };
            s.push_str(&format!(
                "| `{}` | `{}`{null} | {unit} | {} |\n",
                c.name,
                c.ty.doc_name(),
                md_cell(c.doc)
            ));
        }
        s
    }
}

/// A `|` inside a cell would end it.
fn md_cell(text: &str) -> String {
    text.replace('|', "\\|")
}
