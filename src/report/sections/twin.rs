//! Section 10, digital-twin update: the update and updated-modes tables.

use std::path::Path;

use super::generic;
use crate::report::ReportSettings;
use crate::vocab::tables;

pub(super) fn twin_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    generic(dir, &tables::TWIN_UPDATE, settings, &mut body);
    generic(dir, &tables::TWIN_MODES, settings, &mut body);
    body
}
