//! Matrix Market files (`.mtx`): the text of `twin::matrix_market`
//! (formatting and parsing live beside the twin that reads such files),
//! written atomically.

use std::path::Path;

use faer::MatRef;

use super::atomic::write_bytes_atomically;
use crate::twin::matrix_market::{format_matrix_market_general, format_matrix_market_symmetric};
use crate::twin::sparse::CscMatrix;
use crate::Result;

/// A symmetric sparse matrix (lower triangle, `coordinate real symmetric`).
pub fn write_matrix_market_symmetric(a: &CscMatrix, path: &Path) -> Result<()> {
    write_bytes_atomically(path, format_matrix_market_symmetric(a).as_bytes())
}

/// A dense matrix (`coordinate real general`) with `comments` after the banner.
pub fn write_matrix_market_general(
    a: MatRef<'_, f64>,
    comments: &[String],
    path: &Path,
) -> Result<()> {
    write_bytes_atomically(path, format_matrix_market_general(a, comments).as_bytes())
}
