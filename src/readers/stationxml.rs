//! Reader under construction (being written now; replaced by the real reader).

use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::SourceRef;

pub fn read(_bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    Err(Error::input(
        super::location(source),
        "the stationxml reader is not built yet",
    ))
}

/// Metadata of one channel from StationXML.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelMetadata {}

pub fn parse(_bytes: &[u8], _source: &SourceRef) -> Result<Vec<ChannelMetadata>> {
    Ok(Vec::new())
}

pub fn apply(_records: &mut [crate::vocab::Record], _meta: &[ChannelMetadata]) {}
