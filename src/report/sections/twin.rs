//! Section 10, digital-twin update: the update and updated-modes tables.

use std::path::Path;

use super::generic;
use crate::report::ReportSettings;

pub(super) fn twin_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    generic(dir, "twin_update.parquet", settings, &mut body);
    generic(dir, "twin_modes.parquet", settings, &mut body);
    body
}
