//! Reading a user's text file (pipeline, design, twin) with its size capped
//! before it is read or parsed (issue 33 item 2): a parser holds a text many
//! times over, so an unbounded file is unbounded memory.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// The text of the file at `path` if it has at most `limit` bytes; else the
/// error `too_big(size)` (the caller says which limit and which exit code).
/// The size is taken from the file's metadata before reading, and the read
/// stops at the limit should the file grow meanwhile.
pub fn read_text_capped(
    path: &Path,
    limit: u64,
    too_big: impl FnOnce(u64) -> Error,
) -> Result<String> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let size = file.metadata().map_err(|e| Error::io(path, e))?.len();
    if size > limit {
        return Err(too_big(size));
    }
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(too_big(bytes.len() as u64));
    }
    String::from_utf8(bytes).map_err(|e| {
        Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e.utf8_error()),
        )
    })
}
