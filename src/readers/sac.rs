//! Reader under construction (being written now; replaced by the real reader).

use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::SourceRef;

pub fn read(_bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    Err(Error::input(
        super::location(source),
        "the sac reader is not built yet",
    ))
}
