//! MATLAB MAT-file level 5 (the v5/v6/v7 layouts; "MAT-File Format",
//! The MathWorks, 2023): the numeric matrices of a file, by name, as f64,
//! column-major as MATLAB stores them. Structs are read one level deep (a
//! field `x` of struct `test` is `test.x`); cell, char, sparse, object and
//! function arrays are listed as skipped. v7 files compress each variable
//! (miCOMPRESSED: a zlib stream of one element), inflated here with flate2.
//!
//! Written here rather than taken from the `matfile` crate (0.5, the only
//! MAT reader on crates.io): its parser multiplies the dimensions in i32
//! without an overflow check (a panic in debug builds, a wrap in release),
//! unwraps the numeric class of a matrix, and inflates compressed elements
//! without a bound, so a 1 kB file could ask for gigabytes. Here every size
//! is checked against the bytes present before it is used, inflation stops
//! at [`MAX_INFLATED_BYTES`], and nesting at [`MAX_DEPTH`].
//!
//! MAT v7.3 files are HDF5 containers: refused with a message saying so
//! (quaketwin carries no HDF5 library: `hdf5` needs the C library; save with
//! `save(..., '-v7')` or export CSV). Level 4 files (no 128-byte header) are
//! refused too.

use std::io::Read;

use crate::error::{Error, Location, Result};

/// Most bytes one compressed variable may inflate to.
pub const MAX_INFLATED_BYTES: u64 = 1 << 30;
/// Deepest nesting of matrices read (a struct's field is depth 2).
pub const MAX_DEPTH: usize = 2;

/// One numeric matrix of the file.
#[derive(Debug, Clone, PartialEq)]
pub struct MatArray {
    /// Variable name (`struct.field` inside a struct).
    pub name: String,
    /// MATLAB dimensions (at least two).
    pub dims: Vec<usize>,
    /// Real part, column-major, as f64.
    pub values: Vec<f64>,
}

impl MatArray {
    /// Whether it is a vector (one row or one column) or a scalar.
    pub fn is_vector(&self) -> bool {
        self.dims.iter().filter(|&&d| d > 1).count() <= 1
    }
    /// Column `j` of a 2-D matrix.
    pub fn column(&self, j: usize) -> Option<&[f64]> {
        let rows = *self.dims.first()?;
        self.values.get(j * rows..(j + 1) * rows)
    }
}

/// What a file holds: numeric matrices, and what was skipped (with why).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MatContents {
    pub arrays: Vec<MatArray>,
    pub skipped: Vec<String>,
    pub header_text: String,
}

const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;

const MX_STRUCT: u32 = 2;

/// Whether `head` starts like a MAT-file level 5 (or 7.3) header.
pub fn looks_like_mat(head: &[u8]) -> bool {
    head.starts_with(b"MATLAB 5.0 MAT-file") || head.starts_with(b"MATLAB 7.3 MAT-file")
}

struct Cursor<'a> {
    bytes: &'a [u8],
    swap: bool,
    location: &'a Location,
    /// Offset of `bytes` in the file (for messages; 0 inside an inflated element).
    base: u64,
}

impl Cursor<'_> {
    fn fail(&self, at: usize, message: impl Into<String>) -> Error {
        Error::input(
            self.location.clone().at_byte(self.base + at as u64),
            message,
        )
    }
    fn u32_at(&self, at: usize) -> Result<u32> {
        let b: [u8; 4] = self
            .bytes
            .get(at..at + 4)
            .and_then(|s| s.try_into().ok())
            .ok_or_else(|| self.fail(at, "MAT file ends inside a data element tag"))?;
        Ok(if self.swap {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }
    /// The element at `at`: (type, data range, offset of the next element).
    fn element(&self, at: usize) -> Result<(u32, std::ops::Range<usize>, usize)> {
        let first = self.u32_at(at)?;
        let small_bytes = (first >> 16) as usize;
        if small_bytes != 0 {
            // Small data element: type and size in one word, data in the next 4 bytes.
            if small_bytes > 4 {
                return Err(self.fail(
                    at,
                    format!("small data element of {small_bytes} bytes (at most 4)"),
                ));
            }
            if at + 8 > self.bytes.len() {
                return Err(self.fail(at, "MAT file ends inside a small data element"));
            }
            return Ok((first & 0xffff, at + 4..at + 4 + small_bytes, at + 8));
        }
        let nbytes = self.u32_at(at + 4)? as usize;
        let start = at + 8;
        let end = start
            .checked_add(nbytes)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| {
                self.fail(
                    at,
                    format!(
                        "data element of {nbytes} bytes but only {} bytes remain",
                        self.bytes.len().saturating_sub(start)
                    ),
                )
            })?;
        // Compressed elements are not padded; all others to 8 bytes.
        let next = if first == MI_COMPRESSED {
            end
        } else {
            end.div_ceil(8) * 8
        };
        Ok((first, start..end, next.min(self.bytes.len())))
    }
    fn numbers(&self, ty: u32, range: std::ops::Range<usize>) -> Result<Vec<f64>> {
        let data = &self.bytes[range.clone()];
        let size = match ty {
            MI_INT8 | MI_UINT8 => 1,
            MI_INT16 | MI_UINT16 => 2,
            MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
            MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
            _ => {
                return Err(self.fail(
                    range.start,
                    format!("numeric data of unknown MAT type {ty}"),
                ))
            }
        };
        if data.len() % size != 0 {
            return Err(self.fail(
                range.start,
                format!(
                    "{} bytes of data is not a whole number of {size}-byte values",
                    data.len()
                ),
            ));
        }
        let swap = self.swap;
        let word = |c: &[u8]| -> u64 {
            let mut b = [0u8; 8];
            if swap {
                for (k, v) in c.iter().rev().enumerate() {
                    b[k] = *v;
                }
            } else {
                b[..c.len()].copy_from_slice(c);
            }
            u64::from_le_bytes(b)
        };
        Ok(data
            .chunks_exact(size)
            .map(|c| {
                let w = word(c);
                match ty {
                    MI_INT8 => w as u8 as i8 as f64,
                    MI_UINT8 => w as u8 as f64,
                    MI_INT16 => w as u16 as i16 as f64,
                    MI_UINT16 => w as u16 as f64,
                    MI_INT32 => w as u32 as i32 as f64,
                    MI_UINT32 => w as u32 as f64,
                    MI_SINGLE => f32::from_bits(w as u32) as f64,
                    MI_DOUBLE => f64::from_bits(w),
                    MI_INT64 => w as i64 as f64,
                    _ => w as f64,
                }
            })
            .collect())
    }
}

/// Reads the numeric matrices of a MAT v5/v7 file.
pub fn read(bytes: &[u8], location: &Location) -> Result<MatContents> {
    if bytes.starts_with(b"MATLAB 7.3 MAT-file") {
        return Err(Error::input(
            location.clone(),
            "MAT v7.3 file (an HDF5 container): quaketwin reads MAT v5/v7 only (it carries no HDF5 library); save it with save(FILE, '-v7') in MATLAB, or export CSV",
        ));
    }
    if bytes.len() < 128 || !bytes.starts_with(b"MATLAB 5.0 MAT-file") {
        return Err(Error::input(
            location.clone(),
            "not a MAT v5/v7 file (its 128-byte header does not start with \"MATLAB 5.0 MAT-file\"; level 4 files are not read)",
        ));
    }
    let swap = match &bytes[126..128] {
        b"IM" => false,
        b"MI" => true,
        other => {
            return Err(Error::input(
                location.clone().at_byte(126),
                format!("MAT header endian indicator {other:?} is neither \"IM\" nor \"MI\""),
            ))
        }
    };
    let header_text = String::from_utf8_lossy(&bytes[..116])
        .trim_end_matches(['\0', ' '])
        .to_string();
    let cursor = Cursor {
        bytes,
        swap,
        location,
        base: 0,
    };
    let mut out = MatContents {
        header_text,
        ..Default::default()
    };
    let mut at = 128;
    while at + 8 <= bytes.len() {
        let (ty, range, next) = cursor.element(at)?;
        element(&cursor, ty, range, "", 0, &mut out)?;
        at = next;
    }
    Ok(out)
}

fn element(
    cursor: &Cursor<'_>,
    ty: u32,
    range: std::ops::Range<usize>,
    prefix: &str,
    depth: usize,
    out: &mut MatContents,
) -> Result<()> {
    match ty {
        MI_COMPRESSED => {
            let mut inflated = Vec::new();
            flate2::read::ZlibDecoder::new(&cursor.bytes[range.clone()])
                .take(MAX_INFLATED_BYTES + 1)
                .read_to_end(&mut inflated)
                .map_err(|e| {
                    cursor.fail(
                        range.start,
                        format!("compressed MAT element does not inflate: {e}"),
                    )
                })?;
            if inflated.len() as u64 > MAX_INFLATED_BYTES {
                return Err(cursor.fail(
                    range.start,
                    format!("compressed MAT element inflates beyond {MAX_INFLATED_BYTES} bytes"),
                ));
            }
            let inner = Cursor {
                bytes: &inflated,
                swap: cursor.swap,
                location: cursor.location,
                base: 0,
            };
            let mut at = 0;
            while at + 8 <= inflated.len() {
                let (t, r, next) = inner.element(at)?;
                if t == MI_COMPRESSED {
                    return Err(inner.fail(at, "compressed element inside a compressed element"));
                }
                element(&inner, t, r, prefix, depth, out)?;
                at = next;
            }
            Ok(())
        }
        MI_MATRIX => matrix(cursor, range, prefix, depth, out),
        other => {
            out.skipped
                .push(format!("top-level data element of type {other}"));
            Ok(())
        }
    }
}

fn matrix(
    cursor: &Cursor<'_>,
    range: std::ops::Range<usize>,
    prefix: &str,
    depth: usize,
    out: &mut MatContents,
) -> Result<()> {
    if range.is_empty() {
        return Ok(()); // an empty matrix element (struct fields may be empty)
    }
    if depth >= MAX_DEPTH {
        out.skipped
            .push(format!("{prefix}…: nested deeper than {MAX_DEPTH} levels"));
        return Ok(());
    }
    let sub = Cursor {
        bytes: &cursor.bytes[..range.end],
        swap: cursor.swap,
        location: cursor.location,
        base: cursor.base,
    };
    let (fty, frange, at) = sub.element(range.start)?;
    if fty != MI_UINT32 || frange.len() < 8 {
        return Err(sub.fail(range.start, "matrix without its array-flags subelement"));
    }
    let flags = sub.u32_at(frange.start)?;
    let class = flags & 0xff;
    let complex = flags & 0x800 != 0;
    let (dty, drange, at) = sub.element(at)?;
    if dty != MI_INT32 || drange.len() < 8 || drange.len() % 4 != 0 {
        return Err(sub.fail(at, "matrix without a dimensions subelement of int32"));
    }
    let mut dims = Vec::new();
    for k in (drange.start..drange.end).step_by(4) {
        let d = sub.u32_at(k)? as i32;
        if d < 0 {
            return Err(sub.fail(k, format!("negative matrix dimension {d}")));
        }
        dims.push(d as usize);
    }
    let count = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| sub.fail(drange.start, format!("matrix dimensions {dims:?} overflow")))?;
    let (nty, nrange, at) = sub.element(at)?;
    if nty != MI_INT8 && nty != MI_UINT8 {
        return Err(sub.fail(at, "matrix without an array-name subelement"));
    }
    let own = String::from_utf8_lossy(&sub.bytes[nrange]).to_string();
    let name = if prefix.is_empty() {
        own
    } else {
        format!("{prefix}.{own}")
    };
    match class {
        6..=15 => {
            let (rty, rrange, at) = sub.element(at)?;
            let values = sub.numbers(rty, rrange)?;
            if values.len() != count {
                return Err(sub.fail(
                    at,
                    format!(
                        "matrix {name:?} of dimensions {dims:?} holds {} values, not {count}",
                        values.len()
                    ),
                ));
            }
            if complex {
                out.skipped
                    .push(format!("{name}: complex (its real part is read)"));
            }
            out.arrays.push(MatArray { name, dims, values });
        }
        MX_STRUCT => {
            let (lty, lrange, at) = sub.element(at)?;
            if lty != MI_INT32 || lrange.len() != 4 {
                return Err(sub.fail(at, format!("struct {name:?} without its field-name length")));
            }
            let len = sub.u32_at(lrange.start)? as usize;
            let (fty, frange, mut at) = sub.element(at)?;
            if fty != MI_INT8 || len == 0 || frange.len() % len != 0 {
                return Err(sub.fail(
                    at,
                    format!("struct {name:?} field names do not divide into names of {len} bytes"),
                ));
            }
            let names: Vec<String> = sub.bytes[frange]
                .chunks(len)
                .map(|c| {
                    String::from_utf8_lossy(c)
                        .trim_end_matches('\0')
                        .to_string()
                })
                .collect();
            if count != 1 {
                out.skipped.push(format!(
                    "{name}: struct array of {count} elements (only 1×1 structs are read)"
                ));
                return Ok(());
            }
            for field in &names {
                if at + 8 > range.end {
                    return Err(sub.fail(
                        at,
                        format!("struct {name:?} ends before its field {field:?}"),
                    ));
                }
                let (t, r, next) = sub.element(at)?;
                if t != MI_MATRIX {
                    return Err(sub.fail(
                        at,
                        format!("field {field:?} of struct {name:?} is not a matrix"),
                    ));
                }
                // Field matrices carry an empty name; the struct names them.
                let field_prefix = format!("{name}.{field}");
                let before = out.arrays.len();
                matrix(&sub, r, "", depth + 1, out)?;
                for a in &mut out.arrays[before..] {
                    a.name = if a.name.is_empty() {
                        field_prefix.clone()
                    } else {
                        format!("{field_prefix}.{}", a.name)
                    };
                }
                at = next;
            }
        }
        1 => out.skipped.push(format!("{name}: cell array")),
        4 => out.skipped.push(format!("{name}: char array")),
        5 => out.skipped.push(format!("{name}: sparse matrix")),
        other => out.skipped.push(format!("{name}: array class {other}")),
    }
    Ok(())
}
