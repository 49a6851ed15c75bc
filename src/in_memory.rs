//! Calls on tables held in memory, without files: what the Python bindings
//! (`python/`, docs/python.md) expose as functions taking and returning
//! pyarrow tables.  A table here is Arrow record batches with the schema a
//! file would have — the same columns, and the `quaketwin.*` metadata in
//! the Arrow schema — so a table read from a file and one made here are
//! interchangeable.

use arrow_array::RecordBatch;
use arrow_schema::SchemaRef;

use crate::error::{Error, Result};
use crate::sinks::provenance::Provenance;
use crate::sinks::{event_tables, modal_tables, parquet::with_table_metadata};
use crate::stages::modal::ModalParams;

/// Arrow record batches of one schema (the schema is kept for a table
/// without batches).
#[derive(Debug, Clone)]
pub struct Table {
    pub schema: SchemaRef,
    pub batches: Vec<RecordBatch>,
}

impl Table {
    fn of(batches: Vec<RecordBatch>) -> Result<Table> {
        let schema = batches
            .first()
            .map(|b| b.schema())
            .ok_or_else(|| Error::numerical("internal error: a table without batches"))?;
        Ok(Table { schema, batches })
    }

    /// A table handed over by a caller, with its schema's metadata.
    pub fn new(schema: SchemaRef, batches: Vec<RecordBatch>) -> Table {
        Table { schema, batches }
    }

    pub fn rows(&self) -> usize {
        self.batches.iter().map(|b| b.num_rows()).sum()
    }
}

/// The records of an event folder or zip as the `samples` table (as
/// recorded: the file's units converted to SI where the reader does so, no
/// filtering), its channels in the `quaketwin.channels` metadata.
pub fn read_event(path: &std::path::Path) -> Result<Table> {
    let loaded = crate::event_folder::load(path)?;
    Table::of(event_tables::samples_table(&loaded.event, &[])?)
}

/// What [`modal`] identified.
#[derive(Debug, Clone)]
pub struct ModalTables {
    pub modes: Table,
    pub stabilization: Table,
    /// Why fewer modes were selected than the stable pole columns suggest.
    pub warnings: Vec<String>,
}

/// Subspace modal identification of the event held in `samples` (a table
/// from [`read_event`] or a `samples.parquet`) with the `modal` stage's
/// parameters given as JSON (`{}`: the defaults; docs/pipelines.md).
pub fn modal(samples: &Table, params_json: &str) -> Result<ModalTables> {
    // The same summation order as a pipeline run: same modes to the last bit.
    crate::fixed_order_reductions();
    let params: ModalParams = serde_json::from_str(params_json)
        .map_err(|e| Error::usage(format!("modal settings: {e}")))?;
    params.validate()?;
    let (event, _) = event_tables::samples_from_batches(
        "samples table",
        samples
            .schema
            .metadata()
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect(),
        samples.batches.clone(),
    )?;
    let (result, settings) = params.identify(&event)?;
    let settings_json = serde_json::to_string(&settings).unwrap_or_default();
    let meta = modal_tables::modal_metadata(&result, &settings_json, &Provenance::of_event(&event));
    let table = |batch: RecordBatch| -> Result<Table> {
        Table::of(with_table_metadata(vec![batch], &meta)?)
    };
    Ok(ModalTables {
        modes: table(modal_tables::modes_batch(&result)?)?,
        stabilization: table(modal_tables::stabilization_batch(&result)?)?,
        warnings: result.warnings.clone(),
    })
}
